#!/usr/bin/env python3
"""Writes bench/RESULTS.md, every measurement vkrad's documents quote,
from the committed bench/*.json (and bench/h200/*.json):

    python3 bench/results.py                  # bench/RESULTS.md
    python3 bench/results.py --gallery-table  # print the README's gallery table

Python 3 standard library only. Each section names the file it reads, the
command that makes that file and the date of its last commit (git log; a
date recorded in the file itself wins). Missing files and fields are
skipped, not fatal.
"""
import glob
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OUT = os.path.join(HERE, "RESULTS.md")
MiB = 1 << 20
# Absolute prefixes the runs recorded, shown relative to the repository.
RECORDED_ROOTS = ["/work/main/", ROOT + "/"]

# Commands for the files that do not record how they were made; the second
# element says where the command comes from.
COMMANDS = {
    "gallery.json": ("python3 bench/gallery.py", "bench/gallery.py; needs bench/pathtracer's references"),
    "memory.json": ("python3 bench/memory.py --large", "bench/memory.py"),
    "scenes.json": ("python3 bench/memory.py --large && python3 bench/plot_scenes.py", "bench/plot_scenes.py"),
    "scaling.json": ("cargo bench --bench scaling && python3 bench/plot_scaling.py", "benches/scaling.rs"),
    "gather_cost.json": ("cargo bench --bench gather_cost -- [SCENE...]", "benches/gather_cost.rs"),
    "bench.json": ("cargo run --release -- bench", "src/bench, the `vkrad bench` subcommand"),
    "meshers.json": ("cargo run --release -- bench --meshers", "src/bench, the `vkrad bench` subcommand"),
    "lightmap.json": ("python3 bench/lightmap.py", "bench/lightmap.py; needs chromium and npm ci in tools/lightmap"),
    "lightmap-blender.json": (
        "python3 scenes/generate_scenes.py --textured /tmp/vkrad-textured && python3 bench/lightmap_blender.py "
        "--scenes cornell,/tmp/vkrad-textured/cornell-checker.obj,rfield",
        "bench/lightmap_blender.py; needs apt-get install blender python3-numpy"),
    "many-lights.json": ("cd bench/pathtracer && python3 many_lights.py", "bench/pathtracer/many_lights.py"),
    "race-cornell.json": (
        "cd bench/pathtracer && python3 compare.py && python3 compare.py --skip-race --tag=-final "
        "--converge default,1e-1,1e-2 && cd ../.. && python3 bench/plot_race.py",
        "bench/plot_race.py"),
    "h200/memory-h200.json": (
        "python3 bench/memory.py --large --vkrad $V --out $OUT/memory-h200.json",
        "bench/h200/gpu_run.sh"),
    "h200/race-rfield.json": (
        "cd bench/pathtracer && python3 compare.py --scene rfield --vkrad $V --size 256x256 --ref-spp 4096 "
        "--converge default --variant cuda_ad_rgb --target 0.02 --max-spp 4096",
        "bench/h200/gpu_run2.sh"),
    "h200/race-cornell.json": (
        "cd bench/pathtracer && python3 compare.py --scene cornell --vkrad $V --size 256x256 --ref-spp 65536 "
        "--converge default --variant cuda_ad_rgb --target 0.015 --max-spp 8192",
        "bench/h200/gpu_run2.sh"),
}

# Charts with no JSON of their own.
CAPTIONS = {
    "curved.png": "a tessellated sphere and torus (`scenes/curved.obj`) without and with the final gather",
    "trace/cornell.png": "`vkrad cornell`'s `--trace` timeline in Chromium DevTools (`bench/trace/view.py`)",
    "trace/cornell-gather.png": "the same timeline, its final gather",
    "trace/rfield.png": "`rfield`'s `--trace` timeline in Chromium DevTools",
}


# ---------------------------------------------------------------- helpers

def load(rel):
    path = os.path.join(HERE, rel)
    try:
        with open(path) as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as e:
        print(f"results.py: skipping {rel}: {e}", file=sys.stderr)
        return None
    if not isinstance(doc, dict):
        print(f"results.py: skipping {rel}: not a JSON object", file=sys.stderr)
        return None
    return doc


def dicts(x):
    """The objects of a JSON list (anything else: none)."""
    return [r for r in x if isinstance(r, dict)] if isinstance(x, list) else []


