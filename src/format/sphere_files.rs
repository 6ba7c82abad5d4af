//! Sphere files: spheres kept outside the keyframe file, as PLY (ASCII or binary little-endian)
//! or CSV, the forms particle systems, point clouds and molecule tools write.
//!
//! - **PLY**: `element vertex N` with `x`, `y`, `z` and `radius` (any numeric type), and
//!   optionally `red`, `green`, `blue`: `uchar` 0–255 (divided by 255) or `float`/`double` 0–1.
//!   Other properties and elements are read past. An ASCII value is read as its declared type
//!   (a `float` rounded to f32, as a binary body holds it), so ASCII and binary give the same
//!   spheres. A header line is at most 4,096 bytes (a `comment` or `obj_info` line is read past).
//! - **CSV**: a header `x,y,z,radius` or `x,y,z,radius,r,g,b` (colours 0–1), then one sphere a
//!   line; blank lines are skipped.
//!
//! Numbers are read exactly: a `double` in PLY, or a number in CSV (the value `f64::from_str`
//! gives, as RON reads its floats), gives the same bits as the same number in RON. Nothing is checked here
//! beyond the form: each sphere is handed, with its index, to the caller's `make` as it is read
//! ([`crate::document`] checks it there), so a file's spheres are never held twice. A body
//! passes through buffers of [`BLOCK_BYTES`], never held whole: a binary PLY's vertices parsed
//! on the rayon pool straight into the caller's vector, in file order; a text body's lines
//! (CSV, ASCII PLY) cut into pieces parsed on the pool, handed over in file order.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use rayon::prelude::*;

use super::SphereSpec;
use crate::error::PROBLEMS_SHOWN;

/// The most bytes of a binary PLY body read at a time (whole vertices, at least one): a
/// million spheres' 56 MB pass through 4 MiB, and the body is never held whole. A long
/// keyframe file is read in blocks of this size too (`pieces::read`).
pub const BLOCK_BYTES: usize = 4 << 20;

/// The fewest vertices a pool task parses: a small file stays one task.
const TASK_VERTICES: usize = 4096;

/// The longest header line read (PLY's, CSV's), without its line end: a header line is a few
/// words, and a PLY whose `end_header` is missing is cut here, not read whole into one line. A
/// PLY `comment` or `obj_info` line may be longer: what follows this is read past.
const HEADER_LINE_BYTES: usize = 4096;

/// `text` quoted for a message, cut after 60 characters: a line of a body read as a header
/// is named, not printed whole.
fn quoted(text: &str) -> String {
    match text.char_indices().nth(60) {
        Some((cut, _)) => format!("{:?}…", &text[..cut]),
        None => format!("{text:?}"),
    }
}

/// A text header's lines (PLY's, and CSV's first), each at most [`HEADER_LINE_BYTES`]; the
/// last may end the file without a line end.
struct HeaderLines {
    /// Lines read.
    line: usize,
    raw: Vec<u8>,
    /// What a line too long suggests, when its lines do not end in CR alone.
    suggest: &'static str,
    /// Whether a longer line that starts `comment` or `obj_info` is taken, cut (PLY's).
    comments: bool,
}

impl HeaderLines {
    fn new(suggest: &'static str, comments: bool) -> HeaderLines {
        HeaderLines {
            line: 0,
            raw: Vec::new(),
            suggest,
            comments,
        }
    }

    /// The next line and its number, trimmed (bytes that are not UTF-8 replaced); None at the
    /// end of the file.
    fn next(&mut self, file: &mut dyn BufRead) -> Result<Option<(usize, String)>, FileProblem> {
        self.raw.clear();
        // The line, its CR and its LF.
        (&mut *file)
            .take(HEADER_LINE_BYTES as u64 + 2)
            .read_until(b'\n', &mut self.raw)
            .map_err(FileProblem::io)?;
        if self.raw.is_empty() {
            return Ok(None);
        }
        self.line += 1;
        let ended = self.raw.last() == Some(&b'\n');
        for end in [b'\n', b'\r'] {
            if self.raw.last() == Some(&end) {
                self.raw.pop();
            }
        }
        let comment = |raw: &[u8]| {
            let words = raw.trim_ascii_start();
            [&b"comment"[..], b"obj_info"].iter().any(|w| {
                words.starts_with(w) && words.get(w.len()).is_some_and(|b| b.is_ascii_whitespace())
            })
        };
        // A long comment (not a text whose lines end in CR alone, read as one line): cut, and
        // the rest of it read past to its line end.
        if self.raw.len() > HEADER_LINE_BYTES
            && self.comments
            && comment(&self.raw)
            && !self.raw.contains(&b'\r')
        {
            if !ended {
                skip_line(file).map_err(FileProblem::io)?;
            }
            self.raw.truncate(HEADER_LINE_BYTES);
        }
        if self.raw.len() > HEADER_LINE_BYTES {
            let why = match !ended && self.raw.contains(&b'\r') {
                true => CR_ALONE,
                false => self.suggest,
            };
            return Err(FileProblem::at(
                Location::Line(self.line),
                format!("a header line longer than {HEADER_LINE_BYTES} bytes: {why}"),
            ));
        }
        let line = String::from_utf8_lossy(&self.raw);
        Ok(Some((self.line, line.trim().to_string())))
    }
}

/// Reads past the rest of a line and its line end: whether there was one.
fn skip_line(file: &mut dyn BufRead) -> io::Result<bool> {
    loop {
        let buf = file.fill_buf()?;
        if buf.is_empty() {
            return Ok(false);
        }
        match buf.iter().position(|&b| b == b'\n') {
            Some(k) => {
                file.consume(k + 1);
                return Ok(true);
            }
            None => {
                let n = buf.len();
                file.consume(n);
            }
        }
    }
}

/// What a text whose lines end in CR alone is told.
const CR_ALONE: &str = "its lines end in CR alone: save it with LF or CRLF line endings";

/// Where in a sphere file a sphere or a problem is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A PLY vertex, from 0.
    Vertex(usize),
    /// A line of text, from 1 (CSV, and PLY headers).
    Line(usize),
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Location::Vertex(v) => write!(f, "vertex {v}"),
            Location::Line(l) => write!(f, "line {l}"),
        }
    }
}

/// What is wrong with a sphere file's form, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileProblem {
    /// Where in the file, when the problem has a place (not for a missing header line).
    pub at: Option<Location>,
    /// What is wrong.
    pub message: String,
}

impl FileProblem {
    fn at(at: Location, message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: Some(at),
            message: message.into(),
        }
    }

    fn whole(message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: None,
            message: message.into(),
        }
    }

    fn io(e: io::Error) -> FileProblem {
        FileProblem::whole(format!("cannot read: {e}"))
    }
}

/// What a sphere file gave: how many spheres, and where each is.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Listing {
    /// How many spheres the file gave.
    pub count: usize,
    /// Each sphere's line, for a text file whose lines are not one a sphere (CSV with blank
    /// lines); empty when sphere `i` is at [`Listing::location`]'s default.
    lines: Vec<u32>,
    /// The line of the first sphere in a text file, or None for PLY vertices.
    first_line: Option<usize>,
    /// What is wrong with the file's form, each with the number of spheres read before it, in
    /// file order: the rows that could not be read (passed, so that the rest are read and
    /// checked too; an ASCII PLY's keeps its vertex's place with a stand-in sphere), then what
    /// ended the reading early, if anything.
    pub problems: Vec<(usize, FileProblem)>,
    /// Rows that could not be read past the first [`PROBLEMS_SHOWN`] − 1 named: counted, not
    /// kept (a file of a million bad rows costs no message a row), and named as a count in
    /// the hundredth place, which a message shows.
    unlisted: usize,
}

