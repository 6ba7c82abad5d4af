//! A PLY body: binary vertices in blocks on the pool, or ASCII lines ([`text_records`]); the
//! elements before the vertices read past.

use std::collections::BinaryHeap;
use std::io::{self, BufRead, Read};
use std::sync::{Mutex, PoisonError};

use rayon::prelude::*;

use super::header::quoted;
use super::listing::{FileProblem, Listing, Location};
use super::look::{Layout, BLUE, RADIUS, RED, SLOTS, X};
use super::ply_header::{self, fixed_offsets, Element, Header, Property, Scalar};
use super::text::{text_records, Rows};
use super::{Sink, BLOCK_BYTES};
use crate::error::PROBLEMS_SHOWN;
use crate::format::blocks::{self, Blocks};
use crate::format::{PlainSphere, SphereFileSpec, SphereSpec};

/// The fewest vertices a pool task parses: a small file stays one task.
const TASK_VERTICES: usize = 4096;

/// The PLY form read from `file`, at most `len` bytes long (a bound on the vertices to make
/// room for, whatever the header claims).
pub(super) fn ply_from<T: Send>(
    mut file: impl BufRead + Send,
    len: u64,
    spec: &SphereFileSpec,
    out: &mut impl Sink<T>,
    make: &(impl Fn(usize, &SphereSpec) -> T + Sync),
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let header = ply_header::header(&mut file, spec)?;
    let Header {
        elements,
        vertex,
        layout,
        last,
        ..
    } = &header;
    listing.ignored = layout.ignored.clone();
    let v = &elements[*vertex];
    if !header.binary {
        return ascii_vertices(&mut file, &header, out, make, listing);
    }
    skip_elements(&mut file, &elements[..*vertex])?;
    match fixed_offsets(v) {
        Some(offsets) => {
            let stride = offsets.last().map_or(0, |(o, t)| o + t.size());
            // Room for the vertices the file can hold, not for whatever the header claims.
            let room = usize::try_from(len / stride as u64).unwrap_or(usize::MAX);
            out.room(v.count.min(room));
            let at = layout.cols.map(|k| k.map(|k| offsets[k]));
            // A row a type table does not name: noted from the pool's tasks, a stand-in in
            // its place, named afterwards in file order; only the first ones named are kept
            // (the rest counted), so a million bad rows cost no message each.
            let unread = Mutex::new((BinaryHeap::new(), 0usize));
            let plain = plain_offsets(layout, &at);
            let read = fixed_vertices(&mut file, v.count, stride, plain, out, |i, vertex| {
                let mut fields = [0.0; SLOTS];
                for (f, at) in fields.iter_mut().zip(at) {
                    if let Some((o, t)) = at {
                        *f = t.le(&vertex[o..o + t.size()]);
                    }
                }
                let sphere = layout.sphere(&fields).unwrap_or_else(|what| {
                    let mut unread = unread.lock().unwrap_or_else(PoisonError::into_inner);
                    let (first, count) = &mut *unread;
                    *count += 1;
                    first.push((i, what));
                    if first.len() > PROBLEMS_SHOWN {
                        first.pop();
                    }
                    STAND_IN
                });
                make(i, &sphere)
            });
            let (first, count) = unread.into_inner().unwrap_or_else(PoisonError::into_inner);
            let first = first.into_sorted_vec();
            for (i, what) in &first {
                listing.unreadable(*i, FileProblem::at(Location::Vertex(*i), what.clone()));
            }
            listing.unreadable_unnamed(count - first.len());
            read
        }
        None => listed_vertices(&mut file, v, layout, out, make, listing),
    }?;
    if *last && !file.fill_buf().map_err(FileProblem::io)?.is_empty() {
        return Err(FileProblem::whole(format!(
            "the body goes on past the header's vertex count ({}): is the count right?",
            v.count
        )));
    }
    Ok(())
}

/// Reads past the elements before the vertices, lists included.
fn skip_elements(body: &mut impl BufRead, elements: &[Element]) -> Result<(), FileProblem> {
    for e in elements {
        let cut = |i: u64| {
            FileProblem::whole(format!(
                "truncated: the body ends inside element {} {i} (before the vertices)",
                e.name
            ))
        };
        if let Some(offsets) = fixed_offsets(e) {
            // All at once: the element's records are all the same size.
            let size = offsets.last().map_or(0, |(o, t)| o + t.size()) as u64;
            let want = size.saturating_mul(e.count as u64);
            let got = skip(body, want)?;
            if got < want {
                return Err(cut(got / size));
            }
            continue;
        }
        for i in 0..e.count as u64 {
            for p in &e.properties {
                let (count, item) = match p {
                    Property::Scalar(t, _) => (1.0, *t),
                    Property::List(c, t, _) => {
                        let mut n = [0; 8];
                        let n = &mut n[..c.size()];
                        exact(body, n)?.ok_or_else(|| cut(i))?;
                        let count = c.le(n);
                        if count < 0.0 {
                            return Err(FileProblem::whole(format!(
                                "element {} {i}: a negative list count ({count})",
                                e.name
                            )));
                        }
                        (count, *t)
                    }
                };
                let want = (count as u64).saturating_mul(item.size() as u64);
                if skip(body, want)? < want {
                    return Err(cut(i));
                }
            }
        }
    }
    Ok(())
}

