//! `campath plot`: the camera path drawn from above and from the side, drawn so that the plot
//! agrees with the frames.
//!
//! - From above, the viewer is on +y looking down with +z up the page; the world is right-handed
//!   (the notes' u = n × VUV makes a camera looking along +z with VUV = +y see −x on its right),
//!   so +x points left. What is on a camera's right in its frames is on the right of its
//!   frustum in the plot.
//! - From the side, the page's horizontal axis is the path's main horizontal direction of travel
//!   and y is up, so a path along any horizontal direction is spread across the panel.
//! - Spheres are their true outlines at the plot's scale: a huge ground sphere is a nearly
//!   straight line.
//! - The legend lists only what the file has.

use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::args::{default_out_dir, Shot};
use super::chart::{draw_png, Drawn};
use super::error::Result;
use crate::animation::Pointing;
use crate::camera::Camera;
use crate::document::Document;
use crate::output::{folder_of, pictures, LOCK};
use crate::scene::Sphere;

type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Page points of a line or a region.
type Points = Vec<(f64, f64)>;

/// Pixels of the whole picture.
pub const SIZE: (u32, u32) = (1400, 700);

/// A panel: world point to the page's (right, up), with its title and axis names.
struct View {
    title: String,
    right: DVec3,
    up: DVec3,
    x_desc: String,
    y_desc: String,
}

impl View {
    fn project(&self, p: DVec3) -> (f64, f64) {
        (p.dot(self.right), p.dot(self.up))
    }
}

/// The most cameras the path is drawn through: a longer file is sampled evenly (with its last
/// frame), finer than the panel's pixels.
const PATH_POINTS: u64 = 20_000;

/// What the plot shows, gathered from the file in one pass over its cameras, keeping only those
/// it draws: a file of ten million frames costs no more memory than one of twenty thousand.
struct Marks {
    /// The cameras drawn, in frame order: the path's samples and the frustums' frames.
    cams: Vec<(u64, Camera)>,
    /// The last frame.
    last: u64,
    /// Whether the VRP differs between frames.
    moves: bool,
    /// The box of every frame's VRP and COP.
    bounds: (DVec3, DVec3),
    /// The path's main horizontal direction ([`Marks::travel`]).
    travel: DVec3,
    /// The Observer track's keys.
    keys: Vec<DVec3>,
    /// The Track keys, or the fixed target point.
    targets: Vec<DVec3>,
    /// The target point at each of `cams`, where a Track moves it.
    target_path: Vec<DVec3>,
}

impl Marks {
    fn of(doc: &Document, every: u64) -> Result<Marks> {
        let last = doc.animation.frames - 1;
        let stride = doc.animation.frames.div_ceil(PATH_POINTS);
        // The frames about each Observer and Track key, where a path may turn or jump (a Step
        // key): kept whatever the stride.
        let (a, fps) = (&doc.animation, doc.animation.fps);
        let observer = a.observer.as_ref().map_or(&[][..], |o| o.keys());
        // The Track's keys too: its target's path turns or jumps there.
        let track = a.track.as_ref().map_or(&[][..], |t| t.keys());
        let key_times = (observer.iter().map(|k| k.t)).chain(track.iter().map(|k| k.t));
        let turns: std::collections::BTreeSet<u64> = key_times
            .flat_map(|t| {
                let at = (t * fps).clamp(0.0, last as f64);
                let (lo, hi) = (at.floor() as u64, at.ceil() as u64);
                lo.saturating_sub(1)..=(hi + 1).min(last)
            })
            .collect();
        let mut cams = Vec::new();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let mut first: Option<Camera> = None;
        let mut moves = false;
        let mut spread = Spread::default();
        for r in doc.cameras() {
            let (k, cam) = r?;
            let first = *first.get_or_insert(cam);
            let tol = 1e-12 * (1.0 + first.vrp_world.length());
            moves |= (cam.vrp_world - first.vrp_world).length() > tol;
            let (vrp, cop) = (cam.vrp_world, cam.cop_world());
            (lo, hi) = (lo.min(vrp).min(cop), hi.max(vrp).max(cop));
            spread.add(cam.vrp_world);
            if k % stride == 0 || k % every.max(1) == 0 || k == last || turns.contains(&k) {
                cams.push((k, cam));
            }
        }
        let (first, end) = (cams[0].1, cams[cams.len() - 1].1);
        let travel = spread.travel(&first, end.vrp_world - first.vrp_world);
        let keys = observer.iter().map(|k| k.value).collect();
        let mut targets: Vec<DVec3> = a
            .track
            .as_ref()
            .map_or_else(Vec::new, |t| t.keys().iter().map(|k| k.value).collect());
        if let (Pointing::Target(tp), None, None) = (a.pointing, &a.track, &a.look_around) {
            targets.push(tp);
        }
        let target_path = match a.track.is_some() {
            true => cams.iter().filter_map(|(k, _)| a.target(*k)).collect(),
            false => Vec::new(),
        };
        Ok(Marks {
            cams,
            last,
            moves,
            bounds: (lo, hi),
            travel,
            keys,
            targets,
            target_path,
        })
    }

