"""The live page in a real browser: headless Chromium (Debian's, driven by Playwright) opens
``warp-cut live``'s page after a scripted cut; the screenshot's 3D view must not be blank and
must show the wound in the class colours (lip, blue, yellow) where the page draws it.

Needs /usr/bin/chromium (``apt-get install chromium``) and the playwright package (test extra);
``make test-browser`` installs both and runs this file. The screenshot is written to
``$WARP_CUT_SCREENSHOT`` when set (``make test-browser``: docs/images/live_cut.png).
"""

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = os.environ.get("WARP_CUT_CHROMIUM", "/usr/bin/chromium")
pytestmark = pytest.mark.skipif(not Path(CHROMIUM).is_file(),
                                reason=f"no Chromium at {CHROMIUM}: apt-get install chromium, or make test-browser")
pytest.importorskip("viser", reason="the live extra is not installed (pip install -e '.[live]')")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (test extra)")

from warp_cut.cut.classes import NodeClass  # noqa: E402
from warp_cut.live import LiveCut  # noqa: E402
from warp_cut.live.app import LiveApp  # noqa: E402
from warp_cut.live.scene_view import CLASS_RGB  # noqa: E402
from warp_cut.live.scripted import straight_cut  # noqa: E402

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader"]  # WebGL by SwiftShader, on the CPU
TOLERANCE = 24
"""Largest difference per channel (0-255) of a pixel from a class colour to count as it."""
WOUND = (NodeClass.LIP, NodeClass.BLUE, NodeClass.YELLOW)


def _colour_counts(image: np.ndarray) -> dict:
    rgb = image[:, :, :3].astype(np.int16)
    return {cls: int(np.all(np.abs(rgb - CLASS_RGB[cls].astype(np.int16)) <= TOLERANCE, axis=2).sum())
            for cls in WOUND}


def _view_pixels(page, png: Path) -> np.ndarray:
    """The screenshot's 3D view left of the control panel, as (h, w, 3) uint8."""
    import matplotlib.image as mpimg

    title = page.get_by_text("warp-cut live: straight_incision")
    panel = title.locator("xpath=ancestor::div[contains(@class, 'Paper-root')][1]").bounding_box()
    page.screenshot(path=str(png))
    image = (mpimg.imread(png) * 255).round().astype(np.uint8)
    return image[:, : int(panel["x"]) - 2, :3]


@pytest.fixture(scope="module")
def cut_page():
    """The page of a live run, real-time threads running, after a scripted 3 cm cut (the
    scalpel lifted out above the wound's end); the run is then paused."""
    live = LiveCut("straight_incision")
    app = LiveApp(live, port=0)
    try:
        app.start()
        straight_cut(live, 0.03, back_to_start=False)
        live.set_paused(True)
        time.sleep(0.5)  # the page's last frame and status
        _, frame = live.view_frame()
        wound = frame.points[frame.node_class != NodeClass.NORMAL]
        app.viewer.view.aim(wound.mean(axis=0) + [0.006, -0.002, 0.0], 0.055)
        # only the wound may show the class colours: viser's logo (bottom left, 83 blue and 54
        # yellow pixels) and the scalpel's drag handle (blue and yellow axes) are hidden; the
        # logo failed the control whenever the wound's blue dots covered fewer than 830 pixels
        app.server.gui.configure_theme(control_width="large", show_logo=False)
        app.viewer.gizmo.visible = False
        yield app, frame
    finally:
        app.stop()
        live.close()


_FRAMES_DRAWN = """() => new Promise(done => { let n = 0;
    const next = () => (++n >= 3 ? done(n) : requestAnimationFrame(next)); requestAnimationFrame(next); })"""


def _wait_for_connection(app) -> None:
    deadline = time.monotonic() + 60
    while not app.server.get_clients() and time.monotonic() < deadline:
        time.sleep(0.2)


def _screenshot_when(page, png: Path, wanted, tries: int = 6, before=None) -> tuple:
    """Screenshot once the page has drawn a few frames; again (up to ``tries`` times, 2 s
    apart) until ``wanted(counts)`` holds: SwiftShader draws a few frames a second and a busy
    machine delays the page's handling of a scene message. ``before()`` runs before each
    try. Returns the last (view, counts)."""
    for attempt in range(tries):
        if before is not None:
            before()
        page.evaluate(_FRAMES_DRAWN)
        view = _view_pixels(page, png)
        counts = _colour_counts(view)
        if wanted(counts) or attempt == tries - 1:
            return view, counts
        time.sleep(2.0)


def test_page_shows_the_wound_in_class_colours(cut_page, tmp_path):
    app, frame = cut_page
    assert set(WOUND) <= set(np.unique(frame.node_class).tolist())  # the cut made each of them
    png, bare = tmp_path / "live_cut.png", tmp_path / "without_classes.png"
    with sync_api.sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            str(tmp_path / "profile"), executable_path=CHROMIUM, headless=True, args=FLAGS,
            viewport={"width": 1280, "height": 800})
        try:
            page = context.new_page()
            page.goto(app.url)
            page.wait_for_selector("canvas", timeout=60_000)
            _wait_for_connection(app)
            view, counts = _screenshot_when(page, png, lambda n: all(n[c] >= 20 for c in WOUND))
            # control: the same view without the class dots (hidden again at each try, in case
            # a later frame re-created them)
            _, without = _screenshot_when(
                page, bare, lambda n: all(n[c] <= 0.1 * counts[c] for c in WOUND),
                before=lambda: setattr(app.viewer.view.handles["dots"], "visible", False))
        finally:
            context.close()
    flat = view.reshape(-1, 3)
    assert np.all(flat >= 250, axis=1).mean() < 0.9, "the 3D view is blank"
    assert len(np.unique(flat // 16, axis=0)) > 20, "the 3D view has almost no colours"
    for cls in WOUND:
        assert counts[cls] >= 20, f"{cls.name} {tuple(CLASS_RGB[cls])} not on screen: {counts}"
        assert without[cls] <= 0.1 * counts[cls], f"{cls.name} pixels without the wound: {without}"
    target = os.environ.get("WARP_CUT_SCREENSHOT")
    if target:
        Path(target).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(png, target)