def git_date(rel):
    path = os.path.join("bench", rel)
    try:
        dirty = subprocess.run(["git", "status", "--porcelain", "--", path], cwd=ROOT,
                               capture_output=True, text=True, timeout=30).stdout.strip()
        date = subprocess.run(["git", "log", "-1", "--format=%cs", "--", path], cwd=ROOT,
                              capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    if dirty:
        return "not committed yet"
    return date or None


def file_date(rel, doc):
    for key in ("date", "when", "generated_at", "timestamp"):
        if isinstance(doc, dict) and isinstance(doc.get(key), str):
            return doc[key]
    return git_date(rel)


def get(d, *keys):
    for k in keys:
        if not isinstance(d, dict) or k not in d:
            return None
        d = d[k]
    return d


def num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def secs(x):
    if not num(x):
        return None
    if x < 10:
        return f"{x:.2f}"
    if x < 100:
        return f"{x:.1f}"
    return f"{x:.0f}"


def pct(x, signed=False):
    if not num(x):
        return None
    return f"{x * 100:+.2f}%" if signed else f"{x * 100:.2f}%"


def mib(b):
    return f"{b / MiB:,.0f}" if num(b) else None


def count(n):
    return f"{n:,}" if isinstance(n, int) and not isinstance(n, bool) else None


def ms(x):
    return f"{x:.3f}" if num(x) else None


def ratio(a, b):
    if not (num(a) and num(b)) or b <= 0:
        return None
    r = a / b
    return f"{r:.2f}x" if r < 10 else f"{r:.1f}x"


def table(headers, rows):
    """A Markdown table; columns empty in every row are left out."""
    rows = [[None if c is None else str(c) for c in r] for r in rows]
    keep = [i for i in range(len(headers)) if any(r[i] not in (None, "") for r in rows)]
    if not rows or not keep:
        return ["(no rows)"]
    out = ["| " + " | ".join(headers[i] for i in keep) + " |",
           "|" + "|".join("---" for _ in keep) + "|"]
    for r in rows:
        out.append("| " + " | ".join("–" if r[i] in (None, "") else r[i] for i in keep) + " |")
    return out


def relpath(p):
    if not isinstance(p, str):
        return p
    for prefix in RECORDED_ROOTS:
        p = p.replace(prefix, "")
    return p.replace("/work/shared/", "../shared/")


def tidy_cmd(cmd, binary):
    if not isinstance(cmd, str):
        return None
    if isinstance(binary, str) and cmd.startswith(binary):
        cmd = "vkrad" + cmd[len(binary):]
    else:
        first, _, rest = cmd.partition(" ")
        if os.path.basename(first).startswith("vkrad"):
            cmd = "vkrad " + rest
    return relpath(cmd)


def header(doc_rel, doc, what, command=None, source=None):
    lines = [what, ""]
    date = file_date(doc_rel, doc)
    lines.append(f"- File: [`bench/{doc_rel}`]({doc_rel}), " + (f"committed {date}." if date else "date unknown."))
    if command:
        lines.append(f"- Command: `{command}`" + (f" (from {source})." if source else "."))
    return lines


def opening(doc_rel, doc, title, what):
    """A section's heading and the header of its JSON file, with the
    command that writes it (`COMMANDS`)."""
    cmd, src = COMMANDS[doc_rel]
    return [f"## {title}", ""] + header(doc_rel, doc, what, cmd, src)


def charts(names, linked):
    out = []
    for n in names:
        if os.path.exists(os.path.join(HERE, n)):
            linked.add(n)
            out.append(f"![{n}]({n})")
    return out


# ------------------------------------------------------ path-tracer races

def time_to(curve, target, tkey):
    """bench/pathtracer/compare.py's time_to: the first time the curve's
    error is <= target, log-log interpolated; None if never reached."""
    pts = [(p.get(tkey), p.get("rel_rmse_lit")) for p in curve]
    pts = [(t, max(e, 1e-12)) for t, e in pts if num(t) and num(e) and t > 0]
    if not num(target) or target <= 0:
        return None
    for i, (t, e) in enumerate(pts):
        if e <= target:
            if i == 0:
                return t
            t0, e0 = pts[i - 1]
            if e == e0:
                return t
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0)))
    return None


def pt_time(curve, target):
    """(warm, cold, extrapolated): the path tracer's time to `target`, or,
    past its last render, that render's time scaled as error^-2."""
    warm, cold = time_to(curve, target, "warm_s"), time_to(curve, target, "cold_total_s")
    if warm is not None or not curve or not num(target) or target <= 0:
        return warm, cold, False
    last = curve[-1]
    e, w, c = last.get("rel_rmse_lit"), last.get("warm_s"), last.get("cold_total_s")
    if not (num(e) and num(w)):
        return None, None, False
    w2 = w * (e / target) ** 2
    c2 = (c - w) + w2 if num(c) else None
    return w2, c2, True


def race_command(rel, doc):
    if rel in COMMANDS:
        return COMMANDS[rel]
    scene = doc.get("scene")
    if not isinstance(scene, str):
        return None, None
    name = os.path.splitext(os.path.basename(scene))[0]
    repo_scene = relpath(scene) == f"scenes/{name}.obj"
    arg = name if repo_scene else relpath(scene)
    if arg.startswith("../"):
        arg = "../../" + arg  # compare.py runs in bench/pathtracer
    parts = ["cd bench/pathtracer && python3 compare.py", f"--scene {arg}"]
    if num(get(doc, "reference", "spp")):
        parts.append(f"--ref-spp {doc['reference']['spp']}")
    size = doc.get("size")
    if isinstance(size, list) and len(size) == 2:
        parts.append(f"--size {size[0]}x{size[1]}")
    convs = [v.get("converge") for v in dicts(doc.get("vkrad"))]
    if convs:
        parts.append("--converge " + ",".join("default" if c is None else f"{c:g}" for c in convs))
    if doc.get("variant") and doc["variant"] != "llvm_ad_rgb":
        parts.append(f"--variant {doc['variant']}")
    targets = []
    for k in doc:
        if k.startswith("pt_warm_s_to_") and not k.endswith("_corrected"):
            try:
                targets.append(float(k[len("pt_warm_s_to_"):]))
            except ValueError:
                pass
    extra = [t for t in targets if t not in (0.03, 0.01)]
    target = extra[0] if extra else 0.01
    if extra:
        parts.append(f"--target {target:g}")
    curve = dicts(doc.get("pathtracer"))
    if curve and num(curve[-1].get("rel_rmse_lit")) and curve[-1]["rel_rmse_lit"] >= target:
        parts.append(f"--max-spp {curve[-1].get('spp')}")  # the race ran out of renders there
    if doc.get("vkrad_args"):
        parts.append(f"--vkrad-args=\"{doc['vkrad_args']}\"")
    if doc.get("tag"):
        parts.append(f"--tag={doc['tag']}")
    cam = doc.get("camera") if isinstance(doc.get("camera"), dict) else {}
    if not repo_scene and cam and not has_camera_line(scene):
        for key, flag in (("eye", "--eye"), ("look_at", "--look-at"), ("up", "--up")):
            v = cam.get(key)
            if isinstance(v, list) and not (key == "up" and v == [0.0, 1.0, 0.0]):
                parts.append(f"{flag} " + ",".join(f"{x:g}" for x in v))
        if num(cam.get("fov")):
            parts.append(f"--fov {cam['fov']:g}")
    cmd = " ".join(parts)
    if scene.startswith("/tmp/"):
        # a generated scene (scenes/generate_scenes.py), not kept
        cmd = f"python3 scenes/generate_scenes.py --scaling {os.path.dirname(scene)} && " + cmd
    return cmd, "the settings recorded in the json"


