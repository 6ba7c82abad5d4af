//! The shot as a Python script for Blender: `blender --background --python shot.py` (or
//! Blender's Text Editor) builds the camera keyed at every frame, the render size and rate, the
//! spheres with their colours and the lights.
//!
//! The spheres are one sphere mesh instanced by geometry nodes (Instance on Points) on a mesh of
//! their centres, whose `radius` and `color` attributes scale and colour the instances; one
//! material reads the colour (an Attribute node of the instancer). Centres, radii and colours
//! are little-endian f32 in base64 at the script's end, each set with one `foreach_set`: a
//! sphere each through `bpy.ops` took 8 minutes to open 2,000 spheres; this opens 100,000 in a
//! few seconds (docs/performance.md). f32 is what Blender keeps. The Solid view and Workbench
//! do not read an instance's attributes: the script's `REALIZE` makes one mesh of coarser
//! spheres for them.
//!
//! The scene is built Z-up, as Blender's own glTF and USD importers build a Y-up file: campath's
//! point (x, y, z) is Blender's (x, −z, y) ([`z_up`]), a turn of +90° about X. Blender's camera
//! looks down its local −Z with +Y up, like the camera here with axes u, v, −n, so its location
//! is the COP turned so and its rotation the quaternion of [u, v, −n] after that turn. The lens and
//! sensor reproduce the window exactly: with the sensor fitted to the width (36 mm, or wider
//! where a lens would be under 2 mm), lens / sensor = d / w for the COP's distance d and window
//! width w; the off-axis COP (distort), which neither
//! `.chan` nor glTF can carry, becomes Blender's lens shift, in units of the window width:
//! shift = −offset / w. A window whose aspect differs from the image's becomes the pixel aspect.
//! Scene frame k + N is campath's frame k, N the first frame (`campath path --first-frame`, 0
//! unless given), as in every export.
//!
//! Motion blur becomes Blender's: `render.use_motion_blur`, `render.motion_blur_shutter` (in
//! frames, as campath's shutter) and the shutter centred on the frame (`motion_blur_position`
//! on the render settings, or on Cycles' and EEVEE's before Blender 4.2), and EEVEE's own
//! switch, shutter and time steps where it has them. Blender moves the camera linearly between
//! the keys of consecutive frames, so its sub-frame camera follows the chord of campath's path;
//! the camera is also keyed where the first frame's shutter opens and the last's closes.
//! The clipping range clips nothing campath draws (`clipping_range`).

use std::fmt::Write as _;

use base64::Engine as _;
use glam::{DQuat, DVec3};

use crate::camera::Camera;
use crate::document::Document;
use crate::error::Result;
use crate::export::{
    clipping_range, keyed_cameras, quat_wxyz, relative, rotations, triple, unsigned_zero,
};

/// The sensor width in millimetres the lens is computed for, unless the shot is too wide for it.
const SENSOR_MM: f64 = 36.0;

/// The shortest lens the sensor is widened to give: Blender's least is 1 mm, and it raises a
/// shorter one to that silently (a 176° field of view would become 173.6°).
const SHORTEST_LENS_MM: f64 = 2.0;

/// Segments around and rings from pole to pole of the one sphere the script instances: 960
/// triangles, smooth-shaded (a sphere each had 48 × 24, 2,304, when there were a few).
const SEGMENTS: u32 = 32;
const RINGS: u32 = 16;

/// The same for the script's `REALIZE`, which makes every sphere's vertices real: 62 vertices
/// and 120 triangles a sphere, 6.2 million vertices for 100,000 spheres (of 32 × 16, 48 million
/// took 23 GB).
const REALIZED_SEGMENTS: u32 = 12;
const REALIZED_RINGS: u32 = 6;

/// Bytes of f32 per base64 line: 57 make 76 characters, MIME's line, and a whole number of
/// 3-byte groups, so each line encodes on its own without padding.
const LINE_BYTES: usize = 57;

/// campath's point or direction (x, y, z) in Blender's Z-up world: (x, −z, y), as Blender's
/// glTF importer places a Y-up file (a turn of +90° about X, [`to_z_up`]).
pub fn z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, -p.z, p.y)
}

/// The turn of [`z_up`] as a rotation: +90° about X takes +Y to +Z and +Z to −Y.
fn to_z_up() -> DQuat {
    DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2)
}

/// `values` as little-endian f32 in base64, a line of 76 characters at a time (Python's
/// `b64decode` skips the line breaks).
fn base64_f32(values: impl Iterator<Item = f64>) -> String {
    let bytes: Vec<u8> = values.flat_map(|v| (v as f32).to_le_bytes()).collect();
    let mut out = String::with_capacity(bytes.len().div_ceil(LINE_BYTES) * 77);
    for line in bytes.chunks(LINE_BYTES) {
        base64::engine::general_purpose::STANDARD.encode_string(line, &mut out);
        out.push('\n');
    }
    out
}

