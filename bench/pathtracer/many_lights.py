#!/usr/bin/env python3
"""Many lights: the gather's cost against the number of luminaires, at
the error a path tracer judges. Outside CI (needs setup.sh).

    python3 many_lights.py                       # 1, 24, 100, 400 luminaires, 128x128
    python3 many_lights.py --lights 1,24 --repeats 1

Scenes: one open-plan office (desks, partitions) lit by N ceiling panels
of equal total power (`scenes/generate_scenes.py --offices`), written to
out/offices/. References: Mitsuba 3 at --ref-spp (compare.py, cached),
made by no vkrad method. vkrad runs each scene at its defaults and with
`--tune exact_lights=all` (every light with its own shadow rays, as
before the many-lights gather), --repeats times each, one after the
other on an idle machine; the wall time of the whole command and the
gather stage (from --report) are medians. Error: compare.py's relative
RMSE over the lit pixels of vkrad's .exr, also less the reference's own
noise (estimated from its two independent halves) in quadrature: many
small panels keep a path tracer noisy.

Writes ../many-lights.json and ../many-lights.png; `python3
../results.py` puts them in RESULTS.md.
"""

import argparse
import datetime
import json
import math
import os
import statistics
import subprocess
import sys
import time

import compare as C  # sets up Mitsuba (LLVM variant when it loads)
import score as S

HERE = C.HERE
REPO = os.path.dirname(os.path.dirname(HERE))
OFFICES = os.path.join(HERE, "out", "offices")
VARIANTS = [("default", []), ("exact_lights=all", ["--tune", "exact_lights=all"])]


def ensure_scenes(lights):
    missing = [n for n in lights if not os.path.exists(os.path.join(OFFICES, f"office-{n}.obj"))]
    if missing:
        subprocess.run([sys.executable, os.path.join(REPO, "scenes", "generate_scenes.py"),
                        "--offices", OFFICES], check=True)
    for n in lights:
        if not os.path.exists(os.path.join(OFFICES, f"office-{n}.obj")):
            sys.exit(f"generate_scenes.py --offices wrote no office-{n}.obj (it makes 1, 24, 100, 400)")


def ensure_reference(scene, size, spp):
    """compare.py's reference and masks for `scene` (cached by it)."""
    subprocess.run([sys.executable, os.path.join(HERE, "compare.py"), "--scene", scene, "--size", size,
                    "--ref-spp", str(spp), "--skip-vkrad", "--skip-race"], check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(HERE, "out", os.path.basename(scene)[:-4] + "-ref.json")) as fh:
        return json.load(fh)


