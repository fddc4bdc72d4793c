#!/usr/bin/env python3
"""The walkthrough race: N views of one scene. vkrad solves once and draws
its lit mesh from every camera (--views); the path tracer renders each
view from scratch until it reaches vkrad's error on that view. Outside CI
(needs setup.sh).

    python3 walkthrough.py --scene ../../../shared/scenes/mcguire/CornellBox-Sphere.obj
    python3 walkthrough.py --scene rfield --size 512x512 --spp 1024

Cameras: a dolly across the scene's bounds near its +z side, at about
half height, looking back into the scene at targets that swing from side
to side (the McGuire boxes open towards +z).

Errors: relative RMSE over the lit pixels against a Mitsuba reference of
--spp samples (two halves), the reference's own noise taken out in
quadrature (views.py's metric). The path tracer's time to vkrad's error is
interpolated log-log between the powers of two of spp that bracket it.
vkrad's time is its whole command (start-up, solve, gather, every draw);
its cumulative time after view i is that wall less the draws not yet
made. Writes ../race-walkthrough-<scene>.json and .png.
"""

import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

import compare as C
from views import reference

HERE = C.HERE
REPO = C.REPO


def dolly_cameras(obj, n):
    v = obj["vertices"]
    lo, hi = v.min(axis=0), v.max(axis=0)
    at = lambda f: (lo + (hi - lo) * np.asarray(f)).tolist()  # noqa: E731
    cams = []
    for i in range(n):
        t = i / max(n - 1, 1)
        s = math.sin(2 * math.pi * t)
        cams.append({
            "eye": at([0.2 + 0.6 * t, 0.5 + 0.15 * s, 0.9]),
            "look_at": at([0.5 - 0.35 * math.cos(math.pi * t), 0.3, 0.15]),
            "up": [0.0, 1.0, 0.0], "fov": 60.0,
        })
    return cams


def corrected(e, noise):
    return math.sqrt(max(e * e - noise * noise, 0.0))


def pt_time_to(scene, ref, lit, noise, target, max_spp):
    """Seconds the path tracer takes, rendering from scratch, to reach
    `target` (noise-corrected) on this view; the curve as (spp, s, error)."""
    curve = []
    spp = 1
    while spp <= max_spp:
        t = time.perf_counter()
        img = C.render_spp(scene, spp, seed=7)
        s = time.perf_counter() - t
        e = corrected(C.rel_rmse(img, ref, lit), noise)
        curve.append((spp, s, e))
        if e <= target:
            break
        spp *= 2
    if curve[-1][2] > target:
        return None, curve
    if len(curve) == 1:
        return curve[0][1], curve
    (s0, t0, e0), (s1, t1, e1) = curve[-2], curve[-1]
    if e1 <= 0 or e0 <= e1:
        return t1, curve
    f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
    return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), curve


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=os.path.join(REPO, "..", "shared", "scenes", "mcguire", "CornellBox-Sphere.obj"))
    ap.add_argument("--views", type=int, default=16)
    ap.add_argument("--vkrad", default=os.path.join(REPO, "target", "release", "vkrad"))
    ap.add_argument("--vkrad-args", default="")
    ap.add_argument("--size", default="128x128")
    ap.add_argument("--spp", type=int, default=2048, help="reference spp (two halves)")
    ap.add_argument("--max-spp", type=int, default=4096, help="largest spp the path tracer tries")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()
    size = tuple(int(x) for x in args.size.split("x"))
    variant, _ = C.set_variant(args.variant)
    scene_path, name = C.resolve_scene(args.scene)
    obj = C.parse_obj(scene_path)
    cams = dolly_cameras(obj, args.views)
    # The first races ran at 128x128; other sizes keep their own files.
    label = name if size == (128, 128) else f"{name}-{size[0]}x{size[1]}"
    outdir = os.path.join(HERE, "out", f"walkthrough-{label}")
    os.makedirs(outdir, exist_ok=True)

    views = [{**cam, "output": os.path.join(outdir, f"vkrad-{i + 1}.exr")} for i, cam in enumerate(cams)]
    views_path = os.path.join(outdir, "cameras.json")
    with open(views_path, "w") as fh:
        json.dump({"views": views}, fh, indent=1)
    report_path = os.path.join(outdir, "vkrad-report.json")
    cmd = [args.vkrad, scene_path, "-q", "--size", f"{size[0]}x{size[1]}", "--views", views_path,
           "-o", os.path.join(outdir, "vkrad-main.exr"), "--report", report_path] + args.vkrad_args.split()
    C.log("$", " ".join(cmd))
    t = time.perf_counter()
    subprocess.run(cmd, check=True)
    vkrad_wall = time.perf_counter() - t
    with open(report_path) as fh:
        draws = [v["draw_seconds"] for v in json.load(fh)["outputs"]["views"]]

    rows = []
    for i, cam in enumerate(cams):
        ref, noise, lit, _ = reference(scene_path, obj, cam, size, args.spp, outdir)
        x = C.read_exr(views[i]["output"])[..., :3].astype(np.float64)
        e = corrected(C.rel_rmse(x, ref, lit), noise)
        scene, _ = C.build_scene(obj, cam, size)
        pt_s, curve = pt_time_to(scene, ref, lit, noise, e, args.max_spp)
        rows.append({"camera": cam, "lit_pixels": int(lit.sum()), "reference_noise": noise,
                     "vkrad_error": e, "vkrad_draw_seconds": draws[i],
                     "pt_seconds_to_vkrad_error": pt_s, "pt_curve": curve})
        C.log(f"view {i + 1}: vkrad {100 * e:.2f}% (noise {100 * noise:.2f}%), path tracer "
              + (f"{pt_s:.2f} s" if pt_s is not None else f"not there at {args.max_spp} spp"))

    solve_part = vkrad_wall - sum(draws)
    vk_cum = [solve_part + sum(draws[:i + 1]) for i in range(len(draws))]
    pt_each = [r["pt_seconds_to_vkrad_error"] for r in rows]
    pt_cum, acc = [], 0.0
    for s in pt_each:
        acc = acc + s if (s is not None and acc is not None) else None
        pt_cum.append(acc)
    out = {
        "scene": name, "date": datetime.date.today().isoformat(),
        "command": "python3 bench/pathtracer/walkthrough.py " + " ".join(sys.argv[1:]),
        "vkrad_command": " ".join(cmd), "variant": variant, "size": size, "reference_spp": args.spp,
        "vkrad_wall_seconds": vkrad_wall, "vkrad_cumulative_seconds": vk_cum,
        "pt_cumulative_seconds": pt_cum, "views": rows,
        "machine": "2 cores, lavapipe for vkrad, Mitsuba 3 " + variant + " on the CPU",
    }
    path = os.path.join(REPO, "bench", f"race-walkthrough-{label}.json")
    with open(path, "w") as fh:
        json.dump(out, fh, indent=1)
    C.log(f"wrote {path}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    n = list(range(1, len(cams) + 1))
    ax.plot(n, vk_cum, "o-", label="vkrad: one solve, then a draw per view")
    ax.plot([k for k, c in zip(n, pt_cum) if c is not None], [c for c in pt_cum if c is not None], "s-",
            label="path tracer: each view to vkrad's error")
    ax.set_xlabel("views rendered")
    ax.set_ylabel("cumulative wall seconds")
    ax.set_title(f"walkthrough race, {name}, {size[0]}x{size[1]}")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    png = os.path.join(REPO, "bench", f"race-walkthrough-{label}.png")
    fig.savefig(png, dpi=110)
    C.log(f"wrote {png}")


if __name__ == "__main__":
    main()