def has_camera_line(scene):
    """Whether the OBJ names its own camera; a generated scene (in /tmp)
    always does."""
    if scene.startswith("/tmp/"):
        return True
    for path in (scene, os.path.join(os.path.dirname(ROOT), relpath(scene).lstrip("./"))):
        try:
            with open(path, errors="replace") as fh:
                return any(line.startswith("# vkrad camera") for line in fh)
        except OSError:
            pass
    return False


def race_name(rel, doc):
    base = os.path.splitext(os.path.basename(rel))[0][len("race-"):]
    return base


def race_device(rel, doc):
    version = doc.get("mitsuba") or get(doc, "reference", "mitsuba") or "3"
    variant = doc.get("variant") or get(doc, "reference", "variant") or ""
    backend = {"llvm_ad_rgb": "LLVM", "cuda_ad_rgb": "CUDA"}.get(variant, variant)
    cpus = get(doc, "machine", "cpus") or doc.get("threads")
    where = "NVIDIA H200" if rel.startswith("h200/") else "lavapipe"
    return f"vkrad on {where}, Mitsuba {version} {backend}".rstrip() + (f", {cpus} CPUs" if cpus else "")


def race_rows(doc):
    """One row per vkrad run: its figures and the path tracer's to its error."""
    curve = dicts(doc.get("pathtracer"))
    rows, notes = [], False
    for key, label in (("vkrad", None), ("vkrad_before_hierarchical", "before the final gather, hierarchical"),
                       ("vkrad_before_element", "before the final gather, element by element")):
        for v in dicts(doc.get(key)):
            e, wall = v.get("rel_rmse_lit"), v.get("wall_s")
            warm, cold, extra = pt_time(curve, e)
            notes |= extra
            mark = "≈" if extra else ""
            conv = v.get("converge")
            setting = "default" if conv is None else f"--converge {conv:g}"
            if label:
                setting = f"{setting}, {label}"
            rows.append([setting, count(v.get("elements")), count(v.get("shots")), secs(wall), pct(e),
                         pct(v.get("bias_lit"), True), pct(v.get("rel_rmse_lit_corrected")),
                         mark + secs(warm) if warm else None, mark + secs(cold) if cold else None,
                         (mark + ratio(warm, wall)) if ratio(warm, wall) else None,
                         (mark + ratio(cold, wall)) if ratio(cold, wall) else None])
    return rows, notes


RACE_HEADERS = ["vkrad run", "elements", "shots", "wall s", "error", "bias", "error less the reference's noise",
                "path tracer to that error, warm s", "cold s", "path tracer / vkrad, warm", "cold"]
EXTRAPOLATED = ("≈: the path tracer did not reach that error within the race; its time is extrapolated "
                "from its last render as error ∝ 1/√time.")


# --------------------------------------------------------------- sections

def gallery(linked):
    doc = load("gallery.json")
    if not doc:
        return [], []
    lines = opening("gallery.json", doc, "Gallery",
                    f"`vkrad SCENE --size {doc.get('size', '256x256')}` at its defaults, each run timed as the "
                    "whole command (start-up and shader compilation included) on lavapipe, 2 cores; error is the "
                    "relative RMSE over the lit pixels against a Mitsuba 3 path-traced reference with the same "
                    "camera (`bench/pathtracer/`). The path tracer's time to the same error is read off the race "
                    "of the same scene (`race-SCENE.json`, below) by its interpolation.")
    lines.append("")
    rows, readme, extra_any = [], [], False
    for r in dicts(doc.get("runs")):
        scene = r.get("scene")
        race = load(f"race-{scene}.json") if os.path.exists(os.path.join(HERE, f"race-{scene}.json")) else None
        warm = cold = None
        extra = False
        if race and num(r.get("rel_rmse_lit")):
            warm, cold, extra = pt_time(dicts(race.get("pathtracer")), r["rel_rmse_lit"])
        extra_any |= extra and warm is not None
        mark = "≈" if extra else ""
        wall = r.get("wall_s")
        peak, est = r.get("peak_bytes"), r.get("estimate_bytes")
        rows.append([scene, count(r.get("patches")), secs(wall), secs(r.get("gather_s")), mib(peak), mib(est),
                     pct(r.get("rel_rmse_lit")), pct(r.get("bias_lit"), True),
                     mark + secs(warm) if warm else None, mark + secs(cold) if cold else None,
                     (mark + ratio(warm, wall)) if ratio(warm, wall) else None,
                     (mark + ratio(cold, wall)) if ratio(cold, wall) else None])
        readme.append([scene, count(r.get("patches")), f"{secs(wall)} s" if secs(wall) else None,
                       pct(r.get("rel_rmse_lit"))])
    lines += table(["scene", "polygons", "wall s", "gather s", "peak MiB", "estimate MiB", "error", "bias",
                    "path tracer to that error, warm s", "cold s", "path tracer / vkrad, warm", "cold"], rows)
    if extra_any:
        lines += ["", EXTRAPOLATED]
    lines += ["", "The README's gallery table is this table's first columns "
              "(`python3 bench/results.py --gallery-table`).", "", "Commands and provenance:", ""]
    for r in dicts(doc.get("runs")):
        bits = [f"`{r['command']}`" if r.get("command") else None, r.get("provenance")]
        lines.append(f"- {r.get('scene')}: " + "; ".join(str(b) for b in bits if b))
        for w in r.get("warnings") if isinstance(r.get("warnings"), list) else []:
            lines.append(f"  - warning: {relpath(str(w))}")
    lines += [""] + charts(["gallery.png"], linked) + [""]
    readme_table = table(["scene", "polygons", "wall time", "error vs path tracer"], readme)
    return lines, readme_table


