"""One bench scene rendered by OVITO 3 (PyPI ovito), headless, every frame to a PNG.

    python3 render_ovito.py SPHERES.f64 CAMERAS.json RENDERER OUT_DIR

SPHERES.f64: the spheres as little-endian f64, x y z radius r g b each. CAMERAS.json: the
image size, the background, and each frame's camera (position, direction, up, vertical field of
view in radians). RENDERER: tachyon or ospray, both at one sample a pixel with shadows and no
ambient occlusion.
"""
import json
import sys

import numpy as np
from ovito.data import DataCollection
from ovito.pipeline import Pipeline, StaticSource
from ovito.vis import OSPRayRenderer, TachyonRenderer, Viewport


def main():
    spheres_path, cameras_path, renderer, out_dir = sys.argv[1:5]
    with open(cameras_path) as f:
        shot = json.load(f)
    s = np.fromfile(spheres_path, dtype="<f8").reshape(-1, 7)
    data = DataCollection()
    particles = data.create_particles(count=len(s))
    particles.create_property("Position", data=s[:, 0:3])
    particles.create_property("Radius", data=s[:, 3])
    particles.create_property("Color", data=s[:, 4:7])
    pipeline = Pipeline(source=StaticSource(data=data))
    pipeline.add_to_scene()
    if renderer == "tachyon":
        r = TachyonRenderer(
            shadows=True, ambient_occlusion=False, antialiasing=False, direct_light=True
        )
    elif renderer == "ospray":
        r = OSPRayRenderer(
            samples_per_pixel=1,
            refinement_iterations=1,
            denoising_enabled=False,
            sky_light_enabled=False,
            direct_light_enabled=True,
        )
    else:
        sys.exit(f"renderer {renderer!r}: tachyon or ospray")
    vp = Viewport(type=Viewport.Type.Perspective)
    size = (shot["width"], shot["height"])
    for k, cam in enumerate(shot["cameras"]):
        vp.camera_pos = cam["position"]
        vp.camera_dir = cam["direction"]
        vp.camera_up = cam["up"]
        vp.fov = cam["fov"]
        vp.render_image(
            size=size,
            filename=f"{out_dir}/{k:04}.png",
            background=tuple(shot["background"]),
            renderer=r,
        )


main()
