//! `campath report`: what accuracy each renderer setting buys, and at what time.
//!
//! One frame is rendered at every setting that trades accuracy for time (samples per pixel side
//! 1, 2, 3, 4, 8, and adaptive sampling at 2, 4 and 8) and compared with a reference at 16×16
//! samples. Errors are per channel, in 8-bit levels and in linear light. Motion blur's time
//! samples (1, 2, 4, 8, 16) are rows of the same table and plot, on a frame where the camera
//! moves during the shutter, against [`REFERENCE_TIME_SAMPLES`] time samples.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::args::{check_extension, default_out_dir, Shot};
use super::chart::draw_png;
use super::error::{CliError, Result};
use super::table::Table;
use crate::camera::Camera;
use crate::document::Document;
use crate::frames::median;
use crate::output::pictures;
use crate::raster::{MotionBlur, MAX_TIME_SAMPLES};
use crate::render::{srgb_decode, Raster, Renderer, SceneIndex, Simd};
use crate::scene::Scene;

/// Samples per side of the reference.
pub const REFERENCE_SAMPLES: u32 = 16;

/// Time samples of the motion-blur reference.
pub const REFERENCE_TIME_SAMPLES: u32 = MAX_TIME_SAMPLES;

/// The shutter of the motion rows when the file has no motion blur.
pub const DEFAULT_SHUTTER: f64 = 0.5;

/// A setting that trades accuracy for time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// An s×s grid of samples per pixel.
    Samples(u32),
    /// Adaptive sampling up to s×s: corners first, the rest where they disagree.
    Adaptive(u32),
    /// One sample per pixel on an instruction path: the same bytes, another time.
    Path(Simd),
    /// Motion blur with N time samples, one sample a pixel each, against
    /// [`REFERENCE_TIME_SAMPLES`] of them.
    Motion(u32),
}

impl Setting {
    /// The table's name of the setting.
    pub fn label(self) -> String {
        match self {
            Setting::Samples(s) => format!("samples {s}"),
            Setting::Adaptive(s) => format!("samples {s}, adaptive"),
            Setting::Path(simd) => format!("samples 1, f64, {} path", simd.name()),
            Setting::Motion(n) => format!("time samples {n}"),
        }
    }

    /// The plot's series of the setting: grids, adaptive, instruction paths, time samples.
    fn series(self) -> usize {
        match self {
            Setting::Samples(_) => 0,
            Setting::Adaptive(_) => 1,
            Setting::Path(_) => 2,
            Setting::Motion(_) => 3,
        }
    }

    /// The plot's short name beside its marker (its series says the rest).
    pub fn short(self) -> String {
        match self {
            Setting::Samples(s) => format!("s={s}"),
            Setting::Adaptive(s) => format!("s={s}, adaptive"),
            Setting::Path(simd) => simd.name().to_string(),
            Setting::Motion(n) => format!("N={n}"),
        }
    }
}

/// One setting's measurements against the reference.
#[derive(Debug, Clone)]
pub struct Measured {
    pub setting: Setting,
    /// Median seconds per frame over the timed runs (ray table already built).
    pub secs: f64,
    pub rmse_levels: f64,
    pub max_levels: f64,
    pub rmse_linear: f64,
    pub max_linear: f64,
    /// Fraction of pixels with any channel different from the reference.
    pub changed: f64,
}

/// Median time of `runs` renders after one warm-up render, and the last frame: a frame averaged
/// over `cameras` (motion blur's time samples) at `raster` on instruction path `simd`, each run
/// preparing every time sample and rendering the frame.
fn timed(cameras: &[Camera], scene: &Scene, at: (Raster, Simd), runs: usize) -> (f64, Vec<u8>) {
    let (raster, mut r) = (at.0, Renderer::with_simd(at.1).unwrap_or_default());
    // Indexed once, as a render of many frames does.
    let index = SceneIndex::new(scene);
    // One buffer, rendered into once before the timed runs: the runs time no allocation.
    let mut pixels = Vec::new();
    let mut render = || {
        r.prepare_times(cameras, &index, raster)
            .render_into(&mut pixels, &mut |_| {})
    };
    render();
    let (secs, _) = median_time(runs, render);
    (secs, pixels)
}

/// The motion rows' frame: `frame` if the camera moves during its shutter (at the reference's
/// time samples), else the nearest frame that does (the earlier of two as near), or None when
/// the camera never moves.
fn moving_frame(doc: &Document, frame: u64, blur: MotionBlur) -> Result<Option<u64>> {
    let mut moving = Vec::new();
    for item in doc.cameras() {
        let (k, camera) = item.map_err(CliError::from)?;
        moving.extend((exposure(doc, k, camera, blur)?.len() > 1).then_some(k));
    }
    Ok(moving.into_iter().min_by_key(|k| (k.abs_diff(frame), *k)))
}

