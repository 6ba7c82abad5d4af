//! `campath plot`: the camera path drawn from above (x, z) and from the side (x, y): the VRP's
//! path, the Observer keyframes, the targets, a frustum every few frames, and the spheres.

use std::path::Path;

use glam::{DVec2, DVec3};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::chart::{draw_error, draw_png};
use super::error::Result;
use campath::animation::Pointing;
use campath::camera::Camera;
use campath::document::Document;

/// A view: world point to the panel's (horizontal, vertical).
type Projection = fn(DVec3) -> DVec2;

type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Pixels of the whole picture.
pub const SIZE: (u32, u32) = (1400, 700);

/// What the plot shows, gathered from the file.
struct Marks {
    cams: Vec<Camera>,
    /// The Observer track's keys.
    keys: Vec<DVec3>,
    /// The Track keys, or the fixed target point.
    targets: Vec<DVec3>,
}

impl Marks {
    fn of(doc: &Document) -> Result<Marks> {
        let cams: Vec<Camera> = doc
            .cameras()
            .map(|r| r.map(|(_, c)| c))
            .collect::<campath::Result<_>>()?;
        let a = &doc.animation;
        let keys = a
            .observer
            .as_ref()
            .map_or_else(Vec::new, |o| o.keys().iter().map(|k| k.value).collect());
        let mut targets: Vec<DVec3> = a
            .track
            .as_ref()
            .map_or_else(Vec::new, |t| t.keys().iter().map(|k| k.value).collect());
        if let (Pointing::Target(tp), None, None) = (a.pointing, &a.track, &a.look_around) {
            targets.push(tp);
        }
        Ok(Marks {
            cams,
            keys,
            targets,
        })
    }

    /// The region shown: the path, keys and targets, and the spheres no larger than that
    /// region, as a centre and a half-width.
    fn region(&self, doc: &Document) -> (DVec3, f64) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let points = self.cams.iter().map(|c| c.vrp_world);
        for p in points
            .chain(self.keys.iter().copied())
            .chain(self.targets.iter().copied())
        {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let extent = (hi - lo).max_element().max(1.0);
        for s in doc.scene.spheres.iter().filter(|s| s.radius < extent) {
            lo = lo.min(s.center_world - s.radius);
            hi = hi.max(s.center_world + s.radius);
        }
        ((lo + hi) * 0.5, (hi - lo).max_element() * 0.55 + 1e-9)
    }
}

/// Writes the plot as a PNG; a frustum is drawn every `every` frames.
pub fn write(doc: &Document, path: &Path, every: u64) -> Result<()> {
    let marks = Marks::of(doc)?;
    let (mid, half) = marks.region(doc);
    draw_png(path, SIZE, |root| {
        let (left, right) = root.split_horizontally(SIZE.0 / 2);
        let top: Projection = |p| DVec2::new(p.x, p.z);
        let side: Projection = |p| DVec2::new(p.x, p.y);
        for (title, project, area, (xl, yl)) in [
            ("from above", top, left, ("x", "z")),
            ("from the side", side, right, ("x", "y")),
        ] {
            let c = project(mid);
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("camera path {title}"), ("sans-serif", 22))
                .margin(15)
                .x_label_area_size(35)
                .y_label_area_size(50)
                .build_cartesian_2d(c.x - half..c.x + half, c.y - half..c.y + half)
                .map_err(draw_error(path))?;
            chart
                .configure_mesh()
                .x_desc(xl)
                .y_desc(yl)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(draw_error(path))?;
            spheres(&mut chart, doc, project, path)?;
            frustums(&mut chart, &marks.cams, every, half * 0.12, project, path)?;
            path_and_keys(&mut chart, &marks, project, path)?;
        }
        Ok(())
    })
}

fn spheres(chart: &mut Chart, doc: &Document, project: Projection, path: &Path) -> Result<()> {
    for s in &doc.scene.spheres {
        let col = RGBColor(
            (s.color.x * 255.0) as u8,
            (s.color.y * 255.0) as u8,
            (s.color.z * 255.0) as u8,
        );
        let ctr = project(s.center_world);
        let ring: Vec<(f64, f64)> = (0..=64)
            .map(|k| {
                let a = k as f64 / 64.0 * std::f64::consts::TAU;
                (
                    ctr.x + s.radius * libm::cos(a),
                    ctr.y + s.radius * libm::sin(a),
                )
            })
            .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(ring.clone(), col.mix(0.35))))
            .map_err(draw_error(path))?;
        chart
            .draw_series(std::iter::once(PathElement::new(ring, col)))
            .map_err(draw_error(path))?;
    }
    Ok(())
}

/// A frustum every `every` frames and at the last: lines from the COP through the window's
/// corners, `reach` long.
fn frustums(
    chart: &mut Chart,
    cams: &[Camera],
    every: u64,
    reach: f64,
    project: Projection,
    path: &Path,
) -> Result<()> {
    let pt = |p: DVec3| {
        let q = project(p);
        (q.x, q.y)
    };
    for (k, cam) in cams.iter().enumerate() {
        if !(k as u64).is_multiple_of(every.max(1)) && k + 1 != cams.len() {
            continue;
        }
        let cop = cam.cop_world();
        let (w, h) = (cam.window.x * 0.5, cam.window.y * 0.5);
        let corners: Vec<DVec3> = [(-w, -h), (w, -h), (w, h), (-w, h)]
            .iter()
            .map(|&(x, y)| {
                let through = cam.point_to_world(DVec3::new(x, y, 0.0));
                cop + (through - cop).normalize() * reach
            })
            .collect();
        for corner in &corners {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![pt(cop), pt(*corner)],
                    BLACK.mix(0.5),
                )))
                .map_err(draw_error(path))?;
        }
        let mut rim: Vec<(f64, f64)> = corners.iter().map(|p| pt(*p)).collect();
        rim.push(rim[0]);
        chart
            .draw_series(std::iter::once(PathElement::new(rim, BLACK.mix(0.5))))
            .map_err(draw_error(path))?;
    }
    Ok(())
}

/// The VRP's path, the keyframes and the targets, with the legend.
fn path_and_keys<'a>(
    chart: &mut Chart<'a, 'a>,
    marks: &Marks,
    project: Projection,
    path: &Path,
) -> Result<()> {
    let line: Vec<(f64, f64)> = marks
        .cams
        .iter()
        .map(|c| project(c.vrp_world))
        .map(|p| (p.x, p.y))
        .collect();
    chart
        .draw_series(LineSeries::new(line, BLUE.stroke_width(2)))
        .map_err(draw_error(path))?
        .label("VRP path")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
    chart
        .draw_series(
            marks
                .keys
                .iter()
                .map(|k| project(*k))
                .map(|p| Circle::new((p.x, p.y), 5, RED.filled())),
        )
        .map_err(draw_error(path))?
        .label("keyframes")
        .legend(|(x, y)| Circle::new((x + 10, y), 5, RED.filled()));
    chart
        .draw_series(
            marks
                .targets
                .iter()
                .map(|t| project(*t))
                .map(|p| Cross::new((p.x, p.y), 6, GREEN.stroke_width(2))),
        )
        .map_err(draw_error(path))?
        .label("targets")
        .legend(|(x, y)| Cross::new((x + 10, y), 6, GREEN.stroke_width(2)));
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()
        .map_err(draw_error(path))?;
    Ok(())
}
