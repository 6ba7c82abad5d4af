//! The peers benchmark: generated fly-through scenes, timed in campath (PNG and hash-only output,
//! each in its own process so peak memory is its own) and in POV-Ray 3.7's animation mode on
//! the same scene and camera, in the same run; the scaling scenes also in OVITO 3's Tachyon and
//! OSPRay renderers.
//!
//! `scenes` generates the scenes, `timing` times campath's processes, `povray` runs POV-Ray,
//! `ovito` runs OVITO; this module runs them and writes the tables.

pub mod ovito;
mod povray;
mod scenes;
mod timing;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use campath::document::Document;
use campath::internals::Table;
use campath::Error;
pub use scenes::{scaling_scenes, scene_files, scene_ron, scenes, BenchScene, Layout};
use timing::{run_campath, Run};

/// What stops a bench run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Campath(#[from] Error),
    /// An option value that cannot be used (exit 2).
    #[error("{0}")]
    Usage(String),
    /// An outside program (POV-Ray, OVITO, or campath itself) is missing or failed (exit 3).
    #[error("{tool}: {message}")]
    Tool { tool: &'static str, message: String },
    /// A run's numbers (`--stats-json`) do not parse (exit 1).
    #[error("{}: not the JSON campath writes: {cause}", path.display())]
    Json {
        path: PathBuf,
        cause: serde_json::Error,
    },
}

impl BenchError {
    /// `tool` could not be started: missing, most likely.
    fn missing(tool: &'static str, package: &'static str, cause: std::io::Error) -> BenchError {
        let message = format!("cannot run it ({cause}); install the Debian package {package}");
        BenchError::Tool { tool, message }
    }

    /// 2 for a bad option, 3 for an outside program, 1 for the rest.
    pub fn exit_code(&self) -> ExitCode {
        ExitCode::from(match self {
            BenchError::Usage(_) => 2,
            BenchError::Tool { .. } => 3,
            _ => 1,
        })
    }
}

pub type Result<T, E = BenchError> = std::result::Result<T, E>;

/// The cores and the CPU features that matter here (SHA extensions, AVX2, AVX-512F), from
/// std's run-time detection, as the renderer's instruction paths detect them.
pub fn cpu_features() -> String {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    #[cfg(target_arch = "x86_64")]
    {
        let has = |yes: bool| if yes { "yes" } else { "no" };
        format!(
            "{cores} core(s); SHA-NI {}, AVX2 {}, AVX-512 {}",
            has(std::arch::is_x86_feature_detected!("sha")),
            has(std::arch::is_x86_feature_detected!("avx2")),
            has(std::arch::is_x86_feature_detected!("avx512f"))
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        format!("{cores} core(s); {}", std::env::consts::ARCH)
    }
}

/// One measured row.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    pub scene: BenchScene,
    /// campath with PNG output.
    pub png: Run,
    /// campath hash-only.
    pub hash: Run,
    /// POV-Ray: wall ms per frame, and the frames it rendered.
    pub pov: Option<(f64, u64)>,
}

