//! `campath watch`: the studio's page, read-only. It shows the shot, scrubs, plays and flies
//! it, follows every save from the user's editor, shows a broken save's error over the last good
//! version, and never writes the file. (An earlier `watch` wrote a folder of pictures and a page
//! that reloaded them; the studio's page replaces it.)
//!
//! A save is noticed as the studio notices it: from the file's own state every 0.1 s (which file
//! its path resolves to, its size and times), so a folder removed and made again, a link whose
//! target is edited, or a file removed, is noticed too.

use std::io::Write;
use std::path::PathBuf;

use super::args::{NoWait, Shot};
use super::error::{CliError, Result};
use super::studio::{self, Serve, StudioArgs};

/// The options of `campath watch`.
#[derive(clap::Args)]
pub struct WatchArgs {
    #[command(flatten)]
    pub shot: Shot,
    #[command(flatten)]
    pub serve: Serve,
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
        serve: a.serve,
        read_only: true,
    };
    studio::run(args, out)
}
