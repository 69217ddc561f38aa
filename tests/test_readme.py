"""The README's Python example runs against the current API and cuts what it says: the tool
travels 2e-5 m per step for 2000 steps after going in, so the incision is about 4 cm long."""

import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


@pytest.mark.cpu_only(reason="the example runs on the default device, the CPU")
def test_readme_example_runs_and_cuts_four_centimetres():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert blocks, "README.md has no Python example"
    namespace: dict = {}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102 - the documented example
    sim = namespace["sim"]
    incision = sim.cutter.metrics(sim.positions)["incision"]
    travel = 2e-5 * (2200 - 200)
    assert incision["length_m"] == pytest.approx(travel, rel=0.05)
    assert "length_m" in out.getvalue()