/// The cameras of frame `k`'s time samples.
fn exposure(doc: &Document, k: u64, camera: Camera, blur: MotionBlur) -> Result<Vec<Camera>> {
    let exposure = doc.animation.exposure(k, camera, blur).map_err(|e| {
        CliError::Usage(format!("frame {}, t = {} s: {}", e.frame, e.time, e.cause))
    })?;
    Ok(exposure.renders().to_vec())
}

/// Motion blur's time samples on frame `frame` (see [`moving_frame`]) of `doc`, one sample a
/// pixel, against [`REFERENCE_TIME_SAMPLES`]: the frame measured, its shutter and the rows; None
/// when the camera never moves.
fn motion_report(
    doc: &Document,
    frame: u64,
    runs: usize,
) -> Result<Option<(u64, f64, Vec<Measured>)>> {
    let shutter = doc.motion_blur.map_or(DEFAULT_SHUTTER, |b| b.shutter);
    let blur = |samples| MotionBlur { shutter, samples };
    let Some(frame) = moving_frame(doc, frame, blur(REFERENCE_TIME_SAMPLES))? else {
        return Ok(None);
    };
    let camera = doc.camera(frame).map_err(CliError::from)?;
    let cameras = |n: u32| exposure(doc, frame, camera, blur(n));
    let (raster, simd) = (one_sample(doc), Simd::detect());
    let exact = cameras(REFERENCE_TIME_SAMPLES)?;
    let (_, reference) = timed(&exact, &doc.scene, (raster, simd), 0);
    let rows = [1, 2, 4, 8, 16].into_iter().map(|n| {
        let (secs, pixels) = timed(&cameras(n)?, &doc.scene, (raster, simd), runs);
        Ok(measure(Setting::Motion(n), secs, &pixels, &reference))
    });
    Ok(Some((frame, shutter, rows.collect::<Result<_>>()?)))
}

/// The file's raster at one sample a pixel, not adaptive.
fn one_sample(doc: &Document) -> Raster {
    Raster {
        samples: 1,
        adaptive: false,
        ..doc.raster
    }
}

/// `setting`'s row: `secs` a frame, and the errors of `got` against `reference`, both RGB8 sRGB.
pub fn measure(setting: Setting, secs: f64, got: &[u8], reference: &[u8]) -> Measured {
    let linear: Vec<f64> = (0..=255).map(|l| srgb_decode(l as f64 / 255.0)).collect();
    let (mut sq, mut max, mut sq_lin, mut max_lin) = (0.0, 0.0f64, 0.0, 0.0f64);
    for (a, b) in got.iter().zip(reference) {
        let d = (*a as f64 - *b as f64).abs();
        let dl = (linear[*a as usize] - linear[*b as usize]).abs();
        sq += d * d;
        sq_lin += dl * dl;
        max = max.max(d);
        max_lin = max_lin.max(dl);
    }
    let n = got.len().max(1) as f64;
    let changed = got
        .chunks(3)
        .zip(reference.chunks(3))
        .filter(|(a, b)| a != b)
        .count() as f64
        / (n / 3.0);
    Measured {
        setting,
        secs,
        rmse_levels: (sq / n).sqrt(),
        max_levels: max,
        rmse_linear: (sq_lin / n).sqrt(),
        max_linear: max_lin,
        changed,
    }
}

/// Measures every setting on frame `frame` of `doc`.
pub fn renderer_report(doc: &Document, frame: u64, runs: usize) -> Result<Vec<Measured>> {
    let frames = doc.animation.frames;
    if frame >= frames {
        let message = format!("--frame {frame}: the animation has frames 0..{frames}");
        return Err(CliError::Usage(message));
    }
    let camera = doc.camera(frame).map_err(CliError::from)?;
    let (base, fastest) = (one_sample(doc), Simd::detect());
    // A grid of samples, on the fastest instruction path.
    let grid = |samples, adaptive| {
        let raster = Raster {
            samples,
            adaptive,
            ..base
        };
        (raster, fastest)
    };
    let (_, reference) = timed(&[camera], &doc.scene, grid(REFERENCE_SAMPLES, false), 0);
    let samples = [1, 2, 3, 4, 8].map(|s| (Setting::Samples(s), grid(s, false)));
    let adaptive = [2, 4, 8].map(|s| (Setting::Adaptive(s), grid(s, true)));
    // The instruction paths: all f64, all the same bytes; only the time differs.
    let supported = Simd::ALL.into_iter().filter(|s| s.supported());
    let paths = supported.map(|simd| (Setting::Path(simd), (base, simd)));
    let settings = samples.into_iter().chain(adaptive).chain(paths);
    let measured = settings.map(|(setting, how)| {
        let (secs, pixels) = timed(&[camera], &doc.scene, how, runs);
        measure(setting, secs, &pixels, &reference)
    });
    Ok(measured.collect())
}

