//! The shot as one self-contained glTF 2.0 file: the camera animated per frame, the spheres, and
//! the directional lights.
//!
//! - The camera node's translation is the COP and its rotation takes the camera's +X, +Y, −Z to
//!   u, v, n (the columns of the rotation are u, v and −n, a proper rotation since u × v = −n),
//!   sampled LINEAR at the times (k + N) / fps of campath's frames k, N the first frame
//!   (`campath path --first-frame`, 0 unless given, in `asset.extras.campath_first_frame`), so
//!   that a reader at fps puts campath's frame k at its frame k + N. Its `yfov` is the window's height seen from
//!   the COP and its aspect the window's; a Zoom track animates `yfov` through
//!   `KHR_animation_pointer` (used, not required). An off-axis COP has no place in glTF. Its
//!   `znear` is the USD export's near (`clipping_range`), its far infinite: nothing campath
//!   draws is clipped.
//! - Spheres share one unit sphere's geometry. Below [`INSTANCED_FROM`] spheres each is a node
//!   scaled by its radius, with a mesh that pairs the shared geometry with its own colour: every
//!   viewer reads that. From it on, one node instances one mesh of a coarser sphere through
//!   `EXT_mesh_gpu_instancing` (required: a viewer without it would draw one sphere), with a
//!   TRANSLATION, a SCALE (the radius) and a colour (`_COLOR_0`, linear RGB, which three.js
//!   takes as the instance's colour) per instance, over a white material: 36 bytes a sphere,
//!   where its own node, mesh and material took about 350.
//! - Lights are `KHR_lights_punctual` directional lights, pointing their node's −Z along the
//!   light's direction.
//!
//! Everything numeric is f32 in the file, but `asset.extras`: `campath_origin` (`campath path
//! --origin`), which keeps the origin as given, and `campath_first_frame`. No number is `-0`.

use std::io::Write;

use base64::Engine as _;
use glam::{DMat3, DQuat, DVec3};
use serde::Serialize;
use serde_json::{json, Value};

use crate::camera::Camera;
use crate::document::Document;
use crate::error::{Error, Result};
use crate::export::{
    aim_negative_z, clipping_range, off_axis, relative, rotations, unsigned_zero, unsigned_zeros,
    yfov, INSTANCED_FROM,
};

/// Segments around and rings from pole to pole of the shared unit sphere: 2,304 triangles.
const SEGMENTS: u32 = 48;
const RINGS: u32 = 24;

/// The same for the instanced sphere, drawn up to a million times: 960 triangles, as the
/// Blender script's.
const INSTANCED_SEGMENTS: u32 = 32;
const INSTANCED_RINGS: u32 = 16;

/// glTF's component type of f32, and the buffer views' targets.
const FLOAT: u32 = 5126;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer being laid out, with its views and accessors.
#[derive(Default)]
struct Buffer {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    /// Appends `data` as a new buffer view (4-byte aligned) and an accessor over it; returns the
    /// accessor's index.
    fn push(
        &mut self,
        data: &[u8],
        count: usize,
        kind: &str,
        component: u32,
        target: Option<u32>,
        extra: Value,
    ) -> usize {
        self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
        let mut view =
            json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bytes.extend_from_slice(data);
        self.views.push(view);
        let mut accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": component,
            "count": count,
            "type": kind,
        });
        if let (Value::Object(a), Value::Object(e)) = (&mut accessor, extra) {
            a.extend(e);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// f32 values, `width` per element (1 SCALAR, 3 VEC3, 4 VEC4), with min and max when asked.
    fn floats(&mut self, values: &[f32], width: usize, target: Option<u32>, bounds: bool) -> usize {
        let kind = match width {
            1 => "SCALAR",
            3 => "VEC3",
            _ => "VEC4",
        };
        let extra = if bounds {
            let mut lo = vec![f32::INFINITY; width];
            let mut hi = vec![f32::NEG_INFINITY; width];
            for chunk in values.chunks(width) {
                for (i, v) in chunk.iter().enumerate() {
                    lo[i] = lo[i].min(*v);
                    hi[i] = hi[i].max(*v);
                }
            }
            let (lo, hi) = (lo.into_iter(), hi.into_iter());
            let (lo, hi): (Vec<f32>, Vec<f32>) = (
                lo.map(unsigned_zero).collect(),
                hi.map(unsigned_zero).collect(),
            );
            json!({"min": lo, "max": hi})
        } else {
            json!({})
        };
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.push(&bytes, values.len() / width, kind, FLOAT, target, extra)
    }
}