/// Writes the scene files to `dir` and measures every scene.
pub fn run(
    dir: &Path,
    pov_frames: u64,
    runs: usize,
    scenes: &[BenchScene],
    progress: &mut dyn std::io::Write,
) -> Result<Vec<Row>> {
    std::fs::create_dir_all(dir).map_err(Error::write(dir.to_path_buf()))?;
    if pov_frames > 0 {
        povray::check()?;
    }
    let mut rows = Vec::new();
    for s in scenes {
        let ron_path = dir.join(format!("{}.ron", s.name));
        let write =
            |p: &PathBuf, text: &str| std::fs::write(p, text).map_err(Error::write(p.clone()));
        write(&ron_path, &scene_ron(s))?;
        let file = ron_path.to_string_lossy().into_owned();
        // Always a fresh render: frames kept from an earlier run would time nothing.
        let frames_dir = dir.join(&s.name);
        if frames_dir.exists() {
            std::fs::remove_dir_all(&frames_dir).map_err(Error::write(&frames_dir))?;
        }
        let frames_dir = frames_dir.to_string_lossy().into_owned();
        // campath renders the frames POV-Ray renders (all of them without POV-Ray): both
        // processes then spread their start-up over the same frames.
        let n = if pov_frames > 0 {
            pov_frames.min(s.frames)
        } else {
            s.frames
        };
        let range = format!("0..{n}");
        let _ = writeln!(progress, "{}: campath, PNG output, {runs} run(s) …", s.name);
        let stats = dir.join(format!("{}.stats.json", s.name));
        let png = run_campath(
            &[
                "render",
                &file,
                "--frames",
                &range,
                "--out",
                &frames_dir,
                "--force",
                "--quiet",
            ],
            &stats,
            runs,
        )?;
        let _ = writeln!(progress, "{}: campath, hash only, {runs} run(s) …", s.name);
        let hash = run_campath(&["hash", &file, "--frames", &range], &stats, runs)?;
        let pov = if pov_frames > 0 {
            let _ = writeln!(progress, "{}: POV-Ray, {n} frame(s) …", s.name);
            let doc = Document::load(&ron_path)?;
            Some((povray::time(dir, s, &doc, n)?, n))
        } else {
            None
        };
        rows.push(Row {
            scene: s.clone(),
            png,
            hash,
            pov,
        });
    }
    Ok(rows)
}

/// The table README shows.
pub fn table(rows: &[Row]) -> String {
    let mut t = Table::new(&[
        "scene",
        "size, samples",
        "spheres",
        "campath PNG ms/frame (process)",
        "campath hash-only ms/frame (process)",
        "median render ms",
        "primary rays/s",
        "peak MB (PNG, hash)",
        "POV-Ray ms/frame",
        "POV / campath PNG",
        "POV / campath hash",
    ]);
    for r in rows {
        let s = &r.scene;
        let rays = (s.width as f64 * s.height as f64 * (s.samples * s.samples) as f64)
            / (r.hash.stats.median_render_ms / 1e3);
        let (pov, ratio_png, ratio_hash) = match r.pov {
            Some((ms, n)) => (
                format!("{ms:.0} ({n} frames)"),
                format!("{:.1}×", ms / r.png.process_ms_per_frame),
                format!("{:.1}×", ms / r.hash.process_ms_per_frame),
            ),
            None => ("—".into(), "—".into(), "—".into()),
        };
        let peak = |run: &Run| run.stats.peak_memory_mb.unwrap_or(f64::NAN);
        t.row(vec![
            s.name.clone(),
            format!("{}×{}, {}", s.width, s.height, s.samples),
            s.spheres.to_string(),
            format!("{:.1}", r.png.process_ms_per_frame),
            format!("{:.1}", r.hash.process_ms_per_frame),
            format!("{:.1}", r.hash.stats.median_render_ms),
            format!("{:.1} M", rays / 1e6),
            format!("{:.0}, {:.0}", peak(&r.png), peak(&r.hash)),
            pov,
            ratio_png,
            ratio_hash,
        ]);
    }
    t.markdown()
}

/// One scaling scene's hash-only run, and POV-Ray's and OVITO's on the dense cluster.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ScaleRow {
    pub scene: BenchScene,
    pub hash: Run,
    /// POV-Ray: wall ms per frame, and the frames it rendered.
    pub pov: Option<(f64, u64)>,
    /// OVITO's Tachyon and OSPRay: wall ms per frame each, and the frames they rendered.
    pub ovito: Option<Ovito>,
}

/// OVITO's two renderers on one scene, each a whole process over the same frames.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Ovito {
    pub tachyon_ms: f64,
    pub ospray_ms: f64,
    pub frames: u64,
}

/// Which peers run on the dense scenes, and over how many frames (0: not at all).
#[derive(Debug, Clone, Copy)]
pub struct Peers {
    pub pov_frames: u64,
    pub ovito_frames: u64,
}

