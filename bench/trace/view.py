#!/usr/bin/env python3
"""Opens a `vkrad --trace` file in a real trace viewer and screenshots it.

The viewer is the Performance panel of Chromium's own DevTools front end
(the one Chromium serves on its remote-debugging port): headless Chromium
is started with a fresh profile, the panel loads the trace as a user's
"Load profile" would, the process's tracks are expanded, and the page is
captured over the DevTools protocol (Page.captureScreenshot). It also
parses the trace with the DevTools trace model (the parser behind the
panel) and prints, per track, the events it read against those in the
file, so a track or event the viewer dropped shows.

ui.perfetto.dev cannot be reached from the machine this was written on,
and this Chromium (Debian's 156) has no chrome://tracing (ERR_FAILED even
with the internal debugging pages enabled).

Usage:
  pip install websocket-client
  python3 bench/trace/view.py TRACE.json OUT.png [--window START_MS END_MS]
      [--size 1600x900] [--clip PIXELS] [--chromium chromium]

Outside CI: it needs Chromium and websocket-client.
"""

import argparse
import base64
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

import websocket

DEEP = """
function deepAll(sel, root = document) {
  const out = [...root.querySelectorAll(sel)];
  for (const el of root.querySelectorAll('*'))
    if (el.shadowRoot) out.push(...deepAll(sel, el.shadowRoot));
  return out;
}
"""

LOAD = """(async () => {
  const text = TEXT;
  const T = await import('./panels/timeline/timeline.js');
  const UI = await import('./ui/legacy/legacy.js');
  await UI.ViewManager.ViewManager.instance().showView('timeline');
  const panel = T.TimelinePanel.TimelinePanel.instance();
  await panel.loadFromFile(new File([text], NAME, {type: 'application/json'}));
  return text.length;
})()"""

# Per track: the events DevTools' trace model read, its top-level spans,
# and how deep they nest.
MODEL = """(async () => {
  const Trace = await import('./models/trace/trace.js');
  const m = Trace.TraceModel.Model.createWithAllHandlers();
  await m.parse(JSON.parse(TEXT).traceEvents);
  const d = m.parsedTrace(0);
  const data = d.data || d;
  const out = [];
  for (const [pid, p] of data.Renderer.processes) {
    for (const [tid, t] of p.threads) {
      let depth = 0;
      const walk = (n, k) => { depth = Math.max(depth, k); for (const c of n.children) walk(c, k + 1); };
      if (t.tree) for (const r of t.tree.roots) walk(r, 1);
      out.push({pid, tid, name: t.name, entries: t.entries ? t.entries.length : null,
                roots: t.tree ? t.tree.roots.size : null, depth});
    }
  }
  const b = data.Meta.traceBounds;
  return JSON.stringify({tracks: out, bounds: [b.min, b.max]});
})()"""