/// The unit sphere of `segments` around and `rings` from pole to pole: positions (also its
/// normals) and triangle indices, counter-clockwise seen from outside.
fn unit_sphere(segments: u32, rings: u32) -> (Vec<f32>, Vec<u16>) {
    let mut positions = Vec::new();
    for r in 0..=rings {
        let polar = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..=segments {
            let azimuth = std::f64::consts::TAU * s as f64 / segments as f64;
            let (sp, cp) = (libm::sin(polar), libm::cos(polar));
            let p = [sp * libm::cos(azimuth), cp, -sp * libm::sin(azimuth)];
            positions.extend(p.map(|x| x as f32));
        }
    }
    let row = (segments + 1) as u16;
    let mut indices = Vec::new();
    for r in 0..rings as u16 {
        for s in 0..segments as u16 {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            indices.extend([a, b, a + 1, a + 1, b, b + 1]);
        }
    }
    (positions, indices)
}

/// The rotation taking the camera's +X, +Y, −Z to u, v, n.
pub fn camera_rotation(cam: &Camera) -> DQuat {
    let b = cam.basis;
    DQuat::from_mat3(&DMat3::from_cols(b.u, b.v, -b.n)).normalize()
}

/// `v` in f32, never −0 (the JSON text's numbers; the buffer's too).
fn f32s(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array().map(unsigned_zero)
}

/// A rotation as glTF's (x, y, z, w) in f32, never −0.
fn quat_xyzw(q: DQuat) -> [f32; 4] {
    q.as_quat().to_array().map(unsigned_zero)
}

