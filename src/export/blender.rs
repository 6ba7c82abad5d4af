//! The shot as a Python script for Blender: `blender --background --python shot.py` (or
//! Blender's Text Editor) builds the camera keyed at every frame, the render size and rate, the
//! spheres with their colours and the lights.
//!
//! Blender's camera looks down its local −Z with +Y up, like the camera here with axes u, v, −n,
//! so its location is the COP and its rotation the quaternion of [u, v, −n]. The lens and
//! sensor reproduce the window exactly: with the sensor fitted to the width (36 mm, or wider
//! where a lens would be under 2 mm), lens / sensor = d / w for the COP's distance d and window
//! width w; the off-axis COP (distort), which neither
//! `.chan` nor glTF can carry, becomes Blender's lens shift, in units of the window width:
//! shift = −offset / w. A window whose aspect differs from the image's becomes the pixel aspect.
//! Scene frame f is campath's frame f − 1, as in `.chan`.
//!
//! Motion blur becomes Blender's: `render.use_motion_blur`, `render.motion_blur_shutter` (in
//! frames, as campath's shutter) and the shutter centred on the frame (`motion_blur_position`
//! on the render settings, or on Cycles' and EEVEE's before Blender 4.2), and EEVEE's own
//! switch, shutter and time steps where it has them. Blender moves the camera linearly between
//! the keys of consecutive frames, so its sub-frame camera follows the chord of campath's path;
//! the camera is also keyed where the first frame's shutter opens and the last's closes.
//! The clipping range clips nothing campath draws (`clipping_range`).

use std::fmt::Write as _;

use glam::DVec3;

use crate::camera::Camera;
use crate::document::Document;
use crate::error::Result;
use crate::export::gltf::camera_rotation;
use crate::export::{clipping_range, keyed_cameras, relative};

/// The sensor width in millimetres the lens is computed for, unless the shot is too wide for it.
const SENSOR_MM: f64 = 36.0;

/// The shortest lens the sensor is widened to give: Blender's least is 1 mm, and it raises a
/// shorter one to that silently (a 176° field of view would become 173.6°).
const SHORTEST_LENS_MM: f64 = 2.0;

/// The sensor width for cameras `cams`: `SENSOR_MM`, or wider where a frame's lens would be
/// shorter than `SHORTEST_LENS_MM` on it. The lens shift is in units of the sensor's width,
/// so it does not change with it.
pub fn sensor_mm(cams: impl IntoIterator<Item = Camera>) -> f64 {
    cams.into_iter()
        .map(|cam| SHORTEST_LENS_MM * cam.window.x / -cam.cop_view.z)
        .fold(SENSOR_MM, f64::max)
}

/// Blender's (lens mm, shift x, shift y) for a camera, with a sensor `sensor` mm wide fitted to
/// the width.
pub fn lens_and_shift(cam: &Camera, sensor: f64) -> (f64, f64, f64) {
    let d = -cam.cop_view.z;
    let w = cam.window.x;
    (sensor * d / w, -cam.cop_view.x / w, -cam.cop_view.y / w)
}

