#!/usr/bin/env python3
"""Peak memory against vkrad's own estimate, on a corpus of scenes.

Runs `vkrad SCENE --size 256x256 --report R.json` on every scene of the
corpus, one at a time, and reads from each report the estimate vkrad made
before any work (`memory.estimate_bytes`, with its parts) and the peak
resident set the process reached (`memory.peak_bytes`, Linux VmHWM).
Writes bench/memory.json and prints a Markdown table; exits 1 when a
peak is above its estimate (the estimate is meant as an upper bound).

    cargo build --release
    python3 bench/memory.py                    # the whole corpus (about 10 min on 2 cores)
    python3 bench/memory.py cornell rfield     # some of it, by name
    python3 bench/memory.py --large            # add the 95k to 204k-polygon scenes
    python3 bench/memory.py --interiors        # add the dining halls (10k to 200k faces, 1 to 400 lights)
    python3 bench/memory.py --interiors --limit-gb 4 --timeout 600 --out bench/memory-4gb.json \
        interior-10k-1 interior-10k-16 interior-50k-64 interior-200k-400
                                               # as a capped container would run them (RLIMIT_AS)

A run ends with an image, or with a clean error (exit status 1 and a
message), within --timeout; anything else (a signal, a panic, the
timeout) is recorded as `outcome` and fails the bench.

The corpus: the built-in scenes, scenes/*.obj, the public scenes under
../shared/scenes (when present), and generated letter fields and curved
surfaces (`field-N`: N letters R; `surfaces-Nk`: a terrain, a sphere and
a torus of about N thousand triangles) from `scenes/generate_scenes.py
--scaling` (made in a temporary folder).

A run's gather points are the points the final gather traced rays from:
the element centres (once: the later Jacobi passes reuse their links;
the small elements of a smooth surface share one, `centres_gathered`),
then either the display vertices or, when the image is gathered at its
pixels, the pixels' reflected points that were not taken from the centres
(`reflected_reuse.gathered`). The pixels' direct-light points are
recorded beside them (`direct_points`) but not counted: they trace only
to the emitters.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes")


def corpus(scaling_dir, large, interiors_dir=None):
    scenes = [
        ("cornell", "cornell"),
        ("simple", "simple"),
        ("r", "r"),
        ("vise", "vise"),
        ("rfield", "rfield"),
        ("curved", os.path.join(ROOT, "scenes", "curved.obj")),
        ("aliasing", os.path.join(ROOT, "scenes", "aliasing.obj")),
        ("grazing", os.path.join(ROOT, "scenes", "grazing.obj")),
        ("nearfield", os.path.join(ROOT, "scenes", "nearfield.obj")),
        ("CornellBox-Original", os.path.join(SHARED, "mcguire", "CornellBox-Original.obj")),
        ("CornellBox-Sphere", os.path.join(SHARED, "mcguire", "CornellBox-Sphere.obj")),
        ("field-12", os.path.join(scaling_dir, "rfield-12.obj")),
        ("field-50", os.path.join(scaling_dir, "rfield-50.obj")),
        ("surfaces-2k", os.path.join(scaling_dir, "surfaces-2k.obj")),
        ("surfaces-8k", os.path.join(scaling_dir, "surfaces-8k.obj")),
        ("surfaces-32k", os.path.join(scaling_dir, "surfaces-32k.obj")),
    ]
    if large:
        for name in ("rfield-700", "rfield-1500", "surfaces-100k", "surfaces-200k"):
            scenes.append((name.replace("rfield-", "field-"), os.path.join(scaling_dir, name + ".obj")))
    if interiors_dir:
        for name in ("interior-10k-1", "interior-10k-16", "interior-50k-64", "interior-200k-400"):
            scenes.append((name, os.path.join(interiors_dir, name + ".obj")))
    return scenes


def gather_points(r):
    """The points the final gather traced from (see the module text)."""
    # The centres traced (small elements of a smooth surface share one);
    # reports before `centres_gathered` traced every element's.
    centres = r.get("centres_gathered", r["mesh"]["elements"] if r.get("gather_passes") else 0)
    pixels = (r.get("image_gathered_at") or {}).get("pixels")
    if pixels:
        reuse = r.get("reflected_reuse") or {}
        return centres + reuse.get("gathered", pixels["reflected_points"])
    return centres + ((r.get("display_mesh") or {}).get("vertices") or r["mesh"]["vertices"])


def capped(limit_gb):
    """A preexec_fn capping the child's address space (None: no cap)."""
    if not limit_gb:
        return None
    import resource

    def cap():
        b = int(limit_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (b, b))

    return cap


