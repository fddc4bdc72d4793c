#!/usr/bin/env python3
"""vkrad's lightmap in a real browser: each `--export x.glb --lightmap D`
drawn by three.js in headless Chromium (tools/lightmap/render.mjs), against
vkrad's own render of the same lit mesh and its most accurate image.

    (cd tools/lightmap && npm ci)   # three, puppeteer-core; and apt-get install chromium
    cargo build --release
    python3 bench/lightmap.py                       # cornell and rfield: bench/lightmap.json, .png
    python3 bench/lightmap.py --scenes cornell --reuse

Per scene, for each density D (texels per unit, and auto):
    vkrad SCENE --shade mesh --size WxH -o mesh.png --export x.glb --lightmap D
at the scene's camera (its `# vkrad camera` line, passed to vkrad and to
three.js alike), and once `vkrad SCENE --size WxH -o pixels.exr --exposure E`
(--shade pixels, the light gathered at every pixel) at the mesh runs'
exposure E. The browser draws each .glb as plain three.js (one sample per
pixel, straight to the canvas) and at vkrad's own 16 sample positions per
pixel averaged in linear light (antialiased as vkrad's images are: the
render every error below uses), and the auto .glb once more with its vertex
colours (_COLOR_0) instead of the atlas: the lightmap against the vertex
colours through the same rasterizer.

Errors are vkrad's own definition on linear light (8-bit sRGB decoded),
channels pooled: rel RMSE = sqrt(mean((x - r)^2)) / mean(r), over the
"surfaces" mask: pixels whose 16 samples all hit the model, away (1 pixel)
from any pixel clamped at 255 in vkrad's or the browser's images (the
light and its neighbours: 8-bit images hold no light above 1). "interior":
surfaces whose 3x3 neighbourhood has one normal (no crease, edge or chart
seam within a pixel). "off N" is the share of mask pixels whose largest
channel differs by more than N 8-bit levels. With --ref (Mitsuba 3,
bench/pathtracer/compare.py), errors against it too, over its lit mask less
clamped pixels, in radiance (image / E), raw and with the reference's own
noise taken out in quadrature.

Texels against display vertices at equal error: the vertex colours have an
error e_v against the pixels image (vkrad's --shade mesh image, and the
same colours drawn by the browser); the lightmap is baked from those vertex
values, so its error falls towards e_v as texels are added. Reported: the
covered texels per display vertex at each density, and where (log-log
interpolated) the browser's error first comes within 5% and 1% of e_v.
"""

import argparse
import datetime
import json
import os
import shlex
import struct
import subprocess
import sys
import time

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
TOOLS = os.path.join(REPO, "tools", "lightmap")
DENSITIES = {
    # texels per scene unit; auto is added to each
    "cornell": [0.03125, 0.0625, 0.125, 0.25, 0.5, 1.0],
    "rfield": [2.0, 4.0, 8.0, 16.0, 24.0],
}
OFF_LEVELS = (1, 3, 8)


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def scene_path(scene):
    if os.path.exists(scene):
        return scene
    return os.path.join(REPO, "scenes", f"{scene}.obj")


def scene_camera(scene):
    """The `# vkrad camera eye .. look_at .. up .. fov ..` line (fov: vertical, degrees)."""
    with open(scene_path(scene)) as f:
        for line in f:
            words = line.split()
            if words[:3] == ["#", "vkrad", "camera"]:
                w = words[3:]
                cam = {}
                i = 0
                while i < len(w):
                    key = w[i]
                    n = 1 if key == "fov" else 3
                    vals = [float(v) for v in w[i + 1:i + 1 + n]]
                    cam[key] = vals[0] if n == 1 else vals
                    i += 1 + n
                cam.setdefault("up", [0.0, 1.0, 0.0])
                return cam
    sys.exit(f"{scene}: no `# vkrad camera` line")


def camera_args(cam):
    xyz = lambda v: ",".join(f"{x:g}" for x in v)  # noqa: E731
    return ["--eye", xyz(cam["eye"]), "--look-at", xyz(cam["look_at"]), "--up", xyz(cam["up"]),
            "--fov", f"{cam['fov']:g}"]