def races(linked):
    files = sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "race-*.json"))
                   if not os.path.basename(p).startswith("race-walkthrough"))
    files += sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "h200", "race-*.json")))
    docs = [(rel, load(rel)) for rel in files]
    docs = [(rel, d) for rel, d in docs if isinstance(d, dict)]
    if not docs:
        return []
    lines = ["## Races against the path tracer", "",
             "`bench/pathtracer/compare.py` renders a Mitsuba 3 reference (two independent halves, whose "
             "difference gives its own noise), then the path tracer at powers of two samples per pixel and vkrad "
             "at its defaults, each a whole render on the same machine, and scores each against the reference: "
             "relative RMSE over the lit pixels. Warm is a render in a running process; cold adds a fresh "
             "process's start-up and kernel compilation, comparable with vkrad's whole command. "
             "The path tracer's time to vkrad's error is interpolated on its curve (log-log).", "",
             "| race | device | reference spp | its noise | vkrad wall s | error | path tracer to that error, "
             "warm s | cold s | path tracer / vkrad, warm | cold |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    extra_any = False
    for rel, d in docs:
        v = next((x for x in dicts(d.get("vkrad")) if x.get("converge") is None), None)
        if v is None:
            continue
        warm, cold, extra = pt_time(dicts(d.get("pathtracer")), v.get("rel_rmse_lit"))
        extra_any |= extra and warm is not None
        mark = "≈" if extra else ""
        cells = [f"[{rel[:-5]}](#{anchor(rel[:-5])})", race_device(rel, d), count(get(d, "reference", "spp")),
                 pct(get(d, "reference", "est_noise_rel_rmse_lit")), secs(v.get("wall_s")),
                 pct(v.get("rel_rmse_lit")), mark + secs(warm) if warm else None,
                 mark + secs(cold) if cold else None,
                 (mark + ratio(warm, v.get("wall_s"))) if ratio(warm, v.get("wall_s")) else None,
                 (mark + ratio(cold, v.get("wall_s"))) if ratio(cold, v.get("wall_s")) else None]
        lines.append("| " + " | ".join("–" if c is None else c for c in cells) + " |")
    if extra_any:
        lines += ["", EXTRAPOLATED]
    lines.append("")
    for rel, d in docs:
        lines += [f"### {rel[:-5]}", ""]
        cmd, src = race_command(rel, d)
        scene = relpath(d.get("scene")) or race_name(rel, d)
        size = d.get("size")
        size = f"{size[0]}x{size[1]}" if isinstance(size, list) and len(size) == 2 else "256x256"
        lines += header(rel, d, f"`{scene}` at {size}: {race_device(rel, d)}.", cmd, src)
        ref = d.get("reference") if isinstance(d.get("reference"), dict) else {}
        if ref:
            lines.append(f"- Reference: {count(ref.get('spp')) or '?'} spp in {secs(ref.get('seconds')) or '?'} s, "
                         f"its own noise {pct(ref.get('est_noise_rel_rmse_lit')) or '?'} (in both sides' errors).")
        vk = (dicts(d.get("vkrad")) or [{}])[0]
        if vk.get("cmd"):
            lines.append(f"- vkrad's command (recorded): `{tidy_cmd(vk['cmd'], d.get('vkrad_binary'))}`")
        lines.append("")
        rows, extra = race_rows(d)
        lines += table(RACE_HEADERS, rows)
        if extra:
            lines += ["", EXTRAPOLATED]
        curve = dicts(d.get("pathtracer"))
        if curve:
            lines += ["", "The path tracer's curve:", ""]
            lines += table(["spp", "warm s", "cold s", "error", "bias"],
                           [[count(p.get("spp")), secs(p.get("warm_s")), secs(p.get("cold_total_s")),
                             pct(p.get("rel_rmse_lit")), pct(p.get("bias_lit"), True)] for p in curve])
        lines += [""] + charts([rel[:-5] + ".png"], linked) + [""]
    return lines


def memory_section(rel, title, linked):
    doc = load(rel)
    if not doc:
        return []
    cmd, src = COMMANDS.get(rel, (None, None))
    cmd = cmd or doc.get("command")
    where = "an NVIDIA H200 with 16 CPU cores" if rel.startswith("h200/") else "lavapipe, 2 cores"
    cap = (f" Each run's address space capped at {doc['limit_gb']:g} GiB (`RLIMIT_AS`, as `ulimit -v`), "
           f"{doc.get('timeout_s') or 0:g} s allowed: a run must end with an image or a clean error."
           if num(doc.get("limit_gb")) else "")
    lines = [title, ""]
    lines += header(rel, doc,
                    f"Peak resident memory of each run (Linux `VmHWM`) against the estimate vkrad makes before "
                    f"any work; `vkrad SCENE --size {doc.get('size', '256x256')}` at its defaults on {where}, "
                    f"single runs. `bench/memory.py` fails if a peak exceeds its estimate.{cap}", cmd, src)
    lines.append("")
    rows = []
    for r in dicts(doc.get("runs")):
        p, e = r.get("peak_bytes"), r.get("estimate_bytes")
        ended = r.get("outcome") or ("image" if num(p) else None)
        if r.get("error"):
            ended = f"{ended}: {' '.join(r['error'])}"
        rows.append([r.get("scene"), count(r.get("patches")), count(r.get("elements")), secs(r.get("wall_s")),
                     secs(r.get("gather_s")), mib(p), mib(e), f"{p / e:.2f}" if num(p) and num(e) and e else None,
                     ended])
    lines += table(["scene", "polygons", "elements solved", "wall s", "gather s", "peak MiB", "estimate MiB",
                    "peak / estimate", "ended with"], rows)
    return lines + [""]


def walkthrough_section(linked):
    """One solve and N draws against N path-traced images at equal error."""
    rels = sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "race-walkthrough-*.json")))
    docs = [(rel, d) for rel, d in ((rel, load(rel)) for rel in rels) if d]
    if not docs:
        return []
    lines = ["## The walkthrough race", "",
             "`bench/pathtracer/walkthrough.py`: N views of one scene along a dolly inside it. vkrad solves once "
             "and draws its lit mesh from every camera (`--views`); the path tracer (Mitsuba 3, CPU) renders "
             "each view from scratch until it reaches vkrad's error on that view (relative RMSE over the lit "
             "pixels against a reference of two independent halves, its noise taken out). Times are wall "
             "seconds on the same 2 cores; vkrad's include start-up, solve, gather and every draw.", ""]
    rows = []
    for rel, d in docs:
        views = dicts(d.get("views"))
        vk = d.get("vkrad_cumulative_seconds") or []
        pt = d.get("pt_cumulative_seconds") or []
        errs = [v.get("vkrad_error") for v in views if num(v.get("vkrad_error"))]
        size = d.get("size") or []
        rows.append([f"[`{rel}`]({rel})", d.get("scene"), "x".join(str(x) for x in size) or None, len(views),
                     f"{pct(min(errs))}–{pct(max(errs))}" if errs else None,
                     secs(vk[-1]) if vk else None, secs(pt[-1]) if pt and num(pt[-1]) else "did not reach",
                     ratio(pt[-1], vk[-1]) if pt and vk and num(pt[-1]) else None, file_date(rel, d)])
        lines_png = rel[:-5] + ".png"
        linked.add(lines_png)
    lines += table(["file", "scene", "size", "views", "vkrad error per view", "vkrad, all views s",
                    "path tracer, all views s", "path tracer / vkrad", "date"], rows)
    lines.append("")
    for rel, _ in docs:
        lines += charts([rel[:-5] + ".png"], linked)
    return lines + [""]


