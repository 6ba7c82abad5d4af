//! A long `spheres` list parsed in pieces on the rayon pool. RON's parser reads about 60 MB/s,
//! so a file of a million spheres (169 MB) would spend most of its first frame here.
//!
//! The text is scanned once for the list `spheres: [ … ]` and for commas between its
//! elements; the rest of the file (with the list emptied) is parsed by RON, and each piece by
//! [`quick`] when it is written in the plain forms, else by RON, as it would be in place. This
//! only ever speeds up a parse that succeeds: anything the scan does not follow exactly
//! (strings, characters, attributes, raw identifiers, an unclosed comment or bracket) or any
//! piece RON rejects gives `None`, and the caller parses the whole text, so every error is
//! reported exactly as before, at its line and column.
//!
//! A long file is read a block at a time ([`read`], through [`Blocks`], as sphere files are),
//! its pieces parsed as the blocks arrive, so that its text is never held whole; the scan
//! ([`Scan`]) is the same either way.

use rayon::prelude::*;

use super::blocks::{self, Blocks};
use super::{options, quick, FileSpec, SphereSpec};

/// A list shorter than two pieces is not split.
pub const PIECE_BYTES: usize = 32 * 1024;

/// The most a block of [`read`] holds (1 MiB): two such blocks are the text in memory at once.
/// A sphere file's 4 MiB blocks would fault in 6 MB more of fresh pages here.
pub const BLOCK_BYTES: usize = 1 << 20;

/// The file, when its `spheres` list is at least two pieces long and every part parses.
pub fn parse(text: &str, piece_bytes: usize) -> Option<FileSpec> {
    let list = find_list(text.as_bytes(), piece_bytes)?;
    if list.cuts.len() < 2 {
        return None;
    }
    let mut rest = String::with_capacity(list.open + 1 + text.len() - list.close);
    rest.push_str(&text[..=list.open]);
    rest.push_str(&text[list.close..]);
    let bounds: Vec<(usize, usize)> = std::iter::once(list.open + 1)
        .chain(list.cuts.iter().copied())
        .zip(list.cuts.iter().copied().chain(std::iter::once(list.close)))
        .collect();
    let (spec, spheres) = rayon::join(
        || options().from_str::<FileSpec>(&rest).ok(),
        || {
            // A group of pieces at a time, appended in order: the spheres are held once, as
            // by RON alone, and not once more in pieces.
            let mut spheres = Vec::new();
            for group in bounds.chunks(GROUP) {
                let parsed = group
                    .par_iter()
                    .map(|&(a, b)| piece(&text[a..b]))
                    .collect::<Option<Vec<_>>>()?;
                let read = group[group.len() - 1].1 - list.open;
                append(&mut spheres, parsed, read, list.close - list.open);
            }
            Some(spheres)
        },
    );
    finish(spec?, spheres?, &rest)
}

/// Appends the spheres of `parsed` (pieces in order) to `spheres`, on the pool: the list's
/// fresh pages are faulted in by every core (64 MB at a million spheres, 2 µs a page here).
/// The first time, with room for the whole list (`all` bytes, of which the pieces so far are
/// `read`) at their spheres a byte and a sixteenth more: no chain of ever larger copies. A
/// list that holds more grows as usual; room not written to costs no memory.
fn append(spheres: &mut Vec<SphereSpec>, parsed: Vec<Vec<SphereSpec>>, read: usize, all: usize) {
    let firsts: Vec<usize> = parsed
        .iter()
        .scan(0, |n, p| {
            let first = *n;
            *n += p.len();
            Some(first)
        })
        .collect();
    let total = firsts
        .last()
        .map_or(0, |&f| f + parsed[parsed.len() - 1].len());
    if spheres.capacity() == 0 {
        let about = (total as f64 * all as f64 / read.max(1) as f64) as usize;
        spheres.reserve(about + about / 16);
    }
    spheres.par_extend(
        (0..total)
            .into_par_iter()
            .with_min_len(PIECE_SPHERES)
            .map(|i| {
                let p = firsts.partition_point(|&first| first <= i) - 1;
                parsed[p][i - firsts[p]].clone()
            }),
    );
}

