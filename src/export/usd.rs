//! The shot as an OpenUSD stage in the text form (USDA): the camera with a time sample per
//! frame, lens shift included, the spheres and the directional lights.
//!
//! - **Stage.** `metersPerUnit = 1` (a world unit is a metre: without it USD assumes
//!   centimetres and importers scale the shot by 0.01), `upAxis = "Y"`, `timeCodesPerSecond` and
//!   `framesPerSecond` the file's fps, and time code k + N is campath's frame k, N the first
//!   frame (`campath path --first-frame`, 0 unless given; `startTimeCode` N, `endTimeCode` the
//!   last frame's), stated in `customLayerData` (`frames`, `firstFrame`).
//! - **Camera.** A `UsdGeom.Camera` looks down its local −Z with +Y up, like the camera here with
//!   axes u, v, −n: `xformOp:translate` is the COP and `xformOp:orient` the quaternion of
//!   [u, v, −n]. USD gives focal length and apertures in tenths of a scene unit (here 0.1 m, so
//!   36 mm is 0.36). The film back is [`FILM_WIDTH`] wide and the window's aspect; the focal
//!   length is FILM_WIDTH · d / w for the COP's distance d to the view plane and the window's
//!   width w, so that aperture / focal length = window / d in both directions. The off-axis COP
//!   (distort) is the aperture offset: the window's centre seen from the COP lies at
//!   (−COP_u, −COP_v), so the offsets are −COP_u · FILM_WIDTH / w and −COP_v · FILM_WIDTH / w.
//!   Motion blur is the camera's `shutter:open` and `shutter:close`, in time codes relative to
//!   the frame: −S/2 and S/2 for the shutter S centred on the frame (left out without blur:
//!   USD's default 0, 0 is no blur); the camera then has a time sample where the first frame's
//!   shutter opens and where the last frame's closes too. `clippingRange` clips nothing campath
//!   draws (`clipping_range`).
//! - **Image.** A `UsdRender.Settings` prim carries the image size; a window whose aspect differs
//!   from the image's becomes its pixel aspect.
//! - **Scene.** Below [`INSTANCED_FROM`] spheres each sphere is a `UsdGeom.Sphere` with its
//!   radius and colour (`primvars:displayColor`, linear), its centre in f64. From it on, one
//!   `UsdGeom.PointInstancer`, `spheres`, instances a Sphere of radius 1: `positions` the centres
//!   and `scales` the radii (both f32, as the schema has them), `protoIndices` all 0, and the
//!   colours as `primvars:displayColor` with "vertex" interpolation, which OpenUSD applies one
//!   element to each instance. The prototype sits beneath the instancer under an `over`, as
//!   OpenUSD suggests, so that traversals which do not know instancers do not draw it at the
//!   origin. Each light is a `UsdLux.DistantLight`, whose −Z is the way the light travels, with
//!   its shadow switch (`ShadowAPI`).

use std::fmt::Write as _;

use glam::DVec3;

use crate::camera::Camera;
use crate::document::Document;
use crate::error::Result;
use crate::export::{
    aim_negative_z, clipping_range, keyed_cameras, quat_wxyz, relative, rotations, triple,
    unsigned_zero, INSTANCED_FROM,
};
use crate::scene::{Sphere, Spheres};

/// The film back's width in tenths of a scene unit: 0.36 is 36 mm when a unit is a metre.
pub const FILM_WIDTH: f64 = 0.36;

/// The USD lens that sees `cam`'s window from its COP, in tenths of a scene unit: `focalLength`
/// ([`FILM_WIDTH`] · d / w), `verticalAperture` (the film back's height in the window's aspect)
/// and `horizontalApertureOffset`, `verticalApertureOffset` (the COP's u, v on the film back,
/// negated). `horizontalAperture` is [`FILM_WIDTH`].
fn lens(cam: &Camera) -> [f64; 4] {
    let scale = FILM_WIDTH / cam.window.x;
    let c = cam.cop_view;
    [
        -c.z * scale,
        cam.window.y * scale,
        -c.x * scale,
        -c.y * scale,
    ]
}