def run_vkrad(vkrad, scene, size, extra, image, report):
    cmd = [vkrad, scene, "--size", size, "-o", image, "--report", report, *extra]
    t = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    with open(report) as fh:
        rep = json.load(fh)
    return wall, rep


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vkrad", default=os.path.join(REPO, "target", "release", "vkrad"))
    ap.add_argument("--lights", default="1,24,100,400")
    ap.add_argument("--size", default="128x128")
    ap.add_argument("--ref-spp", type=int, default=8192)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    lights = [int(n) for n in a.lights.split(",")]
    ensure_scenes(lights)
    work = os.path.join(HERE, "out", "many-lights")
    os.makedirs(work, exist_ok=True)
    rows = []
    for n in lights:
        scene = os.path.join(OFFICES, f"office-{n}.obj")
        ref = ensure_reference(scene, a.size, a.ref_spp)
        row = {"luminaires": n, "reference": {"spp": ref["spp"], "seconds": ref["seconds"],
                                              "noise_rel_rmse_lit": ref["est_noise_rel_rmse_lit"]}}
        runs = {name: [] for name, _ in VARIANTS}
        # The variants alternate, so that a change in the machine's load
        # falls on both.
        for r in range(a.repeats):
            for name, extra in VARIANTS:
                tag = name.replace("=", "-")
                image = os.path.join(work, f"office-{n}-{tag}.exr")
                report = os.path.join(work, f"office-{n}-{tag}-{r}.json")
                wall, rep = run_vkrad(a.vkrad, scene, a.size, extra, image, report)
                stages = rep["timing"]["wall_s"]
                runs[name].append({"wall_s": wall, "gather_s": stages.get("gather"), "solve_s": stages.get("solve"),
                                   "shots": rep["solve"]["shots"]})
                print(f"office-{n} {name} run {r}: {wall:.1f} s, gather {stages.get('gather')}", flush=True)
        for name, _ in VARIANTS:
            image = os.path.join(work, f"office-{n}-{name.replace('=', '-')}.exr")
            err = S.score(f"office-{n}", image, a.size)
            got = runs[name]
            row[name] = {
                "wall_s": statistics.median(x["wall_s"] for x in got),
                "gather_s": statistics.median(x["gather_s"] for x in got),
                "solve_s": statistics.median(x["solve_s"] for x in got),
                "shots": got[0]["shots"],
                "rel_rmse_lit": err["rel_rmse_lit"],
                # less the reference's own noise (in quadrature)
                "rel_rmse_lit_corrected": math.sqrt(max(err["rel_rmse_lit"] ** 2
                                                        - ref["est_noise_rel_rmse_lit"] ** 2, 0.0)),
                "bias_lit": err["bias_lit"],
                "runs": got,
            }
            print(f"office-{n} {name}: error {err['rel_rmse_lit'] * 100:.2f}%", flush=True)
        rows.append(row)
    # gather ~ N^k: the least-squares slope of log gather on log N
    def exponent(name):
        pts = [(math.log(r["luminaires"]), math.log(r[name]["gather_s"])) for r in rows
               if r["luminaires"] > 0 and r[name]["gather_s"]]
        if len(pts) < 2:
            return None
        mx, my = (sum(p[i] for p in pts) / len(pts) for i in (0, 1))
        sxx = sum((p[0] - mx) ** 2 for p in pts)
        return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx > 0 else None

    out = {
        "what": "gather time and image error against the number of ceiling luminaires (equal total power), "
                "vkrad at its defaults and with every light given its own shadow rays",
        "command": "cd bench/pathtracer && python3 many_lights.py " + " ".join(sys.argv[1:]),
        "date": datetime.date.today().isoformat(),
        "cores": os.cpu_count(),
        "size": a.size,
        "repeats": a.repeats,
        "rows": rows,
        "gather_exponent": {name: exponent(name) for name, _ in VARIANTS},
    }
    path = os.path.join(REPO, "bench", "many-lights.json")
    with open(path, "w") as fh:
        json.dump(out, fh, indent=2)
    chart(out, os.path.join(REPO, "bench", "many-lights.png"))
    print(f"wrote {path}")


def chart(out, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = out["rows"]
    n = [r["luminaires"] for r in rows]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    for name, _ in VARIANTS:
        ax.plot(n, [r[name]["gather_s"] for r in rows], "o-", label=f"gather, {name}")
        bx.plot(n, [100 * r[name]["rel_rmse_lit_corrected"] for r in rows], "o-", label=name)
    g1 = rows[0]["default"]["gather_s"]
    ax.plot(n, [g1 * (k / n[0]) ** 0.5 for k in n], "k:", label="first point x sqrt(N)")
    ax.set_xscale("log"), ax.set_yscale("log")
    ax.set_xlabel("ceiling luminaires"), ax.set_ylabel("gather seconds")
    ax.legend(fontsize=8)
    bx.set_xscale("log")
    bx.set_xlabel("ceiling luminaires"), bx.set_ylabel("rel. RMSE vs Mitsuba 3, lit pixels,\nless the reference's noise (%)")
    bx.set_ylim(bottom=0)
    bx.legend(fontsize=8)
    runs = "single runs" if out["repeats"] == 1 else f"median of {out['repeats']}"
    fig.suptitle(f"open-plan office, {out['size']}, {out['cores']} cores, {runs}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
