//! A campath command timed as whole processes: start-up, loading and output included, as
//! POV-Ray is timed, with the median of several runs.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use super::{BenchError, Result};
use campath::internals::Stats;
use campath::Error;

/// A campath command timed in its own processes: the numbers of its median run, and the wall
/// time of that whole process.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Run {
    #[serde(flatten)]
    pub stats: Stats,
    /// Wall ms per frame from starting the process to its exit: start-up, loading and the last
    /// frame's output included, as POV-Ray is timed. The median of the runs; the ratios
    /// against POV-Ray use this.
    pub process_ms_per_frame: f64,
    /// Every run's process ms per frame, in the order they ran.
    pub process_ms_runs: Vec<f64>,
}

/// Runs `campath ARGS --stats-json FILE` `runs` times, each as its own process (so its peak
/// memory is its own), and keeps the run of median process time (the lower middle of an even
/// count) with the numbers it wrote. A process of a tenth of a second is at the mercy of a
/// shared machine's passing load; the median of a few is not.
pub fn run_campath(args: &[&str], stats: &Path, runs: usize) -> Result<Run> {
    let all = (0..runs.max(1))
        .map(|_| run_campath_once(args, stats))
        .collect::<Result<Vec<(f64, Stats)>>>()?;
    Ok(median_run(all))
}

/// Of the runs' (process ms per frame, numbers), in the order they ran, the run of median
/// time (the lower middle of an even count) with its own numbers, and every run's time.
fn median_run(mut all: Vec<(f64, Stats)>) -> Run {
    assert!(!all.is_empty(), "at least one run");
    let process_ms_runs: Vec<f64> = all.iter().map(|(ms, _)| *ms).collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (process_ms_per_frame, stats) = all.swap_remove((all.len() - 1) / 2);
    Run {
        stats,
        process_ms_per_frame,
        process_ms_runs,
    }
}

/// One timed campath process: its wall ms per frame and the numbers it wrote.
fn run_campath_once(args: &[&str], stats: &Path) -> Result<(f64, Stats)> {
    // A run that wrote no numbers must not pass off an earlier run's as its own.
    if stats.exists() {
        std::fs::remove_file(stats).map_err(Error::write(stats.to_path_buf()))?;
    }
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_campath"))
        .args(args)
        .arg("--stats-json")
        .arg(stats)
        .stdout(std::process::Stdio::null())
        .output()
        .map_err(|e| BenchError::Tool {
            tool: "campath",
            message: format!("cannot run {} ({e})", env!("CARGO_BIN_EXE_campath")),
        })?;
    let secs = started.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(BenchError::Tool {
            tool: "campath",
            message: format!("{args:?} failed: {}", String::from_utf8_lossy(&out.stderr)),
        });
    }
    let text = std::fs::read_to_string(stats).map_err(Error::read(stats))?;
    let stats: Stats = serde_json::from_str(&text).map_err(|cause| BenchError::Json {
        path: stats.to_path_buf(),
        cause,
    })?;
    Ok((secs * 1e3 / stats.frames.max(1) as f64, stats))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers tagged with the run they came from (in `kept`).
    fn stats(run: u64) -> Stats {
        Stats {
            frames: 8,
            kept: run,
            wall_secs: 0.1,
            wall_ms_per_frame: 12.5,
            median_render_ms: 11.0,
            peak_memory_mb: None,
            first_frame_ms: None,
            max_in_view: 0,
        }
    }

    /// The run of median time is kept with its own numbers, the lower middle of an even count,
    /// and every time in the order run.
    #[test]
    fn the_median_run_keeps_its_own_numbers() {
        for (times, median, from_run) in [
            (vec![14.0], 14.0, 0),
            (vec![15.0, 12.0], 12.0, 1),
            (vec![17.1, 14.7, 14.2], 14.7, 1),
            (vec![30.0, 13.0, 14.0, 12.0], 13.0, 1),
            (vec![11.0, 19.0, 13.0, 12.0, 18.0], 13.0, 2),
        ] {
            let runs = times.iter().enumerate();
            let run = median_run(runs.map(|(k, &t)| (t, stats(k as u64))).collect());
            assert_eq!(run.process_ms_per_frame, median, "{times:?}");
            assert_eq!(run.stats.kept, from_run, "{times:?}");
            assert_eq!(run.process_ms_runs, times);
        }
    }
}
