#!/usr/bin/env python3
"""Independent path-traced reference for vkrad, and a "time to image error" race.

vkrad (progressive-refinement radiosity) against the Mitsuba 3 path tracer on
the same machine, on the same scene (OBJ + MTL, parsed here, not by Mitsuba),
with the same camera (the `# vkrad camera ...` comment), both producing
radiance L (vkrad: L = B / pi; Mitsuba: emitters of radiance Ke, diffuse
BSDFs of reflectance Kd).

    python3 compare.py --scene cornell --vkrad ../../target/release/vkrad --size 256x256
    python3 compare.py --scene cornell --skip-vkrad           # path tracer only
    python3 compare.py --scene /path/to/x.obj --ref-spp 65536

Scene conversion
  * `v`, `f` (v, v/vt, v/vt/vn, v//vn; negative indices), `usemtl`, `mtllib`;
    polygons are triangulated as fans; one mi.Mesh per material.
  * MTL `Kd` = diffuse reflectance (default 0.5 grey, as vkrad), `Ke` =
    emitted radiance. Emitters are one-sided: they emit on the side where the
    face's vertices run counter-clockwise (geometric normal, right-hand rule).
  * Diffuse surfaces are one-sided by default (Mitsuba's `diffuse` is black
    from behind), like vkrad's receivers; `--two-sided` wraps them in
    `twosided`. In a closed scene this is moot; the Cornell box is open at the
    front but no light path reaches a back face except in the 0.1 mm gap
    between the light and the ceiling.

Image error
  The error of an image x against the reference r is vkrad's own definition
  (src/bench/mod.rs, relative_rms_error_where), on linear radiance, with the
  three colour channels pooled:
        rel RMSE = sqrt(mean_{p in M, c in RGB} (x_pc - r_pc)^2)
                   / mean_{p in M, c in RGB} r_pc
        mean bias = mean_{M,c} x / mean_{M,c} r - 1
  over the mask M of "lit surfaces": pixels whose reference value (mean of
  its RGB) exceeds 1% of the reference's mean (over all pixels) and whose
  pixel footprint sees no emitter directly (a 1-bounce render, emission only,
  is exactly 0 there). A second, stricter mask "interior" (pixels whose
  centre and four corners all hit the front of the same non-emitting input
  polygon, like vkrad's bench mask) is reported too.

Timing
  Path tracer: spp = 1, 2, 4, ... each rendered once with its own seed, after
  a discarded warm-up render has compiled the kernels: "warm_s" is the
  render alone. The cold start is measured once, in a fresh process
  (`--cold-probe`, run as a subprocess with an empty Dr.Jit kernel cache,
  DRJIT_CACHE_DIR): interpreter start + import + scene build + JIT compile +
  a 1-spp render, wall time of the whole command. cold_total_s(spp) =
  cold_overhead_s + warm_s(spp), where cold_overhead_s = probe wall time -
  warm_s(1 spp). vkrad: the wall time of the whole command (subprocess), at
  each --converge, which includes its own start-up (Vulkan, pipelines, mesh).

Sampler
  Mitsuba's `multijitter` (correlated multi-jittered, stratified) by default,
  for the reference and the race: on the Cornell box it has about 2.3x less
  variance per sample than `independent` (measured: relative noise x
  sqrt(spp) = 0.72 against 1.09 at 256 spp). `--sampler independent` for
  plain Monte Carlo. Samplers may round a sample count (multijitter: 32 ->
  35, 128 -> 132; ldsampler: powers of 4); the spp recorded is the count
  actually rendered. Renders go in chunks of at most 2^22 / (W*H) spp. The reference is
  two independent halves (different seeds); its own noise is estimated as
  rel_rmse(half_a, half_b) / 2. Errors are also given with that noise taken
  out: corrected = sqrt(max(E^2 - noise^2, 0)) (the reference's noise is
  independent of both competitors, so it adds in quadrature).
"""

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DEFAULT_SCENES = os.path.join(REPO, "scenes")
LOCAL_LLVM = os.path.join(HERE, "llvm/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LOCAL_LLVM):
    os.environ["DRJIT_LIBLLVM_PATH"] = LOCAL_LLVM

import numpy as np

_t_import = time.perf_counter()
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

IMPORT_S = time.perf_counter() - _t_import


def log(*a):
    print(*a, flush=True)


# --------------------------------------------------------------------------
# Variant
# --------------------------------------------------------------------------

def set_variant(requested):
    """llvm_ad_rgb when libLLVM loads, else scalar_rgb (said loudly)."""
    t = time.perf_counter()
    if requested != "scalar_rgb":
        try:
            mi.set_variant(requested)
            x = dr.arange(mi.Float, 8) * 2.0
            dr.eval(x)
            assert np.asarray(x).sum() == 56.0
            return requested, time.perf_counter() - t
        except Exception as e:  # noqa: BLE001
            log(f"WARNING: variant {requested} failed ({e}); falling back to scalar_rgb")
    mi.set_variant("scalar_rgb")
    return "scalar_rgb", time.perf_counter() - t


# --------------------------------------------------------------------------
# OBJ + MTL
# --------------------------------------------------------------------------

def parse_mtl(path, materials):
    cur = None
    with open(path, encoding="utf-8", errors="replace") as fh:
        for raw in fh:
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            words = line.split()
            key = words[0]
            if key == "newmtl":
                cur = " ".join(words[1:])
                materials[cur] = {"Kd": None, "Ke": [0.0, 0.0, 0.0]}
            elif key in ("Kd", "Ke") and cur is not None:
                vals = [float(w) for w in words[1:4]]
                if len(vals) == 1:
                    vals = vals * 3
                materials[cur][key] = vals
    return materials


def parse_camera(words):
    cam = {}
    i = 0
    while i < len(words):
        k = words[i]
        if k in ("eye", "look_at", "up"):
            cam[k] = [float(w) for w in words[i + 1:i + 4]]
            i += 4
        elif k == "fov":
            cam[k] = float(words[i + 1])
            i += 2
        else:
            raise ValueError(f"unknown camera field {k!r}")
    cam.setdefault("up", [0.0, 1.0, 0.0])
    return cam


def parse_obj(path):
    """Returns dict(vertices (N,3), polygons [(material, [i0, i1, ...])],
    materials {name: {Kd, Ke}}, camera or None)."""
    verts, polys, mtllibs = [], [], []
    camera, cur = None, None
    base = os.path.dirname(os.path.abspath(path))
    with open(path, encoding="utf-8", errors="replace") as fh:
        for raw in fh:
            s = raw.strip()
            if s.startswith("#"):
                w = s[1:].split()
                if len(w) >= 2 and w[0] == "vkrad" and w[1] == "camera":
                    camera = parse_camera(w[2:])
                continue
            s = s.split("#", 1)[0].strip()
            if not s:
                continue
            words = s.split()
            key = words[0]
            if key == "v":
                verts.append([float(x) for x in words[1:4]])
            elif key == "f":
                idx = []
                for w in words[1:]:
                    i = int(w.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                if len(idx) >= 3:
                    polys.append((cur, idx))
            elif key == "usemtl":
                cur = " ".join(words[1:])
            elif key == "mtllib":
                mtllibs.append(os.path.join(base, s[len("mtllib"):].strip()))
    materials = {}
    for m in mtllibs:
        parse_mtl(m, materials)
    return {
        "vertices": np.asarray(verts, dtype=np.float64),
        "polygons": polys,
        "materials": materials,
        "camera": camera,
    }


def resolve_scene(scene):
    if os.path.exists(scene):
        return os.path.abspath(scene), os.path.splitext(os.path.basename(scene))[0]
    p = os.path.join(DEFAULT_SCENES, scene + ".obj")
    if os.path.exists(p):
        return p, scene
    sys.exit(f"scene {scene!r}: neither a file nor {p}")


# --------------------------------------------------------------------------
# Mitsuba scene
# --------------------------------------------------------------------------

def build_scene(obj, camera, size, two_sided=False, max_depth=100, rr_depth=5, sampler="multijitter"):
    """Builds the Mitsuba scene in Python: one mi.Mesh per material.

    Every mesh carries a face attribute `face_poly`: (input polygon index + 1),
    negated for emitting polygons; used for the 'interior' mask."""
    V = obj["vertices"]
    by_mat = {}
    for pi, (mat, idx) in enumerate(obj["polygons"]):
        by_mat.setdefault(mat, []).append((pi, idx))
    shapes = {}
    emitters = set()
    for k, (mat, plist) in enumerate(by_mat.items()):
        m = obj["materials"].get(mat)
        if m is None:
            if mat is not None:
                log(f"WARNING: material {mat!r} not in the MTL; grey 0.5")
            m = {"Kd": None, "Ke": [0, 0, 0]}
        kd = m["Kd"] if m["Kd"] is not None else [0.5, 0.5, 0.5]
        ke = m["Ke"]
        emits = max(ke) > 0
        # fan triangulation, vertices unshared per mesh (compact re-index)
        used = sorted({i for _, idx in plist for i in idx})
        remap = {v: j for j, v in enumerate(used)}
        tris, tri_poly = [], []
        for pi, idx in plist:
            for t in range(1, len(idx) - 1):
                tris.append([remap[idx[0]], remap[idx[t]], remap[idx[t + 1]]])
                tri_poly.append(-(pi + 1) if emits else (pi + 1))
        pos = V[used].astype(np.float32)
        tris = np.asarray(tris, dtype=np.uint32)
        bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(c) for c in kd]}}
        if two_sided:
            bsdf = {"type": "twosided", "material": bsdf}
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        if emits:
            props["emitter"] = mi.load_dict(
                {"type": "area", "radiance": {"type": "rgb", "value": [float(c) for c in ke]}})
            emitters.add(mat)
        mesh = mi.Mesh(f"mat{k}_{mat}", len(pos), len(tris), props=props,
                       has_vertex_normals=False, has_vertex_texcoords=False)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(pos.ravel())
        params["faces"] = mi.UInt32(tris.ravel())
        params.update()
        mesh.add_attribute("face_poly", 1, mi.Float(np.asarray(tri_poly, dtype=np.float32)))
        shapes[f"mesh{k}"] = mesh
    if not emitters:
        sys.exit("the scene has no emitter (no material with Ke > 0)")
    w, h = size
    sensor = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": float(camera["fov"]),
        "to_world": mi.ScalarTransform4f().look_at(
            origin=camera["eye"], target=camera["look_at"], up=camera["up"]),
        "film": {
            "type": "hdrfilm", "width": w, "height": h, "pixel_format": "rgb",
            "rfilter": {"type": "box"}, "sample_border": False,
        },
        "sampler": {"type": sampler, "sample_count": 1},
    }
    scene_dict = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": rr_depth,
                       "hide_emitters": False},
        "sensor": sensor,
    }
    scene_dict.update(shapes)
    return mi.load_dict(scene_dict), scene_dict