/// Reads past `n` bytes, or to the end: how many were there.
fn skip(body: &mut impl BufRead, n: u64) -> Result<u64, FileProblem> {
    io::copy(&mut body.take(n), &mut io::sink()).map_err(FileProblem::io)
}

/// Fills `buf`, or returns None at the end of the body.
fn exact(body: &mut impl Read, buf: &mut [u8]) -> Result<Option<()>, FileProblem> {
    match body.read_exact(buf) {
        Ok(()) => Ok(Some(())),
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Ok(None),
        Err(e) => Err(FileProblem::io(e)),
    }
}

/// The truncation of vertex `i` of `count`.
fn truncated(i: usize, count: usize) -> FileProblem {
    FileProblem::at(
        Location::Vertex(i),
        format!("truncated: the body ends inside vertex {i} of the header's {count}"),
    )
}

/// `count` vertices of `stride` bytes each, a block at a time ([`Blocks`]), each block's
/// vertices turned by `vertex(i, bytes)` on the rayon pool straight into `out`, in order, while
/// the next block is read beside them (reading is a third of the work, and on one thread).
fn fixed_vertices<T: Send>(
    body: &mut (impl Read + Send),
    count: usize,
    stride: usize,
    plain: Option<[usize; 7]>,
    out: &mut impl Sink<T>,
    vertex: impl Fn(usize, &[u8]) -> T + Sync,
) -> Result<(), FileProblem> {
    let per_block = (BLOCK_BYTES / stride).max(1);
    let n = count.div_ceil(per_block);
    // Block b's bytes, as the header counts them.
    let want = |b: usize| per_block.min(count - b * per_block) * stride;
    let mut this = Vec::with_capacity(per_block.min(count) * stride);
    if n > 0 {
        blocks::read(body, &mut this, want(0)).map_err(FileProblem::io)?;
    }
    let mut blocks = Blocks::new(body, this, false);
    for b in 0..n {
        let (first, got) = (b * per_block, blocks.this.len());
        let next = (b + 1 < n).then(|| want(b + 1));
        let parse = |block: &[u8]| {
            let block = &block[..got - got % stride];
            if let Some(at) = plain {
                let row = |k: usize| plain_row(&block[k * stride..][..stride], &at);
                if out.put_plain(block.len() / stride, row) {
                    return;
                }
            }
            let whole = block.par_chunks_exact(stride);
            out.put_all(
                (whole.with_min_len(TASK_VERTICES))
                    .enumerate()
                    .map(|(k, v)| vertex(first + k, v)),
            )
        };
        let (read, ()) = blocks.turn(got, next, parse, |_, _| ());
        if got < want(b) {
            return Err(truncated(first + got / stride, count));
        }
        read.map_err(FileProblem::io)?;
    }
    Ok(())
}

/// Where a vertex's x, y, z, radius, red, green and blue start, when it is a [`PlainSphere`]
/// to `layout`'s rules: those seven columns f32 and bytes (`at`: each slot's offset and type),
/// and no other slot read.
fn plain_offsets(layout: &Layout, at: &[Option<(usize, Scalar)>; SLOTS]) -> Option<[usize; 7]> {
    let want = |slot: usize| match slot {
        X..=RADIUS => Some(Scalar::F32),
        RED..=BLUE => Some(Scalar::U8),
        _ => None,
    };
    let typed = (0..SLOTS).all(|k| at[k].map(|(_, t)| t) == want(k));
    (layout.plain() && typed).then(|| std::array::from_fn(|k| at[k].map_or(0, |(o, _)| o)))
}

/// The [`PlainSphere`] of a vertex whose seven fields start at `at`.
#[inline(always)]
fn plain_row(vertex: &[u8], at: &[usize; 7]) -> PlainSphere {
    let f = |k: usize| f32::from_le_bytes(std::array::from_fn(|b| vertex[at[k] + b]));
    PlainSphere {
        ball: [f(0), f(1), f(2), f(3)],
        levels: [vertex[at[4]], vertex[at[5]], vertex[at[6]]],
    }
}

