"""Embree 3's rays and campath's frames through the same dense clusters, in one run.

    cargo bench --features bench --bench peers -- --scaling --keep --runs 1 --pov-frames 0 \
      --scenes dense1000000-ply-360p,dense10000000-ply,dense10000000-ply-360p
    g++ -O2 -std=c++17 tests/peers/bench/embree_rays.cpp -o embree_rays -lembree3 -lpthread
    cd out/bench && python3 ../../tests/peers/embree_round.py CAMPATH EMBREE_RAYS ROUNDS

Each round runs, for each case, `EMBREE_RAYS PLY W H 0` (primary rays), `EMBREE_RAYS PLY W H 1`
(and a shadow ray from every hit), then `CAMPATH hash SCENE --stats-json`; the table gives the
median of the rounds. The campath scenes are the bench's kept files, and three made from them
in the current folder: `forty10m.ron` and `forty1m.ron` (the 640×360 ones with 40 frames at
137 fps, a slow orbit), `m1080.ron` (the million at 1920×1080, 8 frames). Embree renders the
first camera of those scenes.
"""
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

# (case, PLY, width, height, campath scene)
CASES = [
    ("10 M, 640×360", "dense10000000-ply-360p.ply", 640, 360, "forty10m.ron"),
    ("10 M, 1080p", "dense10000000-ply.ply", 1920, 1080, "dense10000000-ply.ron"),
    ("1 M, 640×360", "dense1000000-ply-360p.ply", 640, 360, "forty1m.ron"),
    ("1 M, 1080p", "dense1000000-ply-360p.ply", 1920, 1080, "m1080.ron"),
]

# Scenes made from the bench's: (file, from, the text replaced, its replacement).
EIGHT, FORTY = "frames: 8, fps: 24.0", "frames: 40, fps: 137.0"
SMALL, LARGE = "width: 640, height: 360", "width: 1920, height: 1080"
DERIVED = [
    ("forty10m.ron", "dense10000000-ply-360p.ron", EIGHT, FORTY),
    ("forty1m.ron", "dense1000000-ply-360p.ron", EIGHT, FORTY),
    ("m1080.ron", "dense1000000-ply-360p.ron", SMALL, LARGE),
]


def derive():
    for name, source, old, new in DERIVED:
        if os.path.exists(name):
            continue
        with open(source) as f:
            text = f.read()
        if old not in text:
            sys.exit(f"{source} has no `{old}`")
        with open(name, "w") as f:
            f.write(text.replace(old, new))


def embree(binary, ply, w, h, shadows):
    args = [binary, ply, str(w), str(h), str(shadows)]
    run = subprocess.run(args, capture_output=True, text=True)
    m = re.search(r"read (\d+) ms, scene built (\d+) ms, frame median ([\d.]+) ms", run.stdout)
    if run.returncode != 0 or not m:
        sys.exit(f"{binary} {ply}: {run.stdout}{run.stderr}")
    return float(m.group(3)), (int(m.group(1)) + int(m.group(2))) / 1000


def main():
    if len(sys.argv) != 4 or not sys.argv[3].isdigit() or int(sys.argv[3]) < 1:
        sys.exit("usage: embree_round.py CAMPATH EMBREE_RAYS ROUNDS (1 or more)")
    campath, rays, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
    derive()
    stats = os.path.join(tempfile.mkdtemp(), "stats.json")
    got = {case[0]: {k: [] for k in ("rays", "both", "build", "frame", "first")} for case in CASES}
    for r in range(rounds):
        for case, ply, w, h, scene in CASES:
            row = got[case]
            for shadows, key in ((0, "rays"), (1, "both")):
                ms, build = embree(rays, ply, w, h, shadows)
                row[key].append(ms)
                row["build"].append(build)
            args = [campath, "hash", scene, "--stats-json", stats]
            run = subprocess.run(args, capture_output=True)
            if run.returncode != 0:
                sys.exit(f"{campath} hash {scene}: {run.stderr.decode()}")
            with open(stats) as f:
                d = json.load(f)
            row["frame"].append(d["median_render_ms"])
            row["first"].append(d["first_frame_ms"] / 1000)
        print(f"round {r + 1} of {rounds}", file=sys.stderr, flush=True)
    print(
        "| case | Embree rays | Embree rays and shadow rays | Embree read and build "
        "| campath frame | campath first frame | campath frame / Embree's two rays |"
    )
    print("|---|---|---|---|---|---|---|")
    for case, *_ in CASES:
        m = {k: statistics.median(v) for k, v in got[case].items()}
        print(
            f"| {case} | {m['rays']:.1f} ms | {m['both']:.1f} ms | {m['build']:.2f} s "
            f"| {m['frame']:.1f} ms | {m['first']:.2f} s | {m['frame'] / m['both']:.2f} |"
        )
    for case, *_ in CASES:
        print(case, {k: [round(x, 2) for x in v] for k, v in got[case].items()})


main()