/// The script.
pub fn script(doc: &Document, origin: DVec3) -> Result<String> {
    let keys = keyed_cameras(doc)?;
    let sensor = sensor_mm(keys.iter().map(|&(_, cam)| cam));
    let cams: Vec<Camera> = keys.iter().map(|&(_, cam)| cam).collect();
    let (near, far) = clipping_range(&doc.scene.spheres, &cams);
    let mut frames = String::new();
    let mut previous: Option<glam::DQuat> = None;
    for &(frame, cam) in &keys {
        let mut q = camera_rotation(&cam);
        if previous.is_some_and(|p| p.dot(q) < 0.0) {
            q = -q;
        }
        previous = Some(q);
        let cop = relative(cam, origin).cop_world();
        let (lens, sx, sy) = lens_and_shift(&cam, sensor);
        let _ = writeln!(
            frames,
            "    ({:?}, ({:?}, {:?}, {:?}), ({:?}, {:?}, {:?}, {:?}), {lens:?}, {sx:?}, {sy:?}),",
            frame + 1.0,
            cop.x,
            cop.y,
            cop.z,
            q.w,
            q.x,
            q.y,
            q.z
        );
    }
    let mut spheres = String::new();
    for s in &doc.scene.spheres {
        let (c, k) = (s.center_world - origin, s.color);
        let _ = writeln!(
            spheres,
            "    (({:?}, {:?}, {:?}), {:?}, ({:?}, {:?}, {:?})),",
            c.x, c.y, c.z, s.radius, k.x, k.y, k.z
        );
    }
    let mut lights = String::new();
    for l in &doc.scene.lights {
        let (d, k) = (l.direction_world, l.color);
        let _ = writeln!(
            lights,
            "    (({:?}, {:?}, {:?}), ({:?}, {:?}, {:?}), {}),",
            d.x,
            d.y,
            d.z,
            k.x,
            k.y,
            k.z,
            if l.shadows { "True" } else { "False" }
        );
    }
    let r = doc.raster;
    let first = doc.camera(0)?;
    // Square pixels when the window has the image's aspect; otherwise the pixel aspect.
    let pixel_aspect = (first.window.x / first.window.y) / (r.width as f64 / r.height as f64);
    let bg = doc.scene.background;
    Ok(format!(
        r#"# The campath shot "{name}", for Blender: blender --background --python this.py, or run it in
# Blender's Text Editor. Generated by campath {version}; scene frame f is campath frame f - 1.
import bpy

FPS = {fps:?}
WIDTH, HEIGHT = {width}, {height}
PIXEL_ASPECT = {pixel_aspect:?}
SENSOR_MM = {sensor:?}
# near and far: nothing campath draws is clipped (Blender's least clip_start is 1e-6)
CLIP = ({near:?}, {far:?})
LAST_FRAME = {last_frame}
BACKGROUND = ({bg_r:?}, {bg_g:?}, {bg_b:?})
AMBIENT = {ambient:?}
# the point of campath's world at this file's origin (campath path --origin)
ORIGIN = ({origin_x:?}, {origin_y:?}, {origin_z:?})
# shutter (the fraction of the frame interval it is open, centred on the frame), time samples; or None
MOTION_BLUR = {motion_blur}
# scene frame (with motion blur also where the first frame's shutter opens and the last's closes),
# COP (x, y, z), rotation quaternion (w, x, y, z) taking -Z to the VPN, lens mm, shift x, shift y
FRAMES = [
{frames}]
# centre, radius, linear RGB
SPHERES = [
{spheres}]
# direction the light travels, linear RGB, shadows
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
    scene.frame_start, scene.frame_end = 1, LAST_FRAME
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

    for i, (centre, radius, colour) in enumerate(SPHERES):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=radius, location=centre)
        sphere = bpy.context.active_object
        sphere.name = "sphere %d" % i
        bpy.ops.object.shade_smooth()
        material = bpy.data.materials.new("sphere %d" % i)
        material.diffuse_color = (*colour, 1.0)
        material.use_nodes = True
        bsdf = material.node_tree.nodes.get("Principled BSDF")
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
            bsdf.inputs["Roughness"].default_value = 1.0
        sphere.data.materials.append(material)

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
    scene.frame_set(1)


build()
"#,
        // Quoted and escaped: a file name with a line break cannot end the comment.
        name = doc.path.display().to_string().escape_debug(),
        version = env!("CARGO_PKG_VERSION"),
        fps = doc.animation.fps,
        width = r.width,
        height = r.height,
        near = near.max(1e-6),
        last_frame = doc.animation.frames,
        bg_r = bg.x,
        bg_g = bg.y,
        bg_b = bg.z,
        ambient = doc.scene.ambient,
        origin_x = origin.x,
        origin_y = origin.y,
        origin_z = origin.z,
        motion_blur = match doc.motion_blur {
            Some(b) => format!("({:?}, {})", b.shutter, b.samples),
            None => "None".to_string(),
        },
    ))
}