/// Times the scaling scenes, hash-only, each in its own process, and POV-Ray and OVITO on the
/// dense cluster's scenes over the peers' frames, where those are > 0 (the million-sphere scene
/// takes POV-Ray about 35 s a frame). The scene files are removed after their run (a million
/// spheres take 150 MB of RON).
pub fn run_scaling(
    dir: &Path,
    peers: Peers,
    runs: usize,
    scenes: &[BenchScene],
    keep: bool,
    progress: &mut dyn std::io::Write,
) -> Result<Vec<ScaleRow>> {
    std::fs::create_dir_all(dir).map_err(Error::write(dir.to_path_buf()))?;
    let Peers {
        pov_frames,
        ovito_frames,
    } = peers;
    let dense = scenes.iter().any(|s| s.layout == Layout::Dense);
    let pov = pov_frames > 0 && dense;
    if pov {
        povray::check()?;
    }
    let with_ovito = ovito_frames > 0 && dense;
    if with_ovito {
        ovito::check()?;
    }
    let mut rows = Vec::new();
    for s in scenes {
        let files = scene_files(s);
        let ron_path = dir.join(format!("{}.ron", s.name));
        let ply_path = dir.join(format!("{}.ply", s.name));
        std::fs::write(&ron_path, &files.ron).map_err(Error::write(ron_path.clone()))?;
        if let Some(bytes) = &files.ply {
            std::fs::write(&ply_path, bytes).map_err(Error::write(ply_path.clone()))?;
        }
        drop(files);
        let _ = writeln!(progress, "{}: campath, hash only, {runs} run(s) …", s.name);
        let stats = dir.join(format!("{}.stats.json", s.name));
        let hash = run_campath(&["hash", &ron_path.to_string_lossy()], &stats, runs)?;
        // A peer runs on a dense scene whose RON twin did not run it.
        let twin = twin_of(&rows, s);
        let lent_pov = twin.and_then(|t| t.pov);
        let lent_ovito = twin.and_then(|t| t.ovito);
        let dense = s.layout == Layout::Dense;
        let run_pov = pov && dense && lent_pov.is_none();
        let run_ovito = with_ovito && dense && lent_ovito.is_none();
        let peer_doc = (run_pov || run_ovito)
            .then(|| Document::load(&ron_path))
            .transpose()?;
        let pov = match lent_pov {
            Some(twin) => Some(twin),
            None if run_pov => {
                let n = pov_frames.min(s.frames);
                let _ = writeln!(progress, "{}: POV-Ray, {n} frame(s) …", s.name);
                let doc = peer_doc.as_ref().expect("loaded for the peers");
                Some((povray::time(dir, s, doc, n)?, n))
            }
            None => None,
        };
        let ovito = match lent_ovito {
            Some(twin) => Some(twin),
            None if run_ovito => {
                let n = ovito_frames.min(s.frames);
                let doc = peer_doc.as_ref().expect("loaded for the peers");
                let _ = writeln!(
                    progress,
                    "{}: OVITO Tachyon and OSPRay, {n} frame(s) …",
                    s.name
                );
                let both = [ovito::Renderer::Tachyon, ovito::Renderer::Ospray];
                let ms = ovito::time(dir, s, doc, n, &both)?;
                Some(Ovito {
                    tachyon_ms: ms[0],
                    ospray_ms: ms[1],
                    frames: n,
                })
            }
            None => None,
        };
        drop(peer_doc);
        let pov_path = dir.join(format!("{}.pov", s.name));
        for path in [&ron_path, &ply_path, &pov_path] {
            if !keep && path.exists() {
                std::fs::remove_file(path).map_err(Error::write(path.clone()))?;
            }
        }
        rows.push(ScaleRow {
            scene: s.clone(),
            hash,
            pov,
            ovito,
        });
    }
    Ok(rows)
}

/// The row of the RON twin of PLY scene `s` among `rows`, if it is there. The peers read the
/// spheres as they are given them, so a scene from PLY and the same scene inline are one scene to
/// them: both of campath's readings are set against one peer time.
fn twin_of<'a>(rows: &'a [ScaleRow], s: &BenchScene) -> Option<&'a ScaleRow> {
    rows.iter().find(|r| {
        let t = &r.scene;
        s.ply
            && !s.float
            && !t.ply
            && (t.layout, t.spheres, t.frames) == (s.layout, s.spheres, s.frames)
            && (t.width, t.height, t.samples) == (s.width, s.height, s.samples)
    })
}

/// POV-Ray's run of the RON twin of PLY scene `s` among `rows`, if it is there.
#[cfg(test)]
fn twin_pov(rows: &[ScaleRow], s: &BenchScene) -> Option<(f64, u64)> {
    twin_of(rows, s)?.pov
}

