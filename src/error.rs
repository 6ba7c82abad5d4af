//! Typed errors: each says where the problem is (file, line and column, field, frame time) and what
//! is wrong. The binary prints the whole chain and maps [`Error::is_bad_input`] to exit status 2.

use std::fmt;
use std::path::PathBuf;

/// One problem found while checking a keyframe file, named by the field it concerns.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct Problem {
    /// Dotted path of the field, e.g. `animate[1].keys[2].t`.
    pub field: String,
    /// What is wrong and, where it helps, what to do.
    pub message: String,
}

impl Problem {
    /// A problem with the field at `field` (a dotted path).
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Problem {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// campath's result: [`Error`] by default.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The problems of one file, printed one per line.
#[derive(Debug, Clone, PartialEq)]
pub struct Problems(pub Vec<Problem>);

/// The most problems a message lists: a sphere file of a million bad radii is named by its
/// first ones and a count, not a million lines.
pub const PROBLEMS_SHOWN: usize = 100;

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.0.iter().take(PROBLEMS_SHOWN).enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "  {p}")?;
        }
        if let Some(more) = self.0.len().checked_sub(PROBLEMS_SHOWN).filter(|n| *n > 0) {
            write!(f, "\n  … and {more} more")?;
        }
        Ok(())
    }
}

/// Why campath will not write at a path. The command line adds which option named it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// A file stands where a folder goes: the path itself, or a folder above it.
    #[error("{} is a file, not a folder", .0.display())]
    NotAFolder(PathBuf),
    /// A folder stands where a file goes.
    #[error("{} is a folder: name the file to write", .0.display())]
    NotAFile(PathBuf),
    /// The path is, or lies inside, the golden `NAME.golden` of the shot `NAME.ron`.
    #[error("{} is the golden of {}", golden.display(), shot.display())]
    Golden {
        /// The golden folder.
        golden: PathBuf,
        /// The shot beside it.
        shot: PathBuf,
    },
    /// The path is, or lies inside, a golden the run compares with.
    #[error(
        "{} {} the golden {}",
        path.display(),
        if *inside { "lies inside" } else { "is" },
        golden.display()
    )]
    InGolden {
        /// The path.
        path: PathBuf,
        /// The golden.
        golden: PathBuf,
        /// Whether the path lies inside the golden rather than being it.
        inside: bool,
    },
    /// The folder's `hashes.txt` names campath's renderer and lists frames without keys, as the
    /// goldens campath writes do (an output folder's frames have keys).
    #[error(
        "{} is a golden: its hashes.txt names campath's renderer and lists frames without keys",
        .0.display()
    )]
    GoldenHashes(PathBuf),
    /// The path lies inside a folder of rendered frames, which would then hold a file or folder
    /// campath did not write there.
    #[error(
        "{} lies in {}, which is a folder of rendered frames",
        path.display(),
        frames.display()
    )]
    InFrames {
        /// The path.
        path: PathBuf,
        /// The folder of rendered frames.
        frames: PathBuf,
    },
    /// The folder holds files campath did not write there (the first three named).
    #[error("{} holds files campath did not write ({})", dir.display(), names.join(", "))]
    Foreign {
        /// The folder.
        dir: PathBuf,
        /// The first few of them.
        names: Vec<String>,
    },
}

impl Refusal {
    /// The path the refusal is about: the one asked about, or the folder above it that decides.
    pub fn subject(&self) -> &std::path::Path {
        match self {
            Refusal::NotAFolder(p) | Refusal::NotAFile(p) | Refusal::GoldenHashes(p) => p,
            Refusal::Golden { golden, .. } => golden,
            Refusal::InGolden { path, .. } | Refusal::InFrames { path, .. } => path,
            Refusal::Foreign { dir, .. } => dir,
        }
    }

    /// Whether the path is, or lies inside, a golden.
    pub fn is_golden(&self) -> bool {
        matches!(
            self,
            Refusal::Golden { .. } | Refusal::InGolden { .. } | Refusal::GoldenHashes(_)
        )
    }
}

impl From<Refusal> for Error {
    fn from(refusal: Refusal) -> Error {
        Error::Refused(refusal)
    }
}

/// Everything that can go wrong in campath.
///
/// An I/O or encoder failure's cause is part of the message and kept in the variant's `cause`
/// (match on it for the [`std::io::ErrorKind`]); `source()` does not return it again, so a
/// printer of the error chain says it once.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read (exit 1).
    #[error("{}: cannot read: {cause}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// The keyframe file is not RON of the file's shape, or not UTF-8.
    #[error("{}:{line}:{col}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line, as RON reports it.
        line: usize,
        /// 1-based column, as RON reports it.
        col: usize,
        /// What is wrong, in the file's words.
        message: String,
    },
    /// The keyframe file's values break its rules: every problem, by field.
    #[error("{}: {} problem(s):\n{problems}", path.display(), problems.0.len())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Every problem, in the file's order.
        problems: Problems,
    },
    /// The camera is undefined at a frame.
    #[error("{}: frame {frame} (t = {time} s): {message}", path.display())]
    Frame {
        /// The file.
        path: PathBuf,
        /// The frame, from 0.
        frame: u64,
        /// Frame time in seconds.
        time: f64,
        /// Why the camera is undefined.
        message: String,
    },
    /// A hashes.txt, golden file or part file that does not follow the manifest grammar.
    #[error("{}: {message}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// Where in it (line) and what is wrong.
        message: String,
    },
    /// `merge` refused: the parts do not make a whole sequence.
    #[error("{}: cannot merge, nothing written:{}", dir.display(), problems.iter().map(|p| format!("\n  - {p}")).collect::<String>())]
    Merge {
        /// The output folder.
        dir: PathBuf,
        /// Every missing or unfinished shard, and every damaged frame.
        problems: Vec<String>,
    },
    /// A file could not be written (exit 1).
    #[error("{}: cannot write: {cause}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        cause: std::io::Error,
    },
    /// A PNG could not be encoded (exit 1).
    #[error("{}: cannot encode PNG: {cause}", path.display())]
    Encode {
        /// The PNG.
        path: PathBuf,
        /// The encoder's error.
        cause: image::ImageError,
    },
    /// A camera source `import` cannot read, or that holds no camera campath can be (exit 2).
    #[error("{}: {message}", path.display())]
    Import {
        /// The source.
        path: PathBuf,
        /// Where in it and what is wrong.
        message: String,
    },
    /// A request that cannot be met: a path that is a file, a frame past the end (exit 2).
    #[error("{0}")]
    Usage(String),
    /// A path campath will not write (exit 2); nothing was written.
    #[error("{0}; nothing was written")]
    Refused(Refusal),
    /// Another run holds the output folder (or, for a shard, its part of it); see
    /// `output::lock`.
    #[error("{} is being written by another campath run ({})", dir.display(), if holders.is_empty() { "its process id is not recorded".to_string() } else { holders.join("; ") })]
    Busy {
        /// The output folder.
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
                | Error::Import { .. }
                | Error::Merge { .. }
                | Error::Usage(_)
                | Error::Refused(_)
                | Error::Busy { .. }
        )
    }

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