def views_section(linked):
    """The lit mesh (what --export writes) judged from several cameras."""
    rels = sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "views-*.json")))
    docs = [(rel, load(rel)) for rel in rels]
    docs = [(rel, d) for rel, d in docs if d]
    if not docs:
        return []
    lines = ["## The lit mesh from several cameras", "",
             "One vkrad solve, its lit mesh drawn from every camera with `--views`, against Mitsuba 3 from "
             "the same cameras (`bench/pathtracer/views.py`): the scene's own camera, then cameras inside the "
             "scene (across the room, down at the floor, low over it). Errors are relative RMS over the lit "
             "pixels, with the reference's own noise (from two independent halves) taken out in quadrature. Oversample K: vkrad drew "
             "at K times the size, box-filtered down, which takes its edge antialiasing out of the error. "
             "Clear of emitters' outlines: over the lit pixels none of whose 8 neighbours sees an emitter "
             "(a sliver of an emitter's corner can slip past the emitter mask and weigh like the surface; "
             "measured only since 2026-12-07). "
             "The 2% goal is issue 44's.", ""]
    rows = []
    for rel, d in docs:
        views = dicts(d.get("views"))
        errs = " / ".join(pct(v.get("rel_rmse_lit_noise_corrected")) or "?" for v in views)
        noise = max((v.get("reference_noise") for v in views if num(v.get("reference_noise"))), default=None)
        draws = sorted(v["draw_seconds"] for v in views if num(v.get("draw_seconds")))
        rows.append([f"[`{rel}`]({rel})", d.get("scene"), f"{d.get('oversample', 1)}",
                     f"`{d['vkrad_args']}`" if d.get("vkrad_args") else "defaults",
                     count(d.get("display_elements")), errs,
                     pct(d.get("worst_rel_rmse_lit_noise_corrected")),
                     " / ".join(pct(v.get("rel_rmse_clear_noise_corrected")) or "?" for v in views)
                     if any(num(v.get("rel_rmse_clear_noise_corrected")) for v in views) else None,
                     pct(noise), secs(d.get("vkrad_wall_seconds")),
                     f"{1000 * draws[len(draws) // 2]:.0f} ms" if draws else None, file_date(rel, d)])
    lines += table(["file", "scene", "oversample", "vkrad arguments", "display elements",
                    "error per view (noise out)", "worst", "clear of emitters' outlines", "reference noise (max)",
                    "vkrad wall", "draw / view",
                    "date"], rows)
    lines += ["", "Command: `cd bench/pathtracer && python3 views.py --scene SCENE --size 128x128 --spp 2048 "
              "[--oversample 4] [--tag=T --vkrad-args=...]`; 2 cores, lavapipe, other work running "
              "(wall and draw times are not benchmarks). scan-33k: a generated stand-in for a scanned statue "
              "(33,120 noisy triangles in the Cornell room, `python3 scenes/generate_scenes.py --scan DIR`).", ""]
    return lines


