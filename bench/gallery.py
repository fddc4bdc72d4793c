#!/usr/bin/env python3
"""The README's gallery: vkrad at its defaults on public and generated
scenes, each timed as a whole command, with its peak memory and, where a
path-traced reference exists (bench/pathtracer/out, made by compare.py),
its error against it.

    cargo build --release
    source bench/pathtracer/env.sh      # Mitsuba, for reading EXR and scoring
    python3 bench/gallery.py            # bench/gallery.png and bench/gallery.json

Run it with nothing else on the machine: the wall times are the point.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PT = os.path.join(HERE, "pathtracer")
sys.path.insert(0, PT)
import compare  # noqa: E402
from score import score  # noqa: E402

SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes", "mcguire")
BOX_CAMERA = ["--eye", "0,1,3.6", "--look-at", "0,1,0", "--fov", "40"]
# (name, scene argument, extra arguments, provenance)
GALLERY = [
    ("CornellBox-Original", os.path.join(SHARED, "CornellBox-Original.obj"), BOX_CAMERA,
     "Morgan McGuire's OBJ of the Cornell box data (McGuire Computer Graphics Archive, 2011), public domain"),
    ("CornellBox-Sphere", os.path.join(SHARED, "CornellBox-Sphere.obj"), BOX_CAMERA,
     "the same archive, public domain; its mirror and glass spheres are shown diffuse, with a warning"),
    ("rfield", "rfield", [],
     "built in: 175 extruded letters R, 23,802 polygons (scenes/generate_scenes.py)"),
    ("curved", os.path.join(ROOT, "scenes", "curved.obj"), [],
     "generated: a 4,032-triangle sphere and a 2,304-triangle torus in the Cornell room"),
]
SIZE = "256x256"


def main():
    compare.set_variant("scalar_rgb")
    vkrad = os.path.join(ROOT, "target", "release", "vkrad")
    rows, tiles = [], []
    with tempfile.TemporaryDirectory(prefix="vkrad-gallery-") as tmp:
        for name, scene, extra, provenance in GALLERY:
            image = os.path.join(tmp, f"{name}.exr")
            report = os.path.join(tmp, f"{name}.json")
            cmd = [vkrad, scene, "--size", SIZE, *extra, "-o", image, "--report", report, "--quiet"]
            t = time.time()
            subprocess.run(cmd, check=True)
            wall = time.time() - t
            r = json.load(open(report))
            err = score(name, image, SIZE)
            shown = " ".join(
                ["vkrad", scene if os.path.sep not in scene else os.path.relpath(scene, ROOT), "--size", SIZE, *extra]
            )
            rows.append({
                "scene": name,
                "command": shown,
                "provenance": provenance,
                "patches": r["scene"]["patches"],
                "wall_s": round(wall, 2),
                "gather_s": r["timing"]["wall_s"].get("gather"),
                "peak_bytes": r["memory"]["peak_bytes"],
                "estimate_bytes": r["memory"]["estimate_bytes"],
                "warnings": r["scene"]["warnings"] + r["scene"]["run_warnings"],
                "rel_rmse_lit": err and err["rel_rmse_lit"],
                "bias_lit": err and err["bias_lit"],
            })
            x = compare.read_exr(image)
            tiles.append((name, x * r["settings"]["exposure"], rows[-1]))
            print(json.dumps(rows[-1]), file=sys.stderr)
    json.dump({"size": SIZE, "runs": rows}, open(os.path.join(HERE, "gallery.json"), "w"), indent=1)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(tiles), figsize=(4 * len(tiles), 4.6))
    for ax, (name, img, row) in zip(axes, tiles):
        v = compare.np.clip(img, 0, 1)  # vkrad's own tone map: exposure, then sRGB
        srgb = compare.np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
        ax.imshow(srgb)
        ax.set_axis_off()
        err = "" if row["rel_rmse_lit"] is None else f", {100 * row['rel_rmse_lit']:.1f}% vs Mitsuba"
        ax.set_title(f"{name}\n{row['patches']:,} polygons, {row['wall_s']:.1f} s{err}", fontsize=10)
    plt.tight_layout()
    plt.savefig(os.path.join(HERE, "gallery.png"), dpi=80)


if __name__ == "__main__":
    main()