/// The scaling table, and each layout's growth in frame time from 10,000 to 1,000,000 spheres.
pub fn scaling_table(rows: &[ScaleRow]) -> String {
    let mut table = Table::new(&[
        "scene",
        "size",
        "spheres",
        "most in view",
        "first frame ms",
        "ms/frame (process, hash-only)",
        "median render ms",
        "peak MB",
        "POV-Ray ms/frame",
        "POV / campath",
        "OVITO Tachyon ms/frame",
        "Tachyon / campath",
        "OVITO OSPRay ms/frame",
        "OSPRay / campath",
    ]);
    for r in rows {
        let (s, stats) = (&r.scene, &r.hash.stats);
        let times = |ms: f64| format!("{:.1}×", ms / r.hash.process_ms_per_frame);
        let peer = |ms: Option<f64>| match (ms, r.ovito) {
            (Some(ms), Some(o)) => [format!("{ms:.0} ({} frames)", o.frames), times(ms)],
            _ => ["—".into(), "—".into()],
        };
        let [tachyon, tachyon_ratio] = peer(r.ovito.map(|o| o.tachyon_ms));
        let [ospray, ospray_ratio] = peer(r.ovito.map(|o| o.ospray_ms));
        let (pov, ratio) = match r.pov {
            Some((ms, n)) => (
                format!("{ms:.0} ({n} frames)"),
                format!("{:.1}×", ms / r.hash.process_ms_per_frame),
            ),
            None => ("—".into(), "—".into()),
        };
        table.row(vec![
            s.name.clone(),
            format!("{}×{}", s.width, s.height),
            s.spheres.to_string(),
            stats.max_in_view.to_string(),
            format!("{:.0}", stats.first_frame_ms.unwrap_or(f64::NAN)),
            format!("{:.1}", r.hash.process_ms_per_frame),
            format!("{:.1}", stats.median_render_ms),
            format!("{:.0}", stats.peak_memory_mb.unwrap_or(f64::NAN)),
            pov,
            ratio,
            tachyon,
            tachyon_ratio,
            ospray,
            ospray_ratio,
        ]);
    }
    let mut t = table.markdown();
    for layout in [Layout::Patch, Layout::BigCluster] {
        let at = |n: usize| {
            rows.iter()
                .find(|r| {
                    r.scene.layout == layout && r.scene.spheres == n && r.scene.height == 1080
                })
                .map(|r| r.hash.stats.median_render_ms)
        };
        if let (Some(a), Some(b)) = (at(10_000), at(1_000_000)) {
            let _ = writeln!(
                t,
                "\n{layout:?}: median render {:.2}× from 10,000 to 1,000,000 spheres (log ratio {:.1}×, linear 100×).",
                b / a,
                (1e6f64).ln() / (1e4f64).ln()
            );
        }
    }
    t
}

/// What to time: the command line's options.
pub struct Options<'a> {
    pub pov_frames: u64,
    /// With `scaling`, the frames OVITO renders of each dense scene (0: none).
    pub ovito_frames: u64,
    pub runs: usize,
    /// The scenes' names (all when empty).
    pub names: &'a [String],
    pub json: bool,
    /// The scaling scenes, not the POV-Ray table's.
    pub scaling: bool,
    /// With `scaling`, each scene's files kept in `dir`.
    pub keep: bool,
}