def scenes_section(linked):
    doc = load("scenes.json")
    if not doc:
        return []
    lines = opening("scenes.json", doc, "Time, gather cost and memory against polygons",
                    "The runs of `bench/memory.py --large` against input polygons, with a power law fitted to "
                    "each generated family (`scenes/generate_scenes.py --scaling DIR`: fields of letters R, and "
                    "curved surfaces in the Cornell room). A traced point is an element centre the final gather "
                    "traced from, or a pixel block's reflected-light point; the cost a point is the gather's CPU "
                    "time (wall x threads) over them.")
    lines.append("")
    rows = [[r.get("scene"), count(r.get("patches")), secs(r.get("wall_s")), secs(r.get("gather_s")),
             count(r.get("gather_points")), ms(r.get("gather_ms_per_point")), mib(r.get("peak_bytes"))]
            for r in dicts(doc.get("runs"))]
    lines += table(["scene", "polygons", "wall s", "gather s", "traced points", "gather CPU ms a point",
                    "peak MiB"], rows)
    fits = doc.get("fits") if isinstance(doc.get("fits"), dict) else {}
    if fits:
        lines += ["", "Fitted exponents (quantity ∝ polygons^k):", ""]
        frows = []
        for fam, f in fits.items():
            if not isinstance(f, dict):
                continue
            pr = f.get("polygons")
            span = f"{count(pr[0])} to {count(pr[1])}" if isinstance(pr, list) and len(pr) == 2 else None
            frows.append([fam, span] + [f"{f[k]:.2f}" if num(f.get(k)) else None
                                        for k in ("wall", "gather_per_point", "peak")])
        lines += table(["family", "polygons", "wall", "gather cost a point", "peak memory"], frows)
    return lines + [""] + charts(["scenes.png"], linked) + [""]


def scaling_section(linked):
    doc = load("scaling.json")
    if not doc:
        return []
    cmd, src = COMMANDS["scaling.json"]
    lines = ["## Solve time against elements", ""]
    what = doc.get("what") or "solve seconds against element count"
    lines += header("scaling.json", doc,
                    f"The solver alone on `{doc.get('scene', 'cornell')}`, element by element and hierarchical, "
                    f"to `--converge {doc.get('converge', '?')}` on {doc.get('device', 'the device')}: {what}.",
                    cmd, src)
    lines.append("")
    rows = [[r.get("solver"), count(r.get("elements")), count(r.get("shots")), secs(r.get("seconds")),
             f"{r['residual']:.4f}" if num(r.get("residual")) else None, pct(r.get("vs_element_rel_rms")),
             pct(r.get("vs_element_bias"), True)] for r in dicts(doc.get("runs"))]
    lines += table(["solver", "elements", "shots", "solve s", "residual", "difference from element-by-element",
                    "bias"], rows)
    fe = doc.get("fitted_exponent") if isinstance(doc.get("fitted_exponent"), dict) else {}
    if fe:
        lines += ["", "Fitted growth (seconds ∝ elements^k, meshes of 2,000 elements and more): " +
                  ", ".join(f"{k} {v:.2f}" for k, v in fe.items() if num(v)) + "."]
    return lines + [""] + charts(["scaling.png"], linked) + [""]


def gather_cost_section(linked):
    doc = load("gather_cost.json")
    if not doc:
        return []
    cmd, src = COMMANDS["gather_cost.json"]
    lines = ["## The final gather's cost a point", ""]
    le = doc.get("link_error")
    lines += header("gather_cost.json", doc,
                    "For each scene, the default solve, then one gather over a fixed sample of element centres: "
                    "the CPU milliseconds a point (wall x threads), with the clustered source hierarchy and with "
                    "even clusters only, and how far the two results differ against the noise of one estimate"
                    + (f"; link error {le:.3g}" if num(le) else "")
                    + (f"; {doc['device']}, {doc.get('threads', '?'):g} threads" if doc.get("device") and
                       num(doc.get("threads")) else "") + ".", cmd, src)
    lines.append("")
    rows = [[r.get("scene"), count(r.get("patches")), count(r.get("elements")), count(r.get("points")),
             secs(r.get("setup_s")), ms(r.get("ms_per_point")), ms(r.get("ms_per_point_even_clusters_only")),
             f"{r['rel_rms_between_pct']:.3f}%" if num(r.get("rel_rms_between_pct")) else None,
             f"{r['noise_one_estimate_pct']:.3f}%" if num(r.get("noise_one_estimate_pct")) else None]
            for r in dicts(doc.get("rows"))]
    lines += table(["scene", "polygons", "elements", "points", "set-up s", "ms a point", "even clusters only",
                    "difference", "noise of one estimate"], rows)
    return lines + ["", "The rows name the scenes the bench was given (built-in names, or the stems of .obj files).", ""]


def lightmap_section(linked):
    doc = load("lightmap.json")
    if not doc:
        return []
    lines = opening("lightmap.json", doc, "Lightmaps in a browser",
                    "`vkrad SCENE --shade mesh --export x.glb --lightmap D` at several densities, the .glb drawn by "
                    "three.js in headless Chromium (WebGL on SwiftShader, vkrad's 16 sample positions a pixel). "
                    "Errors are relative RMS in linear light over the surfaces: the lightmap against the same "
                    "mesh's vertex colours drawn by the same browser (what the atlas loses), and the browser's "
                    "image against vkrad's `--shade pixels` image.")
    lines.append("")
    rows = []
    for sc in dicts(doc.get("scenes")):
        vc = get(sc, "browser_vertex_colours_vs_pixels", "surfaces")
        for r in dicts(sc.get("runs")):
            at = r.get("atlas") or {}
            lv = r.get("lightmap_vs_vertex_colours_in_browser_surfaces") or {}
            rows.append([sc.get("scene"), r.get("density"), f"{at.get('width')}x{at.get('height')}" if at else None,
                         count(at.get("covered_texels")), count(r.get("display_vertices")),
                         f"{r['covered_texels_per_vertex']:.2f}" if num(r.get("covered_texels_per_vertex")) else None,
                         pct(lv.get("rel_rmse")), pct(r.get("browser_vs_pixels_surfaces")), pct(vc)])
    lines += table(["scene", "texels per unit", "atlas", "covered texels", "display vertices", "texels a vertex",
                    "lightmap vs vertex colours", "browser vs pixels", "vertex colours vs pixels"], rows)
    lines += [""] + charts(["lightmap.png", "lightmap-browser-cornell.png"], linked)
    return lines + [""]