# Largest spp per mi.render call (memory: wavefront of W*H*spp lanes).
_ROUNDED = {}


def actual_count(sampler_type, n):
    """The sample count a sampler really takes when asked for n."""
    if (sampler_type, n) not in _ROUNDED:
        _ROUNDED[(sampler_type, n)] = mi.load_dict({"type": sampler_type, "sample_count": n}).sample_count()
    return _ROUNDED[(sampler_type, n)]


def render_spp(scene, spp, seed, chunk_lanes=1 << 22, integrator=None, with_count=False):
    """Mean of about `spp` samples per pixel, in chunks; returns HxWx3
    float64 (and the sample count actually rendered, with_count)."""
    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    stype = sensor.sampler().class_name().lower().replace("sampler", "") or "independent"
    stype = {"multijitter": "multijitter", "independent": "independent", "stratified": "stratified",
             "lowdiscrepancy": "ldsampler", "orthogonal": "orthogonal"}.get(stype, stype)
    chunk = max(1, min(spp, chunk_lanes // (w * h)))
    acc, done, k, total = None, 0, 0, 0
    while done < spp:
        n = min(chunk, spp - done)
        img = mi.render(scene, spp=n, seed=(seed * 100003 + k) & 0x7FFFFFFF,
                        integrator=integrator)
        m = actual_count(stype, n)
        a = np.asarray(img, dtype=np.float64)[..., :3] * m
        acc = a if acc is None else acc + a
        done += n
        total += m
        k += 1
    return (acc / total, total) if with_count else acc / total


def emitter_visible_mask(scene, spp=1024):
    """Pixels whose footprint sees an emitter directly: a path of depth 1
    (camera ray -> emission only) gives > 0. Many samples, so that a pixel
    with a sliver of emitter is caught (at 16 spp one pixel beside the
    Cornell light, 6% emitter, was missed and weighed like 10,000 others)."""
    integ = mi.load_dict({"type": "path", "max_depth": 1, "hide_emitters": False})
    img = render_spp(scene, spp, seed=999_999, integrator=integ)
    return img.max(axis=2) > 0


def interior_mask(scene, size):
    """Pixels whose centre and four corners all hit the front of one
    non-emitting input polygon."""
    w, h = size
    sensor = scene.sensors()[0]
    ys, xs = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    ids, fronts = [], []
    for dx, dy in [(0.5, 0.5), (0.001, 0.001), (0.999, 0.001), (0.001, 0.999), (0.999, 0.999)]:
        px = ((xs + dx) / w).ravel().astype(np.float32)
        py = ((ys + dy) / h).ravel().astype(np.float32)
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(px, py), mi.Point2f(0.5, 0.5))
        si = scene.ray_intersect(ray)
        pid = si.shape.eval_attribute_1("face_poly", si)
        pid = dr.select(si.is_valid(), pid, 0.0)
        front = dr.dot(si.n, ray.d) < 0
        ids.append(np.asarray(pid).reshape(h, w))
        fronts.append(np.asarray(front).reshape(h, w))
    ids = np.stack(ids)
    fronts = np.stack(fronts)
    same = np.all(ids == ids[0], axis=0)
    return same & (ids[0] > 0) & np.all(fronts, axis=0)


# --------------------------------------------------------------------------
# Images and error
# --------------------------------------------------------------------------

def read_exr(path):
    bmp = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.asarray(bmp, dtype=np.float64)[..., :3]


def write_exr(path, img):
    mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(path)


def write_png(path, img, exposure=None):
    """Tone-mapped preview: 99th percentile of the mean-RGB -> white, sRGB."""
    if exposure is None:
        q = np.percentile(img.mean(axis=2), 99)
        exposure = 1.0 / q if q > 0 else 1.0
    mi.Bitmap((img * exposure).astype(np.float32), mi.Bitmap.PixelFormat.RGB).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(path)
    return exposure


def probe_mask(direct, interior, window=7, change=0.5):
    """Penumbra and contact probes: interior pixels (with their 3x3
    neighbourhood interior too) where the direct light changes by more than
    `change` of its local maximum within `window` pixels, and the pixel's
    own direct light is neither the local maximum nor zero: the inside of
    penumbrae and of contact shadows, where a mesh is most likely wrong."""
    d = direct.mean(axis=2)
    h, w = d.shape
    r = window // 2
    pad = np.pad(d, r, mode="edge")
    stack = np.stack([pad[i:i + h, j:j + w] for i in range(window) for j in range(window)])
    hi, lo = stack.max(axis=0), stack.min(axis=0)
    ipad = np.pad(interior, 1, constant_values=False)
    inner = np.all(np.stack([ipad[i:i + h, j:j + w] for i in range(3) for j in range(3)]), axis=0)
    return inner & (hi > 0) & ((hi - lo) > change * hi) & (d > 0.05 * hi) & (d < 0.95 * hi)


def box3(img):
    h, w = img.shape[:2]
    pad = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="edge")
    return sum(pad[i:i + h, j:j + w] for i in range(3) for j in range(3)) / 9.0