/// The renderer table as Markdown.
pub fn renderer_table(rows: &[Measured]) -> String {
    let mut t = Table::new(&[
        "setting",
        "median ms/frame",
        "RMSE (levels)",
        "max (levels)",
        "RMSE (linear)",
        "max (linear)",
        "pixels changed",
    ]);
    for r in rows {
        t.row(vec![
            r.setting.label(),
            format!("{:.1}", r.secs * 1e3),
            format!("{:.3}", r.rmse_levels),
            format!("{:.0}", r.max_levels),
            format!("{:.5}", r.rmse_linear),
            format!("{:.4}", r.max_linear),
            format!("{:.2}%", r.changed * 100.0),
        ]);
    }
    t.markdown()
}

/// Whole decades around the positive values `vs`, as exponents.
fn decades(vs: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let lo = vs.clone().fold(f64::INFINITY, f64::min);
    let hi = vs.fold(f64::NEG_INFINITY, f64::max);
    let (a, b) = (libm::floor(libm::log10(lo)), libm::ceil(libm::log10(hi)));
    (a, if b > a { b } else { a + 1.0 })
}

/// `10^e` written plainly: 0.01, 0.1, 1, 10, 100.
fn power_label(e: f64) -> String {
    // As many decimals as the negative exponent says.
    format!("{:.*}", (-e).max(0.0) as usize, libm::pow(10.0, e))
}

/// Writes a log-log plot of RMSE (8-bit levels) against median time per frame as a PNG: ticks
/// and grid lines at every decade, each point labelled beside its marker where the label covers
/// no marker, line or other label.
fn plot(rows: &[Measured], path: &Path) -> Result<()> {
    use plotters::prelude::*;
    const FLOOR: f64 = 1e-3;
    let log = libm::log10;
    let point = |r: &Measured| (log(r.secs * 1e3), log(r.rmse_levels.max(FLOOR)));
    let (x0, x1) = decades(rows.iter().map(|r| r.secs * 1e3));
    let (y0, y1) = decades(rows.iter().map(|r| r.rmse_levels.max(FLOOR)));
    draw_png(path, (900, 600), |root| {
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Error against run time (references: 16×16 samples per pixel; 64 time samples)",
                ("sans-serif", 22),
            )
            .margin(20)
            .x_label_area_size(55)
            .y_label_area_size(75)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc("median render time per frame (ms, log scale)")
            .y_desc("RMSE against the reference (8-bit levels, log scale)")
            .x_labels((x1 - x0) as usize + 1)
            .y_labels((y1 - y0) as usize + 1)
            .x_label_formatter(&|v| power_label(*v))
            .y_label_formatter(&|v| power_label(*v))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 16))
            .draw()?;
        // The instruction paths share samples 1's error; the plot shows the samples.
        let mut series: [Vec<_>; 4] = std::array::from_fn(|i| {
            let rows = rows.iter().filter(|r| r.setting.series() == i);
            rows.map(point).collect()
        });
        series[2].sort_by(|a, b| a.0.total_cmp(&b.0));
        // The lines' segments in pixels, for placing the labels off them.
        let segments: Vec<_> = series
            .iter()
            .flat_map(|s| s.windows(2))
            .map(|pair| (chart.backend_coord(&pair[0]), chart.backend_coord(&pair[1])))
            .collect();
        let names = [
            (BLUE, "full s×s grid"),
            (RED, "adaptive (corners first)"),
            (GREEN, "1 sample, each instruction path"),
            (MAGENTA, "N time samples (reference: 64; motion blur)"),
        ];
        for (series, (color, name)) in series.into_iter().zip(names) {
            let dots = series.iter().map(|p| Circle::new(*p, 5, color.filled()));
            let dots: Vec<_> = dots.collect();
            chart
                .draw_series(LineSeries::new(series, color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart.draw_series(dots)?;
        }
        // Each label at the first place around its marker that covers no marker, no line and
        // no label placed before (or, failing that, the least of them), inside the axes.
        let markers: Vec<(i32, i32)> = rows
            .iter()
            .map(|r| chart.backend_coord(&point(r)))
            .collect();
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let mut placed: Vec<LabelBox> = Vec::new();
        for (r, &(px, py)) in rows.iter().zip(&markers) {
            let text = r.setting.short();
            let (w, h) = (8 * text.chars().count() as i32, 15);
            let at = |(dx, dy): (i32, i32)| LabelBox {
                x: px + dx,
                y: py + dy,
                w,
                h,
            };
            let cost = |rect: LabelBox| {
                let outside = rect.x < xs.start
                    || rect.x + w > xs.end
                    || rect.y < ys.start
                    || rect.y + h > ys.end;
                let labels = placed.iter().filter(|o| o.overlaps(&rect)).count();
                let (x, y) = (rect.x - 6..rect.x + w + 6, rect.y - 6..rect.y + h + 6);
                let near = |m: &&(i32, i32)| x.contains(&m.0) && y.contains(&m.1);
                let marks = markers.iter().filter(near).count();
                let lines = segments.iter().filter(|(a, b)| rect.meets(*a, *b)).count();
                usize::from(outside) * 100 + labels * 10 + marks * 10 + lines
            };
            // Beside the marker, right then left, or centred above or below; then farther out.
            let best = [0, 16]
                .into_iter()
                .flat_map(|d| {
                    let (l, c) = (-9 - w, -w / 2);
                    [(9, -18), (9, 4), (l, -18), (l, 4), (c, -26), (c, 10)]
                        .map(|(dx, dy)| (dx, if dy < 0 { dy - d } else { dy + d }))
                })
                .min_by_key(|&c| cost(at(c)))
                .expect("candidates");
            placed.push(at(best));
            let label = Text::new(text, best, ("sans-serif", 14));
            chart
                .plotting_area()
                .draw(&(EmptyElement::at(point(r)) + label))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
        Ok(())
    })
}

