#!/usr/bin/env python3
"""The cost of `--trace`: each command run off and on, alternating, N
times; whole-command wall time and the stages' wall times from the
summary, with the medians. The last traced run's file is kept.

  python3 bench/trace/cost.py [--runs 3] [--out DIR] [--vkrad target/release/vkrad]

Outside CI (minutes: the many-patch scene's gather is most of it).
"""

import argparse
import os
import re
import statistics
import subprocess
import time

COMMANDS = {
    "cornell": ["cornell"],
    "rfield": ["scenes/rfield.obj", "--size", "128x128"],
}


def run(vkrad, args, out, trace):
    cmd = [vkrad] + args + ["--output", os.path.join(out, "image.png")]
    if trace:
        cmd += ["--trace", trace]
    t = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    whole = time.monotonic() - t
    wall = re.search(r"^  wall\s+(.*)$", p.stdout, re.M).group(1)
    stages = {m.group(1): float(m.group(2)) for m in re.finditer(r"([a-z ]+?) ([\d.]+)s", wall)}
    return whole, {k.strip(): v for k, v in stages.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default="/tmp/vkrad-trace-cost")
    ap.add_argument("--vkrad", default="target/release/vkrad")
    ap.add_argument("--only", nargs="*", default=list(COMMANDS))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    for name in a.only:
        rows = {False: [], True: []}
        for k in range(a.runs):
            for on in (False, True):
                trace = os.path.join(a.out, f"{name}.json") if on else None
                whole, stages = run(a.vkrad, COMMANDS[name], a.out, trace)
                rows[on].append((whole, stages))
                print(f"{name} run {k} trace {'on ' if on else 'off'}: {whole:.2f} s  {stages}", flush=True)
        for on in (False, True):
            w = [r[0] for r in rows[on]]
            keys = rows[on][0][1].keys()
            med = {s: statistics.median(r[1][s] for r in rows[on]) for s in keys}
            print(f"{name} trace {'on ' if on else 'off'}: whole {', '.join(f'{x:.2f}' for x in w)} s, "
                  f"median {statistics.median(w):.2f} s; stage medians {med}", flush=True)
        size = os.path.getsize(os.path.join(a.out, f"{name}.json"))
        print(f"{name}: trace {size / 1e6:.2f} MB", flush=True)


if __name__ == "__main__":
    main()