/// The chosen scenes (all when `names` is empty), as a table or as JSON.
pub fn command(dir: &Path, options: &Options, out: &mut dyn std::io::Write) -> Result<()> {
    let &Options {
        pov_frames,
        ovito_frames,
        runs,
        names,
        json,
        scaling,
        keep,
    } = options;
    if ovito_frames > 0 && !scaling {
        return Err(BenchError::Usage(
            "--ovito-frames: OVITO runs on the dense scaling scenes only; add --scaling".into(),
        ));
    }
    let cpu = cpu_features();
    let all = if scaling { scaling_scenes() } else { scenes() };
    if let Some(unknown) = names.iter().find(|n| !all.iter().any(|s| s.name == **n)) {
        let known: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
        return Err(BenchError::Usage(format!(
            "--scenes: {unknown:?} is not a bench scene (the scenes are {})",
            known.join(", ")
        )));
    }
    let chosen: Vec<BenchScene> = all
        .into_iter()
        .filter(|s| names.is_empty() || names.contains(&s.name))
        .collect();
    let (value, rows_table) = if scaling {
        let peers = Peers {
            pov_frames,
            ovito_frames,
        };
        let rows = run_scaling(dir, peers, runs, &chosen, keep, &mut std::io::stderr())?;
        (
            serde_json::json!({"cpu": cpu, "runs": runs, "scaling": rows}),
            scaling_table(&rows),
        )
    } else {
        let rows = run(dir, pov_frames, runs, &chosen, &mut std::io::stderr())?;
        (
            serde_json::json!({"cpu": cpu, "runs": runs, "rows": rows}),
            table(&rows),
        )
    };
    let text = if json {
        serde_json::to_string_pretty(&value).expect("plain numbers serialise") + "\n"
    } else {
        let how = if scaling {
            format!(
                "campath: each row from the run of median process time of {runs}; POV-Ray and OVITO: one run each on the dense scenes (each peer / campath against campath's process ms/frame)"
            )
        } else {
            format!(
                "campath: process ms/frame the median of {runs} process(es), the other columns from that run; POV-Ray: one run over its frames"
            )
        };
        format!("CPU: {cpu}\n{how}\n\n{rows_table}")
    };
    write!(out, "{text}").map_err(Error::stdout)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of scaling scene `name` with POV-Ray's `pov`.
    fn row(name: &str, pov: Option<(f64, u64)>) -> ScaleRow {
        let scene = scaling_scenes()
            .into_iter()
            .find(|s| s.name == name)
            .unwrap();
        let hash = Run {
            stats: Default::default(),
            process_ms_per_frame: 50.0,
            process_ms_runs: vec![50.0],
        };
        ScaleRow {
            scene,
            hash,
            pov,
            ovito: None,
        }
    }

    /// A PLY scene takes POV-Ray's time from its RON twin (same spheres, frames and size), and
    /// only from it; a RON scene never borrows one.
    #[test]
    fn a_ply_scene_is_set_against_its_ron_twins_povray_run() {
        let rows = [
            row("dense1000", Some((1200.0, 4))),
            row("dense100000", Some((2300.0, 4))),
        ];
        let scene = |name: &str| row(name, None).scene;
        assert_eq!(
            twin_pov(&rows, &scene("dense100000-ply")),
            Some((2300.0, 4))
        );
        assert_eq!(twin_pov(&rows, &scene("dense1000000-ply")), None);
        assert_eq!(twin_pov(&rows, &scene("dense100000")), None);
        // A twin run without POV-Ray lends nothing.
        let rows = [row("dense100000", None)];
        assert_eq!(twin_pov(&rows, &scene("dense100000-ply")), None);
    }

    /// OVITO runs on the scaling scenes only: asked for without them, the run is refused before
    /// anything is written, naming the option to add.
    #[test]
    fn ovito_frames_without_scaling_are_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("bench");
        let options = Options {
            pov_frames: 0,
            ovito_frames: 1,
            runs: 1,
            names: &[],
            json: true,
            scaling: false,
            keep: false,
        };
        let mut printed = Vec::new();
        let e = command(&out, &options, &mut printed).unwrap_err();
        assert!(matches!(e, BenchError::Usage(_)), "{e}");
        assert!(e.to_string().contains("add --scaling"), "{e}");
        assert!(printed.is_empty() && !out.exists());
    }

    /// The ratio is POV-Ray's time over the process time the table shows beside it, not over
    /// the in-process wall time (which leaves out start-up and loading).
    #[test]
    fn the_scaling_table_shows_the_process_time_it_divides_by() {
        let mut r = row("dense100000", Some((2300.0, 4)));
        r.hash.stats.wall_ms_per_frame = 40.0;
        let table = scaling_table(&[r]);
        let line = table
            .lines()
            .find(|l| l.starts_with("| dense100000 "))
            .unwrap();
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        assert_eq!(cells[6], "50.0", "{line}");
        assert_eq!(cells[10], "46.0×", "{line}");
    }
}