/// The file from its text without the list's elements (`rest`, parsed to `spec`) and the
/// list's spheres, as RON would give the whole text; None when `rest` has spheres of its own.
fn finish(mut spec: FileSpec, spheres: Vec<SphereSpec>, rest: &str) -> Option<FileSpec> {
    if !spec.scene.spheres.is_empty() {
        return None;
    }
    spec.scene.spheres = spheres;
    // The list's elements are deeper than the fields named in the order.
    spec.order = super::field_order(rest);
    Some(spec)
}

/// Pieces parsed together before they are appended.
const GROUP: usize = 64;

/// The fewest spheres a pool task appends.
const PIECE_SPHERES: usize = 4096;

/// The most bytes [`read`] takes in looking for the list before it gives up.
const HEAD_BYTES: usize = 1 << 20;

/// What [`parse`] gives for the text of `file` (`len` bytes long, as far as is known), read a
/// block at a time and never held whole: each block's pieces are parsed on the pool while the
/// next block is read and scanned, and the block before's spheres appended. The first block
/// is [`FIRST_BLOCK`] bytes (or `block_bytes`, if less), and each next one twice the last, up
/// to `block_bytes`: until the first block is read and scanned, one core works alone. None for
/// a text [`parse`] gives None for, or one that is not UTF-8: then the caller reads the file
/// whole.
pub fn read(
    file: &mut (impl std::io::Read + Send),
    len: u64,
    piece_bytes: usize,
    block_bytes: usize,
) -> Option<FileSpec> {
    let mut size = block_bytes.min(FIRST_BLOCK);
    // The size of the next block: each twice the last, up to `block_bytes`.
    let mut grow = || {
        let want = size;
        size = (size * 2).min(block_bytes);
        want
    };
    // The text up to the list's `[` (as `parse` sees it: after a byte-order mark).
    let mut head = Vec::new();
    let (open, bom, end) = loop {
        let end = blocks::read(file, &mut head, grow()).ok()?;
        let bom = 3 * usize::from(head.starts_with(b"\xef\xbb\xbf"));
        if let Some(open) = find_open(&head[bom..]) {
            break (open, bom, end);
        }
        if end || head.len() > HEAD_BYTES {
            return None;
        }
    };
    let mut scan = Scan::new(open, piece_bytes);
    // The block holds the text from byte `base` on: the first piece not yet parsed, and what
    // has been read past it; the next block starts at the piece that it cuts through.
    let mut blocks = Blocks::new(file, head.split_off(bom + open + 1), end);
    let (mut base, mut start) = (open + 1, open + 1);
    let mut scanned = scan.feed(&blocks.this, base, end);
    let mut spheres: Vec<SphereSpec> = Vec::new();
    // The block before's spheres, and how far into the list they reach.
    let mut parsed_before: Option<(Vec<Vec<SphereSpec>>, usize)> = None;
    let mut pieces = 0;
    let close = loop {
        let mut bounds: Vec<(usize, usize)> = Vec::with_capacity(scan.cuts.len() + 1);
        for &cut in &scan.cuts {
            bounds.push((start - base, cut - base));
            start = cut;
        }
        pieces += scan.cuts.len();
        scan.cuts.clear();
        let close = match scanned {
            Scanned::Bail => return None,
            Scanned::Closed(close) => {
                bounds.push((start - base, close - base));
                Some(close)
            }
            Scanned::More => None,
        };
        // This block's pieces on the pool; beside them, the block before's spheres appended,
        // and the next block read after the piece that runs on into it, and scanned.
        let parse_pieces = |a: &[u8]| {
            bounds
                .par_iter()
                .map(|&(from, to)| piece(std::str::from_utf8(&a[from..to]).ok()?))
                .collect::<Option<Vec<_>>>()
        };
        let before = parsed_before.take();
        let append_and_scan = |b: &[u8], end| {
            if let Some((parsed, read)) = before {
                append(&mut spheres, parsed, read, len as usize);
            }
            close.is_none().then(|| scan.feed(b, start, end))
        };
        let want = close.is_none().then(&mut grow);
        let (next, parsed) = blocks.turn(start - base, want, parse_pieces, append_and_scan);
        parsed_before = Some((parsed?, start - open));
        if let Some(close) = close {
            break close;
        }
        scanned = next.ok()??;
        base = start;
    };
    if let Some((parsed, read)) = parsed_before {
        append(&mut spheres, parsed, read, len as usize);
    }
    if pieces < 2 {
        return None;
    }
    // The text without the list's elements, as `parse` gives RON: the rest of the block after
    // the list (the next block starts where its last piece did), and the rest of the file.
    let mut rest = head;
    rest.drain(..bom);
    rest.extend_from_slice(&blocks.this[close - start..]);
    drop(blocks);
    file.read_to_end(&mut rest).ok()?;
    let rest = String::from_utf8(rest).ok()?;
    finish(options().from_str::<FileSpec>(&rest).ok()?, spheres, &rest)
}

