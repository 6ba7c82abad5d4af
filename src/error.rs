//! Typed errors: each says where the problem is (file, line and column, field, frame time) and what
//! is wrong. The binary prints the whole chain and maps [`Error::is_bad_input`] to exit status 2.

use std::fmt;
use std::path::PathBuf;

/// One problem found while checking a keyframe file, named by the field it concerns.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Dotted path of the field, e.g. `animate[1].keys[2].t`.
    pub field: String,
    /// What is wrong and, where it helps, what to do.
    pub message: String,
}

impl Problem {
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Problem {
            field: field.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

/// The problems of one file, printed one per line.
#[derive(Debug, Clone, PartialEq)]
pub struct Problems(pub Vec<Problem>);

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "  {p}")?;
        }
        Ok(())
    }
}

/// Everything that can go wrong in campath.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{}: cannot read: {cause}", path.display())]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{}:{line}:{col}: {message}", path.display())]
    Parse {
        path: PathBuf,
        /// 1-based line, as RON reports it.
        line: usize,
        /// 1-based column, as RON reports it.
        col: usize,
        message: String,
    },
    #[error("{}: {} problem(s):\n{problems}", path.display(), problems.0.len())]
    Invalid { path: PathBuf, problems: Problems },
    #[error("{}: frame {frame} (t = {time} s): {message}", path.display())]
    Frame {
        path: PathBuf,
        frame: u64,
        /// Frame time in seconds.
        time: f64,
        message: String,
    },
    /// A hashes.txt, golden file or part file that does not follow the manifest grammar.
    #[error("{}: {message}", path.display())]
    Manifest { path: PathBuf, message: String },
    /// `merge` refused: the parts do not make a whole sequence.
    #[error("{}: cannot merge, nothing written:{}", dir.display(), problems.iter().map(|p| format!("\n  - {p}")).collect::<String>())]
    Merge { dir: PathBuf, problems: Vec<String> },
    #[error("{}: cannot write: {cause}", path.display())]
    Write {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{}: cannot encode PNG: {cause}", path.display())]
    Encode {
        path: PathBuf,
        cause: image::ImageError,
    },
    #[error("{0}")]
    Usage(String),
    /// Another run holds the output folder (or, for a shard, its part of it); see
    /// [`crate::lock`].
    #[error("{} is being written by another campath run ({})", dir.display(), if holders.is_empty() { "its process id is not recorded".to_string() } else { holders.join("; ") })]
    Busy {
        dir: PathBuf,
        /// The runs in the way: process id, claim and command line.
        holders: Vec<String>,
    },
}

impl Error {
    /// True when the user's input is at fault (exit status 2); false for I/O failures.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Error::Parse { .. }
                | Error::Invalid { .. }
                | Error::Frame { .. }
                | Error::Manifest { .. }
                | Error::Merge { .. }
                | Error::Usage(_)
                | Error::Busy { .. }
        )
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// For `map_err`: a failure to read `path`.
    pub fn read(path: impl Into<PathBuf>) -> impl Fn(std::io::Error) -> Error {
        let path = path.into();
        move |cause| Error::Read {
            path: path.clone(),
            cause,
        }
    }

    /// For `map_err`: a failure to write `path`.
    pub fn write(path: impl Into<PathBuf>) -> impl Fn(std::io::Error) -> Error {
        let path = path.into();
        move |cause| Error::Write {
            path: path.clone(),
            cause,
        }
    }

    /// A write to standard output failed (the reader went away, or the disk is full).
    pub fn stdout(cause: std::io::Error) -> Error {
        Error::Write {
            path: "<stdout>".into(),
            cause,
        }
    }

    /// Whether this is a write to standard output whose reader went away (`… | head`).
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, Error::Write { path, cause }
            if cause.kind() == std::io::ErrorKind::BrokenPipe && path.as_os_str() == "<stdout>")
    }

    /// For `map_err`: a failure to encode the image `path`.
    pub fn encode(path: impl Into<PathBuf>) -> impl Fn(image::ImageError) -> Error {
        let path = path.into();
        move |cause| Error::Encode {
            path: path.clone(),
            cause,
        }
    }
}