WINDOW = """(async () => {
  const TB = await import('./services/trace_bounds/trace_bounds.js');
  const m = TB.TraceBounds.BoundsManager.instance();
  const min = MIN, max = MAX;
  m.setTimelineVisibleWindow({min, max, range: max - min});
  return 'ok';
})()"""


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Page:
    def __init__(self, port):
        deadline = time.time() + 30
        while True:
            try:
                pages = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list"))
                break
            except OSError:
                if time.time() > deadline:
                    raise
                time.sleep(0.2)
        page = next(p for p in pages if p["type"] == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=120)
        self.n = 0

    def call(self, method, **params):
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            m = json.loads(self.ws.recv())
            if m.get("id") == self.n:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m["result"]

    def eval(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(r["exceptionDetails"].get("exception", {}).get("description", r))
        return r["result"].get("value")

    def click(self, x, y):
        for t in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=t, x=x, y=y, button="left", clickCount=1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("trace")
    ap.add_argument("out")
    ap.add_argument("--window", nargs=2, type=float, metavar=("START_MS", "END_MS"))
    ap.add_argument("--size", default="1600x900")
    ap.add_argument("--chromium", default="chromium")
    ap.add_argument("--clip", type=int, help="capture only the top CLIP pixels")
    ap.add_argument("--collapse", nargs="*", default=[],
                    help="track names (prefixes) to leave collapsed")
    args = ap.parse_args()
    width, height = map(int, args.size.split("x"))
    text = open(args.trace).read()
    in_file = {}
    for e in json.loads(text)["traceEvents"]:
        if e.get("ph") == "X":
            in_file[e["tid"]] = in_file.get(e["tid"], 0) + 1

    port = free_port()
    profile = tempfile.mkdtemp(prefix="vkrad-view-")
    flags = ["--headless=new", "--disable-gpu", f"--remote-debugging-port={port}",
             f"--user-data-dir={profile}", f"--window-size={width},{height}", "about:blank"]
    if os.geteuid() == 0:
        flags.insert(0, "--no-sandbox")
    chrome = subprocess.Popen([args.chromium] + flags, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        page = Page(port)
        page.call("Page.enable")
        page.call("Emulation.setDeviceMetricsOverride", width=width, height=height,
                  deviceScaleFactor=1, mobile=False)
        page.call("Page.navigate", url=f"http://127.0.0.1:{port}/devtools/trace_app.html")
        time.sleep(5)
        quoted = json.dumps(text)
        model = json.loads(page.eval(MODEL.replace("TEXT", quoted)))
        print(f"{args.trace}: DevTools' trace model read these tracks "
              f"(events read / 'X' events in the file):")
        ok = True
        for t in model["tracks"]:
            want = in_file.get(t["tid"], 0)
            ok &= t["entries"] == want
            print(f"  tid {t['tid']:>4}  {t['name']:<60} {t['entries']:>6} / {want:<6}"
                  f" top-level {t['roots']}, nesting depth {t['depth']}")
        missing = set(in_file) - {t["tid"] for t in model["tracks"]}
        if missing:
            ok = False
            print(f"  tracks in the file that the model did not read: {sorted(missing)}")
        print("  every event read" if ok else "  SOME EVENTS WERE NOT READ")

        page.eval(LOAD.replace("TEXT", quoted).replace("NAME", json.dumps(os.path.basename(args.trace))))
        time.sleep(4)
        # The "debugging connection was closed" notice (no page to debug),
        # and the sidebar: out of the way.
        page.eval(DEEP + "(() => deepAll('devtools-button.dialog-close-button').forEach(b => b.click()))()")
        chart_x = DEEP + "(() => deepAll('canvas.flame-chart-canvas')[0].getBoundingClientRect().x)()"
        for _ in range(3):
            if page.eval(chart_x) < 50:
                break
            page.eval(DEEP + "(() => deepAll('devtools-button').find(b => /sidebar/i.test(b.title + ' ' + (b.getAttribute('aria-label') || '') + ' ' + (b.getAttribute('jslog') || ''))).click())()")
            time.sleep(1)
        # The whole run, or the window asked for (ms from the trace's start).
        lo, hi = model["bounds"]
        a, b = (lo + 1e3 * args.window[0], lo + 1e3 * args.window[1]) if args.window else (lo, hi)
        page.eval(WINDOW.replace("MIN", str(a)).replace("MAX", str(b)))
        time.sleep(1)
        rect = json.loads(page.eval(DEEP + "(() => JSON.stringify(deepAll('canvas.flame-chart-canvas')[0].getBoundingClientRect()))()"))
        x0, y0 = rect["x"], rect["y"]
        # The process group, then its tracks from the last up (opening one
        # moves those below it). Rows: a ruler, the group, then one a track.
        row, top = 21, 25
        page.click(x0 + 9, y0 + top)
        time.sleep(1)
        names = [t["name"] for t in model["tracks"]]
        for k in reversed(range(len(names))):
            if any(names[k].startswith(c) for c in args.collapse):
                continue
            page.click(x0 + 20, y0 + top + row * (k + 1))
            time.sleep(0.3)
        time.sleep(1)
        clip = {"clip": {"x": 0, "y": 0, "width": width, "height": args.clip, "scale": 1}} if args.clip else {}
        shot = page.call("Page.captureScreenshot", format="png", **clip)
        with open(args.out, "wb") as f:
            f.write(base64.b64decode(shot["data"]))
        print(f"wrote {args.out}")
        return 0 if ok else 1
    finally:
        chrome.terminate()
        chrome.wait(timeout=10)
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