impl Listing {
    /// Notes a row that cannot be read, after `before` spheres.
    fn unreadable(&mut self, before: usize, problem: FileProblem) {
        match self.problems.len() < PROBLEMS_SHOWN - 1 {
            true => self.problems.push((before, problem)),
            false => self.unlisted += 1,
        }
    }

    /// Where sphere `i` is in its file.
    pub fn location(&self, i: usize) -> Location {
        match (self.first_line, self.lines.get(i)) {
            (_, Some(line)) => Location::Line(*line as usize),
            (Some(first), None) => Location::Line(first + i),
            (None, None) => Location::Vertex(i),
        }
    }
}

/// Reads a sphere file, by its extension (`.ply` or `.csv`), appending `make(i, sphere)` to
/// `out` for each sphere `i` in file order; `make` runs on the rayon pool for a binary PLY.
/// The spheres read stay in `out` whatever the file's problems (the listing's), so their own
/// problems can be named too.
pub fn read<T: Send>(
    path: &Path,
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T + Sync,
) -> Listing {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    listed(out, |out, listing| {
        let mut file = File::open(path)
            .map_err(|e| FileProblem::whole(format!("cannot open {}: {e}", path.display())))?;
        let len = file.metadata().map_err(FileProblem::io)?.len();
        match ext.as_deref() {
            Some("ply") => ply_from(BufReader::new(file), len, out, &make, listing),
            Some("csv") => csv_from(BufReader::new(file), out, &make, listing),
            _ => {
                // A folder, or a file that cannot be read, is named as such whatever its name.
                file.read(&mut [0]).map_err(FileProblem::io)?;
                Err(FileProblem::whole(
                    "a sphere file is .ply or .csv (by its extension)",
                ))
            }
        }
    })
}

/// The listing of what `reader` appends to `out`: its count, and the problem that ended it
/// after those it read past.
fn listed<T>(
    out: &mut Vec<T>,
    reader: impl FnOnce(&mut Vec<T>, &mut Listing) -> Result<(), FileProblem>,
) -> Listing {
    let start = out.len();
    let mut listing = Listing::default();
    let ended = reader(out, &mut listing);
    listing.count = out.len() - start;
    let ended_early = ended.is_err();
    if let Err(problem) = ended {
        listing.problems.push((listing.count, problem));
    }
    if listing.unlisted > 0 {
        let more = format!("and {} more row(s) that cannot be read", listing.unlisted);
        let at = listing.problems.len() - usize::from(ended_early);
        listing
            .problems
            .insert(at, (listing.count, FileProblem::whole(more)));
    }
    listing
}

/// The CSV form, appending `make(i, sphere)` to `out` for each sphere.
pub fn csv<T>(bytes: &[u8], out: &mut Vec<T>, make: impl Fn(usize, &SphereSpec) -> T) -> Listing {
    listed(out, |out, listing| csv_from(bytes, out, &make, listing))
}

