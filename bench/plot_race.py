#!/usr/bin/env python3
"""Draws bench/race-cornell.png and bench/race-cornell.json: image error
against wall seconds for the path tracer (Mitsuba 3) and for vkrad, from
the runs of bench/pathtracer/compare.py:

- out/race-cornell.json: the path-tracer curve (a full run);
- out/race-cornell-final.json: vkrad at its defaults (final gather on a
  discontinuity display mesh), `compare.py --skip-race --tag=-final`;
- out/race-cornell-hierarchical.json, out/race-cornell-element.json: vkrad
  before the final gather (element-averaged vertex values, 2x2 SSAA), both
  solvers, kept from the run that measured them."""
import json, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "pathtracer", "out")
race = json.load(open(os.path.join(out, "race-cornell.json")))
final = json.load(open(os.path.join(out, "race-cornell-final.json")))
hier = json.load(open(os.path.join(out, "race-cornell-hierarchical.json")))
elem = json.load(open(os.path.join(out, "race-cornell-element.json")))
fig, ax = plt.subplots(figsize=(7.5, 5), dpi=110)
pt = race["pathtracer"]
ax.loglog([p["cold_total_s"] for p in pt], [p["rel_rmse_lit"] for p in pt], "o-", color="black",
          label="path tracer (Mitsuba 3 llvm, whole command)")
for name, doc, colour, stops in [
        ("vkrad before: element-by-element", elem, "tab:red", "--converge 1e-1 .. 1e-3"),
        ("vkrad before: hierarchical", hier, "tab:orange", "--converge 1e-1 .. 1e-3"),
        ("vkrad now: final gather, 8 passes, display refinement", final, "tab:blue", "default stop, --converge 1e-1, 1e-2")]:
    runs = sorted(doc["vkrad"], key=lambda r: r["wall_s"])
    ax.loglog([r["wall_s"] for r in runs], [r["rel_rmse_lit"] for r in runs], "s-", color=colour,
              label=f"{name} (whole command, {stops})")
ax.axhline(0.03, color="grey", ls="--", lw=1)
ax.text(ax.get_xlim()[0] * 1.2, 0.031, "3%", color="grey")
ax.set_xlabel("wall seconds (2 cores, lavapipe for vkrad)")
ax.set_ylabel("relative RMSE over lit pixels")
ax.set_title("Cornell box 256x256 against a 65,536-spp reference")
ax.grid(True, which="both", alpha=0.3)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(os.path.join(here, "race-cornell.png"))
summary = {
    "reference": race["reference"],
    "metric": race["metric"],
    "pathtracer": pt,
    "pathtracer_seconds_to_3%": race["pt_cold_s_to_0.03"],
    "pathtracer_seconds_to_1%": race["pt_cold_s_to_0.01"],
    "vkrad_seconds_to_3%": final["vkrad_s_to_0.03"],
    "vkrad": final["vkrad"],
    "vkrad_before_element": elem["vkrad"],
    "vkrad_before_hierarchical": hier["vkrad"],
    "machine": race["machine"],
}
json.dump(summary, open(os.path.join(here, "race-cornell.json"), "w"), indent=1)
print("wrote race-cornell.png/.json")
