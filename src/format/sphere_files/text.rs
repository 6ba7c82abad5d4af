//! A text body (CSV's, an ASCII PLY's): one record a line, read in blocks ([`Blocks`]), each
//! block's lines parsed in pieces on the pool and handed over in file order; and the numbers of
//! its fields.

use std::io::Read;

use rayon::prelude::*;

use super::header::CR_ALONE;
use super::listing::FileProblem;
use super::BLOCK_BYTES;
use crate::format::blocks::{self, Blocks};

/// A text field's number (CSV, and an ASCII PLY's `double`): the value `f64::from_str` gives,
/// and only where it gives one. A finite value from `fast_float2` (correctly rounded, so the
/// same bits, and faster) is taken; anything else it gives or refuses
/// (`inf`, `NaN`, an error) goes to `from_str`. The tests check the two agree over every field
/// of up to five characters of numbers, infinities and NaNs, and six of digits alone.
pub(super) fn text_f64(field: &str) -> Option<f64> {
    match fast_float2::parse::<f64, _>(field) {
        Ok(v) if v.is_finite() => Some(v),
        _ => field.parse().ok(),
    }
}

/// [`text_f64`] for an ASCII PLY's `float`: the value `f32::from_str` gives.
pub(super) fn text_f32(field: &str) -> Option<f32> {
    match fast_float2::parse::<f32, _>(field) {
        Ok(v) if v.is_finite() => Some(v),
        _ => field.parse().ok(),
    }
}

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
pub(super) struct Rows {
    /// The body's first line's number.
    pub first_line: usize,
    /// How many records there are (`usize::MAX`: to the end).
    pub count: usize,
    /// Whether only blank lines may follow the last record (else what follows is another
    /// element's, and never read).
    pub rest_blank: bool,
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
pub(super) fn text_records<R: Send>(
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
    let end = blocks::read(body, &mut this, BLOCK_BYTES).map_err(io)?;
    let mut blocks = Blocks::new(body, this, end);
    loop {
        // The block's whole lines: up to its last line end, or all of it at the end. A full
        // block without a line end is one line, whole only if the body ends with it.
        let this = &blocks.this;
        let last_end = this.iter().rposition(|&b| b == b'\n');
        if last_end.is_none() && !blocks.ended().map_err(io)? {
            let cr = match blocks.this.contains(&b'\r') {
                true => format!(": {CR_ALONE}"),
                false => String::new(),
            };
            let what = format!("a line of {} MiB or more{cr}", BLOCK_BYTES >> 20);
            return Err(problem(taken, before + 1, what));
        }
        let (end, len) = (blocks.end, blocks.this.len());
        let cut = match (end, last_end) {
            (false, Some(k)) => k + 1,
            _ => len,
        };
        let want = (!end).then(|| BLOCK_BYTES - (len - cut));
        let parse_lines = |block: &[u8]| parse_lines(&block[..cut], blank, &parse);
        let (read, pieces) = blocks.turn(cut, want, parse_lines, |_, _| ());
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
        read.map_err(io)?;
    }
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