/// A label's box in pixels: top-left corner, width and height.
#[derive(Clone, Copy)]
struct LabelBox {
    x: i32,
    y: i32,
    w: i32,
    h: i32,
}

impl LabelBox {
    fn overlaps(&self, o: &LabelBox) -> bool {
        self.x < o.x + o.w && o.x < self.x + self.w && self.y < o.y + o.h && o.y < self.y + self.h
    }

    /// Whether the segment from `a` to `b` passes through the box (sampled every pixel or so).
    fn meets(&self, a: (i32, i32), b: (i32, i32)) -> bool {
        let steps = (a.0 - b.0).abs().max((a.1 - b.1).abs()).max(1);
        (0..=steps).any(|k| {
            let t = k as f64 / steps as f64;
            let x = a.0 as f64 + (b.0 - a.0) as f64 * t;
            let y = a.1 as f64 + (b.1 - a.1) as f64 * t;
            let (x, y) = (x.round() as i32, y.round() as i32);
            (self.x..self.x + self.w).contains(&x) && (self.y..self.y + self.h).contains(&y)
        })
    }
}

/// One arc-length table resolution, measured against a 65,536-step reference.
#[derive(Debug, Clone)]
pub struct PathRow {
    /// Table samples per key segment; 0 for the keyed (not re-timed) path.
    pub samples: u32,
    /// Median microseconds to build the table.
    pub build_us: f64,
    /// Median nanoseconds to evaluate one frame's position.
    pub eval_ns: f64,
    /// Largest distance from the reference position over all frames, world units.
    pub max_error: f64,
    /// (largest − smallest) / mean distance moved per frame while moving: 0 is constant speed.
    pub speed_spread: f64,
}

/// Reference resolution of the arc-length table.
pub const PATH_REFERENCE_SAMPLES: u32 = 1 << 16;