def probe_errors(x, ref, probes):
    """Relative error of the 3x3 mean (mean RGB) at every probe: median,
    90th percentile and worst."""
    if probes.sum() == 0:
        return {}
    xs, rs = box3(x).mean(axis=2)[probes], box3(ref).mean(axis=2)[probes]
    e = np.abs(xs - rs) / np.maximum(rs, 1e-12)
    return {"probes": int(probes.sum()), "probe_median": float(np.median(e)),
            "probe_p90": float(np.percentile(e, 90)), "probe_max": float(e.max())}


def rel_rmse(x, ref, mask):
    d = (x - ref)[mask]
    return float(np.sqrt(np.mean(d * d)) / np.mean(ref[mask]))


def mean_bias(x, ref, mask):
    return float(np.mean(x[mask]) / np.mean(ref[mask]) - 1.0)


def errors(x, ref, masks):
    out = {}
    for name, m in masks.items():
        out[f"rel_rmse_{name}"] = rel_rmse(x, ref, m)
        out[f"bias_{name}"] = mean_bias(x, ref, m)
    return out


def time_to(curve, target, tkey, ekey="rel_rmse_lit"):
    """First time at which the curve's error is <= target, log-log
    interpolated between the bracketing points; None if never reached."""
    pts = [(p[tkey], max(p[ekey], 1e-12)) for p in curve]
    for i, (t, e) in enumerate(pts):
        if e <= target:
            if i == 0:
                return t
            t0, e0 = pts[i - 1]
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0)))
    return None