def lightmap_blender_section(linked):
    doc = load("lightmap-blender.json")
    if not doc:
        return []
    lines = opening("lightmap-blender.json", doc, "Lightmaps in Blender",
                    f"`vkrad SCENE --shade mesh --export x.glb --lightmap auto`, the .glb imported by "
                    f"{doc.get('blender') or 'Blender'}'s own glTF importer and drawn by Cycles (one-pixel box "
                    "filter, Standard view transform), against vkrad's `--shade mesh` image of the same lit mesh. "
                    "Relative RMS in linear light and the largest channel's difference in 8-bit levels, over the "
                    "surfaces Blender covers fully away from clamped pixels, and over the interior of those "
                    "(one shading normal in each 3x3 neighbourhood: no edge, crease or seam).")
    lines.append("")
    rows = []
    for sc in dicts(doc.get("scenes")):
        at = sc.get("atlas") or {}
        c = sc.get("blender_vs_mesh") or {}
        su, it = c.get("surfaces") or {}, c.get("interior") or {}
        imp = sc.get("imported") or {}
        rows.append([os.path.splitext(os.path.basename(str(sc.get("scene"))))[0], count(sc.get("display_elements")),
                     f"{at.get('width')}x{at.get('height')}" if at else None, count(su.get("pixels")),
                     pct(su.get("rel_rmse")), num(su.get("mean_levels")) and f"{su['mean_levels']:.2f}",
                     su.get("p99_levels"), count(it.get("pixels")), pct(it.get("rel_rmse")),
                     num(it.get("mean_levels")) and f"{it['mean_levels']:.2f}", it.get("p99_levels"),
                     ", ".join(imp.get("uv_layers") or []), secs(sc.get("blender_s"))])
    lines += table(["scene", "display elements", "atlas", "surface pixels", "rel RMSE", "mean levels", "p99 levels",
                    "interior pixels", "rel RMSE", "mean levels", "p99 levels", "UV maps imported",
                    "Blender s"], rows)
    lines += [""] + charts(["lightmap-blender-cornell.png"], linked)
    return lines + [""]


def many_lights_section(linked):
    doc = load("many-lights.json")
    if not doc:
        return []
    lines = opening("many-lights.json", doc, "Many lights",
                    "One open-plan office lit by N ceiling panels of equal total power "
                    "(`scenes/generate_scenes.py --offices`), at vkrad's defaults (the 16 lights that give a "
                    "point most get their own shadow rays, the rest share one estimate) and with "
                    "`--tune exact_lights=all` (every light its own rays, as before), against Mitsuba 3. "
                    f"{doc.get('size')}, "
                    + ("single runs side by side, the two variants one after the other; with one light they do "
                       "the same work, so their difference there is the runs' own spread"
                       if doc.get("repeats") == 1 else f"median of {doc.get('repeats')} runs each, the variants "
                       "alternating") + "; errors less the reference's own noise.")
    lines.append("")
    rows = []
    for r in dicts(doc.get("rows")):
        d, a = r.get("default") or {}, r.get("exact_lights=all") or {}
        rows.append([count(r.get("luminaires")), secs(d.get("gather_s")), secs(a.get("gather_s")),
                     ratio(a.get("gather_s"), d.get("gather_s")), secs(d.get("wall_s")), secs(a.get("wall_s")),
                     pct(d.get("rel_rmse_lit_corrected")), pct(a.get("rel_rmse_lit_corrected")),
                     pct(get(r, "reference", "noise_rel_rmse_lit"))])
    lines += table(["luminaires", "gather s", "gather s, all exact", "all exact / default", "vkrad wall s",
                    "wall s, all exact", "error", "error, all exact", "reference noise"], rows)
    k = doc.get("gather_exponent") or {}
    if num(k.get("default")):
        lines += ["", f"Gather time grows as N^{k['default']:.2f} at the defaults"
                  + (f", N^{k['exact_lights=all']:.2f} with every light exact" if num(k.get("exact_lights=all")) else "")
                  + " (least-squares slope over the rows; issue 45 asks for at most N^0.5)."]
    lines += [""] + charts(["many-lights.png"], linked)
    return lines + [""]


def bench_section(linked):
    doc = load("bench.json")
    if not doc:
        return []
    cmd, src = COMMANDS["bench.json"]
    size = doc.get("image_size")
    size = f"{size[0]}x{size[1]}" if isinstance(size, list) and len(size) == 2 else "?"
    lines = ["## Form-factor methods: error against time", ""]
    lines += header("bench.json", doc,
                    "`vkrad bench`: the form-factor sweeps are raw solutions on a coarse mesh, solved element by "
                    f"element to {doc.get('converge', '?')} and shown with the solve's own vertex values, timed "
                    "as the solve; `default` is `vkrad SCENE` at its defaults (and at 2x and 4x its edges), final "
                    "gather included, timed whole. Error is the relative RMS over the lit pixels against a "
                    f"mesh-free reference (per-pixel gather from a finer converged solution); {size} images on "
                    f"{doc.get('device', 'the device')}"
                    + (f"; the whole bench took {doc['total_seconds']:.0f} s" if num(doc.get("total_seconds")) else "")
                    + ".", cmd, src)
    lines.append("")
    refs = dicts(doc.get("references"))
    if refs:
        lines += table(["reference", "source elements", "shots", "seconds"],
                       [[r.get("scene"), count(r.get("elements")), count(r.get("shots")), secs(r.get("wall_seconds"))]
                        for r in refs])
        lines.append("")
    rows = [[p.get("scene"), p.get("method"), p.get("setting"), count(p.get("elements")),
             count(p.get("display_elements")), count(p.get("shots")), secs(p.get("wall_seconds")),
             pct(p.get("error"))] for p in dicts(doc.get("points"))]
    lines += table(["scene", "series", "setting", "elements solved", "elements shown", "shots", "wall s", "error"],
                   rows)
    return lines + [""] + charts(["bench.png"], linked) + [""]


