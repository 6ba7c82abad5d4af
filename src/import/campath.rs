//! campath's own exports, `path --format csv` and `--format json`: a camera per frame, read back
//! exactly (both write the shortest decimal that reads back the same f64).

use glam::{DVec2, DVec3};

use super::{Sample, Source};
use crate::camera::{Basis, Camera};
use crate::export::{JsonFrame, CSV_HEADER};

/// The frames of a campath CSV.
pub fn csv(bytes: &[u8], camera: Option<&str>) -> Result<Source, String> {
    no_camera_names(camera)?;
    let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8: {e}"))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or("the file is empty: no header line")?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    // The columns `path` writes, by name; the COP's are `cop_world_*` (an earlier campath
    // wrote `cop_*`).
    let find = |name: &str| {
        let old = name.replace("cop_world_", "cop_");
        (names.iter().position(|n| *n == name || *n == old)).ok_or_else(|| {
            format!("line 1: no column {name:?} in the header: campath's CSV has {CSV_HEADER}")
        })
    };
    let at = CSV_HEADER
        .split(',')
        .map(find)
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != names.len() {
            return Err(format!(
                "line {}: {} values, the header has {}",
                i + 1,
                fields.len(),
                names.len()
            ));
        }
        let mut x = [0.0; 19];
        for (slot, &column) in x.iter_mut().zip(&at) {
            *slot = fields[column].parse().map_err(|_| {
                format!(
                    "line {}: column {} ({}): not a number: {:?}",
                    i + 1,
                    column + 1,
                    names[column],
                    fields[column]
                )
            })?;
        }
        let v3 = |k: usize| DVec3::new(x[k], x[k + 1], x[k + 2]);
        rows.push((
            x[0],
            x[1],
            v3(2),
            [v3(5), v3(8), v3(11)],
            v3(14),
            DVec2::new(x[17], x[18]),
        ));
    }
    source(rows)
}

/// The frames of a campath JSON array.
pub fn json(bytes: &[u8], camera: Option<&str>) -> Result<Source, String> {
    no_camera_names(camera)?;
    let frames: Vec<JsonFrame> = serde_json::from_slice(bytes).map_err(|e| {
        format!(
            "not campath's --format json (an array of frames) nor nerfstudio's camera path: {e}"
        )
    })?;
    let rows = frames
        .into_iter()
        .map(|f| {
            let (v, w) = (DVec3::from_array, DVec2::from_array(f.window));
            (
                f.frame as f64,
                f.t,
                v(f.vrp),
                [v(f.u), v(f.v), v(f.n)],
                v(f.cop_world),
                w,
            )
        })
        .collect();
    source(rows)
}

/// A row: frame number, time, VRP, [u, v, n], the COP in world, the window.
type Row = (f64, f64, DVec3, [DVec3; 3], DVec3, DVec2);

fn no_camera_names(camera: Option<&str>) -> Result<(), String> {
    match camera {
        Some(name) => Err(format!(
            "campath's exports hold one camera, unnamed: leave out --camera {name:?}"
        )),
        None => Ok(()),
    }
}

/// The samples of the rows, in order: each row's camera, checked, at its time; the rate from
/// the frame numbers and times of the first two rows.
fn source(rows: Vec<Row>) -> Result<Source, String> {
    let mut samples = Vec::with_capacity(rows.len());
    for (k, &(frame, t, vrp, [u, v, n], cop, window)) in rows.iter().enumerate() {
        let finite = [vrp, u, v, n, cop].iter().all(|a| a.is_finite()) && window.is_finite();
        if !(finite && frame.is_finite()) {
            return Err(format!("frame {frame}: a value is not a finite number"));
        }
        let basis = Basis { u, v, n };
        let unit = [u, v, n].iter().all(|a| (a.length() - 1.0).abs() < 1e-9);
        let square = u.dot(v).abs() < 1e-9 && v.dot(n).abs() < 1e-9 && n.dot(u).abs() < 1e-9;
        if !(unit && square && u.cross(v).dot(n) < 0.0) {
            return Err(format!("frame {frame}: u, v and n are not campath's basis (unit, at right angles, left-handed)"));
        }
        let cop_view = basis.to_view(cop - vrp);
        if !(cop_view.z < 0.0 && window.x > 0.0 && window.y > 0.0 && t.is_finite()) {
            return Err(format!(
                "frame {frame}: the COP is not behind the view plane, or the window is empty"
            ));
        }
        if k > 0 && t <= rows[k - 1].1 {
            return Err(format!(
                "frame {frame}: its time {t} s does not follow {} s",
                rows[k - 1].1
            ));
        }
        let cam = Camera {
            vrp_world: vrp,
            basis,
            cop_view,
            window,
        };
        samples.push(Sample::of_camera(t, &cam));
    }
    let fps = (rows.len() >= 2).then(|| (rows[1].0 - rows[0].0) / (rows[1].1 - rows[0].1));
    Ok(Source {
        samples,
        fps: fps.filter(|f| f.is_finite() && *f > 0.0),
        size: None,
        camera: "camera".into(),
        view_distance: rows
            .first()
            .map(|&(_, _, vrp, [_, _, n], cop, _)| n.dot(vrp - cop)),
    })
}