# --------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell", help="scene name in the repository's scenes/ or an .obj path")
    ap.add_argument("--vkrad", default=os.path.join(REPO, "target", "release", "vkrad"), help="vkrad binary")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--ref-spp", type=int, default=65536, help="reference spp (two independent halves)")
    ap.add_argument("--max-spp", type=int, default=16384, help="largest spp of the race (powers of two)")
    ap.add_argument("--converge", default="1e-1,3e-2,1e-2,3e-3,1e-3", help="vkrad --converge values ('default': vkrad's own stop rule)")
    ap.add_argument("--vkrad-args", default="", help="extra arguments for vkrad (one string)")
    ap.add_argument("--skip-vkrad", action="store_true")
    ap.add_argument("--vkrad-timeout", type=float, default=None, help="seconds per vkrad run (skip the rest)")
    ap.add_argument("--skip-race", action="store_true", help="no path-tracer race (reference only)")
    ap.add_argument("--two-sided", action="store_true", help="two-sided diffuse surfaces")
    ap.add_argument("--max-depth", type=int, default=100)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--sampler", default="multijitter", help="Mitsuba sampler for reference and race "
                    "(multijitter, independent, stratified, ldsampler, ...)")
    ap.add_argument("--target", type=float, default=0.01,
                    help="race stops at the first spp whose error is below target (or at --max-spp)")
    ap.add_argument("--cold-probe", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, default=0, help="Dr.Jit threads (0 = all cores)")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--tag", default="", help="suffix for the vkrad images and race-<scene><tag>.json/.png "
                    "(e.g. a vkrad variant run with --skip-race --vkrad-args ...); the reference is shared")
    ap.add_argument("--eye"), ap.add_argument("--look-at"), ap.add_argument("--up"), ap.add_argument("--fov", type=float)
    a = ap.parse_args()

    w, h = (int(v) for v in a.size.lower().split("x"))
    size = (w, h)
    os.makedirs(a.out, exist_ok=True)
    variant, variant_s = set_variant(a.variant)
    if a.threads:
        dr.set_thread_count(a.threads)
    log(f"mitsuba {mi.__version__}, variant {variant}, import {IMPORT_S:.2f}s, "
        f"DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH')}")

    obj_path, name = resolve_scene(a.scene)
    obj = parse_obj(obj_path)
    cam = dict(obj["camera"] or {})
    for key, val in (("eye", a.eye), ("look_at", a.look_at), ("up", a.up)):
        if val:
            cam[key] = [float(x) for x in val.split(",")]
    if a.fov:
        cam["fov"] = a.fov
    if not all(k in cam for k in ("eye", "look_at", "fov")):
        sys.exit("the scene has no `# vkrad camera` comment: give --eye, --look-at and --fov")
    cam.setdefault("up", [0.0, 1.0, 0.0])
    log(f"scene {obj_path}: {len(obj['vertices'])} vertices, {len(obj['polygons'])} polygons, "
        f"materials {list(obj['materials'])}; camera {cam}")

    t = time.perf_counter()
    scene, _ = build_scene(obj, cam, size, a.two_sided, a.max_depth, a.rr_depth, a.sampler)
    load_s = time.perf_counter() - t
    log(f"scene build {load_s:.2f}s")
    if a.cold_probe:
        t = time.perf_counter()
        render_spp(scene, 1, seed=7)
        render_s = time.perf_counter() - t
        print("COLD_PROBE " + json.dumps({"import_s": IMPORT_S, "variant_s": variant_s,
                                           "build_s": load_s, "first_render_1spp_s": render_s}))
        return

    tag = f"{name}-{w}x{h}"
    sided = "-2sided" if a.two_sided else ""
    masks_path = os.path.join(a.out, f"{tag}{sided}-masks-v2.npz")
    if os.path.exists(masks_path):
        z = np.load(masks_path)
        sees_emitter, interior = z["sees_emitter"], z["interior"]
    else:
        sees_emitter = emitter_visible_mask(scene)
        interior = interior_mask(scene, size)
        np.savez(masks_path, sees_emitter=sees_emitter, interior=interior)
    # Direct light only, for the penumbra and contact probes (cached).
    direct_path = os.path.join(a.out, f"{tag}{sided}-direct-1024.exr")
    if os.path.exists(direct_path):
        direct = read_exr(direct_path)
    else:
        direct = render_spp(scene, 1024, seed=4242,
                            integrator=mi.load_dict({"type": "path", "max_depth": 2, "hide_emitters": False}))
        write_exr(direct_path, direct)
    probes = probe_mask(direct, interior & ~sees_emitter)

    # ---------------- reference ----------------
    ref_spp = 1 << max(1, (a.ref_spp - 1).bit_length())  # power of two, halves too
    ref_path = os.path.join(a.out, f"{name}-ref.exr")
    meta_path = os.path.join(a.out, f"{name}-ref.json")
    key = {"scene": obj_path, "size": [w, h], "spp": ref_spp, "camera": cam, "two_sided": a.two_sided,
           "max_depth": a.max_depth, "rr_depth": a.rr_depth, "variant": variant, "sampler": a.sampler}
    meta = None
    if os.path.exists(ref_path) and os.path.exists(meta_path):
        with open(meta_path) as fh:
            meta = json.load(fh)
        if meta.get("key") != key:
            log("cached reference has other settings; rendering a new one")
            meta = None
    if meta is not None:
        ref = read_exr(ref_path)
        log(f"reference: cached {ref_path} ({ref_spp} spp, took {meta['seconds']:.1f}s)")
    else:
        log(f"reference: {ref_spp} spp as two independent halves of {ref_spp // 2} ...")
        c = time.process_time()
        t = time.perf_counter()
        half_a, n_a = render_spp(scene, ref_spp // 2, seed=1_000_001, with_count=True)
        ta = time.perf_counter() - t
        log(f"  half A {ta:.1f}s")
        half_b, n_b = render_spp(scene, ref_spp // 2, seed=2_000_003, with_count=True)
        secs = time.perf_counter() - t
        log(f"  half B {secs - ta:.1f}s")
        ref_cpu = time.process_time() - c
        ref = 0.5 * (half_a + half_b)
        lum = ref.mean(axis=2)
        lit = (lum > 0.01 * lum.mean()) & ~sees_emitter
        d = rel_rmse(half_a, half_b, lit)  # rel RMSE between halves
        meta = {
            "key": key, "seconds": secs, "cpu_s": ref_cpu, "spp": n_a + n_b,
            # each half has noise d / sqrt(2); their mean d / 2
            "half_vs_half_rel_rmse_lit": d,
            "est_noise_rel_rmse_lit": d / 2,
            "est_noise_rel_rmse_interior": rel_rmse(half_a, half_b, lit & interior) / 2,
            "half_vs_half_bias_lit": mean_bias(half_a, half_b, lit),
            "mitsuba": mi.__version__, "variant": variant,
            "note": "seconds = wall time of both halves (warm process, includes kernel compile)",
        }
        write_exr(ref_path, ref)
        with open(meta_path, "w") as fh:
            json.dump(meta, fh, indent=2)
        log(f"reference: {secs:.1f}s, est. own noise {meta['est_noise_rel_rmse_lit'] * 100:.3f}% rel RMSE (lit)")
    if meta["est_noise_rel_rmse_lit"] > 0.005:
        log(f"WARNING: the reference's own noise ({meta['est_noise_rel_rmse_lit'] * 100:.2f}%) is not well "
            "below 1%: raise --ref-spp")
    exposure = write_png(os.path.join(a.out, f"{name}-ref.png"), ref)

    lum = ref.mean(axis=2)
    lit = (lum > 0.01 * lum.mean()) & ~sees_emitter
    masks = {"lit": lit, "interior": lit & interior}
    log(f"masks: lit {lit.sum()} px ({lit.mean() * 100:.1f}%), interior {masks['interior'].sum()} px, "
        f"emitter-visible {sees_emitter.sum()} px")
    write_png(os.path.join(a.out, f"{tag}-probes.png"),
              np.stack([probes, masks["interior"] & ~probes, np.zeros_like(probes)], axis=2).astype(np.float64),
              exposure=1.0)
    log(f"probes: {probes.sum()} penumbra and contact pixels (direct light changes by half within 3 px)")
    write_png(os.path.join(a.out, f"{tag}-mask.png"),
              np.stack([lit, masks["interior"], sees_emitter], axis=2).astype(np.float64), exposure=1.0)

    race_path = os.path.join(a.out, f"race-{name}{a.tag}.json")
    prev = {}
    for pth in (race_path, os.path.join(a.out, f"race-{name}.json")):
        if os.path.exists(pth):
            with open(pth) as fh:
                prev = json.load(fh)
            same = (prev.get("scene") == obj_path and prev.get("size") == [w, h]
                    and prev.get("reference", {}).get("spp") == meta["spp"]
                    and prev.get("sampler") == a.sampler and prev.get("two_sided") == a.two_sided)
            if not same:
                prev = {}
            break

    # ---------------- path-tracer race ----------------
    noise = {"lit": meta["est_noise_rel_rmse_lit"], "interior": meta["est_noise_rel_rmse_interior"]}

    def corrected(p):
        for m in ("lit", "interior"):
            e = p[f"rel_rmse_{m}"]
            p[f"rel_rmse_{m}_corrected"] = math.sqrt(max(e * e - noise[m] ** 2, 0.0))
        return p

    pt = prev.get("pathtracer", []) if a.skip_race else []
    cold = prev.get("cold_probe") if a.skip_race else None
    if not a.skip_race:
        # cold start, in a fresh process with an empty kernel cache
        import tempfile
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, DRJIT_CACHE_DIR=cache)
            cmd = [sys.executable, os.path.abspath(__file__), "--cold-probe", "--scene", obj_path,
                   "--size", a.size, "--variant", variant, "--sampler", a.sampler,
                   "--max-depth", str(a.max_depth), "--rr-depth", str(a.rr_depth)]
            cmd += ["--two-sided"] if a.two_sided else []
            cmd += [f"--eye={','.join(map(str, cam['eye']))}", f"--look-at={','.join(map(str, cam['look_at']))}",
                    f"--up={','.join(map(str, cam['up']))}", f"--fov={cam['fov']}"]
            t = time.perf_counter()
            r = subprocess.run(cmd, capture_output=True, text=True, env=env)
            probe_wall = time.perf_counter() - t
        line = [ln for ln in r.stdout.splitlines() if "COLD_PROBE " in ln]
        cold = json.loads(line[0].split("COLD_PROBE ", 1)[1]) if line else {}
        if not line:
            log(f"WARNING: cold probe printed no result: {r.stderr[-500:]}")
        cold["wall_s"] = probe_wall
        log(f"cold probe (fresh process, empty kernel cache, 1 spp): {probe_wall:.2f}s wall {cold}")
        chunk = max(1, (1 << 22) // (w * h))
        spp = 1
        while spp <= a.max_spp:
            if spp <= chunk and actual_count(a.sampler, spp) != spp:
                spp *= 2  # the sampler would round it (multijitter: 32 -> 35): skip
                continue
            if spp <= chunk:
                # warm-up at this spp (another seed): kernels compiled and cached
                t = time.perf_counter()
                render_spp(scene, spp, seed=500 + spp)
                log(f"  (warm-up {spp} spp: {time.perf_counter() - t:.2f}s)")
            load0 = os.getloadavg()[0]
            c = time.process_time()
            t = time.perf_counter()
            x, n = render_spp(scene, spp, seed=1000 + spp, with_count=True)
            warm_s = time.perf_counter() - t
            p = {"spp": n, "warm_s": warm_s, "cpu_s": time.process_time() - c,
                 "loadavg1_before": load0, "loadavg1_after": os.getloadavg()[0]}
            p.update(errors(x, ref, masks))
            p.update(probe_errors(x, ref, probes))
            corrected(p)
            pt.append(p)
            log(f"  pt {n:5d} spp: {warm_s:7.2f}s (cpu {p['cpu_s']:7.2f}s, load {load0:.1f})  relRMSE lit {p['rel_rmse_lit'] * 100:6.2f}% "
                f"(corr. {p['rel_rmse_lit_corrected'] * 100:6.2f}%)  interior {p['rel_rmse_interior'] * 100:6.2f}%"
                f"  bias {p['bias_lit'] * 100:+.2f}%")
            if spp in (1, 16, 256, 4096):
                write_png(os.path.join(a.out, f"{name}-pt-{spp}spp.png"), x, exposure)
            if p["rel_rmse_lit"] < a.target:
                break
            spp *= 2
        overhead = cold["wall_s"] - pt[0]["warm_s"]
        cold["overhead_s"] = overhead
        for p in pt:
            p["cold_total_s"] = overhead + p["warm_s"]

    # ---------------- vkrad ----------------
    vk = prev.get("vkrad", []) if a.skip_vkrad else []
    if not a.skip_vkrad:
        if not os.path.exists(a.vkrad):
            sys.exit(f"no vkrad binary at {a.vkrad}")
        for conv in a.converge.split(","):
            conv = conv.strip()
            out = os.path.join(a.out, f"{name}{a.tag}-vkrad-{conv}.exr")
            report = os.path.join(a.out, f"{name}{a.tag}-vkrad-{conv}.json")
            # "default": vkrad's own stop rule (no --converge).
            stop = [] if conv == "default" else ["--converge", conv]
            cmd = [a.vkrad, obj_path, "-o", out, "--size", f"{w}x{h}", *stop,
                   "--report", report, "-q"]
            cmd += [f"--eye={','.join(map(str, cam['eye']))}",
                    f"--look-at={','.join(map(str, cam['look_at']))}",
                    f"--up={','.join(map(str, cam['up']))}", f"--fov={cam['fov']}"]
            cmd += a.vkrad_args.split()
            load0 = os.getloadavg()[0]
            ru = resource.getrusage(resource.RUSAGE_CHILDREN)
            t = time.perf_counter()
            try:
                r = subprocess.run(cmd, capture_output=True, text=True, timeout=a.vkrad_timeout)
            except subprocess.TimeoutExpired:
                log(f"  vkrad --converge {conv}: over --vkrad-timeout {a.vkrad_timeout}s; stopping the vkrad runs")
                break
            wall = time.perf_counter() - t
            ru2 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (ru2.ru_utime - ru.ru_utime) + (ru2.ru_stime - ru.ru_stime)
            if r.returncode != 0:
                log(f"  vkrad --converge {conv} failed ({r.returncode}): {r.stderr.strip()[-500:]}")
                continue
            x = read_exr(out)
            p = {"converge": None if conv == "default" else float(conv), "wall_s": wall, "cpu_s": cpu, "loadavg1_before": load0,
                 "loadavg1_after": os.getloadavg()[0], "cmd": " ".join(cmd)}
            try:
                with open(report) as fh:
                    rep = json.load(fh)
                p.update({"shots": rep["solve"]["shots"], "solve_s": rep["solve"]["wall_s"],
                          "residual": rep["solve"]["residual"], "elements": rep["mesh"]["elements"]})
            except (OSError, KeyError, ValueError):
                pass
            p.update(errors(x, ref, masks))
            p.update(probe_errors(x, ref, probes))
            corrected(p)
            # orientation check: a mirrored image would match far worse
            p["rel_rmse_lit_if_mirrored"] = rel_rmse(x[:, ::-1], ref, masks["lit"])
            vk.append(p)
            write_png(os.path.join(a.out, f"{name}{a.tag}-vkrad-{conv}.png"), x, exposure)
            diff_figure(ref, x, masks["lit"], os.path.join(a.out, f"{name}{a.tag}-vkrad-{conv}-diff.png"),
                        f"vkrad --converge {conv} {a.vkrad_args}")
            log(f"  vkrad --converge {conv}: wall {wall:7.2f}s (cpu {cpu:7.2f}s, load {load0:.1f}), {p.get('shots')} shots  "
                f"relRMSE lit {p['rel_rmse_lit'] * 100:6.2f}% (corr. {p['rel_rmse_lit_corrected'] * 100:6.2f}%)  interior {p['rel_rmse_interior'] * 100:6.2f}%  "
                f"bias {p['bias_lit'] * 100:+.2f}%  (mirrored: {p['rel_rmse_lit_if_mirrored'] * 100:.1f}%)  "
                f"probes {p.get('probes', 0)}: median {p.get('probe_median', 0) * 100:.1f}% "
                f"p90 {p.get('probe_p90', 0) * 100:.1f}% max {p.get('probe_max', 0) * 100:.1f}%")

    # ---------------- summary ----------------
    summary = {
        "scene": obj_path, "size": [w, h], "camera": cam, "two_sided": a.two_sided,
        "mitsuba": mi.__version__, "variant": variant, "threads": dr.thread_count(),
        "import_s": IMPORT_S, "variant_init_s": variant_s, "scene_build_s": load_s,
        "metric": "sqrt(mean((x-ref)^2))/mean(ref), linear radiance, RGB channels pooled, over a mask; "
                  "bias = mean(x)/mean(ref)-1 over the mask",
        "masks": {"lit": "mean-RGB ref > 1% of the ref's mean over all pixels, and no emitter seen "
                         "directly within the pixel (1-bounce emission render == 0)",
                  "interior": "lit, and the pixel centre and 4 corners hit the front of one non-emitting polygon",
                  "lit_pixels": int(lit.sum()), "interior_pixels": int(masks["interior"].sum())},
        "reference": {k: v for k, v in meta.items() if k != "key"} | {"path": ref_path},
        "sampler": a.sampler, "cold_probe": cold, "vkrad_binary": os.path.abspath(a.vkrad),
        "vkrad_args": a.vkrad_args, "tag": a.tag,
        "pathtracer": pt, "vkrad": vk,
        "machine": {"cpus": os.cpu_count(), "loadavg_at_end": os.getloadavg()},
    }
    targets = sorted({0.03, a.target, 0.01}, reverse=True)
    # The path tracer's time to each vkrad run's own error: the race's answer.
    summary["pt_to_vkrad_error"] = [
        {"vkrad_wall_s": p["wall_s"], "rel_rmse_lit": p["rel_rmse_lit"],
         "pt_warm_s": time_to(pt, p["rel_rmse_lit"], "warm_s") if pt else None,
         "pt_cold_s": time_to(pt, p["rel_rmse_lit"], "cold_total_s") if pt else None}
        for p in vk]
    for target in targets:
        for ek in ("rel_rmse_lit", "rel_rmse_lit_corrected"):
            sfx = "" if ek == "rel_rmse_lit" else "_corrected"
            summary[f"pt_warm_s_to_{target}{sfx}"] = time_to(pt, target, "warm_s", ek) if pt else None
            summary[f"pt_cold_s_to_{target}{sfx}"] = time_to(pt, target, "cold_total_s", ek) if pt else None
            vs = sorted(vk, key=lambda p: p["wall_s"])
            summary[f"vkrad_s_to_{target}{sfx}"] = next((p["wall_s"] for p in vs if p[ek] <= target), None)
    with open(race_path, "w") as fh:
        json.dump(summary, fh, indent=2)
    log(f"wrote {race_path}")
    for r in summary["pt_to_vkrad_error"]:
        log(f"  vkrad {r['rel_rmse_lit'] * 100:.2f}% in {r['vkrad_wall_s']:.2f}s; the path tracer to that error: "
            f"warm {r['pt_warm_s']}, cold {r['pt_cold_s']}")
    for target in targets:
        for sfx in ("", "_corrected"):
            log(f"  to {target * 100:.0f}%{sfx}: path tracer warm {summary[f'pt_warm_s_to_{target}{sfx}']}, "
                f"cold {summary[f'pt_cold_s_to_{target}{sfx}']}; vkrad {summary[f'vkrad_s_to_{target}{sfx}']}")
    chart(summary, os.path.join(a.out, f"race-{name}{a.tag}.png"))


def diff_figure(ref, x, mask, path, title):
    """Reference | image | (x - ref) / ref of the mean RGB over the mask."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(15, 5), dpi=80)
    e = 1.0 / np.percentile(ref.mean(axis=2), 99)
    ax[0].imshow(np.clip(ref * e, 0, 1) ** (1 / 2.2))
    ax[0].set_title("reference (Mitsuba 3)")
    ax[1].imshow(np.clip(x * e, 0, 1) ** (1 / 2.2))
    ax[1].set_title(title)
    r = x.mean(axis=2) / np.maximum(ref.mean(axis=2), 1e-12) - 1.0
    r[~mask] = np.nan
    im = ax[2].imshow(r, cmap="RdBu_r", vmin=-0.3, vmax=0.3)
    ax[2].set_title("image / reference - 1 (mean RGB), lit mask")
    fig.colorbar(im, ax=ax[2])
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def chart(s, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.4), dpi=100)
    pt, vk = s["pathtracer"], s["vkrad"]
    for ax, kind in zip(axes, ("wall", "cpu")):
        if pt:
            tk = "warm_s" if kind == "wall" else "cpu_s"
            ax.loglog([p[tk] for p in pt], [p["rel_rmse_lit"] for p in pt], "o-", color="C0",
                      label=f"Mitsuba 3 path ({s['variant']}, {s['sampler']}), warm render; labels = spp")
            if kind == "wall":
                ax.loglog([p["cold_total_s"] for p in pt], [p["rel_rmse_lit"] for p in pt], "o:", color="C0",
                          alpha=0.5, mfc="none", label="Mitsuba 3 path, cold (fresh-process overhead + warm render)")
            for p in pt[::2]:
                ax.annotate(f"{p['spp']}", (p[tk], p["rel_rmse_lit"]), fontsize=7,
                            xytext=(3, 3), textcoords="offset points", color="C0")
        if vk:
            tk = "wall_s" if kind == "wall" else "cpu_s"
            ax.loglog([p[tk] for p in vk], [p["rel_rmse_lit"] for p in vk], "s-", color="C3",
                      label="vkrad, whole command; labels = --converge")
            for i, p in enumerate(vk):
                ax.annotate("default" if p['converge'] is None else f"{p['converge']:g}", (p[tk], p["rel_rmse_lit"]), fontsize=7,
                            xytext=(-4, 7 if i % 2 else -11), textcoords="offset points", color="C3")
        x0 = ax.get_xlim()[0]
        ax.axhline(0.03, color="k", ls="--", lw=0.8)
        ax.text(x0 * 1.1, 0.031, "3%", fontsize=8)
        ax.axhline(0.01, color="grey", ls=":", lw=0.8)
        ax.text(x0 * 1.1, 0.0103, "1%", fontsize=8, color="grey")
        nr = s["reference"].get("est_noise_rel_rmse_lit")
        if nr:
            ax.axhline(nr, color="C2", ls="-.", lw=0.8)
            ax.text(x0 * 1.1, nr * 1.05, f"reference's own noise {nr * 100:.2f}%", fontsize=7, color="C2")
        if kind == "wall":
            ax.set_xlabel(f"wall seconds ({s['machine']['cpus']} CPU cores, shared with other work)")
        else:
            ax.set_xlabel("CPU seconds (user + system, all threads)")
        ax.set_ylabel("relative RMSE over lit surfaces (vs reference)")
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7)
    w, h = s["size"]
    fig.suptitle(f"{os.path.basename(s['scene'])} {w}x{h}: image error against time "
                 f"(reference: Mitsuba 3, {s['reference']['spp']} spp)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    log(f"wrote {path}")


if __name__ == "__main__":
    main()
