#!/usr/bin/env python3
"""Whole-run time and the final gather's cost per point against input
polygons, from bench/memory.py's runs (bench/memory.json, or the files
given), with the power law fitted to each: bench/scenes.png (+ .json).

    python3 bench/memory.py --large && python3 bench/plot_scenes.py
"""
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def fit(xs, ys):
    """Least-squares slope and intercept of log y against log x."""
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    n = len(lx)
    mx, my = sum(lx) / n, sum(ly) / n
    sxx = sum((a - mx) ** 2 for a in lx)
    slope = sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sxx
    return slope, my - slope * mx


def main():
    paths = sys.argv[1:] or [os.path.join(HERE, "memory.json")]
    runs = {}
    for p in paths:
        for r in json.load(open(p))["runs"]:
            if "error" not in r and r.get("gather_s"):
                runs[r["scene"]] = r
    rows = sorted(runs.values(), key=lambda r: r["patches"])
    for r in rows:
        r["gather_ms_per_point"] = 1000 * 2 * r["gather_s"] / r["gather_points"]  # CPU ms: 2 cores
    # The two generated families the growth is fitted over, and their colours.
    families = {
        "letter fields": ([r for r in rows if r["scene"] == "rfield" or r["scene"].startswith("field-")], "C0"),
        "curved surfaces": ([r for r in rows if r["scene"].startswith("surfaces-")], "C2"),
    }
    keys = {"wall": "wall_s", "gather_per_point": "gather_ms_per_point", "peak": "peak_bytes"}
    out = {"runs": rows, "fits": {}}
    for family, (members, _) in families.items():
        if len(members) >= 2:
            xs = [r["patches"] for r in members]
            out["fits"][family] = {
                "polygons": [min(xs), max(xs)],
                **{name: round(fit(xs, [r[key] for r in members])[0], 3) for name, key in keys.items()},
            }
    json.dump(out, open(os.path.join(HERE, "scenes.json"), "w"), indent=1)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    panels = [
        ("wall_s", "whole command, seconds"),
        ("gather_ms_per_point", "gather CPU ms per traced point (2 cores)"),
        ("peak_bytes", "peak resident memory, bytes"),
    ]
    colour = {r["scene"]: c for members, c in families.values() for r in members}
    for ax, (key, label) in zip(axes, panels):
        for r in rows:
            c = colour.get(r["scene"], "C1")
            ax.loglog(r["patches"], r[key], "s" if c == "C1" else "o", color=c)
            ax.annotate(r["scene"], (r["patches"], r[key]), fontsize=7, xytext=(3, 3), textcoords="offset points")
        for family, (members, c) in families.items():
            if len(members) < 2:
                continue
            xs = [r["patches"] for r in members]
            slope, icpt = fit(xs, [r[key] for r in members])
            lo, hi = min(xs), max(xs)
            ax.loglog([lo, hi], [math.exp(icpt) * lo ** slope, math.exp(icpt) * hi ** slope], "--", color=c,
                      label=f"{family}: polygons^{slope:.2f}")
        ax.legend(fontsize=8)
        ax.set_xlabel("input polygons")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("vkrad at its defaults, 256x256, lavapipe on 2 cores (blue: letter fields; green: curved surfaces; orange: other scenes)")
    plt.tight_layout()
    plt.savefig(os.path.join(HERE, "scenes.png"), dpi=80)
    print(json.dumps(out["fits"]))


if __name__ == "__main__":
    main()