/// The script, campath frame k the scene's frame k + `first_frame`.
pub fn script(doc: &Document, origin: DVec3, first_frame: u64) -> Result<String> {
    let keys = keyed_cameras(doc)?;
    let cams: Vec<Camera> = keys.iter().map(|&(_, cam)| cam).collect();
    // The sensor is `SENSOR_MM` wide, or wider where a frame's lens would be shorter than
    // `SHORTEST_LENS_MM` on it. The lens shift is in units of its width, so it does not change.
    let sensor = (cams.iter())
        .map(|cam| SHORTEST_LENS_MM * cam.window.x / -cam.cop_view.z)
        .fold(SENSOR_MM, f64::max);
    let (near, far) = clipping_range(&doc.scene.spheres, &cams);
    let mut frames = String::new();
    // Turning every quaternion alike keeps consecutive ones on the same side.
    for ((frame, cam), q) in keys.iter().zip(rotations(&cams)) {
        let cop = triple(z_up(relative(*cam, origin).cop_world()));
        // The lens in mm for the sensor fitted to the width, and the shift in window widths.
        let (d, w) = (-cam.cop_view.z, cam.window.x);
        let [lens, sx, sy] =
            [sensor * d / w, -cam.cop_view.x / w, -cam.cop_view.y / w].map(unsigned_zero);
        let q = quat_wxyz(to_z_up() * q);
        let scene_frame = unsigned_zero(frame + first_frame as f64);
        let _ = writeln!(
            frames,
            "    ({scene_frame:?}, {cop}, {q}, {lens:?}, {sx:?}, {sy:?}),"
        );
    }
    let spheres = &doc.scene.spheres;
    let centres = base64_f32(
        spheres
            .iter()
            .flat_map(|s| z_up(s.center_world - origin).to_array()),
    );
    let radii = base64_f32(spheres.iter().map(|s| s.radius));
    let colours = base64_f32(spheres.iter().flat_map(|s| s.color.to_array()));
    let mut lights = String::new();
    for l in &doc.scene.lights {
        let (d, k) = (triple(z_up(l.direction_world)), triple(l.color));
        let shadows = if l.shadows { "True" } else { "False" };
        let _ = writeln!(lights, "    ({d}, {k}, {shadows}),");
    }
    let r = doc.raster;
    let first = doc.camera(0)?;
    // Square pixels when the window has the image's aspect; otherwise the pixel aspect.
    let pixel_aspect = (first.window.x / first.window.y) / (r.width as f64 / r.height as f64);
    Ok(format!(
        r#"# The campath shot "{name}", for Blender: blender --background --python this.py, or run it in
# Blender's Text Editor. Generated by campath {version}.
# Z-up, as Blender's glTF and USD importers: campath's point (x, y, z) is this scene's (x, -z, y).
# Scene frame k + FIRST_FRAME is campath frame k (campath path --first-frame {first_frame}).
import array
import base64
import sys

import bpy

FPS = {fps:?}
WIDTH, HEIGHT = {width}, {height}
PIXEL_ASPECT = {pixel_aspect:?}
SENSOR_MM = {sensor:?}
# near and far: nothing campath draws is clipped (Blender's least clip_start is 1e-6)
CLIP = ({near:?}, {far:?})
FIRST_FRAME, LAST_FRAME = {first_frame}, {last_frame}
BACKGROUND = {background}
AMBIENT = {ambient:?}
# the point of campath's world at this file's origin (campath path --origin), in campath's
# coordinates (Y-up)
ORIGIN = {origin}
# shutter (the fraction of the frame interval it is open, centred on the frame), time samples; or None
MOTION_BLUR = {motion_blur}
# scene frame (with motion blur also where the first frame's shutter opens and the last's closes),
# COP (x, y, z), rotation quaternion (w, x, y, z) taking -Z to the VPN, lens mm, shift x, shift y,
# in this scene's Z-up coordinates
FRAMES = [
{frames}]
# the spheres, at the end of this file: SPHERE_COUNT centres (x, y, z, Z-up, relative to ORIGIN), radii
# and linear RGB colours, little-endian float32 in base64
SPHERE_COUNT = {sphere_count}
# the one sphere every sphere instances: segments around, rings from pole to pole
SPHERE_SEGMENTS, SPHERE_RINGS = {segments}, {rings}
# True makes the instances one mesh, whose colours the Solid view and Workbench show (they do not
# read an instance's), of coarser spheres: a mesh of 100,000 spheres of 32 x 16 took 23 GB
REALIZE = False
REALIZED_SEGMENTS, REALIZED_RINGS = {realized_segments}, {realized_rings}
# direction the light travels (Z-up), linear RGB, shadows
LIGHTS = [
{lights}]


def fcurves(owner):
    """The F-curves of `owner`'s action: the action's own before Blender 4.4, its slot's
    channel bag since (Blender 5 has only those)."""
    action = owner.animation_data.action
    if hasattr(action, "fcurves"):
        return action.fcurves
    from bpy_extras import anim_utils
    return anim_utils.action_get_channelbag_for_slot(action, owner.animation_data.action_slot).fcurves


def floats(text, count):
    """`count` float32 values from base64 `text` (little-endian)."""
    values = array.array("f")
    values.frombytes(base64.b64decode(text))
    if sys.byteorder == "big":
        values.byteswap()
    assert len(values) == count, (len(values), count)
    return values


def sphere_material():
    """The one material of every sphere: its colour read from the `color` attribute of the
    instance (or, realized, of the mesh), rough and not metallic."""
    material = bpy.data.materials.new("campath spheres")
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True  # always on, and deprecated, since Blender 5
    nodes = material.node_tree.nodes
    bsdf = nodes.get("Principled BSDF")
    if bsdf is not None:
        colour = nodes.new("ShaderNodeAttribute")
        colour.attribute_type = "GEOMETRY" if REALIZE else "INSTANCER"
        colour.attribute_name = "color"
        material.node_tree.links.new(colour.outputs["Color"], bsdf.inputs["Base Color"])
        bsdf.inputs["Roughness"].default_value = 1.0
    return material


def instancer(material):
    """Geometry nodes that put a sphere of radius 1, smooth and of `material`, on every point of
    their mesh, scaled by the point's `radius`; the points' other attributes (`color`) pass to
    the instances."""
    tree = bpy.data.node_groups.new("campath spheres", "GeometryNodeTree")
    if hasattr(tree, "interface"):  # Blender 4.0 and later
        tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:
        tree.inputs.new("NodeSocketGeometry", "Geometry")
        tree.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, link = tree.nodes, tree.links.new
    points, out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    sphere = nodes.new("GeometryNodeMeshUVSphere")
    segments, rings = (REALIZED_SEGMENTS, REALIZED_RINGS) if REALIZE else (SPHERE_SEGMENTS, SPHERE_RINGS)
    sphere.inputs["Segments"].default_value = segments
    sphere.inputs["Rings"].default_value = rings
    sphere.inputs["Radius"].default_value = 1.0
    smooth = nodes.new("GeometryNodeSetShadeSmooth")
    link(sphere.outputs["Mesh"], smooth.inputs["Geometry"])
    paint = nodes.new("GeometryNodeSetMaterial")
    paint.inputs["Material"].default_value = material
    link(smooth.outputs["Geometry"], paint.inputs["Geometry"])
    radius = nodes.new("GeometryNodeInputNamedAttribute")
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "radius"
    instances = nodes.new("GeometryNodeInstanceOnPoints")
    link(points.outputs[0], instances.inputs["Points"])
    link(paint.outputs["Geometry"], instances.inputs["Instance"])
    # Blender 3 has an output for each type, the others disabled.
    link(next(s for s in radius.outputs if s.enabled), instances.inputs["Scale"])
    last = instances.outputs["Instances"]
    if REALIZE:
        realize = nodes.new("GeometryNodeRealizeInstances")
        link(last, realize.inputs["Geometry"])
        last = realize.outputs["Geometry"]
    link(last, out.inputs[0])
    return tree


def spheres(scene):
    """The spheres: a mesh of their centres with `radius` and `color` attributes, each filled by
    one `foreach_set`, and the geometry nodes that instance a sphere on it."""
    n = SPHERE_COUNT
    if n == 0:
        return
    mesh = bpy.data.meshes.new("campath spheres")
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", floats(SPHERE_CENTRES, 3 * n))
    # An attribute is used at once: adding another may move its data.
    mesh.attributes.new("radius", "FLOAT", "POINT").data.foreach_set("value", floats(SPHERE_RADII, n))
    rgb = floats(SPHERE_COLOURS, 3 * n)
    rgba = array.array("f", [1.0]) * (4 * n)
    for k in range(3):
        rgba[k::4] = rgb[k::3]
    mesh.attributes.new("color", "FLOAT_COLOR", "POINT").data.foreach_set("color", rgba)
    mesh.update()
    cloud = bpy.data.objects.new("campath spheres", mesh)
    scene.collection.objects.link(cloud)
    modifier = cloud.modifiers.new("campath spheres", "NODES")
    modifier.node_group = instancer(sphere_material())
    if REALIZE:
        realize(scene, cloud)


def realize(scene, cloud):
    """The realized instances made the cloud's own mesh, whose `color` can then be the active
    colour attribute that the Solid view and Workbench show (a modifier's mesh has none)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(
        cloud.evaluated_get(depsgraph), preserve_all_data_layers=True, depsgraph=depsgraph)
    points = cloud.data
    cloud.modifiers.clear()
    cloud.data = mesh
    bpy.data.meshes.remove(points)
    mesh.attributes.active_color = mesh.attributes["color"]
    scene.display.shading.color_type = "VERTEX"


def build():
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    if PIXEL_ASPECT >= 1.0:
        scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = PIXEL_ASPECT, 1.0
    else:
        scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = 1.0, 1.0 / PIXEL_ASPECT
    scene.render.fps = max(1, round(FPS))
    scene.render.fps_base = scene.render.fps / FPS
    scene.frame_start, scene.frame_end = FIRST_FRAME, LAST_FRAME
    scene["campath_origin"] = ORIGIN
    if MOTION_BLUR is not None:
        shutter, steps = MOTION_BLUR
        scene.render.use_motion_blur = True
        scene.render.motion_blur_shutter = shutter
        eevee = getattr(scene, "eevee", None)
        for settings in (scene.render, getattr(scene, "cycles", None), eevee):
            if settings is not None and hasattr(settings, "motion_blur_position"):
                settings.motion_blur_position = "CENTER"
        if eevee is not None and hasattr(eevee, "use_motion_blur"):
            eevee.use_motion_blur = True
            eevee.motion_blur_shutter = shutter
        if eevee is not None and hasattr(eevee, "motion_blur_steps"):
            eevee.motion_blur_steps = steps

    data = bpy.data.cameras.new("campath")
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = SENSOR_MM
    data.clip_start, data.clip_end = CLIP
    camera = bpy.data.objects.new("campath camera", data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.rotation_mode = "QUATERNION"
    # One key a channel makes the F-curves; then every frame's keys go in at once (a key
    # inserted at a time costs time growing with the keys there: minutes at 10,000 frames).
    frame, cop, q, lens, shift_x, shift_y = FRAMES[0]
    camera.location, camera.rotation_quaternion = cop, q
    data.lens, data.shift_x, data.shift_y = lens, shift_x, shift_y
    camera.keyframe_insert("location", frame=frame)
    camera.keyframe_insert("rotation_quaternion", frame=frame)
    for path in ("lens", "shift_x", "shift_y"):
        data.keyframe_insert(path, frame=frame)
    values = dict((("location", i), [f[1][i] for f in FRAMES]) for i in range(3))
    values.update((("rotation_quaternion", i), [f[2][i] for f in FRAMES]) for i in range(4))
    for k, path in enumerate(("lens", "shift_x", "shift_y")):
        values[(path, 0)] = [f[3 + k] for f in FRAMES]
    for owner in (camera, data):
        for curve in fcurves(owner):
            points = curve.keyframe_points
            points.add(len(FRAMES) - len(points))
            co = [0.0] * (2 * len(FRAMES))
            co[0::2] = [f[0] for f in FRAMES]
            co[1::2] = values[(curve.data_path, curve.array_index)]
            points.foreach_set("co", co)
            for key in points:
                key.interpolation = "LINEAR"
            curve.update()

    spheres(scene)

    for i, (direction, colour, shadows) in enumerate(LIGHTS):
        data = bpy.data.lights.new("light %d" % i, type="SUN")
        data.color = tuple(min(1.0, c) for c in colour)
        data.energy = 3.0 * max(1.0, max(colour))
        data.use_shadow = shadows
        sun = bpy.data.objects.new("light %d" % i, data)
        scene.collection.objects.link(sun)
        # A sun shines along its local -Z.
        from mathutils import Vector
        sun.rotation_mode = "QUATERNION"
        sun.rotation_quaternion = Vector((0.0, 0.0, -1.0)).rotation_difference(Vector(direction).normalized())

    if scene.world is None:
        scene.world = bpy.data.worlds.new("campath")
    scene.world.color = BACKGROUND
    scene.frame_set(FIRST_FRAME)


SPHERE_CENTRES = """
{centres}"""
SPHERE_RADII = """
{radii}"""
SPHERE_COLOURS = """
{colours}"""

build()
"#,
        // Quoted and escaped: a file name with a line break cannot end the comment.
        name = doc.path.display().to_string().escape_debug(),
        version = env!("CARGO_PKG_VERSION"),
        fps = doc.animation.fps,
        width = r.width,
        height = r.height,
        near = near.max(1e-6),
        first_frame = first_frame,
        last_frame = first_frame + doc.animation.frames - 1,
        background = triple(doc.scene.background),
        ambient = unsigned_zero(doc.scene.ambient),
        origin = triple(origin),
        sphere_count = spheres.len(),
        segments = SEGMENTS,
        rings = RINGS,
        realized_segments = REALIZED_SEGMENTS,
        realized_rings = REALIZED_RINGS,
        motion_blur = match doc.motion_blur {
            Some(b) => format!("({:?}, {})", b.shutter, b.samples),
            None => "None".to_string(),
        },
    ))
}