/// The first block [`read`] reads: small, so that the pool soon has pieces to parse.
const FIRST_BLOCK: usize = 256 << 10;

/// A piece of the list: in the plain forms without RON; anything else through RON, as a list
/// (the newline ends a line comment that the piece may end in).
fn piece(text: &str) -> Option<Vec<SphereSpec>> {
    quick::spheres(text).or_else(|| {
        let piece = format!("[{text}\n]");
        options().from_str::<Vec<SphereSpec>>(&piece).ok()
    })
}

/// Where the list's brackets are, and the byte after each comma it is cut at.
#[derive(Debug, PartialEq)]
struct List {
    open: usize,
    close: usize,
    cuts: Vec<usize>,
}

/// The list `spheres: [ … ]` (the first `spheres` followed by `:` and `[`), with a cut after
/// the first comma between its elements at least `piece_bytes` past the last cut. Comments
/// are followed up to the list; in it, a comment (or any string) gives `None`.
fn find_list(s: &[u8], piece_bytes: usize) -> Option<List> {
    let open = find_open(s)?;
    let mut scan = Scan::new(open, piece_bytes);
    match scan.feed(s, 0, true) {
        Scanned::Closed(close) => Some(List {
            open,
            close,
            cuts: scan.cuts,
        }),
        Scanned::More | Scanned::Bail => None,
    }
}

/// The scan of a list from its `[` on, fed the text in order (whole, or a block at a time as
/// a file is read): its depth of brackets, whether anything odd was met, and the cuts.
struct Scan {
    depth: i64,
    odd: u8,
    /// No cut before this byte.
    next: usize,
    /// The next byte to read.
    at: usize,
    piece_bytes: usize,
    /// The cuts found (and not yet taken).
    cuts: Vec<usize>,
}

/// Where a [`Scan`] stands after the bytes it was fed.
enum Scanned {
    /// The list goes on past them.
    More,
    /// The list's `]` is at this byte.
    Closed(usize),
    /// Not a list the pieces can follow.
    Bail,
}

impl Scan {
    fn new(open: usize, piece_bytes: usize) -> Scan {
        Scan {
            depth: 0,
            odd: 0,
            next: open + 1 + piece_bytes,
            at: open + 1,
            piece_bytes,
            cuts: Vec::new(),
        }
    }

