//! glTF 2.0 (`.gltf`, `.glb`): an animated camera node, through the `gltf` crate.
//!
//! - **Buffers.** A `.glb`'s binary chunk; `data:` URIs in base64 (campath's `.gltf` embeds its
//!   buffer so); other URIs are files beside the source.
//! - **Camera.** The node with a perspective camera (`--camera` picks one by the node's or the
//!   camera's name when there are several). Its world transform is the product of its own and
//!   its ancestors' matrices or translation, rotation and scale; glTF is Y-up and its camera
//!   looks down −Z with +Y up. The window is (2 tan(yfov / 2) · aspectRatio, 2 tan(yfov / 2)),
//!   without lens shift (glTF has none). A camera without `aspectRatio` (which glTF lets the
//!   viewport decide) is refused, as is an orthographic one.
//! - **Animation.** Channels on the translation, rotation and scale of the camera's node or an
//!   ancestor, with the spec's LINEAR (rotations by slerp), STEP and CUBICSPLINE interpolation,
//!   each held before its first key and after its last; and `KHR_animation_pointer` channels on
//!   the camera's `/cameras/N/perspective/yfov` (campath writes a Zoom track so). The samples
//!   are at every key time of those channels (one at time 0 when nothing moves). A node given
//!   by a matrix cannot be animated (the spec forbids it): refused.
//! - **campath's own files.** `asset.extras` says where the file's origin lies in campath's
//!   world (`campath_origin`, added back) and the rate and first frame (`campath_frames`,
//!   `campath_first_frame`), so that campath's frame k is at time k / fps again; other files
//!   give no rate.

use std::collections::BTreeSet;
use std::path::Path;

use base64::Engine as _;
use glam::{DMat4, DQuat, DVec2, DVec3};
use gltf::animation::util::ReadOutputs;
use gltf::animation::Interpolation;
use serde_json::Value;

use super::{Sample, Source, Up};

/// The pointer prefix of an animated camera property.
const CAMERAS: &str = "/cameras/";

/// A channel's keys: times, and per key the values (for CUBICSPLINE: in-tangent, value,
/// out-tangent).
struct Track {
    times: Vec<f64>,
    values: Vec<Vec<f64>>,
    interpolation: Interpolation,
    /// Whether the values are quaternions (x, y, z, w), interpolated on the sphere.
    rotation: bool,
}

impl Track {
    /// The value at `t` by the spec's interpolation (Appendix C), held outside the keys.
    fn at(&self, t: f64) -> Vec<f64> {
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| match cubic {
            true => &self.values[3 * k + 1],
            false => &self.values[k],
        };
        let n = self.times.len();
        let after = self.times.partition_point(|&x| x <= t);
        if after == 0 {
            return value(0).clone();
        }
        if after == n || self.times[after - 1] == t {
            return value(after - 1).clone();
        }
        let k = after - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let (dt, s) = (t1 - t0, (t - t0) / (t1 - t0));
        let out = match self.interpolation {
            Interpolation::Step => value(k).clone(),
            Interpolation::Linear if self.rotation => {
                let q = |v: &[f64]| DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize();
                let r = q(value(k)).slerp(q(value(k + 1)), s);
                return r.to_array().to_vec();
            }
            Interpolation::Linear => (value(k).iter().zip(value(k + 1)))
                .map(|(a, b)| a + (b - a) * s)
                .collect(),
            Interpolation::CubicSpline => {
                let (s2, s3) = (s * s, s * s * s);
                let (v0, b0) = (&self.values[3 * k + 1], &self.values[3 * k + 2]);
                let (a1, v1) = (&self.values[3 * k + 3], &self.values[3 * k + 4]);
                (0..v0.len())
                    .map(|i| {
                        (2.0 * s3 - 3.0 * s2 + 1.0) * v0[i]
                            + dt * (s3 - 2.0 * s2 + s) * b0[i]
                            + (-2.0 * s3 + 3.0 * s2) * v1[i]
                            + dt * (s3 - s2) * a1[i]
                    })
                    .collect()
            }
        };
        match self.rotation {
            true => DQuat::from_slice(&out).normalize().to_array().to_vec(),
            false => out,
        }
    }
}

/// The JSON and binary chunk of a `.glb`, or the JSON of a `.gltf`.
fn chunks(bytes: &[u8]) -> Result<(Vec<u8>, Option<Vec<u8>>), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok((bytes.to_vec(), None));
    }
    // The crate subtracts the header's 12 bytes from the declared length unchecked.
    let declared = bytes
        .get(8..12)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    if declared.is_none_or(|length| length < 12) {
        return Err("not a GLB file: its header is cut short or its length is too small".into());
    }
    let glb = gltf::binary::Glb::from_slice(bytes).map_err(|e| format!("not a whole GLB: {e}"))?;
    Ok((glb.json.into_owned(), glb.bin.map(|b| b.into_owned())))
}