/// A name USD accepts for a prim: letters, digits and `_`, not starting with a digit.
fn prim_name(stem: &str) -> String {
    let mut name: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
        name.insert(0, '_');
    }
    name
}

/// The shot's top prim: the file's stem as a prim name, apart from the stage's `/Render` scope.
fn root_name(stem: &str) -> String {
    match prim_name(stem) {
        name if name == "Render" => "Render_shot".into(),
        name => name,
    }
}

/// A string in USDA's quotes: `"` and `\` escaped, control characters as spaces.
fn quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' | '\\' => {
                out.push('\\');
                out.push(c);
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out + "\""
}

/// `(x, y, z)` in f32: USDA's `color3f`, `point3f`, `float3`.
fn float3(v: DVec3) -> String {
    let [x, y, z] = v.as_vec3().to_array().map(unsigned_zero);
    format!("({x:?}, {y:?}, {z:?})")
}

/// `x` in f32 as USDA writes it (`float`), never `-0`.
fn float(x: f64) -> String {
    format!("{:?}", unsigned_zero(x as f32))
}

/// `x` as the nearest f32 on the side of `towards` (−∞ or +∞): an extent rounded outward.
fn f32_outward(x: f64, towards: f64) -> f32 {
    let y = x as f32;
    let y = match f64::from(y) {
        z if towards < 0.0 && z > x => y.next_down(),
        z if towards > 0.0 && z < x => y.next_up(),
        _ => y,
    };
    unsigned_zero(y)
}

/// Writes `spheres` (relative to `origin`) as one `PointInstancer` beneath the shot's top prim
/// `root`, its arrays an instance a line.
fn point_instancer(s: &mut String, spheres: &Spheres, origin: DVec3, root: &str) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for sphere in spheres {
        let c = sphere.center_world - origin;
        lo = lo.min(c - sphere.radius);
        hi = hi.max(c + sphere.radius);
    }
    let lo = lo.to_array().map(|x| f32_outward(x, -1.0));
    let hi = hi.to_array().map(|x| f32_outward(x, 1.0));
    let _ = write!(
        s,
        r#"
    def PointInstancer "spheres"
    {{
        float3[] extent = [({:?}, {:?}, {:?}), ({:?}, {:?}, {:?})]
"#,
        lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
    );
    // An array of a value per sphere, then the attribute's metadata, if any.
    let array = |s: &mut String, decl: &str, value: &dyn Fn(&Sphere) -> String, meta: &str| {
        let _ = writeln!(s, "        {decl} = [");
        for sphere in spheres {
            let _ = writeln!(s, "            {},", value(&sphere));
        }
        let _ = writeln!(s, "        ]{meta}");
    };
    let position = |sphere: &Sphere| float3(sphere.center_world - origin);
    array(s, "point3f[] positions", &position, "");
    let vertex = " (\n            interpolation = \"vertex\"\n        )";
    array(
        s,
        "color3f[] primvars:displayColor",
        &|sphere| float3(sphere.color),
        vertex,
    );
    let _ = writeln!(
        s,
        "        int[] protoIndices = [{}]",
        vec!["0"; spheres.len()].join(", ")
    );
    let _ = writeln!(
        s,
        "        rel prototypes = </{root}/spheres/prototypes/sphere>"
    );
    let scale = |sphere: &Sphere| float3(DVec3::splat(sphere.radius));
    array(s, "float3[] scales", &scale, "");
    let _ = write!(
        s,
        r#"
        over "prototypes"
        {{
            def Sphere "sphere"
            {{
                float3[] extent = [(-1, -1, -1), (1, 1, 1)]
                double radius = 1
            }}
        }}
    }}
"#
    );
}

