//! A body read a block at a time in two buffers that take turns: while the pool works on one
//! block, the next is read beside it, so that reading (one thread's work) overlaps the parsing.
//! Sphere files' bodies (`sphere_files/`) and a long keyframe file (`pieces.rs`) are read this
//! way and never held whole.

use std::io::{self, Read};

/// Appends up to `want` bytes of `body` to `into`: whether the body ended (a read fell short).
pub fn read(body: &mut impl Read, into: &mut Vec<u8>, want: usize) -> io::Result<bool> {
    let got = body.take(want as u64).read_to_end(into)?;
    Ok(got < want)
}

/// The block to work on, and the next one, read beside the work.
pub struct Blocks<'r, R> {
    body: &'r mut R,
    /// The block to work on: what the block before left over, then what was read after it.
    pub this: Vec<u8>,
    next: Vec<u8>,
    /// Whether the body ended in `this`.
    pub end: bool,
}

impl<'r, R: Read + Send> Blocks<'r, R> {
    /// The blocks of `body` from `this`, a first block already read (`end`: the body ended in it).
    pub fn new(body: &'r mut R, this: Vec<u8>, end: bool) -> Blocks<'r, R> {
        let next = Vec::with_capacity(this.capacity());
        Blocks {
            body,
            this,
            next,
            end,
        }
    }

    /// `work(&this)`, and beside it the next block: `this[from..]`, then up to `want` more
    /// bytes of the body (with `None`, none are read), handed to `look` with whether the body
    /// ended in them. That block is then `this`.
    pub fn turn<A: Send, B: Send>(
        &mut self,
        from: usize,
        want: Option<usize>,
        work: impl FnOnce(&[u8]) -> A + Send,
        look: impl FnOnce(&[u8], bool) -> B + Send,
    ) -> (io::Result<B>, A) {
        let Blocks {
            body,
            this,
            next,
            end,
        } = self;
        let rest = &this[from..];
        let (looked, worked) = rayon::join(
            || {
                next.clear();
                next.extend_from_slice(rest);
                if let Some(want) = want {
                    *end = read(body, next, want)?;
                }
                Ok(look(next, *end))
            },
            || work(this),
        );
        std::mem::swap(this, next);
        (looked, worked)
    }

    /// Whether the body has ended after `this` (a byte is read past it and lost: for a body
    /// about to be refused).
    pub fn ended(&mut self) -> io::Result<bool> {
        self.end = self.end || self.body.read(&mut [0])? == 0;
        Ok(self.end)
    }
}
