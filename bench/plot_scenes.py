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
    fields = [r for r in rows if r["scene"] in ("field-12", "field-50", "rfield", "field-700")]
    out = {"runs": rows}
    if len(fields) >= 2:
        xs = [r["patches"] for r in fields]
        out["fit_wall"] = fit(xs, [r["wall_s"] for r in fields])[0]
        out["fit_gather_per_point"] = fit(xs, [r["gather_ms_per_point"] for r in fields])[0]
        out["fit_peak"] = fit(xs, [r["peak_bytes"] for r in fields])[0]
    json.dump(out, open(os.path.join(HERE, "scenes.json"), "w"), indent=1)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    panels = [
        ("wall_s", "whole command, seconds", "fit_wall"),
        ("gather_ms_per_point", "gather CPU ms per point (2 cores)", "fit_gather_per_point"),
        ("peak_bytes", "peak resident memory, bytes", "fit_peak"),
    ]
    for ax, (key, label, fitkey) in zip(axes, panels):
        for r in rows:
            field = r in fields
            ax.loglog(r["patches"], r[key], "o" if field else "s", color="C0" if field else "C1")
            ax.annotate(r["scene"], (r["patches"], r[key]), fontsize=7, xytext=(3, 3), textcoords="offset points")
        if fitkey in out:
            xs = [r["patches"] for r in fields]
            slope, icpt = fit(xs, [r[key] for r in fields])
            lo, hi = min(xs), max(xs)
            ax.loglog([lo, hi], [math.exp(icpt) * lo ** slope, math.exp(icpt) * hi ** slope], "--", color="C0",
                      label=f"letter fields: polygons^{slope:.2f}")
            ax.legend(fontsize=8)
        ax.set_xlabel("input polygons")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("vkrad at its defaults, 256x256, lavapipe on 2 cores (blue: letter fields; orange: other scenes)")
    plt.tight_layout()
    plt.savefig(os.path.join(HERE, "scenes.png"), dpi=80)
    print(json.dumps({k: v for k, v in out.items() if k.startswith("fit")}))


if __name__ == "__main__":
    main()
