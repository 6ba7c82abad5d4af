//! The header lines of a text: PLY's, and CSV's first; each at most [`HEADER_LINE_BYTES`].

use std::io::{BufRead, Read};

use super::listing::{FileProblem, Location};

/// The longest header line read (PLY's, CSV's), without its line end: a header line is a few
/// words, and a PLY whose `end_header` is missing is cut here, not read whole into one line. A
/// PLY `comment` or `obj_info` line may be longer: what follows this is read past.
pub(super) const HEADER_LINE_BYTES: usize = 4096;

/// `text` quoted for a message, cut after 60 characters: a line of a body read as a header
/// is named, not printed whole.
pub(super) fn quoted(text: &str) -> String {
    match text.char_indices().nth(60) {
        Some((cut, _)) => format!("{:?}…", &text[..cut]),
        None => format!("{text:?}"),
    }
}

/// A text header's lines (PLY's, and CSV's first), each at most [`HEADER_LINE_BYTES`]; the
/// last may end the file without a line end.
pub(super) struct HeaderLines {
    /// Lines read.
    pub line: usize,
    raw: Vec<u8>,
    /// What a line too long suggests, when its lines do not end in CR alone.
    suggest: &'static str,
    /// Whether a longer line that starts `comment` or `obj_info` is taken, cut (PLY's).
    comments: bool,
}

impl HeaderLines {
    pub fn new(suggest: &'static str, comments: bool) -> HeaderLines {
        HeaderLines {
            line: 0,
            raw: Vec::new(),
            suggest,
            comments,
        }
    }

    /// The next line and its number, trimmed (bytes that are not UTF-8 replaced); None at the
    /// end of the file.
    pub fn next(&mut self, file: &mut dyn BufRead) -> Result<Option<(usize, String)>, FileProblem> {
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
                file.skip_until(b'\n').map_err(FileProblem::io)?;
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

/// What a text whose lines end in CR alone is told.
pub(super) const CR_ALONE: &str = "its lines end in CR alone: save it with LF or CRLF line endings";
