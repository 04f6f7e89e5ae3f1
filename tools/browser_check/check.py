#!/usr/bin/env python3
"""Browser check of a navfuse report: load the HTML file from disk in headless
Chromium, screenshot it, and verify that every plot rendered.

Drives Chromium through the DevTools protocol over --remote-debugging-pipe
(file descriptors 3/4, NUL-terminated JSON): Python standard library only, no
network, no port.

Checks (any failure -> exit status 1 with one line per problem):
  * the page loaded and its inline script ran (body[data-script-ok="1"]);
  * <meta name="navfuse-plots"> equals the number of <svg class="plot">
    (and at least --min-plots);
  * every plot: rendered with a non-zero box, data-series > 0, and exactly
    data-series `.series` elements, each with a non-empty path and a
    non-empty bounding box;
  * clicking a legend entry hides its series and clicking again shows it;
  * no JavaScript exception and no console/log message at level error.

Usage: check.py REPORT.html [--screenshot OUT.png] [--width 1060]
                [--height 0 (full page)] [--top 0] [--min-plots 1] [--chromium PATH]
"""

import argparse
import json
import os
import pathlib
import select
import shutil
import subprocess
import sys
import tempfile
import time

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--remote-debugging-pipe",
]

PAGE_CHECK = r"""
(() => {
  const out = {problems: [], plots: []};
  const meta = document.querySelector('meta[name="navfuse-plots"]');
  const svgs = Array.from(document.querySelectorAll('svg.plot'));
  if (!meta) out.problems.push('no <meta name="navfuse-plots">');
  else if (+meta.content !== svgs.length)
    out.problems.push(`meta says ${meta.content} plots, the page has ${svgs.length}`);
  if (document.body.getAttribute('data-script-ok') !== '1')
    out.problems.push('the inline script did not run to its end');
  for (const svg of svgs) {
    const id = svg.id || '(no id)';
    const want = +svg.dataset.series;
    const series = Array.from(svg.querySelectorAll('.series'));
    const r = svg.getBoundingClientRect();
    const info = {id, want, got: series.length, w: Math.round(r.width), h: Math.round(r.height)};
    out.plots.push(info);
    if (!(r.width > 100 && r.height > 50)) out.problems.push(`${id}: not rendered (${r.width}x${r.height})`);
    if (!(want > 0)) out.problems.push(`${id}: data-series is ${svg.dataset.series}`);
    if (series.length !== want) out.problems.push(`${id}: ${series.length} series drawn, ${want} expected`);
    series.forEach((p, i) => {
      const d = p.getAttribute('d') || '';
      let b = {width: 0, height: 0};
      try { b = p.getBBox(); } catch (e) {}
      if (d.length < 4) out.problems.push(`${id}: series ${i} (${p.dataset.name}) has an empty path`);
      else if (!(b.width > 0 || b.height > 0)) out.problems.push(`${id}: series ${i} (${p.dataset.name}) has an empty box`);
    });
  }
  // Legend click hides the series, a second click shows it again.
  const svg = svgs.find(s => s.querySelector('g.legend'));
  if (svg) {
    const g = svg.querySelector('g.legend');
    const name = g.dataset.name;
    const targets = Array.from(svg.querySelectorAll('.series')).filter(p => p.dataset.name === name);
    g.dispatchEvent(new MouseEvent('click', {bubbles: true}));
    const hidden = targets.every(p => getComputedStyle(p).display === 'none');
    g.dispatchEvent(new MouseEvent('click', {bubbles: true}));
    const shown = targets.every(p => getComputedStyle(p).display !== 'none');
    if (targets.length && !(hidden && shown)) out.problems.push(`${svg.id}: legend click on "${name}" did not toggle its series`);
  }
  out.height = Math.ceil(document.documentElement.scrollHeight);
  return JSON.stringify(out);
})()
"""


class Pipe:
    """DevTools protocol over the pipe pair."""

    def __init__(self, proc, wfd, rfd):
        self.proc, self.wfd, self.rfd = proc, wfd, rfd
        self.buf = b""
        self.next_id = 0
        self.events = []

    def send(self, method, params=None, session=None, timeout=30.0):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.wfd, json.dumps(msg).encode() + b"\0")
        want = self.next_id
        deadline = time.monotonic() + timeout
        while True:
            m = self.read(deadline)
            if m.get("id") == want:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def read(self, deadline):
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no answer from Chromium in time")
            r, _, _ = select.select([self.rfd], [], [], left)
            if r:
                chunk = os.read(self.rfd, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"Chromium closed the pipe (exit {self.proc.poll()})")
                self.buf += chunk
        msg, self.buf = self.buf.split(b"\0", 1)
        return json.loads(msg)

    def wait_event(self, method, timeout=30.0):
        deadline = time.monotonic() + timeout
        while True:
            for i, e in enumerate(self.events):
                if e.get("method") == method:
                    return self.events.pop(i)
            self.events.append(self.read(deadline))