def run(cmd, log_path, fatal=True):
    """Wall seconds of the command (also kept beside its log, for --reuse);
    None (when not fatal) if it failed."""
    t = time.perf_counter()
    with open(log_path, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        if fatal:
            sys.exit(f"failed ({r.returncode}): {shlex.join(cmd)}; see {log_path}")
        return None
    secs = time.perf_counter() - t
    with open(log_path + ".seconds", "w") as f:
        f.write(f"{secs}\n")
    return secs


def seconds_of(log_path):
    try:
        return float(open(log_path + ".seconds").read())
    except (OSError, ValueError):
        return None


def relative(x):
    """Paths in the repository written relative to it."""
    if isinstance(x, str):
        return x.replace(REPO + os.sep, "")
    if isinstance(x, list):
        return [relative(v) for v in x]
    if isinstance(x, dict):
        return {k: relative(v) for k, v in x.items()}
    return x


def glb_json(path):
    with open(path, "rb") as f:
        head = f.read(20)
        n = struct.unpack("<I", head[12:16])[0]
        return json.loads(f.read(n))


def srgb8_to_linear(a):
    c = a.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb8(v):
    """vkrad's tonemap: clamp, exact sRGB transfer, round."""
    v = np.clip(np.nan_to_num(v, nan=0.0), 0.0, 1.0)
    e = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)
    return np.clip(np.round(e * 255.0), 0, 255).astype(np.uint8)


def read_png(path):
    return np.asarray(Image.open(path).convert("RGB"))


def read_exr(path):
    sys.path.insert(0, os.path.join(HERE, "pathtracer"))
    import compare  # noqa: E402  (Mitsuba's EXR reader)
    compare.set_variant("scalar_rgb")
    return compare.read_exr(path)


def rel_rmse(x, r, m):
    if not m.any():
        return None
    return float(np.sqrt(np.mean((x[m] - r[m]) ** 2)) / np.mean(r[m]))


def bias(x, r, m):
    return float(np.mean(x[m]) / np.mean(r[m]) - 1.0) if m.any() else None


def level_stats(a8, b8, m):
    d = np.abs(a8.astype(int) - b8.astype(int)).max(axis=2)[m]
    out = {f"off_{n}": float(np.mean(d > n)) for n in OFF_LEVELS}
    out["p99_levels"] = float(np.percentile(d, 99))
    out["max_levels"] = int(d.max())
    return out


def dilate(m, r=1):
    out = m.copy()
    p = np.pad(m, r)
    h, w = m.shape
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out |= p[r + dy:r + dy + h, r + dx:r + dx + w]
    return out