/// The CSV form read from `file`: the header line, then the body's lines in blocks on the
/// pool ([`text_records`]).
fn csv_from<T>(
    mut file: impl BufRead + Send,
    out: &mut Vec<T>,
    make: &impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let mut lines = HeaderLines::new("is it a CSV file?", false);
    let (n, header) = loop {
        match lines.next(&mut file)? {
            None => return Err(FileProblem::whole("empty: expected a header x,y,z,radius")),
            // A byte-order mark starts the file, whatever line holds the header.
            Some((1, l)) if l.trim_start_matches('\u{feff}').trim().is_empty() => continue,
            Some((_, l)) if l.is_empty() => continue,
            Some((n, l)) => break (n, l),
        }
    };
    let header = match n {
        1 => header
            .strip_prefix('\u{feff}')
            .unwrap_or(&header)
            .to_string(),
        _ => header,
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let colours = match names.as_slice() {
        ["x", "y", "z", "radius"] => false,
        ["x", "y", "z", "radius", "r", "g", "b"] => true,
        _ => {
            // A line that still holds a CR: lines end in CR alone.
            let cr = match header.contains('\r') {
                true => format!(" ({CR_ALONE})"),
                false => String::new(),
            };
            return Err(FileProblem::at(
                Location::Line(n),
                format!(
                    "the header must be x,y,z,radius or x,y,z,radius,r,g,b, got {}{cr}",
                    quoted(&header)
                ),
            ));
        }
    };
    let fields = names.len();
    let parse = |line: &str, _: &mut Vec<f64>| -> Result<SphereSpec, String> {
        let mut words = [""; 7];
        let mut got = 0;
        for (k, field) in line.split(',').enumerate() {
            if let Some(word) = words.get_mut(k) {
                *word = field.trim();
            }
            got = k + 1;
        }
        if got != fields {
            return Err(format!(
                "expected {fields} fields ({}), got {got}",
                CSV_NAMES[..fields].join(",")
            ));
        }
        let mut values = [0.0; 7];
        for (k, (value, word)) in values.iter_mut().zip(words).take(fields).enumerate() {
            *value = text_f64(word)
                .ok_or_else(|| format!("{}: not a number: {}", CSV_NAMES[k], quoted(word)))?;
        }
        let [x, y, z, radius, r, g, b] = values;
        Ok(SphereSpec {
            center: (x, y, z),
            radius,
            color: colours.then_some((r, g, b)),
        })
    };
    let first = n + 1;
    listing.first_line = Some(first);
    let mut gaps = false;
    let mut count = 0;
    let take = |line, sphere: Result<SphereSpec, String>| match sphere {
        Ok(sphere) => {
            gaps |= line != first + count;
            out.push(make(count, &sphere));
            count += 1;
            listing.lines.push(line as u32);
        }
        // Passed: the lines of the spheres after it are kept.
        Err(what) => {
            gaps = true;
            let problem = FileProblem::at(Location::Line(line), what);
            listing.unreadable(count, problem);
        }
    };
    let problem = |_, line, what| FileProblem::at(Location::Line(line), what);
    let blank = |line: &str| line.trim().is_empty();
    let rows = Rows {
        first_line: first,
        count: usize::MAX,
        rest_blank: false,
    };
    let ended = text_records(&mut file, rows, blank, parse, take, problem);
    if !gaps {
        // Every sphere on the line after the one before: the lines need not be kept.
        listing.lines = Vec::new();
    }
    ended.map(|_| ())
}

/// A text field's number (CSV, and an ASCII PLY's `double`): the value `f64::from_str` gives,
/// and only where it gives one. A finite value from `fast_float2` (correctly rounded, so the
/// same bits, and faster) is taken; anything else it gives or refuses
/// (`inf`, `NaN`, an error) goes to `from_str`. The tests check the two agree over every field
/// of up to five characters of numbers, infinities and NaNs, and six of digits alone.
fn text_f64(field: &str) -> Option<f64> {
    match fast_float2::parse::<f64, _>(field) {
        Ok(v) if v.is_finite() => Some(v),
        _ => field.parse().ok(),
    }
}

/// [`text_f64`] for an ASCII PLY's `float`: the value `f32::from_str` gives.
fn text_f32(field: &str) -> Option<f32> {
    match fast_float2::parse::<f32, _>(field) {
        Ok(v) if v.is_finite() => Some(v),
        _ => field.parse().ok(),
    }
}

/// A CSV file's columns, in the order its header names them.
const CSV_NAMES: [&str; 7] = ["x", "y", "z", "radius", "r", "g", "b"];

/// The bytes of text a pool task parses at least: a block's lines are cut into pieces of this
/// size at line ends.
const TASK_BYTES: usize = 64 << 10;

/// A piece of a block's lines, parsed: each record (or what is wrong with its line) with its
/// line (counted from the piece's start, from 1), and how many lines it held.
struct Piece<R> {
    records: Vec<(usize, Result<R, String>)>,
    lines: usize,
}

/// Which lines of a text body are records.
struct Rows {
    /// The body's first line's number.
    first_line: usize,
    /// How many records there are (`usize::MAX`: to the end).
    count: usize,
    /// Whether only blank lines may follow the last record (else what follows is another
    /// element's, and never read).
    rest_blank: bool,
}

/// The records of a text body, one a line (lines `blank` takes so are passed), in file order:
/// the body read in blocks of [`BLOCK_BYTES`], each cut after its last line end, its lines
/// parsed by `parse(line, scratch)` in pieces on the pool while the next block is read, and
/// handed to `take(line, record)`, at most `rows.count` of them. A line that is not UTF-8 or
/// that `parse` refuses is handed over as what is wrong with it, and counts as a record. What
/// follows the records is parsed at most a block on and never taken (with `count` 0 nothing
/// is read), unless only blank lines may follow: then reading goes on to the end. A line of a
/// block or more (4 MiB), or one past the records that may not be there, ends the reading with
/// `problem(the records before it, its line, what is wrong)`. Returns how many records were
/// taken.
fn text_records<R: Send>(
    body: &mut (impl Read + Send),
    rows: Rows,
    blank: fn(&str) -> bool,
    parse: impl Fn(&str, &mut Vec<f64>) -> Result<R, String> + Sync,
    mut take: impl FnMut(usize, Result<R, String>),
    problem: impl Fn(usize, usize, String) -> FileProblem,
) -> Result<usize, FileProblem> {
    let io = FileProblem::io;
    let Rows {
        first_line,
        count,
        rest_blank,
    } = rows;
    let mut taken = 0;
    if count == 0 && !rest_blank {
        return Ok(0);
    }
    // The lines before this block.
    let mut before = first_line - 1;
    let mut this = Vec::with_capacity(BLOCK_BYTES);
    let mut next = Vec::with_capacity(BLOCK_BYTES);
    let mut end = fill_block(body, &mut this).map_err(io)?;
    loop {
        // The block's whole lines: up to its last line end, or all of it at the end. A full
        // block without a line end is one line, whole only if the body ends with it.
        let last_end = this.iter().rposition(|&b| b == b'\n');
        if !end && last_end.is_none() {
            end = body.read(&mut [0]).map_err(io)? == 0;
            if !end {
                let cr = match this.contains(&b'\r') {
                    true => format!(": {CR_ALONE}"),
                    false => String::new(),
                };
                let what = format!("a line of {} MiB or more{cr}", BLOCK_BYTES >> 20);
                return Err(problem(taken, before + 1, what));
            }
        }
        let cut = match (end, last_end) {
            (false, Some(k)) => k + 1,
            _ => this.len(),
        };
        next.clear();
        next.extend_from_slice(&this[cut..]);
        let (read, pieces) = rayon::join(
            || match end {
                true => Ok(true),
                false => fill_block(body, &mut next),
            },
            || parse_lines(&this[..cut], blank, &parse),
        );
        for piece in pieces {
            for (line, record) in piece.records {
                if taken == count {
                    return match rest_blank {
                        true => Err(problem(
                            taken,
                            before + line,
                            format!(
                                "a row past the header's vertex count ({count}): is the count right?"
                            ),
                        )),
                        false => Ok(taken),
                    };
                }
                take(before + line, record);
                taken += 1;
            }
            before += piece.lines;
        }
        if end || (taken == count && !rest_blank) {
            return Ok(taken);
        }
        end = read.map_err(io)?;
        std::mem::swap(&mut this, &mut next);
    }
}

/// Fills `block` (which may hold the end of the last one) up to [`BLOCK_BYTES`] from `body`:
/// whether the body ended.
fn fill_block(body: &mut impl Read, block: &mut Vec<u8>) -> io::Result<bool> {
    let room = BLOCK_BYTES.saturating_sub(block.len());
    let got = body.take(room as u64).read_to_end(block)?;
    Ok(got < room)
}

/// `text`'s lines parsed in pieces of about [`TASK_BYTES`] on the pool, in order.
fn parse_lines<R: Send>(
    text: &[u8],
    blank: fn(&str) -> bool,
    parse: &(impl Fn(&str, &mut Vec<f64>) -> Result<R, String> + Sync),
) -> Vec<Piece<R>> {
    let mut cuts = vec![0];
    while let Some(&from) = cuts.last() {
        let want = from + TASK_BYTES;
        if want >= text.len() {
            break;
        }
        match text[want..].iter().position(|&b| b == b'\n') {
            Some(k) if want + k + 1 < text.len() => cuts.push(want + k + 1),
            _ => break,
        }
    }
    cuts.push(text.len());
    cuts.par_windows(2)
        .map(|w| {
            let mut piece = Piece {
                records: Vec::new(),
                lines: 0,
            };
            let mut scratch = Vec::new();
            for raw in text[w[0]..w[1]].split_inclusive(|&b| b == b'\n') {
                piece.lines += 1;
                let Ok(line) = std::str::from_utf8(raw) else {
                    let what = "not UTF-8 text".to_string();
                    piece.records.push((piece.lines, Err(what)));
                    continue;
                };
                let line = line.strip_suffix('\n').unwrap_or(line);
                let line = line.strip_suffix('\r').unwrap_or(line);
                if blank(line) {
                    continue;
                }
                piece.records.push((piece.lines, parse(line, &mut scratch)));
            }
            piece
        })
        .collect()
}

/// A PLY property's scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// The type's name in a header.
    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    /// Whether a list's count may be of this type.
    fn counts(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The value of an ASCII body's word, read as this type (a `float` rounded to f32, as a
    /// binary body stores it, an integer type in its range) and widened exactly to f64; None
    /// when the word is not one.
    fn ascii(self, w: &str) -> Option<f64> {
        match self {
            Scalar::F32 => text_f32(w).map(f64::from),
            Scalar::F64 => text_f64(w),
            // Read as an i64 (so `-0` is a uchar's 0, as C's readers take it), then kept to
            // the type's range.
            _ => {
                let (lo, hi) = match self {
                    Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
                    Scalar::U8 => (0, u8::MAX.into()),
                    Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
                    Scalar::U16 => (0, u16::MAX.into()),
                    Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
                    _ => (0, u32::MAX.into()),
                };
                let v: i64 = w.parse().ok().filter(|v| (lo..=hi).contains(v))?;
                Some(v as f64)
            }
        }
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The value of little-endian `b` (exactly `size` bytes), widened exactly to f64.
    #[inline(always)]
    fn le(self, b: &[u8]) -> f64 {
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F64 => f64::from_le_bytes(b.try_into().expect("8 bytes")),
        }
    }
}

/// A PLY property: a scalar, or a list (count type, item type), with its name.
#[derive(Debug, Clone, PartialEq)]
enum Property {
    Scalar(Scalar, String),
    List(Scalar, Scalar, String),
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar(_, name) | Property::List(_, _, name) => name,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// The PLY form, appending `make(i, sphere)` to `out` for each vertex (on the rayon pool when
/// the body is binary).
pub fn ply<T: Send>(
    bytes: &[u8],
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T + Sync,
) -> Listing {
    listed(out, |out, listing| {
        ply_from(bytes, bytes.len() as u64, out, &make, listing)
    })
}

/// The PLY form read from `file`, at most `len` bytes long (a bound on the vertices to make
/// room for, whatever the header claims).
fn ply_from<T: Send>(
    mut file: impl BufRead + Send,
    len: u64,
    out: &mut Vec<T>,
    make: &(impl Fn(usize, &SphereSpec) -> T + Sync),
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    // The header is ASCII lines up to `end_header`.
    let mut lines = HeaderLines::new("is `end_header` missing?", true);
    let bad = |n: usize, m: String| FileProblem::at(Location::Line(n), m);
    let head = file.fill_buf().map_err(FileProblem::io)?;
    if head.starts_with(b"ply\r") && head.get(4) != Some(&b'\n') {
        return Err(FileProblem::whole(format!("not read as PLY: {CR_ALONE}")));
    }
    match lines.next(&mut file) {
        Ok(Some((_, l))) if l == "ply" => {}
        // A file that cannot be read is named so; a first line too long is no PLY either.
        Err(e) if e.at.is_none() => return Err(e),
        _ => {
            return Err(FileProblem::whole(
                "not a PLY file: it must start with `ply`",
            ))
        }
    }
    let mut binary = None;
    let mut elements: Vec<Element> = Vec::new();
    // The lines of the `format` and `element vertex` lines, each allowed once.
    let (mut format_at, mut vertex_at) = (None, None);
    loop {
        let Some((n, line)) = lines.next(&mut file)? else {
            return Err(FileProblem::whole("the header has no `end_header`"));
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        let once = |at: &mut Option<usize>, what: &str| match at.replace(n) {
            Some(first) => Err(bad(
                n,
                format!("a second `{what}` line (the first is line {first})"),
            )),
            None => Ok(()),
        };
        match words.as_slice() {
            ["end_header"] => break,
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["format", form, version] => {
                once(&mut format_at, "format")?;
                binary = match *form {
                    "ascii" => Some(false),
                    "binary_little_endian" => Some(true),
                    other => {
                        return Err(bad(
                            n,
                            format!(
                                "format {other} is not read: write ascii or binary_little_endian"
                            ),
                        ))
                    }
                };
                if *version != "1.0" {
                    return Err(bad(
                        n,
                        format!("format version {}: PLY 1.0 is read", quoted(version)),
                    ));
                }
            }
            ["element", name, count] => {
                if *name == "vertex" {
                    once(&mut vertex_at, "element vertex")?;
                }
                elements.push(Element {
                    name: name.to_string(),
                    count: count.parse().map_err(|_| {
                        bad(
                            n,
                            format!("element count {} is not a number", quoted(count)),
                        )
                    })?,
                    properties: Vec::new(),
                })
            }
            ["property", "list", count, item, name] => {
                let (Some(c), Some(i)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(bad(n, format!("unknown list types in {}", quoted(&line))));
                };
                if !c.counts() {
                    return Err(bad(
                        n,
                        format!("a list's count is an integer type, not {}", c.name()),
                    ));
                }
                let e = last_element(&mut elements, name).map_err(|m| bad(n, m))?;
                e.properties.push(Property::List(c, i, name.to_string()));
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| bad(n, format!("unknown type {}", quoted(ty))))?;
                let e = last_element(&mut elements, name).map_err(|m| bad(n, m))?;
                e.properties.push(Property::Scalar(ty, name.to_string()));
            }
            _ => return Err(bad(n, format!("not a PLY header line: {}", quoted(&line)))),
        }
    }
    let binary = binary.ok_or_else(|| FileProblem::whole("the header has no `format` line"))?;
    let vertex = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| FileProblem::whole("the header has no `element vertex`"))?;
    let columns = Columns::of(&elements[vertex])?;
    let v = &elements[vertex];
    // Whether the vertices end the body: then nothing may follow them.
    let last = (elements[vertex + 1..].iter()).all(|e| e.count == 0 || e.properties.is_empty());
    if binary {
        skip_elements(&mut file, &elements[..vertex])?;
        match fixed_offsets(v) {
            Some(offsets) => {
                let stride = offsets.last().map_or(0, |(o, t)| o + t.size());
                // Room for the vertices the file can hold, not for whatever the header claims.
                let room = usize::try_from(len / stride as u64).unwrap_or(usize::MAX);
                out.reserve(v.count.min(room));
                let at = columns.fields.map(|k| offsets[k]);
                fixed_vertices(&mut file, v.count, stride, out, |i, vertex| {
                    let mut fields = [0.0; 7];
                    for (f, (o, t)) in fields.iter_mut().zip(at) {
                        *f = t.le(&vertex[o..o + t.size()]);
                    }
                    make(i, &columns.sphere(fields))
                })
            }
            None => listed_vertices(&mut file, v, &columns, out, make),
        }?;
        if last && fill(&mut file, &mut [0])? > 0 {
            return Err(FileProblem::whole(format!(
                "the body goes on past the header's vertex count ({}): is the count right?",
                v.count
            )));
        }
        Ok(())
    } else {
        let layout = Layout {
            elements: &elements,
            vertex,
            columns: &columns,
            first_line: lines.line + 1,
            last,
        };
        ascii_vertices(&mut file, &layout, out, make, listing)
    }
}

/// The element a `property` line adds to (the last), refusing a property named twice.
fn last_element<'a>(elements: &'a mut [Element], name: &str) -> Result<&'a mut Element, String> {
    let e = elements
        .last_mut()
        .ok_or_else(|| "a property before any element".to_string())?;
    match e.properties.iter().any(|p| p.name() == name) {
        true => Err(format!(
            "element {} has a second property {}",
            e.name,
            quoted(name)
        )),
        false => Ok(e),
    }
}