    /// The region shown: the path, keys and targets, and the spheres no larger than that
    /// region, as a centre and a half-width.
    fn region(&self, doc: &Document) -> (DVec3, f64) {
        let (mut lo, mut hi) = self.bounds;
        for p in self
            .keys
            .iter()
            .chain(&self.targets)
            .chain(&self.target_path)
        {
            (lo, hi) = (lo.min(*p), hi.max(*p));
        }
        let extent = (hi - lo).max_element().max(1.0);
        for s in doc.scene.spheres.iter().filter(|s| s.radius < extent) {
            lo = lo.min(s.center_world - s.radius);
            hi = hi.max(s.center_world + s.radius);
        }
        ((lo + hi) * 0.5, (hi - lo).max_element() * 0.55 + 1e-9)
    }
}

/// The spread of the VRPs in (x, z), gathered one at a time (Welford's updates: no sum of
/// squares far larger than the spread).
#[derive(Default)]
struct Spread {
    n: f64,
    mean: DVec2,
    xx: f64,
    xz: f64,
    zz: f64,
}

impl Spread {
    fn add(&mut self, p: DVec3) {
        self.n += 1.0;
        let d = DVec2::new(p.x, p.z) - self.mean;
        self.mean += d / self.n;
        let e = DVec2::new(p.x, p.z) - self.mean;
        self.xx += d.x * e.x;
        self.xz += d.x * e.y;
        self.zz += d.y * e.y;
    }

    /// The principal axis of the VRPs in (x, z), pointing from the first VRP towards the last
    /// (`first_to_last`), or the first camera's view direction when the VRPs do not spread.
    fn travel(&self, first: &Camera, first_to_last: DVec3) -> DVec3 {
        if self.xx + self.zz < 1e-18 {
            let n = first.basis.n;
            let h = DVec3::new(n.x, 0.0, n.z);
            return if h.length() > 1e-9 {
                h.normalize()
            } else {
                DVec3::X
            };
        }
        // The larger eigenvector of [[xx, xz], [xz, zz]].
        let angle = 0.5 * libm::atan2(2.0 * self.xz, self.xx - self.zz);
        let dir = DVec3::new(libm::cos(angle), 0.0, libm::sin(angle));
        if dir.dot(first_to_last) < 0.0 {
            -dir
        } else {
            dir
        }
    }
}

/// The options of `campath plot`.
#[derive(clap::Args)]
pub struct PlotArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// Where the PNG goes [default: out/<file stem>/plot.png].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A frustum every N frames, N ≥ 1 [default: about eight along the path].
    #[arg(long, value_parser = super::args::at_least_one)]
    pub every: Option<u64>,
    /// Chart the eye's speed against time instead, with the Observer's keys and eases marked
    /// [default --out: out/<file stem>/speed.png].
    #[arg(long, conflicts_with = "every")]
    pub speed: bool,
}

