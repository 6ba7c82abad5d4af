//! POV-Ray 3.7 on a bench scene, in animation mode, timed as a whole process.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use super::BenchScene;
use super::{BenchError, Result};
use campath::document::Document;
use campath::export::povray::{scene, Finish};
use campath::Error;

/// Fails, naming the Debian package, when POV-Ray cannot be run.
pub fn check() -> Result<()> {
    Command::new("povray")
        .arg("--version")
        .output()
        .map_err(|e| BenchError::missing("povray", "povray", e))?;
    Ok(())
}

/// Writes `doc` as `DIR/NAME.pov`, renders its first `frames` frames into `DIR/NAME-pov/` with
/// campath's samples as POV-Ray's antialiasing, and returns the wall ms per frame.
pub fn time(dir: &Path, s: &BenchScene, doc: &Document, frames: u64) -> Result<f64> {
    let pov_path = dir.join(format!("{}.pov", s.name));
    std::fs::write(&pov_path, scene(doc, Finish::Shaded)?).map_err(Error::write(&pov_path))?;
    let out_dir = dir.join(format!("{}-pov", s.name));
    std::fs::create_dir_all(&out_dir).map_err(Error::write(&out_dir))?;
    let aa = if s.samples > 1 {
        format!("+A0.0 +AM1 +R{}", s.samples)
    } else {
        "-A".to_string()
    };
    let started = Instant::now();
    let status = Command::new("povray")
        .arg(format!("+I{}", pov_path.display()))
        .arg(format!("+O{}/", out_dir.display()))
        .args([
            format!("+W{}", s.width),
            format!("+H{}", s.height),
            "+KFI1".into(),
            format!("+KFF{frames}"),
            "+FN".into(),
            "-D".into(),
            "-V".into(),
            "-GA".into(),
        ])
        .args(aa.split(' '))
        .output()
        .map_err(|e| BenchError::missing("povray", "povray", e))?;
    if !status.status.success() {
        return Err(BenchError::Tool {
            tool: "povray",
            message: format!("failed: {}", String::from_utf8_lossy(&status.stderr)),
        });
    }
    Ok(started.elapsed().as_secs_f64() * 1e3 / frames as f64)
}
