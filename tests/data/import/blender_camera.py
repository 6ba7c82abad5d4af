"""A camera animated in Blender and written by Blender's own USD exporter, for campath's import
test: `python blender_camera.py OUT_DIR` (a Python with PyPI `bpy`) writes OUT_DIR/camera.usda
and OUT_DIR/reference.json, Blender's own camera at every frame: `matrix_world` row by row
(Z-up), and the lens, sensor, sensor fit, shift and render size that make its window.

The camera follows a Bezier circle (Follow Path), looks at an empty (Track To) that rises as it
goes, and its focal length goes from 35 mm to 60 mm."""
import json
import sys
from pathlib import Path

import bpy

out = Path(sys.argv[-1])
out.mkdir(parents=True, exist_ok=True)
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 48
scene.render.fps = 24
scene.render.resolution_x, scene.render.resolution_y = 1280, 720

bpy.ops.curve.primitive_bezier_circle_add(radius=8.0, location=(0.0, 0.0, 2.0))
circle = bpy.context.object
circle.data.path_duration = 48

target = bpy.data.objects.new("target", None)
scene.collection.objects.link(target)
target.location = (1.0, 0.5, 0.0)
target.keyframe_insert("location", frame=1)
target.location = (-1.0, 0.0, 3.0)
target.keyframe_insert("location", frame=48)

data = bpy.data.cameras.new("lens")
data.sensor_width, data.sensor_height, data.sensor_fit = 36.0, 24.0, "AUTO"
data.lens = 35.0
data.keyframe_insert("lens", frame=1)
data.lens = 60.0
data.keyframe_insert("lens", frame=48)
camera = bpy.data.objects.new("camera", data)
scene.collection.objects.link(camera)
scene.camera = camera
follow = camera.constraints.new("FOLLOW_PATH")
follow.target = circle
follow.use_curve_follow = True
follow.offset = 0.0
# The path's evaluation time, keyed so that the camera goes round once.
circle.data.eval_time = 0.0
circle.data.keyframe_insert("eval_time", frame=1)
circle.data.eval_time = 48.0
circle.data.keyframe_insert("eval_time", frame=48)
track = camera.constraints.new("TRACK_TO")
track.target = target
track.track_axis, track.up_axis = "TRACK_NEGATIVE_Z", "UP_Y"

frames = []
for frame in range(scene.frame_start, scene.frame_end + 1):
    scene.frame_set(frame)
    m = camera.matrix_world
    frames.append({
        "frame": frame,
        "matrix_world": [m[i][j] for i in range(4) for j in range(4)],
        "lens": data.lens,
        "shift": [data.shift_x, data.shift_y],
    })
reference = {
    "fps": scene.render.fps / scene.render.fps_base,
    "resolution": [scene.render.resolution_x, scene.render.resolution_y],
    "pixel_aspect": [scene.render.pixel_aspect_x, scene.render.pixel_aspect_y],
    "sensor": [data.sensor_width, data.sensor_height],
    "sensor_fit": data.sensor_fit,
    "frames": frames,
}
(out / "reference.json").write_text(json.dumps(reference, indent=1))
bpy.ops.wm.usd_export(
    filepath=str(out / "camera.usda"),
    export_animation=True,
    selected_objects_only=False,
)
