"""Live cutting (``warp-cut live``): physics real-time factor and view frame rate while cutting.

The bundled ``straight_incision`` scene (10 x 6 cm, 2 mm spacing, Table 1, 1 ms steps), a
scripted stroke as a hand would make it: the scalpel goes 4 mm into the skin along its axis,
then cuts 3 cm along +x at 20 mm/s, then leaves. Measured over the 3 cm of cutting alone
(~1.5 s of simulated time, ~90 cut events):

* ``engine``: the run stepped as fast as it goes, no page (``LiveCut.advance``):
  simulated / compute time, what real-time pacing can reach at best;
* ``page``: the real-time threads of ``warp-cut live`` with its page served, no browser;
  ``page, cutting off``: the same stroke with cutting off (the blade only presses the skin);
  ``page, cut in background``: the same with the cut in a worker process
  (``warp-cut live --cut-in-background``);
* ``browser``: the same with headless Chromium showing the page (WebGL in SwiftShader, on the
  same two CPU cores as the simulation; skipped without /usr/bin/chromium and playwright).

Per case: real-time factor (simulated / wall time; at most 1, the run is paced to the wall
clock), compute factor (simulated / compute time of the simulation thread), CPU factor
(simulated / CPU time of that thread: about what a core of its own would give), frames the page
sent per second (``view_fps``, at most 30), and with a browser the websocket messages it
received and the frames it drew per second (requestAnimationFrame), and the machine's load
average when the case ended (the machine's two cores may be shared with other work).

    python benchmarks/bench_live.py            # results/live.csv, results/live.md
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
import time
from pathlib import Path

from common import markdown_table, write_csv, write_markdown

from warp_cut.live import LiveCut
from warp_cut.live.scripted import stroke_targets, wait_until_arrived

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader"]
LENGTH = 0.03
"""Length of the cut [m]."""


def _cut_phase(live: LiveCut, counter=None, slow_counter=None) -> dict:
    """In, then measure the cutting move, then out. Returns simulated, wall and compute time
    [s] of the cutting move, its cut events, and the change of ``counter()`` (read right at
    the start and end) and of ``slow_counter()`` (read just before and after those)."""
    targets = stroke_targets(live, LENGTH)
    live.set_target(targets["in"])
    wait_until_arrived(live, settle=0.05)
    slow0 = slow_counter() if slow_counter else None
    count0, s, t0 = counter() if counter else 0, live.status(), time.perf_counter()
    s0, c0, u0 = s.time, s.compute_s, s.cpu_s
    live.set_target(targets["along"])
    wait_until_arrived(live)
    count1, s, t1 = counter() if counter else 0, live.status(), time.perf_counter()
    slow1 = slow_counter() if slow_counter else None
    live.set_target(targets["out"])
    wait_until_arrived(live)
    return {"sim_s": s.time - s0, "wall_s": t1 - t0, "compute_s": s.compute_s - c0,
            "cpu_s": s.cpu_s - u0, "cut_events": s.cut_events, "count": count1 - count0,
            "slow": (slow0, slow1)}


def engine_case() -> dict:
    with LiveCut("straight_incision") as live:
        m = _cut_phase(live)
    return {"case": "engine", "realtime_factor": None, "compute_factor": m["sim_s"] / m["compute_s"],
            **_common(m), "view_fps": None, "browser_ws_msgs_per_s": None, "browser_draw_fps": None}


def _common(m: dict) -> dict:
    return {"cpu_factor": m["sim_s"] / m["cpu_s"], "cut_sim_s": m["sim_s"], "cut_wall_s": m["wall_s"],
            "cut_events": m["cut_events"]}


_DRAWN = """(() => { window.__drawn = 0;
    const draw = () => { window.__drawn++; requestAnimationFrame(draw); }; requestAnimationFrame(draw); })();"""


class _Browser:
    """Headless Chromium on the page, counting the websocket messages it receives (the page
    reads its websocket in a worker; Playwright sees them) and the frames it draws."""

    def __init__(self, url: str, profile: str):
        from playwright.sync_api import sync_playwright  # optional: the browser case only

        self._pw = sync_playwright().start()
        self.context = self._pw.chromium.launch_persistent_context(
            profile, executable_path=CHROMIUM, headless=True, args=FLAGS,
            viewport={"width": 1280, "height": 800})
        self.page = self.context.new_page()
        self.messages = 0
        self.page.on("websocket", lambda ws: ws.on("framereceived", self._count))
        self.page.add_init_script(_DRAWN)
        self.page.goto(url)
        self.page.wait_for_selector("canvas", timeout=120_000)

    def _count(self, _payload) -> None:
        self.messages += 1

    def counts(self) -> tuple[float, int, int]:
        """(page time [s], websocket messages, frames drawn) now (the call also delivers the
        websocket events Playwright holds)."""
        now, drawn = self.page.evaluate("() => [performance.now(), window.__drawn]")
        return 1e-3 * now, self.messages, int(drawn)

    def close(self) -> None:
        self.context.close()
        self._pw.stop()


def page_case(with_browser: bool, cutting: bool = True, background: bool = False) -> dict:
    from warp_cut.live.app import LiveApp  # needs viser (optional)

    live = LiveCut("straight_incision", cut_in_background=background)
    live.set_cutting(cutting)
    app = LiveApp(live, port=0)
    browser = None
    try:
        if with_browser:
            browser = _Browser(app.url, tempfile.mkdtemp(prefix="bench-live-chromium-"))
            time.sleep(3.0)  # the first scene arrives and is drawn
        app.start()
        m = _cut_phase(live, counter=lambda: app.viewer.view.frames_shown,
                       slow_counter=browser.counts if browser else None)
        case = (("browser" if browser else "page") + ("" if cutting else ", cutting off")
                + (", cut in background" if background else ""))
        row = {"case": case, "realtime_factor": m["sim_s"] / m["wall_s"],
               "compute_factor": m["sim_s"] / m["compute_s"], **_common(m),
               "view_fps": m["count"] / m["wall_s"], "browser_ws_msgs_per_s": None, "browser_draw_fps": None}
        if browser:
            (t0, msgs0, drawn0), (t1, msgs1, drawn1) = m["slow"]
            row["browser_ws_msgs_per_s"] = (msgs1 - msgs0) / (t1 - t0)
            row["browser_draw_fps"] = (drawn1 - drawn0) / (t1 - t0)
        return row
    finally:
        if browser:
            browser.close()
        app.stop()
        live.close()


def _has_browser() -> bool:
    return importlib.util.find_spec("playwright") is not None and Path(CHROMIUM).is_file()


def run(quick: bool = False, repeats: int = 2):
    if importlib.util.find_spec("viser") is None:
        print("  skipped: the live extra is not installed (pip install -e '.[live]')")
        return []
    rows = []
    cases = [("engine", engine_case), ("page", lambda: page_case(False)),
             ("page, cutting off", lambda: page_case(False, cutting=False)),
             ("page, cut in background", lambda: page_case(False, background=True))]
    if _has_browser():
        cases.append(("browser", lambda: page_case(True)))
    for _ in range(1 if quick else repeats):
        for _name, case in cases:
            row = case()
            row["load_avg_1min"] = os.getloadavg()[0]
            rows.append(row)
            print("  " + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                                   for k, v in row.items() if v is not None), flush=True)
    write_csv("live", rows)
    write_markdown("live", "Live cutting: real-time factor and view frame rate while cutting",
                   __doc__.split("\n\n", 1)[1].split("    python")[0].strip() + "\n\n" +
                   markdown_table([{k: ("" if v is None else v) for k, v in r.items()} for r in rows]))
    return rows


if __name__ == "__main__":
    run(quick="--quick" in sys.argv)
