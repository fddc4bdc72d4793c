#!/usr/bin/env python3
"""vkrad's lightmap opened in Blender: each scene's `--export x.glb
--lightmap auto` imported by Blender's own glTF importer and drawn by
Cycles (tools/lightmap/blender_render.py), against vkrad's render of the
same lit mesh.

    apt-get install blender python3-numpy   # Debian bookworm: Blender 3.4 (its glTF importer needs numpy)
    cargo build --release
    python3 scenes/generate_scenes.py --textured /tmp/vkrad-textured
    python3 bench/lightmap_blender.py --scenes cornell,/tmp/vkrad-textured/cornell-checker.obj,rfield

Per scene, at its `# vkrad camera` line:
    vkrad SCENE --shade mesh --size WxH <camera> -o mesh.png --export x.glb --lightmap auto
then Blender (`blender -b --factory-startup --python
tools/lightmap/blender_render.py -- job.json`) at the same camera, one-pixel
box filter as vkrad's antialiasing, Standard view transform (an unlit texel
shows as its own value), transparent film (alpha = coverage).

Compared over "surfaces", the pixels Blender covers fully (alpha 255),
away (1 pixel) from any pixel clamped at 255 in either image (8-bit images
hold no light above 1), and "interior", those of them whose 3x3
neighbourhood has one shading normal in a second Blender pass (no crease,
edge or chart seam within a pixel, where two rasterizers differ by what
each pixel's samples hit rather than by the light): rel RMSE in linear light (8-bit sRGB decoded, channels pooled,
vkrad's definition), mean and 99th percentile of the largest channel's
difference in 8-bit levels, and the share of pixels off by more than 1, 3
and 8 levels. The importer's report (json "imported") lists the UV maps,
colour attributes, materials and images Blender made of the file: vkrad's
atlas coordinates are both TEXCOORD_0 and TEXCOORD_1 (one accessor), so a
viewer that reads either finds the atlas, and the vertex colours, moved to
`_COLOR_0`, are not imported as colours to multiply it.

Writes bench/lightmap-blender.json and bench/lightmap-blender-<first scene>.png
(vkrad | Blender | difference x8).
"""

import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys
import time

import numpy as np
from PIL import Image

from lightmap import (HERE, REPO, camera_args, dilate, glb_json, level_stats, log, one_normal, read_png, rel_rmse,
                      relative, run, scene_camera, srgb8_to_linear)

BLENDER_SCRIPT = os.path.join(REPO, "tools", "lightmap", "blender_render.py")


