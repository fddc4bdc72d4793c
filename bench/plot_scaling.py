#!/usr/bin/env python3
"""Draws bench/scaling.png from bench/scaling.json (cargo bench --bench
scaling): solve seconds against element count, log-log, one line per
solver, with the growth exponent fitted by least squares on log-log
(over the meshes of at least 2,000 elements, where set-up no longer
dominates)."""
import json, math, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))
doc = json.load(open(sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "scaling.json")))
fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
fits = {}
for solver, colour in [("element", "tab:red"), ("hierarchical", "tab:blue")]:
    runs = sorted((r for r in doc["runs"] if r["solver"] == solver), key=lambda r: r["elements"])
    if not runs:
        continue
    n = [r["elements"] for r in runs]
    t = [r["seconds"] for r in runs]
    pts = [(math.log(a), math.log(b)) for a, b in zip(n, t) if a >= 2000]
    slope = None
    if len(pts) >= 2:
        mx = sum(p[0] for p in pts) / len(pts)
        my = sum(p[1] for p in pts) / len(pts)
        slope = sum((x - mx) * (y - my) for x, y in pts) / sum((x - mx) ** 2 for x, _ in pts)
        fits[solver] = slope
    label = solver + ("" if slope is None else f"  (time ~ n^{slope:.2f})")
    ax.loglog(n, t, "o-", color=colour, label=label)
    for a, b, r in zip(n, t, runs):
        note = f"{r['shots']} shots"
        if r.get("vs_element_rel_rms") is not None:
            note += f", {100 * r['vs_element_rel_rms']:.1f}% from element"
        ax.annotate(note, (a, b), textcoords="offset points", xytext=(5, -12), fontsize=7, color=colour)
ax.set_xlabel("elements")
ax.set_ylabel("solve wall seconds")
ax.set_title(f"Cornell box, converge {doc['converge']:g}, {doc['device']}")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
fig.tight_layout()
out = os.path.join(here, "scaling.png")
fig.savefig(out)
doc["fitted_exponent"] = fits
path = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "scaling.json")
json.dump(doc, open(path, "w"), indent=2)
print("wrote", out, "fits:", fits)