def meshers_section(linked):
    doc = load("meshers.json")
    if not doc:
        return []
    lines = opening("meshers.json", doc, "Meshers: error against elements and time",
                    f"`vkrad bench --meshers` on `{doc.get('scene', 'simple')}`: "
                    + (doc.get("method") or "uniform against discontinuity meshing")
                    + (f". Reference: {doc['reference']}" if doc.get("reference") else "") + ".")
    lines.append("")
    rows = [[p.get("mesher"), p.get("setting"), count(p.get("solved_elements")), count(p.get("elements")),
             secs(p.get("wall_seconds")), pct(p.get("error")), pct(p.get("estimated_error"))]
            for p in dicts(doc.get("points"))]
    lines += table(["mesher", "setting", "elements solved", "elements shown", "wall s", "error", "estimated error"],
                   rows)
    return lines + [""] + charts(["meshers.png", "meshers-reference.png"], linked) + [""]


def other_files(handled):
    rest = []
    for p in sorted(glob.glob(os.path.join(HERE, "*.json")) + glob.glob(os.path.join(HERE, "h200", "*.json"))):
        rel = os.path.relpath(p, HERE)
        if rel not in handled:
            rest.append(rel)
    if not rest:
        return []
    lines = ["## Other files", "", "Not summarised here:", ""]
    for rel in rest:
        date = file_date(rel, load(rel))
        lines.append(f"- [`bench/{rel}`]({rel}), " + (f"committed {date}" if date else "date unknown"))
    return lines + [""]


def other_charts(linked):
    try:
        tracked = subprocess.run(["git", "ls-files", "--", "bench"], cwd=ROOT, capture_output=True, text=True,
                                 timeout=30).stdout.split()
        pngs = [os.path.relpath(os.path.join(ROOT, t), HERE) for t in tracked if t.endswith(".png")]
    except (OSError, subprocess.SubprocessError):
        pngs = []
    if not pngs:
        pngs = [os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "**", "*.png"), recursive=True)]
    rest = sorted(p for p in pngs if p not in linked and not p.startswith("pathtracer/"))
    if not rest:
        return []
    lines = ["## Other charts", "", "Committed pictures with no JSON of their own:", ""]
    for p in rest:
        lines.append(f"- [`bench/{p}`]({p})" + (f": {CAPTIONS[p]}" if p in CAPTIONS else ""))
    return lines + [""]


def main():
    linked = set()
    gal, readme_table = gallery(linked)
    if "--gallery-table" in sys.argv[1:]:
        print("\n".join(readme_table))
        return
    body = []
    body += gal
    body += races(linked)
    body += views_section(linked)
    body += lightmap_section(linked)
    body += lightmap_blender_section(linked)
    body += walkthrough_section(linked)
    body += memory_section("memory.json", "## Memory against the estimate", linked)
    body += memory_section("memory-4gb.json", "## Interiors under a 4 GiB address-space cap", linked)
    body += scenes_section(linked)
    body += gather_cost_section(linked)
    body += many_lights_section(linked)
    body += scaling_section(linked)
    body += bench_section(linked)
    body += meshers_section(linked)
    h200 = memory_section("h200/memory-h200.json", "## Memory and time on an NVIDIA H200", linked)
    if h200:
        body += h200
        body += ["The H200 runs' scripts and logs are in `bench/h200/` (`gpu_run*.sh`, `run*-log.txt`).", ""]
    handled = {"gallery.json", "memory.json", "scenes.json", "gather_cost.json", "scaling.json", "bench.json",
               "meshers.json", "h200/memory-h200.json", "many-lights.json",
               "memory-4gb.json", "lightmap.json", "lightmap-blender.json"}
    handled |= {os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "race-*.json"))}
    handled |= {os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "h200", "race-*.json"))}
    handled |= {os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "views-*.json"))}
    body += other_files(handled)
    body += other_charts(linked)

    toc = [l[3:] for l in body if l.startswith("## ")]
    head = ["# vkrad: measured results", "",
            "Generated by `python3 bench/results.py` from bench/*.json; do not edit by hand.", "",
            "Every figure on this page is read from the JSON file its section names; each section says the "
            "command that writes that file and when the file was last committed. Times are wall seconds, memory "
            "is in MiB (2^20 bytes), errors are relative RMS over the lit pixels. \"Path tracer / vkrad\" is the "
            "path tracer's time to vkrad's error over vkrad's time: above 1, vkrad got there first. Unless a section says "
            "otherwise, vkrad ran on lavapipe (Mesa's CPU Vulkan driver) on 2 cores with nothing else running.",
            ""]
    head += [f"- [{t}](#{anchor(t)})" for t in toc] + [""]
    text = "\n".join(head + body).rstrip() + "\n"
    with open(OUT, "w") as fh:
        fh.write(text)
    print(f"wrote {os.path.relpath(OUT, ROOT)} ({text.count(chr(10))} lines)")


def anchor(title):
    """GitHub's heading anchor."""
    out = []
    for ch in title.lower():
        if ch.isalnum() or ch in "-_":
            out.append(ch)
        elif ch == " ":
            out.append("-")
    return "".join(out)


if __name__ == "__main__":
    main()