    /// Reads on through `s`, the text's bytes from byte `base` up to as far as it is known;
    /// `end` when the text ends there. The list is read in blocks of [`BLOCK`] from its `[`
    /// (compares that vectorize; a million spheres are 169 MB of list), and byte by byte only
    /// near a cut or a `]` and where something is odd; a block is read only once it is
    /// whole or the text has ended, so the cuts are the same however the text is fed.
    fn feed(&mut self, s: &[u8], base: usize, end: bool) -> Scanned {
        let len = base + s.len();
        while self.at < len {
            let i = self.at;
            let whole = i + BLOCK <= len;
            if !whole && !end {
                return Scanned::More;
            }
            let block = &s[i - base..(i + BLOCK).min(len) - base];
            if whole && i + BLOCK <= self.next {
                let (opens, closes, stop) = block.iter().fold((0u8, 0u8, 0u8), |(o, c, x), &b| {
                    let open = (b == b'(') | (b == b'[') | (b == b'{');
                    let close = (b == b')') | (b == b'}');
                    let stop = (b == b']') | (b == b'"') | (b == b'\'') | (b == b'#') | (b == b'/');
                    (o + u8::from(open), c + u8::from(close), x | u8::from(stop))
                });
                if stop == 0 {
                    self.depth += i64::from(opens) - i64::from(closes);
                    self.at += BLOCK;
                    continue;
                }
            }
            for (k, &c) in block.iter().enumerate() {
                let class = CLASS[c as usize];
                self.depth += i64::from(class & OPENS) - i64::from((class & CLOSES) >> 1);
                self.odd |= class & ODD;
                if self.depth < 0 {
                    return match self.odd == 0 && c == b']' {
                        true => Scanned::Closed(i + k),
                        false => Scanned::Bail,
                    };
                }
                if (class & COMMA != 0) & (self.depth == 0) & (i + k >= self.next) {
                    self.cuts.push(i + k + 1);
                    self.next = i + k + 1 + self.piece_bytes;
                }
            }
            self.at = i + block.len();
        }
        match end {
            true => Scanned::Bail,
            false => Scanned::More,
        }
    }
}

/// The bytes the list's scan reads at once when nothing in them needs a closer look.
const BLOCK: usize = 64;

const OPENS: u8 = 1;
const CLOSES: u8 = 2;
const COMMA: u8 = 4;
const ODD: u8 = 8;

/// What each byte is to the list's scan: a bracket, a comma, or the start of a comment, a
/// string, a character or an attribute.
const CLASS: [u8; 256] = {
    let mut table = [0; 256];
    let mut k = 0;
    while k < 256 {
        table[k] = match k as u8 {
            b'(' | b'[' | b'{' => OPENS,
            b')' | b']' | b'}' => CLOSES,
            b',' => COMMA,
            b'"' | b'\'' | b'#' | b'/' => ODD,
            _ => 0,
        };
        k += 1;
    }
    table
};

/// The `[` of the first `spheres` field, following comments and bailing at strings.
fn find_open(s: &[u8]) -> Option<usize> {
    let mut i = 0;
    while i < s.len() {
        match s[i] {
            b'"' | b'\'' | b'#' => return None,
            b'/' if s.get(i + 1) == Some(&b'/') => {
                i = line_comment_end(s, i);
                continue;
            }
            b'/' if s.get(i + 1) == Some(&b'*') => {
                i = block_comment_end(s, i)?;
                continue;
            }
            b's' if is_word(s, i, b"spheres") => {
                let colon = skip_blank(s, i + 7)?;
                if s[colon] == b':' {
                    let bracket = skip_blank(s, colon + 1)?;
                    if s[bracket] == b'[' {
                        return Some(bracket);
                    }
                }
            }
            _ => {}
        }
        i += 1;
    }
    None
}