/// Where an ASCII PLY body's vertices are.
struct Layout<'a> {
    /// The header's elements.
    elements: &'a [Element],
    /// Which of them is `vertex`.
    vertex: usize,
    columns: &'a Columns,
    /// The body's first line.
    first_line: usize,
    /// Whether nothing follows the vertices.
    last: bool,
}

/// Which scalar of a vertex holds each sphere field, and whether colours are bytes.
struct Columns {
    /// The properties holding x, y, z, radius, red, green and blue (without colours, the last
    /// three are x's, read and not used).
    fields: [usize; 7],
    colours: bool,
    rgb_bytes: bool,
}

impl Columns {
    fn of(vertex: &Element) -> Result<Columns, FileProblem> {
        let find = |name: &str| {
            vertex.properties.iter().position(|p| match p {
                Property::Scalar(_, n) => n == name,
                Property::List(..) => false,
            })
        };
        let mut xyz_radius = [0; 4];
        for (slot, name) in xyz_radius.iter_mut().zip(["x", "y", "z", "radius"]) {
            *slot = find(name).ok_or_else(|| {
                FileProblem::whole(format!("element vertex has no property {name}"))
            })?;
        }
        let rgb = match (find("red"), find("green"), find("blue")) {
            (Some(r), Some(g), Some(b)) => Some([r, g, b]),
            (None, None, None) => None,
            _ => {
                return Err(FileProblem::whole(
                    "element vertex has some of red, green, blue but not all three",
                ))
            }
        };
        let rgb_bytes = match rgb {
            Some(c) => {
                let types: Vec<Scalar> = c
                    .iter()
                    .map(|&k| match &vertex.properties[k] {
                        Property::Scalar(t, _) => *t,
                        Property::List(..) => unreachable!("found among scalars"),
                    })
                    .collect();
                if types.iter().all(|t| *t == Scalar::U8) {
                    true
                } else if types.iter().all(|t| matches!(t, Scalar::F32 | Scalar::F64)) {
                    false
                } else {
                    return Err(FileProblem::whole(
                        "red, green and blue must all be uchar (0–255) or all float or double (0–1)",
                    ));
                }
            }
            None => false,
        };
        let [x, y, z, radius] = xyz_radius;
        let [red, green, blue] = rgb.unwrap_or([x; 3]);
        Ok(Columns {
            fields: [x, y, z, radius, red, green, blue],
            colours: rgb.is_some(),
            rgb_bytes,
        })
    }

    /// A vertex's fields, in the order of [`Columns::fields`], from its properties' values.
    fn fields(&self, values: &[f64]) -> [f64; 7] {
        self.fields.map(|k| values[k])
    }