/// The bytes of a buffer's URI: a base64 `data:` URI, or a file relative to the source.
fn uri_bytes(uri: &str, path: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or_else(|| format!("a data URI not in base64: {:.40}", uri))?;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("a data URI's base64: {e}"));
    }
    if uri.contains("://") {
        return Err(format!("the buffer {uri:?} is not a local file"));
    }
    let file = path.parent().unwrap_or(Path::new(".")).join(uri);
    std::fs::read(&file).map_err(|e| format!("the buffer {}: {e}", file.display()))
}

/// The camera of a glTF asset.
pub fn read(bytes: &[u8], path: &Path, camera: Option<&str>) -> Result<Source, String> {
    let (json, bin) = chunks(bytes)?;
    let mut root: Value =
        serde_json::from_slice(&json).map_err(|e| format!("not glTF's JSON: {e}"))?;
    // `KHR_animation_pointer` channels have no node, which the crate's types require: they are
    // taken out here and read below, (animation, sampler, pointer).
    let mut pointers = Vec::new();
    if let Some(animations) = root.get_mut("animations").and_then(Value::as_array_mut) {
        for (a, animation) in animations.iter_mut().enumerate() {
            if let Some(channels) = animation.get_mut("channels").and_then(Value::as_array_mut) {
                channels.retain(|channel| {
                    let target = &channel["target"];
                    if target["path"] != "pointer" {
                        return true;
                    }
                    let pointer = &target["extensions"]["KHR_animation_pointer"]["pointer"];
                    if let (Some(s), Some(p)) = (channel["sampler"].as_u64(), pointer.as_str()) {
                        pointers.push((a, s as usize, p.to_string()));
                    }
                    false
                });
            }
        }
    }
    let extras = root["asset"]["extras"].clone();
    let root: gltf::json::Root =
        serde_json::from_value(root).map_err(|e| format!("not a glTF 2.0 document: {e}"))?;
    let doc = gltf::Document::from_json(root).map_err(|e| format!("an invalid glTF: {e}"))?;

    let mut buffers = Vec::new();
    for buffer in doc.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => bin
                .clone()
                .ok_or("buffer 0 is the GLB's binary chunk, which the file does not have")?,
            gltf::buffer::Source::Uri(uri) => uri_bytes(uri, path)?,
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} has {} bytes, its byteLength says {}",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(Vec::as_slice);

    // The camera node.
    let nodes: Vec<gltf::Node> = doc.nodes().filter(|n| n.camera().is_some()).collect();
    let label = |n: &gltf::Node| match (n.name(), n.camera().and_then(|c| c.name())) {
        (Some(node), _) => node.to_string(),
        (None, Some(cam)) => cam.to_string(),
        (None, None) => format!("node {}", n.index()),
    };
    let names = |nodes: &[gltf::Node]| nodes.iter().map(label).collect::<Vec<_>>().join(", ");
    let node = match (camera, &nodes[..]) {
        (_, []) => return Err("no camera: no node of the asset has a camera".into()),
        (None, [one]) => one.clone(),
        (None, _) => {
            return Err(format!(
                "several camera nodes: {}; choose one with --camera",
                names(&nodes)
            ))
        }
        (Some(name), _) => {
            let named: Vec<gltf::Node> = (nodes.iter())
                .filter(|n| {
                    n.name() == Some(name) || n.camera().and_then(|c| c.name()) == Some(name)
                })
                .cloned()
                .collect();
            match &named[..] {
                [one] => one.clone(),
                [] => {
                    return Err(format!(
                        "no camera named {name:?}: the camera nodes are {}",
                        names(&nodes)
                    ))
                }
                _ => return Err(format!("several cameras are named {name:?}")),
            }
        }
    };
    let cam = node.camera().ok_or("the node has no camera")?;
    let gltf::camera::Projection::Perspective(lens) = cam.projection() else {
        return Err(format!(
            "the camera of {} is orthographic: campath's camera is perspective",
            label(&node)
        ));
    };
    let aspect = f64::from(lens.aspect_ratio().ok_or_else(|| {
        format!(
            "the camera of {} has no aspectRatio (glTF leaves it to the viewport): add \
             \"aspectRatio\": width / height to its perspective",
            label(&node)
        )
    })?);

    // The chain from the root to the camera's node.
    let mut parent = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for child in n.children() {
            parent[child.index()] = Some(n.index());
        }
    }
    let mut chain = vec![node.index()];
    while let Some(p) = parent[chain[chain.len() - 1]] {
        if chain.contains(&p) || chain.len() > parent.len() {
            return Err(format!("node {p} is its own ancestor"));
        }
        chain.push(p);
    }
    chain.reverse();

    // The animated properties of the chain, by node: translation, rotation, scale.
    let mut tracks: Vec<[Option<Track>; 3]> = chain.iter().map(|_| [None, None, None]).collect();
    for animation in doc.animations() {
        for channel in animation.channels() {
            let target = channel.target();
            let Some(at) = chain.iter().position(|&i| i == target.node().index()) else {
                continue;
            };
            let what = format!(
                "animation {} channel {}",
                animation.index(),
                channel.index()
            );
            let reader = channel.reader(get);
            let times: Vec<f64> = reader
                .read_inputs()
                .ok_or_else(|| format!("{what}: its times cannot be read"))?
                .map(f64::from)
                .collect();
            let widen = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
            let (slot, values): (usize, Vec<Vec<f64>>) = match reader.read_outputs() {
                Some(ReadOutputs::Translations(it)) => (0, it.map(|v| widen(&v)).collect()),
                Some(ReadOutputs::Rotations(it)) => (1, it.into_f32().map(|v| widen(&v)).collect()),
                Some(ReadOutputs::Scales(it)) => (2, it.map(|v| widen(&v)).collect()),
                Some(ReadOutputs::MorphTargetWeights(_)) => continue,
                None => return Err(format!("{what}: its values cannot be read")),
            };
            let track = track(times, values, channel.sampler().interpolation(), slot == 1)
                .map_err(|e| format!("{what}: {e}"))?;
            if tracks[at][slot].is_some() {
                return Err(format!(
                    "{what}: a second channel on node {}'s {:?}",
                    chain[at],
                    target.property()
                ));
            }
            tracks[at][slot] = Some(track);
        }
    }
    for (k, &i) in chain.iter().enumerate() {
        let n = doc.nodes().nth(i).ok_or("a node past the list")?;
        let animated = tracks[k].iter().any(Option::is_some);
        if animated && matches!(n.transform(), gltf::scene::Transform::Matrix { .. }) {
            return Err(format!(
                "node {i} is given by a matrix and animated, which glTF forbids"
            ));
        }
    }
    // The camera's yfov through KHR_animation_pointer.
    let mut yfov_track = None;
    let own = format!("{CAMERAS}{}/perspective/yfov", cam.index());
    for (a, s, pointer) in pointers {
        if pointer != own {
            continue;
        }
        let what = format!("animation {a}'s pointer channel on {pointer}");
        let sampler = (doc.animations().nth(a))
            .and_then(|anim| anim.samplers().nth(s))
            .ok_or_else(|| format!("{what}: no sampler {s}"))?;
        let floats = |accessor: gltf::Accessor| {
            gltf::accessor::Iter::<f32>::new(accessor, get)
                .map(|it| it.map(f64::from).collect::<Vec<f64>>())
                .ok_or_else(|| format!("{what}: its keys cannot be read"))
        };
        let times = floats(sampler.input())?;
        let values = floats(sampler.output())?.into_iter().map(|v| vec![v]);
        let track = track(times, values.collect(), sampler.interpolation(), false)
            .map_err(|e| format!("{what}: {e}"))?;
        yfov_track = Some(track);
    }

    // campath's own: where the file's origin is, and the rate and first frame.
    let origin = extras["campath_origin"]
        .as_array()
        .and_then(|a| {
            Some(DVec3::new(
                a.first()?.as_f64()?,
                a.get(1)?.as_f64()?,
                a.get(2)?.as_f64()?,
            ))
        })
        .unwrap_or(DVec3::ZERO);
    let fps = extras["campath_frames"].as_str().and_then(|s| {
        let rate = s.strip_suffix(" fps")?.rsplit(' ').next()?;
        rate.parse::<f64>()
            .ok()
            .filter(|f| *f > 0.0 && f.is_finite())
    });
    let first_frame = extras["campath_first_frame"].as_f64().unwrap_or(0.0);
    let start = fps.map_or(0.0, |f| first_frame / f);

    let mut times = BTreeSet::new();
    let all = tracks.iter().flatten().flatten().chain(&yfov_track);
    for track in all {
        times.extend(track.times.iter().map(|t| (t + 0.0).to_bits()));
    }
    // Key times are finite and at least 0 (`track`), −0 made +0: their bits sort as they do.
    let times: Vec<f64> = match times.is_empty() {
        true => vec![0.0],
        false => times.into_iter().map(f64::from_bits).collect(),
    };
    let mut samples = Vec::with_capacity(times.len());
    for t in times {
        let mut world = DMat4::IDENTITY;
        for (k, &i) in chain.iter().enumerate() {
            let n = doc.nodes().nth(i).ok_or("a node past the list")?;
            let local = match n.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
                }
                gltf::scene::Transform::Decomposed {
                    translation,
                    rotation,
                    scale,
                } => {
                    let value = |slot: usize, rest: Vec<f64>| match &tracks[k][slot] {
                        Some(track) => track.at(t),
                        None => rest,
                    };
                    let tr = value(0, translation.map(f64::from).to_vec());
                    let r = value(1, rotation.map(f64::from).to_vec());
                    let s = value(2, scale.map(f64::from).to_vec());
                    let q = DQuat::from_slice(&r);
                    if q.length() == 0.0 {
                        return Err(format!("node {i}: a zero rotation at {t} s"));
                    }
                    DMat4::from_scale_rotation_translation(
                        DVec3::from_slice(&s),
                        q.normalize(),
                        DVec3::from_slice(&tr),
                    )
                }
            };
            world *= local;
        }
        let yfov = yfov_track
            .as_ref()
            .map_or(f64::from(lens.yfov()), |track| track.at(t)[0]);
        if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
            return Err(format!(
                "the camera's yfov at {t} s is {yfov} radians: not between 0 and π"
            ));
        }
        let tall = 2.0 * libm::tan(yfov / 2.0);
        let window = DVec2::new(tall * aspect, tall);
        if !(window.is_finite() && aspect > 0.0) {
            return Err(format!("the camera's aspectRatio {aspect} is not positive"));
        }
        let mut sample = Sample::of_matrix(t - start, world, Up::Y, window, DVec2::ZERO)
            .map_err(|e| format!("{} at {t} s: {e}", label(&node)))?;
        sample.eye += origin;
        samples.push(sample);
    }
    Ok(Source {
        samples,
        fps,
        size: None,
        camera: label(&node),
        view_distance: None,
    })
}