/// Vertices with lists among their properties, one at a time.
fn listed_vertices<T>(
    body: &mut impl BufRead,
    v: &Element,
    layout: &Layout,
    out: &mut impl Sink<T>,
    make: impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let mut values = vec![0.0; v.properties.len()];
    let mut bytes = [0; 8];
    for i in 0..v.count {
        for (k, p) in v.properties.iter().enumerate() {
            let mut scalar = |t: Scalar| -> Result<f64, FileProblem> {
                let b = &mut bytes[..t.size()];
                exact(body, b)?.ok_or_else(|| truncated(i, v.count))?;
                Ok(t.le(b))
            };
            match p {
                Property::Scalar(t, _) => values[k] = scalar(*t)?,
                Property::List(c, t, _) => {
                    let n = scalar(*c)?;
                    if n < 0.0 {
                        return Err(FileProblem::at(
                            Location::Vertex(i),
                            format!("a negative list count ({n})"),
                        ));
                    }
                    let want = (n as u64).saturating_mul(t.size() as u64);
                    if skip(body, want)? < want {
                        return Err(truncated(i, v.count));
                    }
                }
            }
        }
        let row = layout.cols.map(|k| k.map_or(0.0, |k| values[k]));
        let sphere = layout.sphere(&row).unwrap_or_else(|what| {
            listing.unreadable(i, FileProblem::at(Location::Vertex(i), what));
            STAND_IN
        });
        out.put(make(i, &sphere));
    }
    Ok(())
}

/// Whether an ASCII PLY line is blank: ASCII whitespace alone, the separators of its values.
fn ascii_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
}

/// The vertices of an ASCII body, one record a line, blank lines passed: the elements before
/// them read past line by line (an element without properties takes no line), then the vertices
/// in blocks on the pool ([`text_records`]); what follows the last vertex is never named, unless
/// nothing should (then a line that is not blank is). Values are separated by ASCII whitespace
/// (PLY is ASCII), each read as its property's type. A vertex line that cannot be read is
/// named in the listing and keeps its place with a stand-in sphere, so the vertices after it are
/// read and keep their numbers.
fn ascii_vertices<T>(
    body: &mut (impl BufRead + Send),
    header: &Header,
    out: &mut impl Sink<T>,
    make: impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let Header {
        ref elements,
        vertex,
        ref layout,
        first_line,
        last,
        ..
    } = *header;
    let mut line = first_line - 1;
    let mut raw = Vec::new();
    for e in elements[..vertex]
        .iter()
        .filter(|e| !e.properties.is_empty())
    {
        for i in 0..e.count {
            // The element's next record: its next line that is not blank.
            loop {
                raw.clear();
                if body.read_until(b'\n', &mut raw).map_err(FileProblem::io)? == 0 {
                    return Err(FileProblem::whole(format!(
                        "truncated: the body ends at element {} {i} (before the vertices)",
                        e.name
                    )));
                }
                line += 1;
                if !ascii_blank(&raw) {
                    break;
                }
            }
        }
    }
    let v = &elements[vertex];
    let parse = |line: &str, values: &mut Vec<f64>| -> Result<SphereSpec, String> {
        values.clear();
        let mut words = line.split_ascii_whitespace();
        for p in &v.properties {
            let mut word = |what: &str| {
                words
                    .next()
                    .ok_or_else(|| format!("a short row: no value for {what}"))
            };
            match p {
                Property::Scalar(t, name) => {
                    let w = word(name)?;
                    values.push(t.ascii(w).ok_or_else(|| {
                        let what = match t {
                            Scalar::F32 | Scalar::F64 => "a number".to_string(),
                            _ => format!("a value of type {}", t.name()),
                        };
                        format!("{name}: not {what}: {}", quoted(w))
                    })?);
                }
                Property::List(c, _, _) => {
                    let w = word("a list's count")?;
                    let count = c.ascii(w).filter(|n| *n >= 0.0).ok_or_else(|| {
                        format!(
                            "a list's count must be a whole number of type {}, 0 or more: {}",
                            c.name(),
                            quoted(w)
                        )
                    })?;
                    for _ in 0..count as u64 {
                        word("a list item")?;
                    }
                    // A list is not a field: its place holds nothing read.
                    values.push(0.0);
                }
            }
        }
        if words.next().is_some() {
            return Err("more values than the header's properties".to_string());
        }
        layout.sphere(&layout.cols.map(|k| k.map_or(0.0, |k| values[k])))
    };
    let problem = |i, at, what: String| {
        let what = match i < v.count {
            true => format!("vertex {i}: {what}"),
            false => what,
        };
        FileProblem::at(Location::Line(at), what)
    };
    let mut taken = 0;
    let take = |at, sphere: Result<SphereSpec, String>| {
        let sphere = sphere.unwrap_or_else(|what| {
            listing.unreadable(taken, problem(taken, at, what));
            STAND_IN
        });
        out.put(make(taken, &sphere));
        taken += 1;
    };
    let blank = |line: &str| ascii_blank(line.as_bytes());
    let rows = Rows {
        first_line: line + 1,
        count: v.count,
        rest_blank: last,
    };
    let got = text_records(body, rows, blank, parse, take, problem)?;
    if got < v.count {
        return Err(FileProblem::at(
            Location::Vertex(got),
            format!("truncated: the file ends at vertex {got} of {}", v.count),
        ));
    }
    Ok(())
}

/// What stands in for a vertex that could not be read: a sphere that passes every check, so
/// only the vertex's own problem is named (and the scene, having a problem, is never made).
const STAND_IN: SphereSpec = SphereSpec {
    center: (0.0, 0.0, 0.0),
    radius: 1.0,
    color: None,
};