    /// The sphere of a vertex's fields, in the order of [`Columns::fields`].
    #[inline(always)]
    fn sphere(&self, [x, y, z, radius, red, green, blue]: [f64; 7]) -> SphereSpec {
        // A byte's level k is k / 255, as the same colour written in RON.
        let level = |v: f64| if self.rgb_bytes { v / 255.0 } else { v };
        SphereSpec {
            center: (x, y, z),
            radius,
            color: self
                .colours
                .then(|| (level(red), level(green), level(blue))),
        }
    }
}

/// Each vertex property's byte offset and type, when all are scalars: a vertex is then a
/// fixed number of bytes, and the body can be cut anywhere between vertices.
fn fixed_offsets(v: &Element) -> Option<Vec<(usize, Scalar)>> {
    let mut at = 0;
    v.properties
        .iter()
        .map(|p| match p {
            Property::Scalar(t, _) => {
                at += t.size();
                Some((at - t.size(), *t))
            }
            Property::List(..) => None,
        })
        .collect()
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

/// Fills as much of `buf` as the body holds: how many bytes that is.
fn fill(body: &mut impl Read, buf: &mut [u8]) -> Result<usize, FileProblem> {
    let mut got = 0;
    while got < buf.len() {
        match body.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(FileProblem::io(e)),
        }
    }
    Ok(got)
}

/// The truncation of vertex `i` of `count`.
fn truncated(i: usize, count: usize) -> FileProblem {
    FileProblem::at(
        Location::Vertex(i),
        format!("truncated: the body ends inside vertex {i} of the header's {count}"),
    )
}

/// `count` vertices of `stride` bytes each, a block at a time, each block's vertices turned by
/// `vertex(i, bytes)` on the rayon pool straight into `out`, in order, while the next block is
/// read beside them (reading is a third of the work, and on one thread).
fn fixed_vertices<T: Send>(
    body: &mut (impl Read + Send),
    count: usize,
    stride: usize,
    out: &mut Vec<T>,
    vertex: impl Fn(usize, &[u8]) -> T + Sync,
) -> Result<(), FileProblem> {
    let per_block = (BLOCK_BYTES / stride).max(1);
    let blocks = count.div_ceil(per_block);
    // Block b's bytes, as the header counts them.
    let want = |b: usize| per_block.min(count - b * per_block) * stride;
    let mut this = vec![0; per_block.min(count) * stride];
    let mut next = this.clone();
    let mut got = match blocks {
        0 => 0,
        _ => fill(body, &mut this[..want(0)])?,
    };
    for b in 0..blocks {
        let first = b * per_block;
        let whole = &this[..got - got % stride];
        let (read, ()) = rayon::join(
            || match b + 1 < blocks {
                true => fill(body, &mut next[..want(b + 1)]),
                false => Ok(0),
            },
            || {
                out.par_extend(
                    (whole.par_chunks_exact(stride).with_min_len(TASK_VERTICES))
                        .enumerate()
                        .map(|(k, v)| vertex(first + k, v)),
                )
            },
        );
        if got < want(b) {
            return Err(truncated(first + got / stride, count));
        }
        got = read?;
        std::mem::swap(&mut this, &mut next);
    }
    Ok(())
}

