//! The folders where `verify --save-failures` and `test --review` put pictures of failures,
//! claimed before anything renders (see [`crate::output::claim_pictures`]).

use std::path::{Path, PathBuf};

use super::error::{CliError, Result};
use crate::output::lock::FolderLock;
use crate::output::within;

/// Before anything is written: refuses a `--junit` report among the `goldens` or over a file
/// campath did not write, and claims the folder `dir`, named by `option`, for the run's pictures
/// of failures ([`crate::output::claim_pictures`]), waiting for another run that holds it. The
/// report may not lie in that folder: the folder is the run's pictures only, and a report there
/// would be refused as another's file by the next run.
pub fn claim(
    junit: Option<&Path>,
    dir: Option<&Path>,
    option: &str,
    goldens: &[PathBuf],
    ours: impl Fn(&str) -> bool,
) -> Result<Option<FolderLock>> {
    if let Some(path) = junit {
        crate::output::outside_goldens(path, goldens)
            .map_err(|r| CliError::refused("--junit", path, &r))?;
        super::junit::check_target(path)?;
    }
    let Some(dir) = dir else { return Ok(None) };
    if let Some(report) = junit.filter(|r| within(r, dir)) {
        return Err(CliError::Usage(format!(
            "--junit {} is in the {option} folder {}; nothing was written (choose a report path \
             outside it)",
            report.display(),
            dir.display()
        )));
    }
    super::progress::with_wait(false, false, |wait| {
        crate::output::claim_pictures(dir, goldens, ours, wait)
    })
    .map(Some)
    .map_err(|e| e.at(option, dir))
}