/// `campath plot`: the plot, written as one of the runs of its folder when the folder is one
/// campath's runs write (it has their lock file).
pub fn run(a: PlotArgs, out: &mut dyn std::io::Write) -> Result<()> {
    let file = &a.shot.file;
    let name = if a.speed {
        pictures::SPEED
    } else {
        pictures::PLOT
    };
    let png = (a.out).unwrap_or_else(|| default_out_dir(file).join(name));
    super::args::check_extension("--out", &png, &["png"], "plot writes PNG")?;
    let doc = Document::load(file)?;
    super::args::check_writable(&png)?;
    let every = a.every.unwrap_or((doc.animation.frames / 8).max(1));
    let folder = folder_of(&png);
    let locked = folder.join(LOCK).is_file();
    let _lock = (locked.then(|| super::progress::lock_whole(folder, false))).transpose()?;
    match a.speed {
        true => write_speed(&doc, &png)?,
        false => write(&doc, &png, every)?,
    }
    Ok(writeln!(out, "wrote {}", png.display()).map_err(crate::Error::stdout)?)
}

/// Writes the chart of the speeds of the VRP (the Observer's path) and of the eye (the COP in
/// world, which also moves as the view turns), in units per second between each pair of
/// consecutive frames, at their middle time, against time; the Observer's key times are dashed
/// grey lines and its eases' ends green ones.
pub fn write_speed(doc: &Document, path: &Path) -> Result<()> {
    let a = &doc.animation;
    let cameras: Vec<Camera> = (doc.cameras())
        .map(|c| c.map(|(_, cam)| cam))
        .collect::<crate::Result<_>>()?;
    let speeds = |at: fn(&Camera) -> DVec3| -> Vec<(f64, f64)> {
        let points: Vec<DVec3> = cameras.iter().map(at).collect();
        (points.windows(2).enumerate())
            .map(|(k, w)| ((k as f64 + 0.5) / a.fps, (w[1] - w[0]).length() * a.fps))
            .collect()
    };
    let (vrp, eye) = (speeds(|c| c.vrp_world), speeds(Camera::cop_world));
    let keys: Vec<f64> = a
        .observer
        .iter()
        .flat_map(|o| o.keys())
        .map(|k| k.t)
        .collect();
    let eases: Vec<f64> = match &a.observer {
        Some(crate::keyframes::PathTrack::Uniform(u)) if u.is_eased() => {
            let (first, last, ease) = (keys[0], keys[keys.len() - 1], u.ease());
            vec![first + ease.start, last - ease.end]
        }
        _ => Vec::new(),
    };
    let end = a.time(a.frames - 1).max(1.0 / a.fps);
    let fastest = vrp.iter().chain(&eye).map(|p| p.1).fold(0.0, f64::max);
    let top = fastest.max(1e-9) * 1.1;
    draw_png(path, SPEED_SIZE, |root| {
        let mut chart = ChartBuilder::on(&root)
            .caption("speed against time", ("sans-serif", 18))
            .margin(MARGIN as u32)
            .x_label_area_size(X_LABELS as u32)
            .y_label_area_size(Y_LABELS as u32)
            .build_cartesian_2d(0.0..end, 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc("speed (world units/s)")
            .label_style(("sans-serif", 14))
            .draw()?;
        let upright = |t: f64, style: ShapeStyle| {
            plotters::element::DashedPathElement::new([(t, 0.0), (t, top)], 6, 4, style)
        };
        let sample = |style: ShapeStyle| {
            move |(x, y): (i32, i32)| PathElement::new(vec![(x, y), (x + 20, y)], style)
        };
        let key = ShapeStyle::from(&GREY).stroke_width(1);
        chart
            .draw_series(keys.iter().map(|&t| upright(t, key)))?
            .label("Observer keys")
            .legend(sample(key));
        if !eases.is_empty() {
            let ease = ShapeStyle::from(&START).stroke_width(2);
            chart
                .draw_series(eases.iter().map(|&t| upright(t, ease)))?
                .label("ease ends")
                .legend(sample(ease));
        }
        let lines = [
            (vrp, "the VRP (the Observer's path)", BLUE),
            (eye, "the eye (the COP in world)", RGBColor(220, 90, 0)),
        ];
        for (points, label, colour) in lines {
            let style = ShapeStyle::from(&colour).stroke_width(2);
            chart
                .draw_series(LineSeries::new(points, style))?
                .label(label)
                .legend(sample(style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerMiddle)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
    })
}

/// Writes the plot as a PNG; a frustum is drawn every `every` frames.
pub fn write(doc: &Document, path: &Path, every: u64) -> Result<()> {
    let marks = Marks::of(doc, every)?;
    let (mid, half) = marks.region(doc);
    let h = marks.travel;
    // Plus 0.0: −0.0 is shown as 0.00.
    let (hx, hz) = (h.x + 0.0, h.z + 0.0);
    let (title, along) = match marks.moves {
        true => ("along the travel", "along the travel"),
        false => (
            "across the first view direction",
            "along the first view direction",
        ),
    };
    let views = [
        View {
            title: "from above (+y), as the frames see left and right".into(),
            right: DVec3::NEG_X,
            up: DVec3::Z,
            x_desc: "x (world units, grows to the left)".into(),
            y_desc: "z (world units)".into(),
        },
        View {
            title: format!("from the side, {title} ({hx:.2}, 0, {hz:.2})"),
            right: h,
            up: DVec3::Y,
            x_desc: format!("distance {along} (world units)"),
            y_desc: "y (world units)".into(),
        },
    ];
    draw_png(path, SIZE, |root| {
        // The legend goes in a strip below both panels, where it covers nothing.
        let (panels, strip) = root.split_vertically(SIZE.1 - LEGEND_HEIGHT);
        let (left, right) = panels.split_horizontally(SIZE.0 / 2);
        for (view, area) in views.iter().zip([left, right]) {
            let (cx, cy) = view.project(mid);
            let flip = view.right == DVec3::NEG_X;
            // One scale on both axes (true sizes): the x range widened to the plotting
            // area's width in pixels.
            let (w, h) = area.dim_in_pixel();
            let plot_w = f64::from(w) - 2.0 * MARGIN - Y_LABELS;
            let plot_h = f64::from(h) - 2.0 * MARGIN - X_LABELS - CAPTION;
            let half_x = half * (plot_w / plot_h).max(1.0);
            let mut chart = ChartBuilder::on(&area)
                .caption(&view.title, ("sans-serif", 18))
                .margin(MARGIN as u32)
                .x_label_area_size(X_LABELS as u32)
                .y_label_area_size(Y_LABELS as u32)
                .build_cartesian_2d(cx - half_x..cx + half_x, cy - half..cy + half)?;
            chart
                .configure_mesh()
                .x_desc(&view.x_desc)
                .y_desc(&view.y_desc)
                // The top view's page x is −x: label the world's x (0.0, never −0.0).
                .x_label_formatter(&|v| tick(if flip { -v } else { *v }))
                .y_label_formatter(&|v| tick(*v))
                .label_style(("sans-serif", 14))
                .draw()?;
            let spans = (DVec2::new(cx, cy), half);
            spheres(&mut chart, doc, view, spans, plot_h / (2.0 * half))?;
            frustums(&chart, &marks, every, half * 0.12, view)?;
            path_and_keys(&chart, &marks, view, half)?;
        }
        legend(&strip, &marks, every, doc)
    })
}

/// The speed chart's size in pixels.
const SPEED_SIZE: (u32, u32) = (900, 420);
/// Pixels of the legend strip below the panels, and of the panels' margins and label areas.
const LEGEND_HEIGHT: u32 = 70;
const MARGIN: f64 = 15.0;
const X_LABELS: f64 = 40.0;
const Y_LABELS: f64 = 55.0;
/// About the height of an 18-point caption with its gap.
const CAPTION: f64 = 28.0;
/// The colours of the start and of the view directions.
const START: RGBColor = RGBColor(0, 150, 0);
const GREY: RGBColor = RGBColor(90, 90, 90);

/// An axis label with one decimal, never `-0.0`.
fn tick(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0;
    format!("{:.1}", if r == 0.0 { 0.0 } else { r })
}

/// The region `s` covers in `view` and its outline, as page points fine enough at the plot's
/// scale. A sphere that holds the whole panel fills it; one whose centre is far from the panel
/// is drawn only near the panel: an arc of its outline, closed into a region by a concentric arc
/// nearer the centre than any point of the panel.
fn outline(s: &Sphere, view: &View, (centre, half): (DVec2, f64)) -> (Points, Points) {
    let c = view.project(s.center_world);
    let c = DVec2::new(c.0, c.1);
    let to_panel = centre - c;
    let d = to_panel.length();
    let reach = half * std::f64::consts::SQRT_2; // the panel's circumscribed circle
    if d + reach < s.radius {
        let (lo, hi) = (centre - 2.0 * half, centre + 2.0 * half);
        return (
            vec![(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)],
            Vec::new(),
        );
    }
    let (from, span) = if d > reach {
        // Only the angles that can meet the panel.
        let w = libm::asin(reach / d) * 1.05;
        (libm::atan2(to_panel.y, to_panel.x) - w, 2.0 * w)
    } else {
        (0.0, std::f64::consts::TAU)
    };
    // About 200 segments across the panel's width (3 pixels each), and at least 16: a sphere
    // a few pixels wide is round without 64 points (a million of them drew in 12 s).
    let steps = ((s.radius * span) / (half / 100.0))
        .ceil()
        .clamp(16.0, 20_000.0) as usize;
    let arc = |r: f64| -> Vec<(f64, f64)> {
        (0..=steps)
            .map(|k| {
                let a = from + span * k as f64 / steps as f64;
                (c.x + r * libm::cos(a), c.y + r * libm::sin(a))
            })
            .collect()
    };
    let edge = arc(s.radius);
    let mut region = edge.clone();
    if d > reach {
        let inner = ((d - reach) * 0.99).clamp(0.0, s.radius);
        region.extend(arc(inner).into_iter().rev());
    }
    (region, edge)
}

/// Each sphere in scene order: its region a third opaque, its outline opaque; one under 2.5
/// pixels across (which its outline would cover) as a filled square of its size and the
/// stroke's, a run of those drawn together (a million spheres 2 px across took 3.2 s as
/// outlines, 0.34 s as squares; `the_plot_from_above_…` checks one, the examples' plots are
/// the same pictures).
fn spheres(
    chart: &mut Chart,
    doc: &Document,
    view: &View,
    panel: (DVec2, f64),
    px_per_unit: f64,
) -> Drawn {
    // The small ones' squares, each outline's under its colour's, sphere by sphere: a dense
    // white cloud shows as its outlines' shade (every outline first, then every colour, left
    // its core as white as the page).
    let mut dots = Vec::new();
    for s in &doc.scene.spheres {
        let [r, g, b] = (s.color * 255.0).to_array().map(|c| c as u8);
        let col = RGBColor(r, g, b);
        // The outline half as bright: a white sphere shows on the white page.
        let [r, g, b] = (s.color * 127.5).to_array().map(|c| c as u8);
        let edge_col = RGBColor(r, g, b);
        if s.radius * px_per_unit < 1.25 {
            // Half a pixel wider on each side, as the outline's stroke is; the outline's shade
            // a pixel wider again, under the colour.
            let (x, y) = view.project(s.center_world);
            let r = s.radius + 0.5 / px_per_unit;
            let rim = r + 1.0 / px_per_unit;
            dots.push(Rectangle::new(
                [(x - rim, y - rim), (x + rim, y + rim)],
                edge_col.filled(),
            ));
            dots.push(Rectangle::new(
                [(x - r, y - r), (x + r, y + r)],
                col.filled(),
            ));
            continue;
        }
        chart.draw_series(dots.drain(..))?;
        let (region, edge) = outline(&s, view, panel);
        // A ring of the shade a pixel outside the colour's outline.
        let ring = Sphere {
            radius: s.radius + 1.0 / px_per_unit,
            ..s
        };
        let area = chart.plotting_area();
        area.draw(&PathElement::new(outline(&ring, view, panel).1, edge_col))?;
        area.draw(&Polygon::new(region, col.mix(0.3)))?;
        area.draw(&PathElement::new(edge, col))?;
    }
    chart.draw_series(dots)?;
    Ok(())
}

/// A frustum every `every` frames and at the last, drawn from the camera forwards as Blender and
/// Unity draw one: edges from the COP through the window's corners to `reach` beyond the window,
/// where the far rectangle is drawn; the right edge (+u) heavier.
///
/// A camera that does not move gets its frustum at the first and the last frame only, and its
/// view direction (from the window's centre, on the ray from the COP) at the others: frustums
/// turning about one point would pile up into a pinwheel.
fn frustums(chart: &Chart, marks: &Marks, every: u64, reach: f64, view: &View) -> Drawn {
    let area = chart.plotting_area();
    let line = |from: DVec3, to: DVec3, style: ShapeStyle| {
        let ends = vec![view.project(from), view.project(to)];
        area.draw(&PathElement::new(ends, style))
    };
    for &(k, ref cam) in &marks.cams {
        let ends = k == 0 || k == marks.last;
        if !k.is_multiple_of(every.max(1)) && !ends {
            continue;
        }
        let cop = cam.cop_world();
        // The COP is −cop.n behind the window.
        let depth = -cam.cop_view.z;
        if !marks.moves && !ends {
            let centre = cam.point_to_world(DVec3::ZERO);
            let tip = cop + (centre - cop) * ((depth + 2.0 * reach) / depth);
            line(centre, tip, GREY.stroke_width(2))?;
            continue;
        }
        let (w, h) = (cam.window.x * 0.5, cam.window.y * 0.5);
        // The corners' rays, scaled to reach `reach` past the window along the view direction.
        let scale = (depth + reach) / depth;
        let corners = [(-w, -h), (w, -h), (w, h), (-w, h)]
            .map(|(x, y)| cop + (cam.point_to_world(DVec3::new(x, y, 0.0)) - cop) * scale);
        for (i, corner) in corners.iter().enumerate() {
            // Corners 1 and 2 are on the camera's right (+u).
            let style = if i == 1 || i == 2 {
                BLACK.stroke_width(2)
            } else {
                BLACK.mix(0.4).stroke_width(1)
            };
            line(cop, *corner, style)?;
        }
        let rim = corners.iter().chain(&corners[..1]);
        let rim: Points = rim.map(|p| view.project(*p)).collect();
        area.draw(&PathElement::new(rim, BLACK.stroke_width(1)))?;
    }
    Ok(())
}

/// The VRP's path with its start (and direction of travel) and end, the keyframes and the
/// targets.
fn path_and_keys(chart: &Chart, marks: &Marks, view: &View, half: f64) -> Drawn {
    let area = chart.plotting_area();
    let line: Points = marks
        .cams
        .iter()
        .map(|(_, c)| view.project(c.vrp_world))
        .collect();
    let (start, end) = (line[0], line[line.len() - 1]);
    // The direction of travel at the start: towards the first VRP that differs enough.
    let ahead = line
        .iter()
        .find(|p| (p.0 - start.0).hypot(p.1 - start.1) > half * 0.02)
        .copied();
    if ahead.is_some() {
        area.draw(&PathElement::new(line, BLUE.stroke_width(2)))?;
    }
    area.draw(&Circle::new(start, 7, START.filled()))?;
    if let Some(p) = ahead {
        let (dx, dy) = (p.0 - start.0, p.1 - start.1);
        let len = dx.hypot(dy);
        let (ux, uy) = (dx / len * half * 0.08, dy / len * half * 0.08);
        let tip = (start.0 + ux, start.1 + uy);
        let barb = |s: f64| {
            (
                tip.0 - ux * 0.35 - uy * 0.25 * s,
                tip.1 - uy * 0.35 + ux * 0.25 * s,
            )
        };
        let arrow = vec![start, tip, barb(1.0), tip, barb(-1.0)];
        area.draw(&PathElement::new(arrow, START.stroke_width(3)))?;
        let corner = |s: f64| (end.0 + s * half * 0.012, end.1 + s * half * 0.012);
        area.draw(&Rectangle::new([corner(-1.0), corner(1.0)], BLACK.filled()))?;
    }
    for k in &marks.keys {
        area.draw(&Circle::new(view.project(*k), 5, RED.filled()))?;
    }
    if marks.target_path.len() > 1 {
        let path: Points = marks.target_path.iter().map(|p| view.project(*p)).collect();
        area.draw(&PathElement::new(path, GREEN.mix(0.8).stroke_width(2)))?;
    }
    for t in &marks.targets {
        area.draw(&Cross::new(view.project(*t), 6, GREEN.stroke_width(2)))?;
    }
    Ok(())
}

/// The legend, in its strip below the panels: only what the file has, in one or two rows.
fn legend(
    strip: &DrawingArea<BitMapBackend<'_>, Shift>,
    marks: &Marks,
    every: u64,
    doc: &Document,
) -> Drawn {
    let moves = marks.moves;
    let line = |c: RGBColor| PathElement::new(vec![(0, 0), (20, 0)], c.stroke_width(2)).into_dyn();
    let frustum = if moves {
        format!("view frustum every {every} frame(s), COP to beyond the window; heavy edges on the camera's right")
    } else {
        "view frustum at the first and last frame; heavy edges on the camera's right".to_string()
    };
    // Each entry, shown when the file has it: its label and its mark about the entry's (0, 0).
    let dot = |r, style: ShapeStyle| Circle::new((10, 0), r, style).into_dyn();
    let end = Rectangle::new([(5, -5), (15, 5)], BLACK.filled()).into_dyn();
    let cross = Cross::new((10, 0), 6, GREEN.stroke_width(2)).into_dyn();
    let heavy = PathElement::new(vec![(0, 5), (20, -5)], BLACK.stroke_width(2)).into_dyn();
    let sphere = dot(6, BLACK.mix(0.3).filled());
    let start = || dot(6, START.filled());
    let has = (!marks.keys.is_empty(), !marks.targets.is_empty());
    let views = format!("view direction every {every} frame(s)");
    let spheres = !doc.scene.spheres.is_empty();
    let entries = [
        (moves, "VRP path".into(), line(BLUE)),
        (moves, "start, with the direction of travel".into(), start()),
        (!moves, "camera position (it does not move)".into(), start()),
        (moves, "end".into(), end),
        (has.0, "Observer keyframes".into(), dot(5, RED.filled())),
        (has.1, "target points (TP)".into(), cross),
        (
            marks.target_path.len() > 1,
            "target path".into(),
            line(GREEN),
        ),
        (!moves, views, line(GREY)),
        (true, frustum, heavy),
        (
            spheres,
            "spheres, true size and colour, outlined".into(),
            sphere,
        ),
    ];
    // Laid out left to right, wrapping to the next row; about 7 px per character.
    let font: TextStyle = ("sans-serif", 14).into();
    let (width, _) = strip.dim_in_pixel();
    let (mut x, mut y) = (20i32, 20i32);
    for (_, label, mark) in entries.into_iter().filter(|e| e.0) {
        let entry_w = 30 + strip.estimate_text_size(&label, &font)?.0 as i32 + 28;
        if x + entry_w > width as i32 && x > 20 {
            (x, y) = (20, y + 26);
        }
        strip.draw(&(EmptyElement::at((x, y)) + mark))?;
        strip.draw(&Text::new(label, (x + 30, y - 8), font.clone()))?;
        x += entry_w;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_file_keeps_a_sample_of_its_cameras_and_the_measures_of_all() {
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/long.ron");
        let doc = Document::load(Path::new(file)).unwrap();
        let frames = doc.animation.frames;
        assert_eq!(frames, 100_000);
        let marks = Marks::of(&doc, 12_500).unwrap();
        // Every fifth frame (20,000 points), with the frustums' frames and the last.
        let kept: Vec<u64> = marks.cams.iter().map(|(k, _)| *k).collect();
        // With the frames about each Observer key.
        let turns: Vec<u64> = kept.iter().copied().filter(|k| k % 5 != 0).collect();
        let keys = doc.animation.observer.as_ref().unwrap().keys().len();
        assert!(turns.len() <= 3 * keys, "{turns:?}");
        assert_eq!(kept.len(), 20_000 + turns.len());
        assert_eq!(kept.last(), Some(&(frames - 1)));
        // The bounds and the direction of travel are those of every camera, computed directly.
        let all: Vec<Camera> = doc.cameras().map(|r| r.unwrap().1).collect();
        let points = all.iter().flat_map(|c| [c.vrp_world, c.cop_world()]);
        let lo = points.clone().fold(DVec3::INFINITY, DVec3::min);
        let hi = points.fold(DVec3::NEG_INFINITY, DVec3::max);
        assert_eq!(marks.bounds, (lo, hi));
        let n = all.len() as f64;
        let mean = all.iter().map(|c| c.vrp_world).sum::<DVec3>() / n;
        let (mut xx, mut xz, mut zz) = (0.0, 0.0, 0.0);
        for c in &all {
            let d = c.vrp_world - mean;
            (xx, xz, zz) = (xx + d.x * d.x, xz + d.x * d.z, zz + d.z * d.z);
        }
        let angle = 0.5 * (2.0 * xz).atan2(xx - zz);
        let mut dir = DVec3::new(angle.cos(), 0.0, angle.sin());
        if dir.dot(all[all.len() - 1].vrp_world - all[0].vrp_world) < 0.0 {
            dir = -dir;
        }
        assert!(
            (marks.travel - dir).length() < 1e-9,
            "{} {dir}",
            marks.travel
        );
        assert!(marks.moves);
    }

    #[test]
    fn a_step_key_held_between_samples_stays_on_the_path() {
        // 40,001 frames, sampled every third: B is held for frame 20,000 alone, which is not a
        // multiple of 3.
        let text = "(frames: 40001, fps: 1.0, camera: (vrp: (0.0, 0.0, 0.0), vpn: (0.0, 0.0, 1.0)),
            animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)),
                (t: 20000.0, value: (10.0, 0.0, 0.0)), (t: 20001.0, value: (10.0, 0.0, 10.0))],
                interpolation: Step)])";
        let doc = Document::from_str(Path::new("step.ron"), text).unwrap();
        let marks = Marks::of(&doc, 7000).unwrap();
        let b = DVec3::new(10.0, 0.0, 0.0);
        assert!(marks
            .cams
            .iter()
            .any(|(k, c)| *k == 20_000 && c.vrp_world == b));
    }
}