/// The glTF document (JSON) and its binary buffer; the caller embeds the buffer (`.gltf`) or
/// appends it (`.glb`). Also returns the frames with an off-axis COP that glTF cannot carry.
fn build(
    doc: &Document,
    embed: bool,
    origin: DVec3,
    first_frame: u64,
) -> Result<(Gltf, Vec<u8>, u64)> {
    let mut buf = Buffer::default();
    let spheres = &doc.scene.spheres;
    let instanced = spheres.len() >= INSTANCED_FROM;
    // The unit sphere every sphere's mesh scales: positions, normals, indices (none without
    // spheres: an accessor nothing uses).
    let (mut position, mut normal, mut index) = (0, 0, 0);
    if !spheres.is_empty() {
        let (positions, indices) = match instanced {
            true => unit_sphere(INSTANCED_SEGMENTS, INSTANCED_RINGS),
            false => unit_sphere(SEGMENTS, RINGS),
        };
        position = buf.floats(&positions, 3, Some(ARRAY_BUFFER), true);
        normal = buf.floats(&positions, 3, Some(ARRAY_BUFFER), false);
        let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        index = buf.push(
            &index_bytes,
            indices.len(),
            "SCALAR",
            5123,
            Some(ELEMENT_ARRAY_BUFFER),
            json!({}),
        );
    }

    let frames: Vec<(u64, Camera)> = doc.cameras().collect::<Result<_>>()?;
    // Campath's frame k at (k + N) / fps: at N = 0 its time t.
    let times: Vec<f32> = (frames.iter())
        .map(|(k, _)| doc.animation.time(k + first_frame) as f32)
        .collect();
    let cams: Vec<Camera> = frames.into_iter().map(|(_, cam)| cam).collect();
    let translations: Vec<f32> = (cams.iter())
        .flat_map(|&cam| f32s(relative(cam, origin).cop_world()))
        .collect();
    let rotations: Vec<f32> = (rotations(&cams).iter())
        .flat_map(|&q| quat_xyzw(q))
        .collect();
    let fovs: Vec<f32> = cams.iter().map(|cam| yfov(cam) as f32).collect();
    let off_axis = cams.iter().filter(|cam| off_axis(cam)).count() as u64;
    let first = cams[0];
    // As USD's near: nothing campath draws is clipped (no far: glTF's is then infinite).
    let (near, _) = clipping_range(&doc.scene.spheres, &cams);
    let time = buf.floats(&times, 1, None, true);
    let translation = buf.floats(&translations, 3, None, false);
    let rotation = buf.floats(&rotations, 4, None, false);
    let zoom = doc.animation.zoom.is_some();
    let mut samplers = vec![
        json!({"input": time, "output": translation, "interpolation": "LINEAR"}),
        json!({"input": time, "output": rotation, "interpolation": "LINEAR"}),
    ];
    let mut channels = vec![
        json!({"sampler": 0, "target": {"node": 0, "path": "translation"}}),
        json!({"sampler": 1, "target": {"node": 0, "path": "rotation"}}),
    ];
    if zoom {
        let fov = buf.floats(&fovs, 1, None, false);
        samplers.push(json!({"input": time, "output": fov, "interpolation": "LINEAR"}));
        channels.push(
            json!({"sampler": 2, "target": {"path": "pointer", "extensions": {
            "KHR_animation_pointer": {"pointer": "/cameras/0/perspective/yfov"}}}}),
        );
    }

    let mut nodes = vec![Node::Other(json!({
        "name": "camera",
        "camera": 0,
        "translation": f32s(relative(first, origin).cop_world()),
        "rotation": quat_xyzw(camera_rotation(&first)),
    }))];
    let (mut meshes, mut materials) = (vec![], vec![]);
    let sphere = |i: usize, name: String, color: DVec3| {
        let material = Material {
            name: name.clone(),
            pbr_metallic_roughness: Pbr {
                base_color_factor: color.as_vec3().extend(1.0).to_array().map(unsigned_zero),
                metallic_factor: 0.0,
                roughness_factor: 1.0,
            },
        };
        let mesh = Mesh {
            name,
            primitives: [Primitive {
                attributes: Attributes { position, normal },
                indices: index,
                material: i,
            }],
        };
        (material, mesh)
    };
    if instanced {
        // One white sphere, coloured per instance: three.js multiplies the material's colour
        // by `_COLOR_0`.
        let (material, mesh) = sphere(0, "spheres".into(), DVec3::ONE);
        materials.push(material);
        meshes.push(mesh);
        let per_instance = |f: &dyn Fn(&crate::scene::Sphere) -> [f32; 3]| -> Vec<f32> {
            spheres.iter().flat_map(|s| f(&s)).collect()
        };
        let translation = per_instance(&|s| f32s(s.center_world - origin));
        let scale = per_instance(&|s| [s.radius as f32; 3]);
        let color = per_instance(&|s| f32s(s.color));
        let attributes = json!({
            "TRANSLATION": buf.floats(&translation, 3, None, false),
            "SCALE": buf.floats(&scale, 3, None, false),
            "_COLOR_0": buf.floats(&color, 3, None, false),
        });
        nodes.push(Node::Other(json!({
            "name": "spheres",
            "mesh": 0,
            "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}},
        })));
    } else {
        for (i, s) in spheres.iter().enumerate() {
            let (material, mesh) = sphere(i, format!("sphere {i}"), s.color);
            materials.push(material);
            meshes.push(mesh);
            let r = s.radius as f32;
            nodes.push(Node::Sphere(SphereNode {
                name: format!("sphere {i}"),
                mesh: i,
                translation: f32s(s.center_world - origin),
                scale: [r, r, r],
            }));
        }
    }
    let mut lights = vec![];
    for (i, l) in doc.scene.lights.iter().enumerate() {
        lights.push(json!({
            "name": format!("light {i}"),
            "type": "directional",
            "color": f32s(l.color.clamp(DVec3::ZERO, DVec3::ONE)),
            "intensity": l.color.max_element().max(1.0) as f32,
        }));
        nodes.push(Node::Other(json!({
            "name": format!("light {i}"),
            "rotation": quat_xyzw(aim_negative_z(l.direction_world)),
            "extensions": {"KHR_lights_punctual": {"light": i}},
        })));
    }

    let used: Vec<&str> = [
        (!lights.is_empty(), "KHR_lights_punctual"),
        (zoom, "KHR_animation_pointer"),
        (instanced, "EXT_mesh_gpu_instancing"),
    ]
    .into_iter()
    .filter_map(|(on, name)| on.then_some(name))
    .collect();
    let aspect = first.window.x / first.window.y;
    let mut buffer = json!({"byteLength": buf.bytes.len()});
    if embed {
        let data = base64::engine::general_purpose::STANDARD.encode(&buf.bytes);
        buffer["uri"] = json!(format!("data:application/octet-stream;base64,{data}"));
    }
    let mut gltf = json!({
        "asset": {"version": "2.0", "generator": concat!("campath ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": unsigned_zero(yfov(&first) as f32),
            "aspectRatio": unsigned_zero(aspect as f32),
            "znear": unsigned_zero(near as f32),
        }}],
        "animations": [{"name": "camera", "samplers": samplers, "channels": channels}],
        "buffers": [buffer],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    });
    // Where the file's origin lies in campath's world (`campath path --origin`), and the number
    // of campath's frame 0 (`--first-frame`): its time is that over fps.
    gltf["asset"]["extras"] = json!({
        "campath_origin": unsigned_zeros(origin).to_array(),
        "campath_first_frame": first_frame,
        "campath_frames": format!(
            "campath frame k is at time (k + {first_frame}) / {:?} s: frame k + {first_frame} at {:?} fps",
            doc.animation.fps, doc.animation.fps
        ),
    });
    if !lights.is_empty() {
        gltf["extensions"] = json!({"KHR_lights_punctual": {"lights": lights}});
    }
    if !used.is_empty() {
        gltf["extensionsUsed"] = json!(used);
    }
    if instanced {
        gltf["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    }
    let Value::Object(rest) = gltf else {
        unreachable!("json! of an object")
    };
    let scene = Scene {
        name: doc
            .path
            .file_stem()
            .map_or_else(|| "shot".into(), |s| s.to_string_lossy().into_owned()),
        nodes: (0..nodes.len()).collect(),
    };
    let gltf = Gltf {
        rest,
        scenes: [scene],
        nodes,
        meshes,
        materials,
    };
    Ok((gltf, buf.bytes, off_axis))
}

/// The document: the parts with an entry a sphere typed, the rest as JSON values (as values, a
/// million spheres took 9.8 GB).
#[derive(Serialize)]
struct Gltf {
    #[serde(flatten)]
    rest: serde_json::Map<String, Value>,
    scenes: [Scene; 1],
    nodes: Vec<Node>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    meshes: Vec<Mesh>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    materials: Vec<Material>,
}

#[derive(Serialize)]
struct Scene {
    name: String,
    nodes: Vec<usize>,
}

#[derive(Serialize)]
#[serde(untagged)]
enum Node {
    Sphere(SphereNode),
    /// The camera's and the lights'.
    Other(Value),
}

#[derive(Serialize)]
struct SphereNode {
    name: String,
    mesh: usize,
    translation: [f32; 3],
    scale: [f32; 3],
}

#[derive(Serialize)]
struct Mesh {
    name: String,
    primitives: [Primitive; 1],
}

#[derive(Serialize)]
struct Primitive {
    attributes: Attributes,
    indices: usize,
    material: usize,
}

#[derive(Serialize)]
#[serde(rename_all = "UPPERCASE")]
struct Attributes {
    position: usize,
    normal: usize,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Material {
    name: String,
    pbr_metallic_roughness: Pbr,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Pbr {
    base_color_factor: [f32; 4],
    metallic_factor: f32,
    roughness_factor: f32,
}

/// Writes the shot as glTF into `out`: binary `.glb` when `binary`, else `.gltf` text with the
/// buffer embedded; returns the number of frames with an off-axis COP that glTF cannot carry.
/// The document goes straight to `out`, never whole in memory beside another copy (a million
/// spheres' JSON is about 400 MB).
pub fn write(
    doc: &Document,
    origin: DVec3,
    first_frame: u64,
    binary: bool,
    out: &mut dyn Write,
) -> Result<u64> {
    let (json, mut bin, off_axis) = build(doc, !binary, origin, first_frame)?;
    if !binary {
        serde_json::to_writer_pretty(&mut *out, &json).map_err(|e| Error::stdout(e.into()))?;
        out.write_all(b"\n").map_err(Error::stdout)?;
        return Ok(off_axis);
    }
    let mut text = serde_json::to_vec(&json).expect("finite numbers serialise");
    drop(json);
    text.resize(text.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + bin.len();
    // GLB's lengths are 32-bit: a file past 4 GiB cannot be written as one.
    let Ok(total32) = u32::try_from(total) else {
        return Err(Error::Usage(format!(
            "the shot as .glb would be {} MiB, past GLB's 4 GiB; write .gltf (text), which has \
             no such limit, or fewer spheres",
            total >> 20
        )));
    };
    let mut write = |bytes: &[u8]| out.write_all(bytes).map_err(Error::stdout);
    write(b"glTF")?;
    write(&2u32.to_le_bytes())?;
    write(&total32.to_le_bytes())?;
    write(&(text.len() as u32).to_le_bytes())?;
    write(b"JSON")?;
    write(&text)?;
    write(&(bin.len() as u32).to_le_bytes())?;
    write(b"BIN\0")?;
    write(&bin)?;
    Ok(off_axis)
}
