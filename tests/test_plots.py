"""Pictures: written by a run, atomically, and showing what they claim to show."""

import numpy as np
from matplotlib.image import imread

from warp_cut import Material, TissueModel
from warp_cut.cli import main
from warp_cut.cut.classes import NODE_CLASS_COLORS, NodeClass
from warp_cut.io.plots import CURVED_DEG, RunPicture, _view, plot_preview, write_run_plots


def _has_color(img, rgb, tol=0.03):
    return bool(np.any(np.all(np.abs(img[:, :, :3] - np.asarray(rgb)) < tol, axis=2)))


def test_run_writes_preview_and_force_plots(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "skin_press", "--quiet", "--no-usd", "--out", str(out), "--set", "duration=0.5",
                 "--set", "tissue.size=[0.02,0.02]"]) == 0
    for name in ("preview.png", "tool_force.png"):
        img = imread(out / name)
        assert img.shape[0] > 300 and img.shape[1] > 400  # a figure (6.4 x 4.8 in at 120 dpi or more)
        assert img[:, :, :3].std() > 0.05  # not a blank page (std 0); drawn lines and text give ~0.1+
    assert not (out / "width.png").exists()  # no incision width column without a cut
    preview = imread(out / "preview.png")
    assert _has_color(preview, NODE_CLASS_COLORS[NodeClass.NORMAL])
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_preview_shows_each_node_class_and_the_incision(tmp_path):
    model = TissueModel.from_patch((0.02, 0.01), 0.002, material=Material())
    classes = np.zeros(model.node_count, np.int8)
    classes[:4] = [NodeClass.GREY, NodeClass.YELLOW, NodeClass.BLUE, NodeClass.LIP]
    controls = np.array([[-0.008, 0, 0], [-0.003, 0.001, 0], [0.003, -0.001, 0], [0.008, 0, 0]])
    pic = RunPicture(model.points, model.triangles, model.active, classes, incision=controls,
                     tool=(np.array([0.008, 0, 0]), np.array([0.02, 0, 0.01])), time=1.0)
    img = imread(plot_preview(tmp_path / "p.png", pic))
    for cls in (NodeClass.GREY, NodeClass.YELLOW, NodeClass.BLUE, NodeClass.LIP):
        assert _has_color(img, NODE_CLASS_COLORS[cls], tol=0.05), cls.name
    assert _has_color(img, (0.45, 0.02, 0.02), tol=0.05)  # the incision curve


def test_width_plot_when_the_column_exists(tmp_path):
    t = np.linspace(0, 1, 61)
    w = np.interp(t, [0, 0.1, 0.4, 1], [0, 3e-3, 1e-3, 1e-3])
    cols = {"t": t, "tool_fx": 0 * t, "tool_fy": 0 * t, "tool_fz": -t, "incision_width_m": w}
    written = write_run_plots(tmp_path, cols, None, "demo")
    assert [p.name for p in written] == ["tool_force.png", "width.png"]
    img = imread(tmp_path / "width.png")
    assert img[:, :, :3].std() > 0.05


def test_the_view_follows_the_surface_not_a_few_tilted_triangles():
    """A flat 10 x 10 grid with its corner raised (two triangles tilted by ~60 degrees, 1 % of
    the area) is seen from above; bent into a half cylinder it is seen in perspective."""
    g = np.linspace(0.0, 0.01, 11)
    xx, yy = np.meshgrid(g, g)
    flat = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)
    quads = [(i * 11 + j, i * 11 + j + 1, (i + 1) * 11 + j + 1, (i + 1) * 11 + j) for i in range(10) for j in range(10)]
    tri = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    tilted = flat.copy()
    tilted[0, 2] = 0.001 * np.tan(np.radians(60.0))  # the corner raised: its two triangles tilt
    def picture(x):
        return RunPicture(positions=x, triangles=tri, active=np.ones(len(x), bool), node_class=np.zeros(len(x), int))
    normal, turn = _view(picture(tilted))
    assert np.allclose(normal, [0, 0, 1], atol=0.05) and turn < CURVED_DEG
    phi = np.pi * flat[:, 0] / 0.01
    bent = np.stack([0.01 / np.pi * np.cos(phi), flat[:, 1], 0.01 / np.pi * np.sin(phi)], axis=1)
    assert _view(picture(bent))[1] > CURVED_DEG