def one_normal(normal8, full):
    """Pixels whose 3x3 neighbourhood is fully covered with one normal."""
    n = normal8.astype(int)
    h, w = full.shape
    p = np.pad(n, ((1, 1), (1, 1), (0, 0)), mode="edge")
    pf = np.pad(full, 1)
    ok = full.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            q = p[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
            ok &= np.abs(q - n).max(axis=2) <= 3
            ok &= pf[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
    return ok


def crossing(points, target):
    """First x (log-log interpolated) at which y <= target; points sorted by x."""
    prev = None
    for x, y in points:
        if y <= target:
            if prev is None:
                return x
            (x0, y0) = prev
            f = (np.log(target) - np.log(y0)) / (np.log(y) - np.log(y0))
            return float(np.exp(np.log(x0) + f * (np.log(x) - np.log(x0))))
        prev = (x, y)
    return None


def density_name(d):
    return "auto" if d == "auto" else f"{d:g}"


def bench_scene(a, scene, densities, size):
    w, h = size
    cam = scene_camera(scene)
    name = os.path.splitext(os.path.basename(scene))[0]
    cache = os.path.join(a.cache, name)
    os.makedirs(cache, exist_ok=True)
    cam_args = camera_args(cam)
    rows = []
    refused = []
    exposure = None
    for d in list(densities) + ["auto"]:
        tag = density_name(d)
        glb = os.path.join(cache, f"lm-{tag}.glb")
        png = os.path.join(cache, f"mesh-{tag}.png")
        report = os.path.join(cache, f"mesh-{tag}.json")
        cmd = [a.vkrad, scene, "--shade", "mesh", "--size", f"{w}x{h}", *cam_args, "-o", png,
               "--export", glb, "--lightmap", tag, "--report", report]
        log_path = os.path.join(cache, f"mesh-{tag}.log")
        secs = seconds_of(log_path)
        if not (a.reuse and all(os.path.exists(p) for p in (glb, png, report))):
            log(f"{name}: {shlex.join(cmd)}")
            for p in (glb, png, report):
                if os.path.exists(p):
                    os.remove(p)
            secs = run(cmd, log_path, fatal=False)
            if secs is None:
                why = [line for line in open(log_path) if "lightmap" in line.lower()]
                refused.append({"density": tag, "vkrad": why[-1].strip() if why else open(log_path).read()[-500:]})
                log(f"{name}: --lightmap {tag} refused: {refused[-1]['vkrad']}")
                continue
        rep = json.load(open(report))
        e = rep["settings"]["exposure"]
        exposure = e if exposure is None else exposure
        lm = glb_json(glb)["meshes"][0]["extras"]["lightmap"]
        rows.append({
            "density": tag, "glb": glb, "mesh_png": png, "exposure": e, "vkrad_s": secs,
            "command": shlex.join(["vkrad", *cmd[1:]]), "device": rep.get("device"),
            "display_vertices": rep["display_mesh"]["vertices"],
            "display_elements": rep["display_mesh"]["elements"],
            "atlas": {k: lm[k] for k in ("width", "height", "texels_per_unit", "charts", "covered_texels")},
            "atlas_texels": lm["width"] * lm["height"],
            "covered_texels_per_vertex": lm["covered_texels"] / rep["display_mesh"]["vertices"],
            "glb_bytes": os.path.getsize(glb),
        })
    mesh_images = [read_png(r["mesh_png"]) for r in rows]
    same = all(np.array_equal(mesh_images[0], m) for m in mesh_images[1:])
    exposures = sorted({r["exposure"] for r in rows})

    # The pixels image at the same exposure.
    px_exr = os.path.join(cache, "pixels.exr")
    px_report = os.path.join(cache, "pixels.json")
    px_cmd = [a.vkrad, scene, "--size", f"{w}x{h}", *cam_args, "-o", px_exr, "--exposure", f"{exposure!r}",
              "--report", px_report]
    px_s = seconds_of(os.path.join(cache, "pixels.log"))
    if not (a.reuse and os.path.exists(px_exr) and os.path.exists(px_report)):
        log(f"{name}: {shlex.join(px_cmd)}")
        px_s = run(px_cmd, os.path.join(cache, "pixels.log"))
    px_lin = read_exr(px_exr)  # radiance
    px8 = linear_to_srgb8(px_lin * exposure)

    # The browser.
    jobs = []
    for r in rows:
        base = os.path.join(cache, f"browser-{r['density']}")
        r["browser16_png"], r["browser1_png"] = base + "-16.png", base + "-1.png"
        r["coverage_png"], r["normal_png"] = base + "-coverage.png", base + "-normal.png"
        common = {"glb": r["glb"], "width": w, "height": h, "eye": cam["eye"], "look_at": cam["look_at"],
                  "up": cam["up"], "fov": cam["fov"]}
        jobs.append({**common, "out": r["browser16_png"], "coverage": r["coverage_png"],
                     "normal": r["normal_png"], "samples": 16})
        jobs.append({**common, "out": r["browser1_png"], "samples": 1})
    vertex16 = os.path.join(cache, "browser-vertex-16.png")
    jobs.append({"glb": rows[-1]["glb"], "width": w, "height": h, "eye": cam["eye"], "look_at": cam["look_at"],
                 "up": cam["up"], "fov": cam["fov"], "samples": 16, "vertex": True, "out": vertex16})
    if name == a.shot_scene:
        auto = rows[-1]
        s = a.shot_size
        jobs.append({"glb": auto["glb"], "width": s, "height": s, "eye": cam["eye"], "look_at": cam["look_at"],
                     "up": cam["up"], "fov": cam["fov"], "samples": 1, "antialias": True,
                     "out": os.path.join(HERE, f"lightmap-browser-{name}.png")})
    jobs_path = os.path.join(cache, "jobs.json")
    json.dump(jobs, open(jobs_path, "w"), indent=1)
    cmd = ["node", os.path.join(TOOLS, "render.mjs"), "--jobs", jobs_path]
    log(f"{name}: {shlex.join(cmd)}")
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    browser_s = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"render.mjs failed:\n{r.stderr}")
    browser = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]

    # Masks (from the auto run's browser passes: geometry does not depend on D).
    ref = None
    if a.ref:
        ref_path = os.path.join(a.ref, f"{name}-ref.exr")
        masks_path = os.path.join(a.ref, f"{name}-{w}x{h}-masks-v2.npz")
        if os.path.exists(ref_path) and os.path.exists(masks_path):
            ref = read_exr(ref_path)
            z = np.load(masks_path)
            lum = ref.mean(axis=2)
            ref_lit = (lum > 0.01 * lum.mean()) & ~z["sees_emitter"]
            ref_meta_path = os.path.join(a.ref, f"{name}-ref.json")
            ref_meta = json.load(open(ref_meta_path)) if os.path.exists(ref_meta_path) else {}
        else:
            log(f"{name}: no Mitsuba reference in {a.ref}")
    any_clamped = np.zeros((h, w), bool)
    for m in mesh_images:
        any_clamped |= (m == 255).any(axis=2)
    bv8 = read_png(vertex16)
    for r, mesh8 in zip(rows, mesh_images):
        cov = read_png(r["coverage_png"])[..., 0]
        full = cov == 255
        b16 = read_png(r["browser16_png"])
        b1 = read_png(r["browser1_png"])
        clamped = dilate(any_clamped | (px8 == 255).any(axis=2) | (b16 == 255).any(axis=2))
        surf = full & ~clamped
        interior = surf & one_normal(read_png(r["normal_png"]), full)
        masks = {"surfaces": surf, "interior": interior}
        lin = {k: srgb8_to_linear(v) for k, v in (("mesh", mesh8), ("b16", b16), ("b1", b1), ("px", px8),
                                                   ("bv", bv8))}
        r["mask_pixels"] = {k: int(m.sum()) for k, m in masks.items()}
        for mname, m in masks.items():
            r[f"browser_vs_mesh_{mname}"] = {"rel_rmse": rel_rmse(lin["b16"], lin["mesh"], m),
                                             "bias": bias(lin["b16"], lin["mesh"], m),
                                             **level_stats(b16, mesh8, m)}
            r[f"plain_threejs_vs_mesh_{mname}"] = {"rel_rmse": rel_rmse(lin["b1"], lin["mesh"], m),
                                                   **level_stats(b1, mesh8, m)}
            r[f"browser_vs_pixels_{mname}"] = rel_rmse(lin["b16"], lin["px"], m)
            r[f"mesh_vs_pixels_{mname}"] = rel_rmse(lin["mesh"], lin["px"], m)
            # The same rasterizer (three.js, 16 samples) with the vertex colours instead.
            r[f"lightmap_vs_vertex_colours_in_browser_{mname}"] = {
                "rel_rmse": rel_rmse(lin["b16"], lin["bv"], m), "bias": bias(lin["b16"], lin["bv"], m),
                **level_stats(b16, bv8, m)}
            r[f"browser_vertex_colours_vs_mesh_{mname}"] = {"rel_rmse": rel_rmse(lin["bv"], lin["mesh"], m),
                                                           **level_stats(bv8, mesh8, m)}
            r[f"browser_vertex_colours_vs_pixels_{mname}"] = rel_rmse(lin["bv"], lin["px"], m)
        if ref is not None:
            m = ref_lit & ~clamped
            r["ref_mask_pixels"] = int(m.sum())
            e = exposure
            noise = ref_meta.get("est_noise_rel_rmse_lit")
            r["vs_mitsuba_lit"] = {
                "browser": rel_rmse(lin["b16"] / e, ref, m),
                "browser_vertex_colours": rel_rmse(lin["bv"] / e, ref, m),
                "mesh": rel_rmse(lin["mesh"] / e, ref, m),
                "pixels_8bit": rel_rmse(lin["px"] / e, ref, m),
                "pixels_exr": rel_rmse(px_lin, ref, m),
            }
            if noise:
                r["vs_mitsuba_lit_noise_corrected"] = {
                    k: float(np.sqrt(max(v * v - noise * noise, 0.0))) for k, v in r["vs_mitsuba_lit"].items()}
    ev = rows[-1]["mesh_vs_pixels_surfaces"]
    ev_i = rows[-1]["mesh_vs_pixels_interior"]
    bv_s = rows[-1]["browser_vertex_colours_vs_pixels_surfaces"]
    bv_i = rows[-1]["browser_vertex_colours_vs_pixels_interior"]
    pts = sorted((r["atlas"]["covered_texels"] / r["display_vertices"], r["browser_vs_pixels_surfaces"])
                 for r in rows)
    pts_i = sorted((r["atlas"]["covered_texels"] / r["display_vertices"], r["browser_vs_pixels_interior"])
                   for r in rows)
    out = {
        "scene": name,
        "camera": cam,
        "size": [w, h],
        "exposure": exposure,
        "exposures_seen": exposures,
        "mesh_image_identical_across_runs": same,
        "display_vertices": rows[-1]["display_vertices"],
        "pixels_run": {"command": shlex.join(["vkrad", *px_cmd[1:]]), "seconds": px_s},
        "refused": refused,
        "browser_seconds": browser_s,
        "browser": {k: browser[0].get(k) for k in ("browser", "flags", "renderer", "gpu", "three", "subpixel_bits",
                                                   "depth_bits")},
        "browser_jobs": [{k: j.get(k) for k in ("out", "samples", "antialias", "vertex_colours", "seconds",
                                                "screenshot_values_differing_from_canvas", "materials", "textures",
                                                "console")} for j in browser],
        "vertices_vs_pixels": {"surfaces": ev, "interior": ev_i},
        "browser_vertex_colours_vs_pixels": {"surfaces": bv_s, "interior": bv_i},
        "equal_error_in_browser": {
            "covered_texels_per_vertex_within_5pct_surfaces": crossing(pts, 1.05 * bv_s),
            "covered_texels_per_vertex_within_1pct_surfaces": crossing(pts, 1.01 * bv_s),
            "covered_texels_per_vertex_within_5pct_interior": crossing(pts_i, 1.05 * bv_i),
            "covered_texels_per_vertex_within_1pct_interior": crossing(pts_i, 1.01 * bv_i),
        },
        "equal_error": {
            "covered_texels_per_vertex_within_5pct_surfaces": crossing(pts, 1.05 * ev),
            "covered_texels_per_vertex_within_1pct_surfaces": crossing(pts, 1.01 * ev),
            "covered_texels_per_vertex_within_5pct_interior": crossing(pts_i, 1.05 * ev_i),
            "covered_texels_per_vertex_within_1pct_interior": crossing(pts_i, 1.01 * ev_i),
        },
        "runs": rows,
    }
    if ref is not None:
        out["mitsuba_reference"] = {"path": ref_path, **{k: v for k, v in ref_meta.items()
                                                          if not isinstance(v, (list, dict))}}
    return out, {"mesh": mesh_images[-1], "browser": read_png(rows[-1]["browser16_png"]), "vertex": bv8,
                 "plain": read_png(rows[-1]["browser1_png"])}