/// The stage as USDA text, campath frame k at time code k + `first_frame`.
pub fn usda(doc: &Document, origin: DVec3, first_frame: u64) -> Result<String> {
    let (times, cams): (Vec<f64>, Vec<Camera>) = (keyed_cameras(doc)?.into_iter())
        .map(|(frame, cam)| (frame + first_frame as f64, cam))
        .unzip();
    let orients = rotations(&cams);
    let lenses: Vec<[f64; 4]> = cams.iter().map(lens).collect();
    let frames = doc.animation.frames;
    let (near, far) = clipping_range(&doc.scene.spheres, &cams);
    let r = doc.raster;
    let first = lenses[0];
    let window = doc.animation.window;
    let pixel_aspect = (window.x / window.y) / (r.width as f64 / r.height as f64);
    let fps = doc.animation.fps;
    let root = root_name(
        &doc.path
            .file_stem()
            .map_or_else(|| "shot".into(), |s| s.to_string_lossy()),
    );
    let bg = doc.scene.background;

    let mut s = String::new();
    let _ = write!(
        s,
        r#"#usda 1.0
(
    customLayerData = {{
        string generator = "campath {version}"
        string source = {source}
        string units = "One scene unit is one campath world unit, taken as a metre (metersPerUnit = 1). focalLength, horizontalAperture, verticalAperture and their offsets are in tenths of a scene unit, as USD defines them: 0.36 is 36 mm."
        string frames = "Time code k + {first_frame} is campath frame k (campath path --first-frame {first_frame}), at {fps:?} frames per second."
        int firstFrame = {first_frame}
        int imageWidth = {width}
        int imageHeight = {height}
        double pixelAspect = {pixel_aspect:?}
        double3 background = {background}
        double ambient = {ambient:?}
        double3 origin = {origin}
    }}
    defaultPrim = "{root}"
    endTimeCode = {end}
    framesPerSecond = {fps:?}
    metersPerUnit = 1
    renderSettingsPrimPath = "/Render/settings"
    startTimeCode = {first_frame}
    timeCodesPerSecond = {fps:?}
    upAxis = "Y"
)

def Xform "{root}" (
    kind = "assembly"
)
{{
    def Camera "camera"
    {{
        float2 clippingRange = ({near}, {far})
        float horizontalAperture = {ha}
        float verticalAperture = {va}
        token projection = "perspective"
{shutter}"#,
        version = env!("CARGO_PKG_VERSION"),
        source = quoted(&doc.path.display().to_string()),
        width = r.width,
        height = r.height,
        background = triple(bg),
        ambient = unsigned_zero(doc.scene.ambient),
        origin = triple(origin),
        first_frame = first_frame,
        end = first_frame + frames - 1,
        near = float(near),
        far = float(far),
        ha = float(FILM_WIDTH),
        va = float(first[1]),
        shutter = match doc.motion_blur {
            Some(b) => format!(
                "        double shutter:close = {:?}\n        double shutter:open = {:?}\n",
                unsigned_zero(b.shutter / 2.0),
                unsigned_zero(-b.shutter / 2.0)
            ),
            None => String::new(),
        },
    );
    let samples = |s: &mut String, decl: &str, value: &dyn Fn(usize) -> String| {
        let _ = writeln!(s, "        {decl}.timeSamples = {{");
        for (k, &time) in times.iter().enumerate() {
            // A frame's time code as an integer; the shutter's ends as they are.
            let _ = match time.fract() == 0.0 {
                true => writeln!(s, "            {}: {},", time as i64, value(k)),
                false => writeln!(s, "            {:?}: {},", unsigned_zero(time), value(k)),
            };
        }
        let _ = writeln!(s, "        }}");
    };
    // The lens's entries animated, by their place in `lens`.
    let names = [
        (0, "focalLength"),
        (2, "horizontalApertureOffset"),
        (3, "verticalApertureOffset"),
    ];
    for (i, name) in names {
        samples(&mut s, &format!("float {name}"), &|k| float(lenses[k][i]));
    }
    samples(&mut s, "double3 xformOp:translate", &|k| {
        triple(relative(cams[k], origin).cop_world())
    });
    samples(&mut s, "quatd xformOp:orient", &|k| quat_wxyz(orients[k]));
    let _ = writeln!(
        s,
        "        uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\"]\n    }}"
    );

    let spheres = &doc.scene.spheres;
    let one_by_one = match spheres.len() >= INSTANCED_FROM {
        true => {
            point_instancer(&mut s, spheres, origin, &root);
            0
        }
        false => spheres.len(),
    };
    for (i, sphere) in spheres.iter().take(one_by_one).enumerate() {
        let r = unsigned_zero(sphere.radius);
        let e = unsigned_zero(r as f32);
        let _ = write!(
            s,
            r#"
    def Sphere "sphere_{i}"
    {{
        float3[] extent = [({m:?}, {m:?}, {m:?}), ({e:?}, {e:?}, {e:?})]
        color3f[] primvars:displayColor = [{color}] (
            interpolation = "constant"
        )
        double radius = {r:?}
        double3 xformOp:translate = {centre}
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
"#,
            m = unsigned_zero(-e),
            color = float3(sphere.color),
            centre = triple(sphere.center_world - origin),
        );
    }
    for (i, light) in doc.scene.lights.iter().enumerate() {
        // Colours above 1 become intensity, as in the glTF export.
        let intensity = light.color.max_element().max(1.0);
        let _ = write!(
            s,
            r#"
    def DistantLight "light_{i}" (
        prepend apiSchemas = ["ShadowAPI"]
    )
    {{
        color3f inputs:color = {color}
        float inputs:intensity = {intensity}
        bool inputs:shadow:enable = {shadows}
        quatd xformOp:orient = {orient}
        uniform token[] xformOpOrder = ["xformOp:orient"]
    }}
"#,
            color = float3(light.color / intensity),
            intensity = float(intensity),
            shadows = light.shadows,
            orient = quat_wxyz(aim_negative_z(light.direction_world)),
        );
    }
    let _ = write!(
        s,
        r#"}}

def Scope "Render"
{{
    def RenderSettings "settings"
    {{
        uniform token aspectRatioConformPolicy = "adjustPixelAspectRatio"
        rel camera = </{root}/camera>
        uniform float pixelAspectRatio = {pixel_aspect}
        uniform int2 resolution = ({width}, {height})
    }}
}}
"#,
        pixel_aspect = float(pixel_aspect),
        width = r.width,
        height = r.height,
    );
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Basis;
    use glam::DVec2;

    #[test]
    fn the_lens_sees_the_window_from_the_cop() {
        let cam = Camera {
            vrp_world: DVec3::ZERO,
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.5, -0.25, -2.0),
            window: DVec2::new(1.6, 0.9),
        };
        let [focal, vertical, h_offset, v_offset] = lens(&cam);
        // The window's edges seen from the COP, u from −0.8 − 0.5 to 0.8 − 0.5 at distance 2,
        // v from −0.45 + 0.25 to 0.45 + 0.25.
        let left = (-FILM_WIDTH / 2.0 + h_offset) / focal;
        let right = (FILM_WIDTH / 2.0 + h_offset) / focal;
        let bottom = (-vertical / 2.0 + v_offset) / focal;
        let top = (vertical / 2.0 + v_offset) / focal;
        for (got, want) in [(left, -1.3), (right, 0.3), (bottom, -0.2), (top, 0.7)] {
            assert!((got - want / 2.0).abs() < 1e-12, "{got} against {want} / 2");
        }
    }

    #[test]
    fn extents_round_outward_to_f32() {
        // 0.1 is between two f32s: the one below for a lower bound, above for an upper bound.
        let (down, up) = (f32_outward(0.1, -1.0), f32_outward(0.1, 1.0));
        assert!(f64::from(down) < 0.1 && f64::from(up) > 0.1);
        assert_eq!(down.next_up(), up);
        // One an f32 holds stays.
        assert_eq!(f32_outward(0.5, -1.0), 0.5);
        assert_eq!(f32_outward(-2.0, 1.0), -2.0);
    }

    #[test]
    fn strings_are_quoted_for_usda() {
        assert_eq!(quoted(r#"a "b" \c"#), r#""a \"b\" \\c""#);
        assert_eq!(quoted("é\nx"), "\"é x\"");
    }

    #[test]
    fn prim_names_are_identifiers() {
        assert_eq!(prim_name("distort"), "distort");
        assert_eq!(prim_name("2 shots-b"), "_2_shots_b");
        assert_eq!(prim_name(""), "_");
        assert_eq!(root_name("Render"), "Render_shot");
        assert_eq!(root_name("render"), "render");
    }
}