/// Vertices with lists among their properties, one at a time.
fn listed_vertices<T>(
    body: &mut impl BufRead,
    v: &Element,
    columns: &Columns,
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T,
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
        out.push(make(i, &columns.sphere(columns.fields(&values))));
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
    layout: &Layout,
    out: &mut Vec<T>,
    make: impl Fn(usize, &SphereSpec) -> T,
    listing: &mut Listing,
) -> Result<(), FileProblem> {
    let Layout {
        elements,
        vertex,
        columns,
        first_line,
        last,
    } = *layout;
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
        Ok(columns.sphere(columns.fields(values)))
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
        out.push(make(taken, &sphere));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::Triple;

    /// A file's spheres as read, and its listing; or its first problem.
    type Read = Result<(Vec<SphereSpec>, Listing), FileProblem>;

    fn first(out: Vec<SphereSpec>, listing: Listing) -> Read {
        assert_eq!(out.len(), listing.count);
        match listing.problems.first() {
            Some((_, e)) => Err(e.clone()),
            None => Ok((out, listing)),
        }
    }

    fn csv(bytes: &[u8]) -> Read {
        let mut out = Vec::new();
        let listing = super::csv(bytes, &mut out, |_, s| s.clone());
        first(out, listing)
    }

    fn ply(bytes: &[u8]) -> Read {
        let mut out = Vec::new();
        let listing = super::ply(bytes, &mut out, |_, s| s.clone());
        first(out, listing)
    }

    /// Every problem of a file, with the spheres read before each.
    fn problems(listing: Listing) -> Vec<(usize, Option<Location>, String)> {
        (listing.problems.into_iter())
            .map(|(i, e)| (i, e.at, e.message))
            .collect()
    }

    fn sphere(c: Triple, r: f64, color: Option<Triple>) -> SphereSpec {
        SphereSpec {
            center: c,
            radius: r,
            color,
        }
    }

    #[test]
    fn csv_with_and_without_colours() {
        let (s, listing) = csv(b"x,y,z,radius\n1,2,3,0.5\n\n-1e3, .5, 7., 2\n").unwrap();
        assert_eq!(
            s,
            [
                sphere((1.0, 2.0, 3.0), 0.5, None),
                sphere((-1000.0, 0.5, 7.0), 2.0, None)
            ]
        );
        assert_eq!(listing.location(1), Location::Line(4));
        let (s, listing) = csv(b"x, y, z, radius, r, g, b\r\n0,0,0,1,0.25,0.5,1\r\n").unwrap();
        assert_eq!(s, [sphere((0.0, 0.0, 0.0), 1.0, Some((0.25, 0.5, 1.0)))]);
        assert_eq!(listing.location(0), Location::Line(2));
        for (bad, at) in [
            (&b"x,y,radius\n"[..], Some(Location::Line(1))),
            (b"x,y,z,radius\n1,2,3\n", Some(Location::Line(2))),
            (b"x,y,z,radius\n1,2,3,4\n1,2,x,4\n", Some(Location::Line(3))),
            (b"", None),
        ] {
            assert_eq!(
                csv(bad).unwrap_err().at,
                at,
                "{}",
                String::from_utf8_lossy(bad)
            );
        }
    }

    fn header(format: &str, props: &str, n: usize) -> Vec<u8> {
        format!(
            "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {n}\n{props}end_header\n"
        )
        .into_bytes()
    }

    #[test]
    fn ply_ascii_and_binary_read_the_same_spheres() {
        let props = "property float x\nproperty float y\nproperty double z\nproperty double radius\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty list uchar int extra\n";
        let mut ascii = header("ascii", props, 2);
        ascii.extend_from_slice(b"1.5 -2 3.25 0.5 255 128 0 2 7 8\n0 0 0.1 1 0 0 0 0\n");
        let mut bin = header("binary_little_endian", props, 2);
        for (x, y, z, r, c, list) in [
            (
                1.5f32,
                -2f32,
                3.25f64,
                0.5f64,
                [255u8, 128, 0],
                vec![7i32, 8],
            ),
            (0.0, 0.0, 0.1, 1.0, [0, 0, 0], vec![]),
        ] {
            bin.extend(x.to_le_bytes());
            bin.extend(y.to_le_bytes());
            bin.extend(z.to_le_bytes());
            bin.extend(r.to_le_bytes());
            bin.extend(c);
            bin.push(list.len() as u8);
            for v in list {
                bin.extend(v.to_le_bytes());
            }
        }
        let want = [
            sphere((1.5, -2.0, 3.25), 0.5, Some((1.0, 128.0 / 255.0, 0.0))),
            sphere((0.0, 0.0, 0.1), 1.0, Some((0.0, 0.0, 0.0))),
        ];
        assert_eq!(ply(&ascii).unwrap().0, want);
        assert_eq!(ply(&bin).unwrap().0, want);
        // Truncated: the last byte gone.
        bin.pop();
        let e = ply(&bin).unwrap_err();
        assert_eq!(e.at, Some(Location::Vertex(1)), "{e:?}");
        assert!(e.message.contains("truncated"));
    }

    #[test]
    fn ply_problems_name_what_is_missing() {
        let e = ply(&header(
            "ascii",
            "property float x\nproperty float y\nproperty float z\n",
            0,
        ))
        .unwrap_err();
        assert!(e.message.contains("no property radius"), "{e:?}");
        let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let mut short = header("ascii", props, 1);
        short.extend_from_slice(b"1 2 3\n");
        let e = ply(&short).unwrap_err();
        assert_eq!(e.at, Some(Location::Line(10)), "{e:?}");
        assert!(e.message.contains("short row"), "{e:?}");
        assert!(ply(&header("binary_big_endian", props, 0))
            .unwrap_err()
            .message
            .contains("binary_big_endian"));
        assert!(ply(b"PLY\n").is_err());
    }

    /// A binary body of several blocks: every vertex handed over once, with its own index, in
    /// file order; a body that ends early names the vertex it ends in, past the first block.
    #[test]
    fn binary_blocks_keep_file_order_and_name_the_cut_vertex() {
        let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let n = 2 * BLOCK_BYTES / 16 + 5;
        let mut bin = header("binary_little_endian", props, n);
        let value = |i: usize, k: usize| (i * 4 + k) as f32;
        for i in 0..n {
            for k in 0..4 {
                bin.extend(value(i, k).to_le_bytes());
            }
        }
        let mut out = Vec::new();
        let listing = super::ply(&bin, &mut out, |i, s| (i, s.clone()));
        assert_eq!(listing.problems, []);
        assert_eq!((listing.count, out.len()), (n, n));
        for (k, (i, s)) in out.iter().enumerate() {
            let v = |j| f64::from(value(k, j));
            assert_eq!((*i, s), (k, &sphere((v(0), v(1), v(2)), v(3), None)));
        }
        // Cut inside vertex n - 4, in the third block.
        bin.truncate(bin.len() - 3 * 16 - 1);
        let e = ply(&bin).unwrap_err();
        assert_eq!(e.at, Some(Location::Vertex(n - 4)), "{e:?}");
        assert_eq!(
            e.message,
            format!(
                "truncated: the body ends inside vertex {} of the header's {n}",
                n - 4
            )
        );
    }

    /// Elements before the vertices are read past, whole records or list by list; a body that
    /// ends inside them names the element.
    #[test]
    fn binary_elements_before_the_vertices_are_read_past() {
        let text = "ply\nformat binary_little_endian 1.0\nelement camera 2\nproperty double t\nproperty uchar k\nelement face 2\nproperty list uchar ushort idx\nproperty char f\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nproperty double radius\nend_header\n";
        let mut bin = text.as_bytes().to_vec();
        for (t, k) in [(0.5f64, 1u8), (1.5, 2)] {
            bin.extend(t.to_le_bytes());
            bin.push(k);
        }
        for list in [&[1u16, 2, 3][..], &[]] {
            bin.push(list.len() as u8);
            for v in list {
                bin.extend(v.to_le_bytes());
            }
            bin.push(7);
        }
        for v in [1.0f64, 2.0, 3.0, 0.25] {
            bin.extend(v.to_le_bytes());
        }
        assert_eq!(ply(&bin).unwrap().0, [sphere((1.0, 2.0, 3.0), 0.25, None)]);
        let camera_end = text.len() + 2 * 9;
        for (cut, want) in [
            (text.len() + 9 + 4, "element camera 1 "),
            (camera_end + 1 + 2, "element face 0 "),
            (camera_end + 1 + 6 + 1 + 1, "element face 1 "),
        ] {
            let e = ply(&bin[..cut]).unwrap_err();
            assert!(e.message.contains(want), "{cut}: {e:?}");
            assert_eq!(e.at, None);
        }
    }

    /// The unkind forms: a header without `end_header` before a long body, `end_header` at
    /// the very end, an element without properties, ASCII values of the declared type (a
    /// `float` as a binary body stores it), negative and float list counts, bytes that are not
    /// UTF-8 where they are read and where they are not; every message short.
    #[test]
    fn unkind_ply_and_csv_forms() {
        let short = |e: FileProblem| {
            assert!(e.message.len() < 200, "{e:?}");
            e
        };
        let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        // No end_header: the body's first "line" is cut at HEADER_LINE_BYTES, named, not quoted.
        let mut cut = b"ply\nformat binary_little_endian 1.0\nelement vertex 9\n".to_vec();
        cut.extend(xyzr.as_bytes());
        cut.extend(vec![7u8; 3 * HEADER_LINE_BYTES]);
        cut.push(b'\n');
        let e = short(ply(&cut).unwrap_err());
        assert_eq!(e.at, Some(Location::Line(8)), "{e:?}");
        assert!(e.message.contains("end_header"), "{e:?}");
        assert!(short(ply(&[b'x'; 2 * HEADER_LINE_BYTES]).unwrap_err())
            .message
            .contains("not a PLY file"));
        // end_header ending the file, no newline.
        let mut end = header("binary_little_endian", xyzr, 0);
        end.pop();
        assert_eq!(ply(&end).unwrap().1.count, 0);
        // An element without properties before the vertices takes no line.
        let text = format!("ply\nformat ascii 1.0\nelement marker 3\nelement vertex 1\n{xyzr}end_header\n\n1 2 3 4\n");
        assert_eq!(
            ply(text.as_bytes()).unwrap().0,
            [sphere((1.0, 2.0, 3.0), 4.0, None)]
        );
        // A float in ASCII is the f32 a binary body holds.
        let mut ascii = header("ascii", xyzr, 1);
        ascii.extend(b"0.1 0.2 0.3 0.7\n");
        let mut bin = header("binary_little_endian", xyzr, 1);
        for v in [0.1f32, 0.2, 0.3, 0.7] {
            bin.extend(v.to_le_bytes());
        }
        let f = |v: f32| f64::from(v);
        let want = [sphere((f(0.1), f(0.2), f(0.3)), f(0.7), None)];
        assert_eq!(ply(&ascii).unwrap().0, want);
        assert_eq!(ply(&bin).unwrap().0, want);
        // An integer property takes only integers in its range.
        for (props, row, field) in [
            (
                "property int x\nproperty float y\nproperty float z\nproperty float radius\n",
                "0.5 0 0 1",
                "x: not a value of type int",
            ),
            (
                "property float x\nproperty float y\nproperty float z\nproperty uchar radius\n",
                "0 0 0 300",
                "radius: not a value of type uchar",
            ),
        ] {
            let mut text = header("ascii", props, 1);
            text.extend(row.as_bytes());
            let e = short(ply(&text).unwrap_err());
            assert!(e.message.contains(field), "{e:?}");
        }
        // List counts: negative in binary and ASCII, or of a float type.
        let listed = format!("{xyzr}property list char float extra\n");
        let mut bin = header("binary_little_endian", &listed, 1);
        for v in [0.0f32, 0.0, 0.0, 1.0] {
            bin.extend(v.to_le_bytes());
        }
        bin.push(0xff);
        let e = ply(&bin).unwrap_err();
        assert_eq!(e.at, Some(Location::Vertex(0)), "{e:?}");
        assert!(e.message.contains("negative list count"), "{e:?}");
        let mut ascii = header("ascii", &listed, 1);
        ascii.extend(b"0 0 0 1 -1\n");
        assert!(ply(&ascii).unwrap_err().message.contains("0 or more"));
        let floaty = header(
            "ascii",
            &format!("{xyzr}property list float int extra\n"),
            0,
        );
        assert!(ply(&floaty).unwrap_err().message.contains("integer type"));
        // Bytes that are not UTF-8: named on a vertex's line, not read after the vertices.
        let tail = format!("ply\nformat ascii 1.0\nelement vertex 1\n{xyzr}element note 1\nproperty uchar n\nend_header\n0 0 0 1\n");
        let mut after = tail.into_bytes();
        after.extend(b"\xe9\n");
        assert_eq!(ply(&after).unwrap().1.count, 1);
        let mut inside = header("ascii", xyzr, 2);
        inside.extend(b"0 0 0 1\n0 0 0 1 \xe9\n");
        let e = ply(&inside).unwrap_err();
        assert_eq!(e.at, Some(Location::Line(11)), "{e:?}");
        assert!(e.message.contains("UTF-8"), "{e:?}");
        // With no vertices nothing after the header is read; a CRLF header line of the most
        // bytes is whole; an integer `-0` is 0.
        let mut none = format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}element note 1\nproperty uchar k\nend_header\n").into_bytes();
        none.extend(vec![b'7'; BLOCK_BYTES + 10]);
        assert_eq!(ply(&none).unwrap().1.count, 0);
        let comment = format!("comment {}", "c".repeat(HEADER_LINE_BYTES - 8));
        let mut crlf = format!(
            "ply\r\nformat ascii 1.0\r\n{comment}\r\nelement vertex 1\r\n{}end_header\r\n",
            xyzr.replace('\n', "\r\n")
        )
        .into_bytes();
        crlf.extend(b"1 2 3 4\r\n");
        assert_eq!(ply(&crlf).unwrap().0, [sphere((1.0, 2.0, 3.0), 4.0, None)]);
        let uchar = "property float x\nproperty float y\nproperty float z\nproperty uchar radius\n";
        let mut zero = header("ascii", uchar, 1);
        zero.extend(b"0 0 0 -0\n");
        assert_eq!(ply(&zero).unwrap().0[0].radius, 0.0);
        // Blank is ASCII whitespace alone, before the vertices and among them: a line of a
        // no-break space is a record in both.
        let mut before = format!("ply\nformat ascii 1.0\nelement note 1\nproperty uchar k\nelement vertex 1\n{xyzr}end_header\n").into_bytes();
        before.extend("\u{a0}\n1 2 3 4\n".as_bytes());
        assert_eq!(ply(&before).unwrap().1.count, 1);
        let mut among = header("ascii", xyzr, 2);
        among.extend("1 2 3 4\n\u{a0}\n1 2 3 4\n".as_bytes());
        assert_eq!(ply(&among).unwrap_err().at, Some(Location::Line(11)));
        // A vertex line of a whole block: whole when the file ends with it, else refused.
        let mut long = header("ascii", xyzr, 1);
        let body = long.len();
        long.extend(b"1 2 3 4");
        long.resize(body + BLOCK_BYTES, b' ');
        assert_eq!(ply(&long).unwrap().1.count, 1);
        long.push(b'\n');
        let e = short(ply(&long).unwrap_err());
        assert!(e.message.contains("4 MiB or more"), "{e:?}");
        // CSV: a header line is quoted short, and lines ending in a lone CR are named.
        let mut cr = b"x,y,z,radius".to_vec();
        for _ in 0..1000 {
            cr.extend(b"\r1,2,3,4");
        }
        let e = short(csv(&cr).unwrap_err());
        assert!(e.message.contains("CR alone"), "{e:?}");
    }

    /// A text body of three blocks, read on the pool: every sphere once, in file order, with
    /// its line past blank lines and lines cut by a block's end; the first bad line named
    /// however the blocks fall, in CSV and in ASCII PLY; what follows the last vertex of an
    /// ASCII PLY never read.
    #[test]
    fn text_blocks_keep_file_order_and_name_the_first_bad_line() {
        let n = 2 * BLOCK_BYTES / 10 + 1234;
        let blank = |i: usize| i % 1000 == 7;
        let mut csv_text = String::from("x,y,z,radius\n");
        let mut ply_rows = String::new();
        let mut line_of = Vec::new();
        let mut line = 1;
        for i in 0..n {
            if blank(i) {
                csv_text.push_str(" \r\n");
                ply_rows.push('\n');
                line += 1;
            }
            line += 1;
            line_of.push(line);
            csv_text.push_str(&format!("{i},0,0,1\n"));
            ply_rows.push_str(&format!("{i} 0 0 1\n"));
        }
        let (spheres, listing) = csv(csv_text.as_bytes()).unwrap();
        assert_eq!(spheres.len(), n);
        for (i, s) in spheres.iter().enumerate() {
            assert_eq!(s.center.0, i as f64);
            assert_eq!(listing.location(i), Location::Line(line_of[i]));
        }
        // Two bad rows past the first block: the first is named.
        let (a, b) = (n / 2, n - 3);
        let bad = csv_text
            .replacen(&format!("\n{a},0,0,1\n"), &format!("\n{a},0,zero,1\n"), 1)
            .replacen(&format!("\n{b},0,0,1\n"), &format!("\n{b},0\n"), 1);
        let e = csv(bad.as_bytes()).unwrap_err();
        assert_eq!(e.at, Some(Location::Line(line_of[a])), "{e:?}");
        assert_eq!(e.message, "z: not a number: \"zero\"");

        let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let mut ply_text =
            format!("ply\nformat ascii 1.0\nelement vertex {n}\n{xyzr}element note 2\nproperty uchar k\nend_header\n").into_bytes();
        let header_lines = 10;
        ply_text.extend(ply_rows.as_bytes());
        ply_text.extend(b"\xff\xfe not text\nnor this\n");
        let (spheres, listing) = ply(&ply_text).unwrap();
        assert_eq!((spheres.len(), listing.count), (n, n));
        assert!(spheres
            .iter()
            .enumerate()
            .all(|(i, s)| s.center.0 == i as f64));
        // A bad vertex past the first block, named by its line and index.
        let row = format!("\n{a} 0 0 1\n");
        let at = ply_text
            .windows(row.len())
            .position(|w| w == row.as_bytes())
            .unwrap();
        let mut bad = ply_text.clone();
        bad[at + 1] = b'#';
        let e = ply(&bad).unwrap_err();
        assert_eq!(
            e.at,
            Some(Location::Line(header_lines + line_of[a] - 1)),
            "{e:?}"
        );
        assert!(
            e.message
                .starts_with(&format!("vertex {a}: x: not a number")),
            "{e:?}"
        );
        // The last vertex gone: named as missing, not the lines after it as vertices.
        let cut = ply_text.len() - b"\xff\xfe not text\nnor this\n".len();
        let mut short = ply_text[..cut].to_vec();
        short.truncate(short.len() - format!("{} 0 0 1\n", n - 1).len());
        let e = ply(&short).unwrap_err();
        assert_eq!(e.at, Some(Location::Vertex(n - 1)), "{e:?}");
    }

    /// Rows that cannot be read are named and passed, so every one is found; a CSV's spheres
    /// after them keep their lines, an ASCII PLY's vertices their numbers (a stand-in holds
    /// the bad vertex's place).
    #[test]
    fn every_bad_row_is_named_and_the_rest_still_read() {
        let mut out = Vec::new();
        let text = b"x,y,z,radius\n0,0,0,1\nfoo,0,0,1\n\n0,0,0,2\n0,0\n\xe9\n0,0,0,3\n";
        let listing = super::csv(text, &mut out, |_, s| s.radius);
        assert_eq!(out, [1.0, 2.0, 3.0]);
        assert_eq!(
            (1..3).map(|i| listing.location(i)).collect::<Vec<_>>(),
            [Location::Line(5), Location::Line(8)]
        );
        let line = |l| Some(Location::Line(l));
        assert_eq!(
            problems(listing),
            [
                (1, line(3), "x: not a number: \"foo\"".to_string()),
                (
                    2,
                    line(6),
                    "expected 4 fields (x,y,z,radius), got 2".to_string()
                ),
                (2, line(7), "not UTF-8 text".to_string()),
            ]
        );
        let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let mut ascii = header("ascii", xyzr, 5);
        ascii.extend(b"0 0 0 1\n0 0 zz 1\n0 0 0 2\n0 0\n0 0 0 3\n");
        let mut out = Vec::new();
        let listing = super::ply(&ascii, &mut out, |i, s| (i, s.radius));
        assert_eq!(out, [(0, 1.0), (1, 1.0), (2, 2.0), (3, 1.0), (4, 3.0)]);
        assert_eq!(listing.location(4), Location::Vertex(4));
        assert_eq!(
            problems(listing),
            [
                (1, line(11), "vertex 1: z: not a number: \"zz\"".to_string()),
                (
                    3,
                    line(13),
                    "vertex 3: a short row: no value for z".to_string()
                ),
            ]
        );
    }

    /// What a header may hold once is refused twice; a long comment is read past; nothing
    /// may follow the vertices when no element does; a BOM before a blank line, and lines
    /// ending in CR alone, are named as such.
    #[test]
    fn ambiguous_headers_and_stray_data_are_refused() {
        let xyzr = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        for (text, want) in [
            (
                format!("ply\nformat ascii 1.0\nformat binary_little_endian 1.0\nelement vertex 0\n{xyzr}end_header\n"),
                "a second `format` line (the first is line 2)",
            ),
            (
                format!("ply\nformat ascii 2.0\nelement vertex 0\n{xyzr}end_header\n"),
                "format version \"2.0\": PLY 1.0 is read",
            ),
            (
                format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}element vertex 2\n{xyzr}end_header\n"),
                "a second `element vertex` line (the first is line 3)",
            ),
            (
                format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}property double radius\nend_header\n"),
                "element vertex has a second property \"radius\"",
            ),
            (
                format!("ply\nformat ascii 1.0\nelement vertex 0\n{xyzr}property list uchar int x\nend_header\n"),
                "element vertex has a second property \"x\"",
            ),
            (
                "ply\rformat ascii 1.0\relement vertex 0\rend_header\r".to_string(),
                "its lines end in CR alone",
            ),
        ] {
            let e = ply(text.as_bytes()).unwrap_err();
            assert!(e.message.contains(want), "{want:?}: {e:?}");
        }
        // A comment and an obj_info line of 5,000 bytes, in ASCII and binary.
        let long = |w: &str| format!("{w} {}\n", "{\"meta\":1}".repeat(500));
        for format in ["ascii", "binary_little_endian"] {
            let mut text = format!(
                "ply\nformat {format} 1.0\n{}{}element vertex 1\n{xyzr}end_header\n",
                long("comment"),
                long("obj_info")
            )
            .into_bytes();
            match format {
                "ascii" => text.extend(b"1 2 3 4\n"),
                _ => (1..5).for_each(|v| text.extend((v as f32).to_le_bytes())),
            }
            assert_eq!(ply(&text).unwrap().0, [sphere((1.0, 2.0, 3.0), 4.0, None)]);
        }
        let mut long_element = header("ascii", xyzr, 0);
        long_element.splice(4..4, long("element").bytes());
        assert!(ply(&long_element)
            .unwrap_err()
            .message
            .contains("longer than"));
        // More vertices than the header's count, with no element after them.
        let mut ascii = header("ascii", xyzr, 1);
        ascii.extend(b"1 2 3 4\n\n  \n5 6 7 8\n");
        let e = ply(&ascii).unwrap_err();
        assert_eq!(e.at, Some(Location::Line(13)), "{e:?}");
        assert_eq!(
            e.message,
            "a row past the header's vertex count (1): is the count right?"
        );
        ascii.truncate(ascii.len() - 8);
        assert_eq!(ply(&ascii).unwrap().1.count, 1);
        let mut bin = header("binary_little_endian", xyzr, 1);
        (0..8).for_each(|v| bin.extend((v as f32).to_le_bytes()));
        let e = ply(&bin).unwrap_err();
        assert!(
            e.message
                .contains("goes on past the header's vertex count (1)"),
            "{e:?}"
        );
        // What follows the vertices is the next element's, and not read.
        let mut face = header(
            "binary_little_endian",
            &format!("{xyzr}element face 1\nproperty uchar k\n"),
            1,
        );
        (0..8).for_each(|v| face.extend((v as f32).to_le_bytes()));
        assert_eq!(ply(&face).unwrap().1.count, 1);
        // A comment of exactly the most bytes and one or two more, with LF and with CRLF.
        for len in HEADER_LINE_BYTES - 1..HEADER_LINE_BYTES + 3 {
            for end in ["\n", "\r\n"] {
                let comment = format!("comment {}{end}", "c".repeat(len - 8));
                let mut text =
                    format!("ply\nformat ascii 1.0\n{comment}element vertex 1\n{xyzr}end_header\n")
                        .into_bytes();
                text.extend(b"1 2 3 4\n");
                assert_eq!(ply(&text).unwrap().1.count, 1, "{len} {end:?}");
            }
        }
        // Lines that end in CR alone, in a file of many lines.
        let mut cr = format!(
            "ply\rformat ascii 1.0\relement vertex 2000\r{}end_header\r",
            xyzr.replace('\n', "\r")
        )
        .into_bytes();
        (0..2000).for_each(|_| cr.extend(b"1 2 3 4\r"));
        assert!(ply(&cr).unwrap_err().message.contains("CR alone"));
        // A file of many unreadable rows: the first hundred named, the rest counted.
        let mut rows = String::from("x,y,z,radius\n");
        (0..250).for_each(|i| rows.push_str(&format!("{i};0;0;1\n")));
        let mut out = Vec::new();
        let listing = super::csv(rows.as_bytes(), &mut out, |_, s| s.radius);
        let named = problems(listing);
        assert_eq!(named.len(), PROBLEMS_SHOWN);
        assert_eq!(named[98].1, Some(Location::Line(100)));
        assert_eq!(
            named[99],
            (0, None, "and 151 more row(s) that cannot be read".into())
        );
        // A byte-order mark, then a blank line, then the header.
        let (s, _) = csv(b"\xef\xbb\xbf\nx,y,z,radius\n0,0,0,1\n").unwrap();
        assert_eq!(s.len(), 1);
    }

    /// [`text_f64`] and [`text_f32`] give what `from_str` gives, bit for bit, and refuse what
    /// it refuses: every short field of number, infinity and NaN characters, and others.
    #[test]
    fn text_numbers_are_what_from_str_reads() {
        let check = |field: &str| {
            let std = field.parse::<f64>().ok().map(f64::to_bits);
            assert_eq!(text_f64(field).map(f64::to_bits), std, "{field:?}");
            let std = field.parse::<f32>().ok().map(f32::to_bits);
            assert_eq!(text_f32(field).map(f32::to_bits), std, "{field:?}");
        };
        for (alphabet, longest) in [(&b"0159.eE+-"[..], 6), (b"09.eE+-infatyNIx(", 5)] {
            for len in 0..=longest {
                super::super::each_string(alphabet, len, check);
            }
        }
        for field in [
            "inf",
            "-Infinity",
            "+NaN",
            "nan",
            "0.30000000000000004",
            "2.2250738585072011e-308",
            "4.9406564584124654e-324",
            "1.7976931348623157e308",
            "1.7976931348623159e308",
            "3.4028235e38",
            "3.4028236e38",
            "1e-46",
            "0.1",
            "9007199254740993",
            "18446744073709551616",
            "1e-400",
            "0x10",
            "1_000",
            " 1",
            "١",
            "infinity",
            "-INFINITY",
            "nan(1)",
            "infinit",
        ] {
            check(field);
        }
    }
}