def errors_in(events):
    out = []
    for e in events:
        m, p = e.get("method"), e.get("params", {})
        if m == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            out.append("script exception: " + d.get("exception", {}).get("description", d.get("text", "?")))
        elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            out.append("console.error: " + " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", [])))
        elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            en = p["entry"]
            out.append(f"log error ({en.get('source')}): {en.get('text')} {en.get('url', '')}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("report")
    ap.add_argument("--screenshot")
    ap.add_argument("--width", type=int, default=1060)
    ap.add_argument("--height", type=int, default=0, help="screenshot height in px (0: whole page)")
    ap.add_argument("--top", type=int, default=0, help="screenshot from this page y [px]")
    ap.add_argument("--min-plots", type=int, default=1)
    ap.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium")
    a = ap.parse_args()

    report = pathlib.Path(a.report).resolve()
    if not report.is_file():
        print(f"browser check: {report}: no such file", file=sys.stderr)
        return 1
    if not os.access(a.chromium, os.X_OK):
        print(f"browser check: Chromium not found at {a.chromium} (apt-get install -y chromium)", file=sys.stderr)
        return 1

    profile = tempfile.mkdtemp(prefix="navfuse-chromium-")
    to_chrome_r, to_chrome_w = os.pipe()
    from_chrome_r, from_chrome_w = os.pipe()

    def child_fds():
        # Chromium reads commands on fd 3 and writes answers on fd 4.
        r, w = os.dup(to_chrome_r), os.dup(from_chrome_w)
        os.dup2(r, 3)
        os.dup2(w, 4)
        os.set_inheritable(3, True)
        os.set_inheritable(4, True)

    proc = subprocess.Popen(
        [a.chromium, *FLAGS, f"--user-data-dir={profile}", f"--window-size={a.width},900", "about:blank"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        pass_fds=(3, 4),  # kept open in the child after preexec_fn dup2s them
        preexec_fn=child_fds,
    )
    os.close(to_chrome_r)
    os.close(from_chrome_w)
    cdp = Pipe(proc, to_chrome_w, from_chrome_r)
    problems = []
    try:
        target = cdp.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        sess = cdp.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for m in ("Page.enable", "Runtime.enable", "Log.enable"):
            cdp.send(m, session=sess)
        cdp.send("Emulation.setDeviceMetricsOverride",
                 {"width": a.width, "height": 900, "deviceScaleFactor": 1, "mobile": False}, session=sess)
        cdp.events.clear()
        nav = cdp.send("Page.navigate", {"url": report.as_uri()}, session=sess)
        if nav.get("errorText"):
            problems.append(f"navigation failed: {nav['errorText']}")
        else:
            cdp.wait_event("Page.loadEventFired", timeout=60)
            res = cdp.send("Runtime.evaluate", {"expression": PAGE_CHECK, "returnByValue": True}, session=sess)
            if "exceptionDetails" in res:
                problems.append("page check raised: " + json.dumps(res["exceptionDetails"])[:500])
            else:
                out = json.loads(res["result"]["value"])
                problems += out["problems"]
                n = len(out["plots"])
                if n < a.min_plots:
                    problems.append(f"{n} plots, at least {a.min_plots} expected")
                for p in out["plots"]:
                    print(f"  plot {p['id']:<22} {p['got']}/{p['want']} series  {p['w']}x{p['h']} px")
                if a.screenshot:
                    top = max(0, min(a.top, out["height"] - 1))
                    h = out["height"] - top if a.height <= 0 else min(a.height, out["height"] - top)
                    cdp.send("Emulation.setDeviceMetricsOverride",
                             {"width": a.width, "height": top + h, "deviceScaleFactor": 1, "mobile": False},
                             session=sess)
                    shot = cdp.send("Page.captureScreenshot",
                                    {"format": "png", "captureBeyondViewport": True,
                                     "clip": {"x": 0, "y": top, "width": a.width, "height": h, "scale": 1}},
                                    session=sess, timeout=60)
                    import base64
                    data = base64.b64decode(shot["data"])
                    pathlib.Path(a.screenshot).write_bytes(data)
                    print(f"  screenshot {a.screenshot}: {a.width}x{h} px, {len(data)} bytes")
                    if len(data) < 10_000:
                        problems.append(f"screenshot is only {len(data)} bytes: blank page?")
        # Let late errors arrive, then collect every error of the session.
        time.sleep(0.3)
        try:
            cdp.send("Runtime.evaluate", {"expression": "1"}, session=sess, timeout=5)
        except Exception:
            pass
        problems += errors_in(cdp.events)
    except Exception as e:  # timeouts, a crashed browser, protocol errors
        problems.append(f"{type(e).__name__}: {e}")
    finally:
        try:
            os.write(to_chrome_w, json.dumps({"id": 999999, "method": "Browser.close"}).encode() + b"\0")
        except OSError:
            pass
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        shutil.rmtree(profile, ignore_errors=True)

    if problems:
        print(f"browser check FAILED: {report}", file=sys.stderr)
        for p in problems:
            print(f"  - {p}", file=sys.stderr)
        return 1
    print(f"browser check ok: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