def blender_env():
    """Blender's embedded Python finds its prefix through PATH: a pyenv or
    venv Python first on it (this one's) hides the system's numpy, which
    Blender's glTF importer needs."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYENV", "VIRTUAL_ENV", "PYTHON"))}
    prefix = os.path.dirname(os.path.realpath(sys.executable))
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if ".pyenv" not in p and os.path.realpath(p) != prefix)
    return env


def blender_version(blender):
    r = subprocess.run([blender, "--version"], capture_output=True, text=True)
    return r.stdout.splitlines()[0].strip() if r.returncode == 0 and r.stdout else None


def bench_scene(a, scene, size):
    w, h = size
    cam = scene_camera(scene)
    name = os.path.splitext(os.path.basename(scene))[0]
    cache = os.path.join(a.cache, name)
    os.makedirs(cache, exist_ok=True)
    glb, png, report = (os.path.join(cache, f) for f in ("lm-auto.glb", "mesh.png", "mesh.json"))
    cmd = [a.vkrad, scene, "--shade", "mesh", "--size", f"{w}x{h}", *camera_args(cam), "-o", png, "--export", glb,
           "--lightmap", "auto", "--report", report]
    vkrad_s = None
    if not (a.reuse and all(os.path.exists(p) for p in (glb, png, report))):
        log(f"{name}: {shlex.join(cmd)}")
        vkrad_s = run(cmd, os.path.join(cache, "vkrad.log"))
    rep = json.load(open(report))
    lm = glb_json(glb)["meshes"][0]["extras"]["lightmap"]

    job = {"glb": glb, "out": os.path.join(cache, "blender.png"), "width": w, "height": h, "eye": cam["eye"],
           "look_at": cam["look_at"], "up": cam["up"], "fov": cam["fov"], "samples": a.samples,
           "normal": os.path.join(cache, "blender-normal.png")}
    job_path = os.path.join(cache, "blender-job.json")
    json.dump(job, open(job_path, "w"), indent=1)
    bcmd = [a.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", BLENDER_SCRIPT, "--", job_path]
    log(f"{name}: {shlex.join(bcmd)}")
    t = time.perf_counter()
    r = subprocess.run(bcmd, capture_output=True, text=True, env=blender_env())
    blender_s = time.perf_counter() - t
    open(os.path.join(cache, "blender.log"), "w").write(r.stdout + r.stderr)
    imported = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]
    if r.returncode != 0 or not imported or not os.path.exists(job["out"]):
        sys.exit(f"{name}: Blender failed ({r.returncode}); see {os.path.join(cache, 'blender.log')}")

    vk8 = read_png(png)
    rgba = np.asarray(Image.open(job["out"]).convert("RGBA"))
    bl8, alpha = rgba[..., :3], rgba[..., 3]
    clamped = dilate((vk8 == 255).any(axis=2) | (bl8 == 255).any(axis=2))
    masks = {"surfaces": (alpha == 255) & ~clamped}
    masks["interior"] = masks["surfaces"] & one_normal(read_png(job["normal"]), alpha == 255)
    absdiff = np.abs(bl8.astype(int) - vk8.astype(int))
    d = absdiff.max(axis=2)
    compared = {}
    for k, m in masks.items():
        compared[k] = {"pixels": int(m.sum()), "rel_rmse": rel_rmse(srgb8_to_linear(bl8), srgb8_to_linear(vk8), m),
                       "mean_levels": float(d[m].mean()), **level_stats(bl8, vk8, m)}
    out = {
        "scene": scene, "size": [w, h], "camera": cam,
        "command": shlex.join(["vkrad", *cmd[1:]]), "vkrad_s": vkrad_s,
        "blender_command": shlex.join(["blender", *bcmd[1:]]), "blender_s": blender_s,
        "display_elements": rep["display_mesh"]["elements"], "display_vertices": rep["display_mesh"]["vertices"],
        "atlas": {k: lm[k] for k in ("width", "height", "texels_per_unit", "charts", "covered_texels")},
        "imported": imported[-1],
        "covered_pixels": int((alpha == 255).sum()), "blender_vs_mesh": compared,
    }
    for k, c in compared.items():
        log(f"{name}: Blender against vkrad's mesh image, {k}: {100 * c['rel_rmse']:.2f}% rel RMSE, "
            f"{c['mean_levels']:.2f} levels mean, p99 {c['p99_levels']:.0f}, over {c['pixels']} pixels")
    diff = np.clip(absdiff * 8, 0, 255).astype(np.uint8)
    diff[alpha < 255] = 0
    return relative(out), np.concatenate([vk8, bl8, diff], axis=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vkrad", default=os.path.join(REPO, "target", "release", "vkrad"))
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--scenes", default="cornell,rfield", help="built-in names or .obj paths with a camera line")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--samples", type=int, default=64, help="Cycles samples a pixel (antialiasing only)")
    ap.add_argument("--cache", default=os.path.join(HERE, "cache", "lightmap-blender"))
    ap.add_argument("--reuse", action="store_true", help="reuse vkrad outputs already in --cache")
    ap.add_argument("--out", default=os.path.join(HERE, "lightmap-blender"))
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    results, strips = [], []
    for scene in a.scenes.split(","):
        res, strip = bench_scene(a, scene, size)
        results.append(res)
        strips.append(strip)
    first = os.path.splitext(os.path.basename(a.scenes.split(",")[0]))[0]
    Image.fromarray(strips[0]).save(f"{a.out}-{first}.png")
    json.dump({"date": datetime.date.today().isoformat(), "blender": blender_version(a.blender),
               "scenes": results}, open(f"{a.out}.json", "w"), indent=1)
    log(f"wrote {a.out}.json, {a.out}-{first}.png")


if __name__ == "__main__":
    main()
