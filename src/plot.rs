//! `campath plot`: the camera path drawn from above (x, z) and from the side (x, y): the VRP's
//! path, the Observer keyframes, the targets, a frustum every few frames, and the spheres.

use std::path::Path;

use glam::{DVec2, DVec3};
use plotters::prelude::*;

use crate::animation::Pointing;
use crate::camera::Camera;
use crate::document::Document;
use crate::error::{Error, Result};
use crate::output::{write_png, Compression};

/// A view: world point to the panel's (horizontal, vertical).
type Projection = fn(DVec3) -> DVec2;

/// Pixels of the whole picture.
pub const SIZE: (u32, u32) = (1400, 700);

/// Writes the plot as a PNG; a frustum is drawn every `every` frames.
pub fn write(doc: &Document, path: &Path, every: u64) -> Result<()> {
    crate::report::register_font();
    let cams: Vec<Camera> = doc
        .cameras()
        .map(|r| r.map(|(_, c)| c))
        .collect::<Result<_>>()?;
    let keys: Vec<DVec3> = doc
        .animation
        .observer
        .as_ref()
        .map_or_else(Vec::new, |o| o.keys().iter().map(|k| k.value).collect());
    let mut targets: Vec<DVec3> = doc
        .animation
        .track
        .as_ref()
        .map_or_else(Vec::new, |t| t.keys().iter().map(|k| k.value).collect());
    if let (Pointing::Target(tp), None, None) = (
        doc.animation.pointing,
        &doc.animation.track,
        &doc.animation.look_around,
    ) {
        targets.push(tp);
    }
    // The view: the path, keys and targets, and the spheres no larger than that region.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in cams
        .iter()
        .map(|c| c.vrp_world)
        .chain(keys.iter().copied())
        .chain(targets.iter().copied())
    {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let extent = (hi - lo).max_element().max(1.0);
    for s in doc.scene.spheres.iter().filter(|s| s.radius < extent) {
        lo = lo.min(s.center_world - s.radius);
        hi = hi.max(s.center_world + s.radius);
    }
    let half = (hi - lo).max_element() * 0.55 + 1e-9;
    let mid = (lo + hi) * 0.5;
    let reach = half * 0.12;

    let mut buf = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| {
            Error::Usage(format!("{}: cannot draw the plot: {e}", path.display()))
        };
        root.fill(&WHITE).map_err(err)?;
        let (left, right) = root.split_horizontally(SIZE.0 / 2);
        let top: Projection = |p| DVec2::new(p.x, p.z);
        let side: Projection = |p| DVec2::new(p.x, p.y);
        let views = [
            ("from above", top, left, ("x", "z")),
            ("from the side", side, right, ("x", "y")),
        ];
        for (title, project, area, (xl, yl)) in views {
            let c = project(mid);
            let mut chart = ChartBuilder::on(&area)
                .caption(format!("camera path {title}"), ("sans-serif", 22))
                .margin(15)
                .x_label_area_size(35)
                .y_label_area_size(50)
                .build_cartesian_2d(c.x - half..c.x + half, c.y - half..c.y + half)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(xl)
                .y_desc(yl)
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(err)?;
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
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(PathElement::new(ring, col)))
                    .map_err(err)?;
            }
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
                let pt = |p: DVec3| {
                    let q = project(p);
                    (q.x, q.y)
                };
                for corner in &corners {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![pt(cop), pt(*corner)],
                            BLACK.mix(0.5),
                        )))
                        .map_err(err)?;
                }
                let mut rim: Vec<(f64, f64)> = corners.iter().map(|p| pt(*p)).collect();
                rim.push(rim[0]);
                chart
                    .draw_series(std::iter::once(PathElement::new(rim, BLACK.mix(0.5))))
                    .map_err(err)?;
            }
            let line: Vec<(f64, f64)> = cams
                .iter()
                .map(|c| project(c.vrp_world))
                .map(|p| (p.x, p.y))
                .collect();
            chart
                .draw_series(LineSeries::new(line, BLUE.stroke_width(2)))
                .map_err(err)?
                .label("VRP path")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
            chart
                .draw_series(
                    keys.iter()
                        .map(|k| project(*k))
                        .map(|p| Circle::new((p.x, p.y), 5, RED.filled())),
                )
                .map_err(err)?
                .label("keyframes")
                .legend(|(x, y)| Circle::new((x + 10, y), 5, RED.filled()));
            chart
                .draw_series(
                    targets
                        .iter()
                        .map(|t| project(*t))
                        .map(|p| Cross::new((p.x, p.y), 6, GREEN.stroke_width(2))),
                )
                .map_err(err)?
                .label("targets")
                .legend(|(x, y)| Cross::new((x + 10, y), 6, GREEN.stroke_width(2)));
            chart
                .configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE)
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    write_png(path, &buf, SIZE, Compression::Default)
}
