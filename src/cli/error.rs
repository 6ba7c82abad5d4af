//! The command line's errors: the library's, plus bad options, outside programs and drawing.
//! Each kind has its exit status.

use std::path::{Path, PathBuf};

use crate::output::Refusal;

/// Everything that can go wrong in a `campath` command.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    #[error(transparent)]
    Campath(#[from] crate::Error),
    /// An option value that cannot be used (exit 2).
    #[error("{0}")]
    Usage(String),
    /// An outside program is missing or failed (exit 3).
    #[error("{0}: {1}")]
    Tool(&'static str, String),
    /// Stopped by Ctrl-C, what the run wrote removed (exit 130).
    #[error("{0}")]
    Stopped(String),
    /// A chart could not be drawn (exit 1).
    #[error("{}: cannot draw the chart: {message}", path.display())]
    Draw { path: PathBuf, message: String },
}

impl CliError {
    /// 2 for bad input or options, 3 for an outside program, 130 for a stop by a signal, 1 for
    /// the rest (I/O).
    pub fn exit_status(&self) -> u8 {
        match self {
            CliError::Campath(e) if e.is_bad_input() => 2,
            CliError::Usage(_) => 2,
            CliError::Tool(..) => 3,
            CliError::Stopped(_) => 130,
            _ => 1,
        }
    }

    /// A write to standard output whose reader went away: not an error for a pipeline.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, CliError::Campath(e) if e.is_broken_pipe())
    }

    /// The library's refusal of a path, in the command line's words: `option` names the path
    /// (`--out`, `DIR`), and the message says what to do. Other errors pass as they are.
    pub fn at(self, option: &str, path: &Path) -> CliError {
        match self {
            CliError::Campath(crate::Error::Refused(r)) => CliError::refused(option, path, &r),
            e => e,
        }
    }

    /// [`CliError::at`] of one refusal of `path`, which `option` names.
    pub fn refused(option: &str, path: &Path, refusal: &Refusal) -> CliError {
        let fix = match refusal {
            Refusal::NotAFolder(_) => format!("{option} names a folder"),
            Refusal::NotAFile(_) => format!("{option} names a file"),
            Refusal::InFrames { .. } => format!("choose {option} outside it"),
            Refusal::Foreign { .. } => format!("choose another {option} so nothing is clobbered"),
            // Golden refusals, and any the library adds later.
            _ => format!(
                "a golden is written only on approval, `campath test --update`; choose another \
                 {option}"
            ),
        };
        // An option is named before its path; the path, where a folder above it decides.
        let mut named = match option.starts_with('-') {
            true => format!("{option} "),
            false => String::new(),
        };
        if refusal.subject() != path {
            named += &format!("{}: ", path.display());
        }
        CliError::Usage(format!("{named}{refusal}; nothing was written ({fix})"))
    }
}

pub type Result<T, E = CliError> = std::result::Result<T, E>;