/// Arc-length table resolution against accuracy and time, for the file's Observer path; None
/// when the file has no Observer track.
pub fn path_report(doc: &Document) -> Option<Vec<PathRow>> {
    use crate::keyframes::{PathTrack, Track, UniformSpeed};
    let keys = doc.animation.observer.as_ref()?.keys().to_vec();
    if keys.len() < 2 {
        return None;
    }
    let track = Track::new(keys.clone());
    let (t0, t1) = (keys[0].t, keys[keys.len() - 1].t);
    let times: Vec<f64> = (0..doc.animation.frames)
        .map(|k| doc.animation.time(k))
        .filter(|t| *t >= t0 && *t <= t1)
        .collect();
    let reference = UniformSpeed::new(track.clone(), PATH_REFERENCE_SAMPLES);
    let exact: Vec<_> = times.iter().map(|t| reference.sample(*t)).collect();
    let measure = |path: &PathTrack, build_us: f64, samples: u32| {
        let (secs, positions) = median_time(5, || times.iter().map(|t| path.sample(*t)).collect());
        let positions: Vec<_> = positions.expect("five runs");
        let max_error = positions
            .iter()
            .zip(&exact)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        let steps: Vec<f64> = positions
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .collect();
        let mean = steps.iter().sum::<f64>() / steps.len().max(1) as f64;
        let lo = steps.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = steps.iter().copied().fold(0.0, f64::max);
        PathRow {
            samples,
            build_us,
            eval_ns: secs * 1e9 / times.len().max(1) as f64,
            max_error,
            speed_spread: if mean > 0.0 { (hi - lo) / mean } else { 0.0 },
        }
    };
    let mut rows = vec![measure(&PathTrack::Keyed(track.clone()), 0.0, 0)];
    rows[0].max_error = f64::NAN;
    for samples in [2, 4, 16, 64, 256, 1024] {
        let (secs, table) = median_time(5, || UniformSpeed::new(track.clone(), samples));
        let table = PathTrack::Uniform(table.expect("five runs"));
        rows.push(measure(&table, secs * 1e6, samples));
    }
    Some(rows)
}

/// The median seconds of `runs` runs of `f`, and the last run's result.
fn median_time<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, Option<T>) {
    let mut secs = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        last = Some(f());
        secs.push(start.elapsed().as_secs_f64());
    }
    (median(&secs), last)
}

/// The camera path table as Markdown.
pub fn path_table(rows: &[PathRow]) -> String {
    let mut t = Table::new(&[
        "timing",
        "table samples per segment",
        "build µs",
        "eval ns/frame",
        "max position error",
        "speed spread",
    ]);
    for r in rows {
        // The keyed path has no table: no size, build time or error against one.
        let keyed = r.samples == 0;
        let table = |cell: String| if keyed { "—".into() } else { cell };
        t.row(vec![
            (if keyed { "keyed" } else { "uniform" }).into(),
            table(r.samples.to_string()),
            table(format!("{:.1}", r.build_us)),
            format!("{:.0}", r.eval_ns),
            table(format!("{:.2e}", r.max_error)),
            match keyed {
                true => format!("{:.3}", r.speed_spread),
                false => format!("{:.2e}", r.speed_spread),
            },
        ]);
    }
    t.markdown()
}

/// The options of `campath report`.
#[derive(clap::Args)]
pub struct ReportArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// The frame to measure [default: the middle frame].
    #[arg(long)]
    pub frame: Option<u64>,
    /// Timed renders per setting (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub runs: u64,
    /// Where the log-log plot goes [default: out/<file stem>/report.png].
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `campath report`: both tables on `out`, and the plot at `--plot`.
pub fn run(a: ReportArgs, out: &mut dyn std::io::Write) -> Result<()> {
    let file = &a.shot.file;
    let plot_path = (a.plot).unwrap_or_else(|| default_out_dir(file).join(pictures::REPORT));
    check_extension("--plot", &plot_path, &["png"], "the report's plot is PNG")?;
    let doc = Document::load(file)?;
    // Measuring takes a while: find out first that the plot can be written.
    super::args::check_writable(&plot_path)?;
    let (frame, runs) = (a.frame.unwrap_or(doc.animation.frames / 2), a.runs as usize);
    let mut rows = renderer_report(&doc, frame, runs)?;
    let motion = motion_report(&doc, frame, runs)?;
    rows.extend(motion.iter().flat_map(|m| m.2.iter().cloned()));
    let stdout = crate::Error::stdout;
    writeln!(out, "Renderer, frame {frame} of {}:\n", file.display()).map_err(stdout)?;
    write!(out, "{}", renderer_table(&rows)).map_err(stdout)?;
    match &motion {
        Some((moving, shutter, _)) => writeln!(
            out,
            "\nTime samples: frame {moving}, shutter {shutter}, one sample a pixel, against {REFERENCE_TIME_SAMPLES} time samples (the other rows: against {REFERENCE_SAMPLES}×{REFERENCE_SAMPLES} samples)."
        ),
        None => writeln!(
            out,
            "\nTime samples: none, the camera does not move during any frame's shutter."
        ),
    }
    .map_err(stdout)?;
    plot(&rows, &plot_path)?;
    writeln!(out, "\nplot: {}", plot_path.display()).map_err(stdout)?;
    if let Some(path) = path_report(&doc) {
        writeln!(
            out,
            "\nCamera path, speed: Uniform against a {PATH_REFERENCE_SAMPLES}-step arc-length table:\n"
        )
        .map_err(stdout)?;
        write!(out, "{}", path_table(&path)).map_err(stdout)?;
    }
    Ok(())
}
