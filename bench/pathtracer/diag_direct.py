#!/usr/bin/env python3
"""Diagnostic: direct lighting only, vkrad against Mitsuba.

Mitsuba: path integrator with max_depth=2 (camera ray + one bounce to the
emitters). vkrad: `--max-shots N --no-ambient`, N = the number of emitter
elements, so that only the emitters have shot (they carry by far the most
unshot power, so they shoot first; the script checks the shot count).
Errors use compare.py's metric and masks.

    python3 diag_direct.py --scene cornell --light-elements 16 [--spp 4096] [--vkrad-args="--ff raytrace"]
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.argv_saved = list(sys.argv)
import compare as C  # noqa: E402  (sets DRJIT_LIBLLVM_PATH, imports mitsuba)

np = C.np
mi = C.mi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--vkrad", default=os.path.join(C.REPO, "target", "release", "vkrad"))
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--light-elements", type=int, required=True,
                    help="emitter elements in vkrad's mesh (`vkrad mesh SCENE -o m.obj`)")
    ap.add_argument("--vkrad-args", default="")
    ap.add_argument("--bounces", type=int, default=0,
                    help="indirect bounces in the reference (Mitsuba max_depth = 2 + BOUNCES); "
                         "1 judges vkrad's final gather from the first-bounce element solution")
    ap.add_argument("--out", default=os.path.join(C.HERE, "out"))
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    C.set_variant("llvm_ad_rgb")
    obj_path, name = C.resolve_scene(a.scene)
    obj = C.parse_obj(obj_path)
    cam = obj["camera"]
    scene, d = C.build_scene(obj, cam, (w, h))
    d["integrator"] = {"type": "path", "max_depth": 2 + a.bounces, "hide_emitters": False}
    scene = mi.load_dict(d)
    ref_path = os.path.join(a.out, f"{name}-direct-ref-{a.spp}" + (f"-b{a.bounces}" if a.bounces else "") + ".exr")
    if os.path.exists(ref_path):
        ref = C.read_exr(ref_path)
    else:
        t = time.perf_counter()
        ha = C.render_spp(scene, a.spp // 2, seed=11)
        hb = C.render_spp(scene, a.spp // 2, seed=12)
        ref = 0.5 * (ha + hb)
        C.write_exr(ref_path, ref)
        z = np.load(os.path.join(a.out, f"{name}-{w}x{h}-masks.npz"))
        lum = ref.mean(axis=2)
        lit = (lum > 0.01 * lum.mean()) & ~z["sees_emitter"]
        print(f"direct-only reference {a.spp} spp: {time.perf_counter() - t:.1f}s, "
              f"est. noise {C.rel_rmse(ha, hb, lit) / 2 * 100:.3f}%")
    z = np.load(os.path.join(a.out, f"{name}-{w}x{h}-masks.npz"))
    lum = ref.mean(axis=2)
    lit = (lum > 0.01 * lum.mean()) & ~z["sees_emitter"]
    interior = lit & z["interior"]
    tag = a.vkrad_args.replace("-", "").replace(" ", "_") + (f"_b{a.bounces}" if a.bounces else "")
    out = os.path.join(a.out, f"{name}-direct-vkrad{('-' + tag) if tag else ''}.exr")
    rep = out[:-4] + ".json"
    cmd = [a.vkrad, obj_path, "-o", out, "--size", f"{w}x{h}", "--max-shots", str(a.light_elements),
           "--converge", "1e-9", "--no-ambient", "--report", rep, "-q"] + a.vkrad_args.split()
    t = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t
    with open(rep) as fh:
        shots = json.load(fh)["solve"]["shots"]
    x = C.read_exr(out)
    print(f"vkrad direct-only ({' '.join(cmd[1:])}): {shots} shots, {wall:.1f}s")
    print(f"  rel RMSE lit {C.rel_rmse(x, ref, lit) * 100:.2f}%  interior {C.rel_rmse(x, ref, interior) * 100:.2f}%"
          f"  bias lit {C.mean_bias(x, ref, lit) * 100:+.2f}%  interior {C.mean_bias(x, ref, interior) * 100:+.2f}%")
    C.diff_figure(ref, x, lit, out[:-4] + "-diff.png", "vkrad direct only " + a.vkrad_args)


if __name__ == "__main__":
    main()