/// The end of the line comment at `i` (its `\n`, or the text's end).
pub(super) fn line_comment_end(s: &[u8], i: usize) -> usize {
    s[i..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(s.len(), |n| i + n)
}

/// The byte after the block comment that starts at `i` (RON's block comments nest).
pub(super) fn block_comment_end(s: &[u8], mut i: usize) -> Option<usize> {
    let mut level = 0usize;
    while i + 1 < s.len() {
        match (s[i], s[i + 1]) {
            (b'/', b'*') => {
                level += 1;
                i += 2;
            }
            (b'*', b'/') => {
                level -= 1;
                i += 2;
                if level == 0 {
                    return Some(i);
                }
            }
            _ => i += 1,
        }
    }
    None
}

/// The first byte at or after `i` that is neither white space nor in a comment.
fn skip_blank(s: &[u8], mut i: usize) -> Option<usize> {
    loop {
        match s.get(i)? {
            c if c.is_ascii_whitespace() => i += 1,
            b'/' if s.get(i + 1) == Some(&b'/') => {
                i += s[i..].iter().position(|&c| c == b'\n')?;
            }
            b'/' if s.get(i + 1) == Some(&b'*') => i = block_comment_end(s, i)?,
            _ => return Some(i),
        }
    }
}

/// Whether `word` stands at `i` as a whole identifier.
fn is_word(s: &[u8], i: usize, word: &[u8]) -> bool {
    let ident = |c: &u8| c.is_ascii_alphanumeric() || *c == b'_' || !c.is_ascii();
    s[i..].starts_with(word)
        && (i == 0 || !ident(&s[i - 1]))
        && !s.get(i + word.len()).is_some_and(ident)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::splitmix::SplitMix;
    use proptest::prelude::*;

    /// RON on the whole text, and the fields' order from the whole text: what a split parse
    /// must agree with.
    fn whole(text: &str) -> Option<FileSpec> {
        let mut spec: FileSpec = options().from_str(text).ok()?;
        spec.order = super::super::field_order(text);
        Some(spec)
    }

    /// Equal field by field and bit by bit (`{:?}` prints each float's shortest round trip).
    fn same(a: &FileSpec, b: &FileSpec) -> bool {
        format!("{a:?}") == format!("{b:?}")
    }

    /// A file of `n` spheres written in every form the list allows; comments before the list
    /// hold brackets, commas and a decoy `spheres: [`.
    fn file(n: usize, trailing_comma: bool) -> String {
        let mut rng = SplitMix(n as u64 + 7);
        let mut x = || format!("{:?}", (rng.unit() - 0.5) * 1e3);
        let mut list = Vec::new();
        for k in 0..n {
            list.push(match k % 5 {
                0 => format!("(center: ({}, {}, {}), radius: 1.5, color: (0.5, 0.25, 1.0))", x(), x(), x()),
                1 => format!("(center: ({},{},{}),radius: 2e-3)", x(), x(), x()),
                2 => format!("(\n  radius: 0.75,\n  color: Some((1.0, 0.0, 0.0)),\n  center: ({}, {}, {}),\n)", x(), x(), x()),
                3 => format!("(center:({},{},{}), radius:{}, color: None)", x(), x(), x(), 1.0 + k as f64),
                _ => format!("\t( center : ( {} , {} , {} ) , radius : 3.0 )", x(), x(), x()),
            });
        }
        let mut spheres = list.join(",\n");
        if trailing_comma && n > 0 {
            spheres.push(',');
        }
        format!(
            "// spheres: [ (a, b) ], ] ) {{\n/* (outer /* spheres: [ nested ], */ still , ] ) */\n\
             (\n    frames: 4,\n    camera: (tp: (0.0, 1.0, 0.0), hfov: 60.0),\n    \
             scene: (\n        lights: [(direction: (0.0, -1.0, 0.0))], // ), [\n        \
             spheres /* : [ */ : [\n{spheres}\n        ],\n        ambient: 0.2,\n    ),\n)\n"
        )
    }

    #[test]
    fn pieces_give_what_ron_gives_for_the_whole_file() {
        let mut split = 0;
        for n in [0, 1, 2, 3, 10, 57] {
            for trailing_comma in [false, true] {
                let text = file(n, trailing_comma);
                let expected = whole(&text).unwrap_or_else(|| panic!("RON rejects\n{text}"));
                assert!(expected.order.contains(&"scene.ambient".to_string()));
                assert_eq!(expected.scene.spheres.len(), n);
                for piece_bytes in [1, 2, 5, 40, 300, 100_000] {
                    let cuts = find_list(text.as_bytes(), piece_bytes)
                        .expect("a list")
                        .cuts;
                    match parse(&text, piece_bytes) {
                        Some(spec) => {
                            assert!(same(&spec, &expected), "n {n}, pieces of {piece_bytes}");
                            split += 1;
                        }
                        None => assert!(cuts.len() < 2, "n {n}, pieces of {piece_bytes}"),
                    }
                }
            }
        }
        assert!(split >= 30, "only {split} files were split");
    }

    #[test]
    fn the_list_is_found_past_comments_and_cut_between_elements() {
        let text = file(10, false);
        let list = find_list(text.as_bytes(), 1).expect("a list");
        assert_eq!(&text[list.open - 5..=list.open], "*/ : [");
        assert_eq!(&text[list.close..list.close + 3], "],\n");
        assert_eq!(list.cuts.len(), 9, "a cut after each element but the last");
        for cut in list.cuts {
            assert_eq!(&text[cut - 2..cut], "),");
        }
    }

    #[test]
    fn a_comment_or_string_in_the_list_leaves_it_to_ron() {
        let text = file(10, false);
        for odd in ["// note\n", "/* note */", "\"x\", ", "#"] {
            let inside = text.replacen("\n\t(", &format!("\n{odd}\t("), 1);
            assert_ne!(inside, text);
            assert!(parse(&inside, 1).is_none(), "{odd}");
        }
        assert!(parse(&text.replacen("//", "#![enable(unwrap_newtypes)] //", 1), 1).is_none());
    }

    #[test]
    fn what_ron_rejects_is_never_split() {
        let text = file(10, false);
        let broken = [
            text.replacen("radius: 1.5,", "radius: 1.5", 1),
            text.replacen("),\n\t(", ")\n\t(", 1),
            text.replacen("),\n\t(", "),,\n\t(", 1),
            text.replacen("),\n\t(", ")),\n\t(", 1),
            text.replacen("radius: 2e-3", "radius: 2e-3, size: 1.0", 1),
            text.replacen("ambient: 0.2", "ambient: 0.2, spheres: []", 1),
            text.replacen(
                "hfov: 60.0",
                "hfov: 60.0, spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0)]",
                1,
            ),
            text.replacen("        ],\n", "\n", 1),
        ];
        for (k, text) in broken.iter().enumerate() {
            assert!(whole(text).is_none(), "case {k} parses");
            assert!(parse(text, 1).is_none(), "case {k} was split");
        }
    }

    /// The text fed `chunk` bytes at a time however much is asked for: reads that fall short
    /// before the end, as a pipe's do.
    struct Trickle<'a> {
        bytes: &'a [u8],
        chunk: usize,
    }

    impl std::io::Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.chunk.min(buf.len()).min(self.bytes.len());
            buf[..n].copy_from_slice(&self.bytes[..n]);
            self.bytes = &self.bytes[n..];
            Ok(n)
        }
    }

    /// Read a block at a time, from a file and through short reads, with and without a
    /// byte-order mark: what `parse` gives for the whole text, field by field.
    fn read_as_parse(text: &str, piece_bytes: usize, blocks: &[usize]) -> bool {
        let expected = parse(text, piece_bytes).map(|spec| format!("{spec:?}"));
        let with_bom = format!("\u{feff}{text}");
        [text, &with_bom].iter().all(|t| {
            let bytes = t.as_bytes();
            let len = bytes.len() as u64;
            blocks.iter().all(|&block| {
                let mut file = std::io::Cursor::new(bytes);
                let mut short = Trickle { bytes, chunk: 3 };
                let got = [
                    read(&mut file, len, piece_bytes, block),
                    read(&mut short, len, piece_bytes, block),
                ];
                got.iter()
                    .all(|g| g.as_ref().map(|spec| format!("{spec:?}")) == expected)
            })
        })
    }

    #[test]
    fn a_file_read_in_blocks_gives_what_the_whole_text_gives() {
        for n in [0, 1, 2, 3, 10, 57] {
            for trailing_comma in [false, true] {
                let text = file(n, trailing_comma);
                for piece_bytes in [1, 2, 5, 40, 300, 100_000] {
                    let blocks = [1, 7, 64, 65, 1000, 1 << 20];
                    assert!(
                        read_as_parse(&text, piece_bytes, &blocks),
                        "n {n}, {piece_bytes}"
                    );
                }
            }
        }
        // Longer than the first block, with and without a head that spans the first two: read
        // in blocks growing to 1 MB, it gives what the whole text gives.
        let long = file(12_000, true);
        assert!(long.len() > 2 * FIRST_BLOCK);
        let comment = format!("/* {} */\n", "x".repeat(FIRST_BLOCK + FIRST_BLOCK / 2));
        for text in [long.clone(), comment + &long] {
            assert!(parse(&text, PIECE_BYTES).is_some());
            assert!(read_as_parse(&text, PIECE_BYTES, &[BLOCK_BYTES]));
        }
        // Split, so read in blocks.
        let text = file(57, false);
        let len = text.len() as u64;
        assert!(read(&mut text.as_bytes(), len, 40, 64).is_some());
        // A byte that is not UTF-8 in a comment before or after the list: read whole. With the
        // character whole, the same file is read in blocks.
        for (at, what) in [
            ("(a, b)", "(a, \u{e9})"),
            ("ambient: 0.2,", "ambient: 0.2, // \u{e9}"),
        ] {
            let edited = text.replacen(at, what, 1);
            let len = edited.len() as u64;
            assert!(read(&mut edited.as_bytes(), len, 40, 64).is_some(), "{at}");
            let mut bytes = edited.into_bytes();
            let e9 = bytes.windows(2).position(|w| w == [0xc3, 0xa9]).unwrap();
            bytes.remove(e9);
            assert!(std::str::from_utf8(&bytes).is_err());
            assert!(
                read(&mut bytes.as_slice(), len - 1, 40, 64).is_none(),
                "{at}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, rng_seed: proptest::test_runner::RngSeed::Fixed(0x91EC), failure_persistence: None, ..ProptestConfig::default() })]

        /// Any small edit of a file: when the pieces parse, RON parses the whole file to the
        /// same thing; read in blocks (of 1 to 101 bytes), the file gives what the pieces give.
        #[test]
        fn an_edited_file_splits_only_into_what_ron_reads(
            at in 0.0..1.0f64,
            cut in 0usize..4,
            insert in prop::sample::select(vec!["", "(", ")", "[", "]", ",", ":", "/", "*", "\n", "0", "e", "spheres: [", "),(", "], ["]),
            piece_bytes in 1usize..200,
        ) {
            let text = file(12, true);
            let mut i = (at * text.len() as f64) as usize;
            while !text.is_char_boundary(i) {
                i -= 1;
            }
            let edited = format!("{}{insert}{}", &text[..i], &text[(i + cut).min(text.len())..]);
            if let Some(spec) = parse(&edited, piece_bytes) {
                let expected = whole(&edited);
                prop_assert!(expected.is_some(), "split, but RON rejects it");
                prop_assert!(same(&spec, &expected.unwrap()));
            }
            prop_assert!(read_as_parse(&edited, piece_bytes, &[piece_bytes * 3 % 101 + 1]));
        }
    }
}
