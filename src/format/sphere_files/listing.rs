//! Where a sphere or a problem is in its file, and what a file gave: its count and problems.

use std::io;

use super::Sink;
use crate::error::PROBLEMS_SHOWN;

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
    pub(super) fn at(at: Location, message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: Some(at),
            message: message.into(),
        }
    }

    pub(super) fn whole(message: impl Into<String>) -> FileProblem {
        FileProblem {
            at: None,
            message: message.into(),
        }
    }

    pub(super) fn io(e: io::Error) -> FileProblem {
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
    pub(super) lines: Vec<u32>,
    /// The line of the first sphere in a text file, or None for PLY vertices.
    pub(super) first_line: Option<usize>,
    /// What is wrong with the file's form, each with the number of spheres read before it, in
    /// file order: the rows that could not be read (passed, so that the rest are read and
    /// checked too; an ASCII PLY's keeps its vertex's place with a stand-in sphere), then what
    /// ended the reading early, if anything.
    pub problems: Vec<(usize, FileProblem)>,
    /// The file's columns that no field reads, as its header names them.
    pub ignored: Vec<String>,
    /// Rows that could not be read past the first [`PROBLEMS_SHOWN`] − 1 named: counted, not
    /// kept (a file of a million bad rows costs no message a row), and named as a count in
    /// the hundredth place, which a message shows.
    unlisted: usize,
}

impl Listing {
    /// Notes a row that cannot be read, after `before` spheres.
    pub(super) fn unreadable(&mut self, before: usize, problem: FileProblem) {
        match self.problems.len() < PROBLEMS_SHOWN - 1 {
            true => self.problems.push((before, problem)),
            false => self.unlisted += 1,
        }
    }

    /// Counts `n` rows that cannot be read, past those named.
    pub(super) fn unreadable_unnamed(&mut self, n: usize) {
        self.unlisted += n;
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

/// The listing of what `reader` appends to `out`: its count, and the problem that ended it
/// after those it read past.
pub(super) fn listed<T, S: Sink<T>>(
    out: &mut S,
    reader: impl FnOnce(&mut S, &mut Listing) -> Result<(), FileProblem>,
) -> Listing {
    let start = out.count();
    let mut listing = Listing::default();
    let ended = reader(out, &mut listing);
    listing.count = out.count() - start;
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
