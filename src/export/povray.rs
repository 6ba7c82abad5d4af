//! The shot as a POV-Ray 3.7 scene: the independent renderer that campath's projection is
//! cross-checked against (`tests/it/povray.rs`) and benchmarked against (`tests/peers`).
//!
//! Every frame's camera is given as explicit vectors, indexed by POV-Ray's `frame_number` in
//! animation mode (`+KFI1 +KFFn`; a single frame is frame 0): `location` = the COP in world,
//! `direction` = VRP − COP, `right` = w·u and `up` = h·v, so POV-Ray's image plane is the notes'
//! window, off-axis COPs included.

use std::fmt::Write as _;

use glam::DVec3;

use crate::document::Document;
use crate::error::Result;

/// How the spheres are lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Finish {
    /// campath's shading: `ambient A diffuse 1`, every light a parallel light (with shadows
    /// unless the light has them off).
    Shaded,
    /// Each sphere its flat colour (`ambient 1 diffuse 0`, no lights): every pixel names the
    /// sphere it sees, whatever the transfer function.
    Flat,
}

fn pov3(v: DVec3) -> String {
    format!("<{:.15}, {:.15}, {:.15}>", v.x, v.y, v.z)
}

/// The scene file for every frame of `doc`.
pub fn scene(doc: &Document, finish: Finish) -> Result<String> {
    let (mut loc, mut dir, mut right, mut up) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for item in doc.cameras() {
        let (_, cam) = item?;
        let cop = cam.cop_world();
        loc.push(pov3(cop));
        dir.push(pov3(cam.vrp_world - cop));
        right.push(pov3(cam.basis.u * cam.window.x));
        up.push(pov3(cam.basis.v * cam.window.y));
    }
    let scene = &doc.scene;
    let mut pov = String::from("#version 3.7;\n");
    pov += "global_settings { assumed_gamma 1.0 ambient_light rgb <1, 1, 1> }\n";
    let _ = writeln!(pov, "background {{ rgb {} }}", pov3(scene.background));
    for (name, list) in [("Loc", &loc), ("Dir", &dir), ("Right", &right), ("Up", &up)] {
        let (n, items) = (list.len(), list.join(", "));
        let _ = writeln!(pov, "#declare {name} = array[{n}] {{ {items} }}");
    }
    // Frames are numbered from 1 in animation mode; a single frame (+KFF1) is not animation
    // mode and has frame_number 0.
    pov += "#declare K = max(frame_number, 1) - 1;\n";
    pov += "camera { perspective location Loc[K] direction Dir[K] right Right[K] up Up[K] }\n";
    let (ambient, diffuse) = match finish {
        Finish::Shaded => (scene.ambient, 1.0),
        Finish::Flat => (1.0, 0.0),
    };
    if finish == Finish::Shaded {
        for l in &scene.lights {
            let _ = writeln!(
                pov,
                "light_source {{ {} color rgb {} parallel point_at <0, 0, 0>{} }}",
                pov3(-l.direction_world * 1e7),
                pov3(l.color),
                if l.shadows { "" } else { " shadowless" }
            );
        }
    }
    for s in &scene.spheres {
        let _ = writeln!(
            pov,
            "sphere {{ {}, {:.15} pigment {{ rgb {} }} finish {{ ambient {ambient} diffuse {diffuse} }} }}",
            pov3(s.center_world),
            s.radius,
            pov3(s.color),
        );
    }
    Ok(pov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn each_frame_is_an_array_entry_and_flat_drops_the_lights() {
        let doc = Document::from_str(
            Path::new("t.ron"),
            "(frames: 3, image: (width: 8, height: 4), camera: (vrp: (0.0, 0.0, -4.0), tp: (0.0, 0.0, 0.0), window: (2.0, 1.0)),
              scene: (ambient: 0.25, lights: [(direction: (0.0, -1.0, 0.0))], spheres: [(center: (1.0, 2.0, 3.0), radius: 0.5)]))",
        )
        .unwrap();
        let shaded = scene(&doc, Finish::Shaded).unwrap();
        assert!(shaded.contains("#declare Loc = array[3]"), "{shaded}");
        // The COP is 1 behind the VRP on the view axis (z): location <0, 0, -5>.
        assert!(shaded.contains(
            "Loc = array[3] { <0.000000000000000, 0.000000000000000, -5.000000000000000>"
        ));
        assert!(shaded.contains("light_source"));
        assert!(shaded.contains("finish { ambient 0.25 diffuse 1 }"));
        let flat = scene(&doc, Finish::Flat).unwrap();
        assert!(!flat.contains("light_source"));
        assert!(flat.contains("finish { ambient 1 diffuse 0 }"));
    }
}