def run(vkrad, name, scene, out_dir, limit_gb=None, timeout=None):
    report = os.path.join(out_dir, f"{name}.json")
    image = os.path.join(out_dir, f"{name}.exr")
    t = time.time()
    try:
        p = subprocess.run(
            [vkrad, scene, "--size", "256x256", "-o", image, "--report", report, "--quiet"],
            capture_output=True,
            text=True,
            preexec_fn=capped(limit_gb),
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return {"scene": name, "outcome": f"timeout after {timeout} s", "error": ["timed out"]}
    wall = time.time() - t
    if p.returncode != 0:
        lines = (p.stderr or p.stdout).strip().splitlines()
        panicked = any("panicked" in ln for ln in lines)
        clean = p.returncode == 1 and not panicked
        outcome = "clean error" if clean else (
            "panic" if panicked else f"status {p.returncode}" if p.returncode > 0 else f"signal {-p.returncode}")
        return {"scene": name, "outcome": outcome, "wall_s": round(wall, 2), "error": lines[-1:]}
    r = json.load(open(report))
    m = r["memory"]
    return {
        "scene": name,
        "outcome": "image",
        "warnings": r["scene"].get("run_warnings"),
        "patches": r["scene"]["patches"],
        "elements": r["mesh"]["elements"],
        "display_elements": (r.get("display_mesh") or {}).get("elements"),
        "estimated_display_elements": m["estimate_elements"]["display"],
        "wall_s": round(wall, 2),
        "gather_s": r["timing"]["wall_s"].get("gather"),
        "display_vertices": (r.get("display_mesh") or {}).get("vertices"),
        "gather_passes": r.get("gather_passes"),
        "gather_points": gather_points(r),
        "direct_points": ((r.get("image_gathered_at") or {}).get("pixels") or {}).get("direct_points"),
        "peak_bytes": m["peak_bytes"],
        "estimate_bytes": m["estimate_bytes"],
        "estimate_parts": m["estimate_parts"],
        "peak_bytes_after": m["peak_bytes_after"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", help="scenes of the corpus to run (default: all)")
    ap.add_argument("--vkrad", default=os.path.join(ROOT, "target", "release", "vkrad"))
    ap.add_argument("--large", action="store_true", help="add the 95k to 204k-polygon fields and surfaces")
    ap.add_argument("--interiors", action="store_true", help="add the dining halls of generate_scenes.py --interiors")
    ap.add_argument("--out", default=os.path.join(HERE, "memory.json"))
    ap.add_argument("--limit-gb", type=float, help="cap each run's address space (RLIMIT_AS), as ulimit -v does")
    ap.add_argument("--timeout", type=float, help="seconds a run may take (past it: a failure)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vkrad-memory-") as tmp:
        scaling = os.path.join(tmp, "scaling")
        subprocess.run(
            [sys.executable, os.path.join(ROOT, "scenes", "generate_scenes.py"), "--scaling", scaling],
            check=True,
            capture_output=True,
        )
        interiors = None
        if a.interiors:
            interiors = os.path.join(tmp, "interiors")
            subprocess.run(
                [sys.executable, os.path.join(ROOT, "scenes", "generate_scenes.py"), "--interiors", interiors],
                check=True,
                capture_output=True,
            )
        rows = []
        for name, scene in corpus(scaling, a.large, interiors):
            if a.names and name not in a.names:
                continue
            if os.path.sep in scene and not os.path.exists(scene):
                print(f"skipped {name}: {scene} not found", file=sys.stderr)
                continue
            row = run(a.vkrad, name, scene, tmp, a.limit_gb, a.timeout)
            print(json.dumps({k: row.get(k) for k in ("scene", "outcome", "wall_s", "peak_bytes", "estimate_bytes",
                                                      "error")}), file=sys.stderr)
            rows.append(row)
    json.dump({"vkrad": a.vkrad, "size": "256x256", "limit_gb": a.limit_gb, "timeout_s": a.timeout,
               "command": "python3 bench/memory.py " + " ".join(sys.argv[1:]), "runs": rows},
              open(a.out, "w"), indent=1)
    mb = lambda b: f"{b / 2**20:.0f}"
    print("| scene | polygons | elements solved / shown (estimated shown) | wall | peak RSS | estimate | peak / estimate |")
    print("|---|---|---|---|---|---|---|")
    over = []
    for r in rows:
        if "error" in r:
            print(f"| {r['scene']} | {r['outcome']}: {r['error']} |")
            if r["outcome"] != "clean error":
                over.append(r["scene"])
            continue
        ratio = r["peak_bytes"] / r["estimate_bytes"]
        if ratio > 1:
            over.append(r["scene"])
        shown = (
            f"{r['display_elements']:,} ({r['estimated_display_elements'] or 0:,})"
            if r["display_elements"]
            else "at the pixels"
        )
        print(
            f"| {r['scene']} | {r['patches']:,} | {r['elements']:,} / {shown} | {r['wall_s']:.1f} s "
            f"| {mb(r['peak_bytes'])} MB | {mb(r['estimate_bytes'])} MB | {ratio:.2f} |"
        )
    if over:
        print(f"over the estimate or failed: {', '.join(over)}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
