"""Old and new campath binaries timed as whole processes, alternated.

    python3 tests/peers/alternate.py OLD NEW PAIRS SCENE.ron...

Runs `OLD hash SCENE --stats-json` and `NEW hash …` PAIRS times each, in alternating order
(old first on even pairs, new first on odd), in the current folder, and prints for each scene
the medians of the first frame, the median render, the peak memory, the process's wall time
and the spheres in view, and whether the two binaries printed the same hashes.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile


def main():
    old, new, pairs = sys.argv[1], sys.argv[2], int(sys.argv[3])
    stats = os.path.join(tempfile.mkdtemp(), "stats.json")
    for scene in sys.argv[4:]:
        rows = {old: [], new: []}
        printed = {}
        for i in range(pairs):
            for binary in (old, new) if i % 2 == 0 else (new, old):
                if os.path.exists(stats):
                    os.remove(stats)
                run = subprocess.run(
                    [binary, "hash", scene, "--stats-json", stats], capture_output=True
                )
                if run.returncode != 0:
                    sys.exit(f"{binary} hash {scene}: {run.stderr.decode()}")
                with open(stats) as f:
                    d = json.load(f)
                rows[binary].append(
                    (
                        d["first_frame_ms"],
                        d["median_render_ms"],
                        d["peak_memory_mb"],
                        d["wall_secs"],
                        d["max_in_view"],
                    )
                )
                printed.setdefault(binary, run.stdout)

        def med(binary, k):
            return statistics.median(r[k] for r in rows[binary])

        same = "same" if printed[old] == printed[new] else "DIFFER"
        print(
            f"{scene} ({pairs} pairs): first frame {med(old, 0):.0f} -> {med(new, 0):.0f} ms; "
            f"median render {med(old, 1):.1f} -> {med(new, 1):.1f} ms; "
            f"peak {med(old, 2):.0f} -> {med(new, 2):.0f} MB; "
            f"process {med(old, 3):.2f} -> {med(new, 3):.2f} s; "
            f"in view {med(old, 4):.0f} -> {med(new, 4):.0f}; hashes {same}",
            flush=True,
        )


main()