def figure(results, images, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = len(results)
    fig = plt.figure(figsize=(17, 3.9 * n))
    grid = fig.add_gridspec(n, 5, width_ratios=[1, 1, 1, 1, 1.6], wspace=0.12)
    for k, (res, im) in enumerate(zip(results, images)):
        auto = res["runs"][-1]
        panels = [
            (im["mesh"], f"{res['scene']}: vkrad --shade mesh"),
            (im["browser"], f"three.js in Chromium, lightmap auto\n{auto['atlas']['width']}x"
                            f"{auto['atlas']['height']} atlas, 16 samples/pixel"),
            (np.abs(im["browser"].astype(int) - im["mesh"].astype(int)).max(axis=2),
             "|three.js lightmap - vkrad|"),
            (np.abs(im["browser"].astype(int) - im["vertex"].astype(int)).max(axis=2),
             "|three.js lightmap - three.js\nvertex colours|"),
        ]
        for j, (img, title) in enumerate(panels):
            ax = fig.add_subplot(grid[k, j])
            if img.ndim == 2:
                ax.imshow(np.minimum(img, 16), cmap="magma", vmin=0, vmax=16)
                title += "\n(8-bit levels, black 0, white 16+)"
            else:
                ax.imshow(img)
            ax.set_title(title, fontsize=8)
            ax.set_xticks([])
            ax.set_yticks([])
        ax = fig.add_subplot(grid[k, 4])
        runs = sorted(res["runs"], key=lambda r: r["atlas"]["covered_texels"])
        x = [r["covered_texels_per_vertex"] for r in runs]
        ax.loglog(x, [r["lightmap_vs_vertex_colours_in_browser_surfaces"]["rel_rmse"] for r in runs], "o-",
                  label="lightmap vs vertex colours (both three.js)")
        ax.loglog(x, [r["browser_vs_pixels_surfaces"] for r in runs], "s-", label="three.js lightmap vs vkrad pixels")
        ax.axhline(res["browser_vertex_colours_vs_pixels"]["surfaces"], color="k", ls="--", lw=1,
                   label="three.js vertex colours vs vkrad pixels")
        if "vs_mitsuba_lit" in runs[0]:
            spp = res.get("mitsuba_reference", {}).get("spp", "?")
            ax.loglog(x, [r["vs_mitsuba_lit"]["browser"] for r in runs], "^-",
                      label=f"three.js lightmap vs Mitsuba ({spp} spp, its noise in)")
            ax.axhline(runs[0]["vs_mitsuba_lit"]["browser_vertex_colours"], color="grey", ls=":", lw=1,
                       label="three.js vertex colours vs Mitsuba")
        for r in runs:
            if r["density"] == "auto":
                ax.annotate("auto", (r["covered_texels_per_vertex"], r["browser_vs_pixels_surfaces"]),
                            fontsize=7, xytext=(3, 4), textcoords="offset points")
        ax.set_xlabel(f"covered texels per display vertex ({res['display_vertices']:,} vertices)", fontsize=8)
        ax.set_ylabel("relative RMSE, linear", fontsize=8)
        ax.yaxis.set_major_locator(matplotlib.ticker.FixedLocator([0.003, 0.005, 0.01, 0.02, 0.03, 0.05, 0.1, 0.2]))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v * 100:g}%"))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.yaxis.set_label_position("right")
        ax.yaxis.tick_right()
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, loc="upper right")
    fig.savefig(path, dpi=80, bbox_inches="tight")
    plt.close(fig)


