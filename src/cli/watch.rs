//! `campath watch`: the studio's page, read-only. It shows the shot, scrubs, plays and flies
//! it, follows every save from the user's editor, shows a broken save's error over the last good
//! version, and never writes the file. (An earlier `watch` wrote a folder of pictures and a page
//! that reloaded them; the studio's page replaces it.)
//!
//! A save is noticed from the file's own state every 0.1 s ([`stamp`]: which file its path
//! resolves to, its size and times), so a folder removed and made again, a link whose target is
//! edited, or a file removed, is noticed too.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::args::{NoWait, Shot};
use super::error::{CliError, Result};
use super::studio::{self, StudioArgs};

/// The options of `campath watch`.
#[derive(clap::Args)]
pub struct WatchArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// The port on 127.0.0.1 [default: a free one the system picks].
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
    /// An earlier watch's folder of pictures: refused, with the fix.
    #[arg(long, hide = true)]
    pub out: Option<PathBuf>,
    /// An earlier watch's picture width: refused, with the fix.
    #[arg(long, hide = true)]
    pub width: Option<u32>,
    #[command(flatten)]
    pub no_wait: NoWait,
}

/// Serves the studio's page, read-only, until Ctrl-C.
pub fn run(a: WatchArgs, out: &mut dyn Write) -> Result<()> {
    let old = match (&a.out, a.width) {
        (Some(_), _) => Some("--out"),
        (None, Some(_)) => Some("--width"),
        _ => None,
    };
    if let Some(option) = old {
        return Err(CliError::Usage(format!(
            "{option}: `campath watch` now serves its page (the studio's, read-only) instead of \
             writing a folder of pictures; leave {option} out and open the address it prints"
        )));
    }
    let args = StudioArgs {
        shot: a.shot,
        port: a.port,
        open: a.open,
        read_only: true,
    };
    studio::run(args, out)
}

/// What tells the file's versions apart: the file its path resolves to, its size and times,
/// and the link's own when the path is a link. None while nothing is there.
pub fn stamp(file: &Path) -> Option<Vec<i128>> {
    let target = std::fs::metadata(file).ok()?;
    let link = std::fs::symlink_metadata(file).ok()?;
    Some([target, link].iter().flat_map(identity).collect())
}

#[cfg(unix)]
fn identity(m: &std::fs::Metadata) -> [i128; 7] {
    use std::os::unix::fs::MetadataExt;
    let ns = |s: i64, n: i64| i128::from(s) * 1_000_000_000 + i128::from(n);
    [
        m.dev().into(),
        m.ino().into(),
        m.len().into(),
        ns(m.mtime(), m.mtime_nsec()),
        ns(m.ctime(), m.ctime_nsec()),
        m.mode().into(),
        m.nlink().into(),
    ]
}

#[cfg(not(unix))]
fn identity(m: &std::fs::Metadata) -> [i128; 2] {
    let since = |t: std::io::Result<std::time::SystemTime>| {
        t.ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos() as i128)
    };
    [m.len().into(), since(m.modified())]
}