/// A checked track: as many values as keys (three times as many for CUBICSPLINE), key times
/// finite, at least 0 and increasing.
fn track(
    times: Vec<f64>,
    values: Vec<Vec<f64>>,
    interpolation: Interpolation,
    rotation: bool,
) -> Result<Track, String> {
    let per_key = match interpolation {
        Interpolation::CubicSpline => 3,
        _ => 1,
    };
    if times.is_empty() || values.len() != per_key * times.len() {
        return Err(format!(
            "{} key times and {} values ({per_key} a key for {interpolation:?})",
            times.len(),
            values.len()
        ));
    }
    if !(times.iter().all(|t| t.is_finite() && *t >= 0.0) && times.windows(2).all(|w| w[0] < w[1]))
    {
        return Err("its key times are not increasing finite seconds from 0".into());
    }
    if values.iter().flatten().any(|v| !v.is_finite()) {
        return Err("a value is not finite".into());
    }
    Ok(Track {
        times,
        values,
        interpolation,
        rotation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_splines_follow_their_tangents() {
        // One key at 0 (value 0, out-tangent 1) and one at 2 (value 2, in-tangent 1): the
        // line v = t, which the Hermite curve reproduces.
        let track = Track {
            times: vec![0.0, 2.0],
            values: [[9.0], [0.0], [1.0], [1.0], [2.0], [9.0]]
                .map(|v| v.to_vec())
                .to_vec(),
            interpolation: Interpolation::CubicSpline,
            rotation: false,
        };
        for t in [0.0, 0.5, 1.0, 1.7, 2.0] {
            assert!((track.at(t)[0] - t).abs() < 1e-15, "{t}");
        }
        assert_eq!(track.at(3.0)[0], 2.0);
    }

    #[test]
    fn steps_hold_and_rotations_slerp() {
        let quarter = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let track = |interpolation, rotation, values: Vec<Vec<f64>>| Track {
            times: vec![1.0, 2.0],
            values,
            interpolation,
            rotation,
        };
        let step = track(Interpolation::Step, false, vec![vec![3.0], vec![5.0]]);
        assert_eq!(
            (step.at(0.0)[0], step.at(1.9)[0], step.at(2.0)[0]),
            (3.0, 3.0, 5.0)
        );
        let q = vec![
            DQuat::IDENTITY.to_array().to_vec(),
            quarter.to_array().to_vec(),
        ];
        let turn = track(Interpolation::Linear, true, q);
        let half = DQuat::from_slice(&turn.at(1.5));
        assert!(half.angle_between(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4)) < 1e-12);
    }

    #[test]
    fn cut_glbs_are_errors() {
        for bytes in [
            &b"glTF"[..],
            b"glTF\x02\0\0\0\x04\0\0\0",
            b"glTF\x02\0\0\0\xff\0\0\0",
        ] {
            assert!(read(bytes, Path::new("x.glb"), None).is_err());
        }
    }
}