def versions():
    out = {}
    try:
        out["chromium"] = subprocess.run(["/usr/bin/chromium", "--version"], capture_output=True,
                                         text=True).stdout.strip()
    except OSError:
        pass
    for pkg in ("three", "puppeteer-core"):
        p = os.path.join(TOOLS, "node_modules", pkg, "package.json")
        if os.path.exists(p):
            out[pkg] = json.load(open(p))["version"]
    out["node"] = subprocess.run(["node", "--version"], capture_output=True, text=True).stdout.strip()
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vkrad", default=os.path.join(REPO, "target", "release", "vkrad"))
    ap.add_argument("--scenes", default="cornell,rfield", help="built-in names or .obj paths with a camera line")
    ap.add_argument("--densities", help="texels per unit, comma-separated (default: per scene; auto is added)")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--cache", default=os.path.join(HERE, "cache", "lightmap"))
    ap.add_argument("--reuse", action="store_true", help="reuse vkrad outputs already in --cache")
    ap.add_argument("--ref", default=os.path.join(HERE, "pathtracer", "out"),
                    help="compare.py's output folder (SCENE-ref.exr); '' for none")
    ap.add_argument("--shot-scene", default="cornell", help="whose README screenshot to write")
    ap.add_argument("--shot-size", type=int, default=320)
    ap.add_argument("--out", default=os.path.join(HERE, "lightmap"))
    a = ap.parse_args()
    if not os.path.exists(os.path.join(TOOLS, "node_modules", "puppeteer-core")):
        sys.exit(f"run `npm ci` in {TOOLS} first")
    size = tuple(int(v) for v in a.size.lower().split("x"))
    results, images = [], []
    for scene in a.scenes.split(","):
        name = os.path.splitext(os.path.basename(scene))[0]
        dens = ([float(d) for d in a.densities.split(",")] if a.densities
                else DENSITIES.get(name, [1.0, 2.0, 4.0, 8.0]))
        res, im = bench_scene(a, scene, dens, size)
        results.append(res)
        images.append(im)
    doc = {
        "what": "vkrad --export x.glb --lightmap D drawn by three.js in headless Chromium, against vkrad's "
                "own --shade mesh render of the same lit mesh, its --shade pixels image and a Mitsuba 3 reference",
        "command": shlex.join(["python3", "bench/lightmap.py", *sys.argv[1:]]),
        "reused_vkrad_outputs": a.reuse,
        "date": datetime.date.today().isoformat(),
        "versions": versions(),
        "device": results[0]["runs"][0].get("device") if results else None,
        "metric": "rel RMSE = sqrt(mean((x - r)^2)) / mean(r) on linear light (8-bit sRGB decoded), channels "
                  "pooled; off_N = share of mask pixels whose largest channel differs by more than N 8-bit levels",
        "masks": {"surfaces": "all 16 browser samples hit the model; no pixel within 1 of one clamped at 255",
                  "interior": "surfaces whose 3x3 neighbourhood has one normal (no crease, edge or chart seam)",
                  "lit (Mitsuba)": "compare.py's lit mask (reference above 1% of its mean, sees no emitter) "
                                   "less clamped pixels"},
        "scenes": results,
    }
    with open(a.out + ".json", "w") as f:
        json.dump(relative(doc), f, indent=1)
        f.write("\n")
    figure(results, images, a.out + ".png")
    log(f"wrote {a.out}.json, {a.out}.png")
    for res in results:
        log(f"{res['scene']}: {res['display_vertices']:,} display vertices; mesh vs pixels "
            f"{res['vertices_vs_pixels']['surfaces'] * 100:.3f}% (interior "
            f"{res['vertices_vs_pixels']['interior'] * 100:.3f}%)")
        for r in sorted(res["runs"], key=lambda r: r["atlas"]["covered_texels"]):
            bm = r["browser_vs_mesh_surfaces"]
            log(f"  D {r['density']:>7} ({r['atlas']['texels_per_unit']:.4g}/unit): atlas "
                f"{r['atlas']['width']}x{r['atlas']['height']}, {r['atlas']['covered_texels']:,} covered "
                f"({r['covered_texels_per_vertex']:.2f}/vertex); browser vs mesh {bm['rel_rmse'] * 100:.3f}% "
                f"(off>3 {bm['off_3'] * 100:.2f}%, interior {r['browser_vs_mesh_interior']['rel_rmse'] * 100:.3f}%)"
                f", plain three.js vs mesh {r['plain_threejs_vs_mesh_surfaces']['rel_rmse'] * 100:.3f}%; "
                f"lightmap vs vertex colours {r['lightmap_vs_vertex_colours_in_browser_surfaces']['rel_rmse'] * 100:.3f}% "
                f"(interior {r['lightmap_vs_vertex_colours_in_browser_interior']['rel_rmse'] * 100:.3f}%); "
                f"browser vs pixels {r['browser_vs_pixels_surfaces'] * 100:.3f}%"
                + (f"; vs Mitsuba browser {r['vs_mitsuba_lit']['browser'] * 100:.3f}% mesh "
                   f"{r['vs_mitsuba_lit']['mesh'] * 100:.3f}% pixels {r['vs_mitsuba_lit']['pixels_exr'] * 100:.3f}%"
                   if "vs_mitsuba_lit" in r else ""))
        log(f"  browser vertex colours vs pixels {res['browser_vertex_colours_vs_pixels']}")
        log(f"  equal error (vkrad mesh): {res['equal_error']}")
        log(f"  equal error (in browser): {res['equal_error_in_browser']}")


if __name__ == "__main__":
    main()
