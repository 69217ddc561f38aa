"""A gate in front of the batch's scenarios on Dask workers, for the batch tests (not a test
module): ``client.run(install, gate_dir)`` makes each worker's ``run_scenario`` announce
itself and wait for the test before it runs the scenario.

A gated scenario writes ``started-PID`` into ``gate_dir`` (its Dask task key inside, written
atomically), then waits until ``gate_dir/open`` exists. So a test knows which worker process
holds which scenario, and can kill that process while the scenario is certainly unfinished:
no race with the scenario's end, however fast or slow the machine. A worker started later (the
nanny's replacement of a killed one) has no gate.
"""

import os
import time
from pathlib import Path

from distributed import get_worker

from warp_cut.batch import pool

GATE_TIMEOUT_S = 600.0
"""Longest a gated scenario waits for the gate [s] (a test that died never opens it)."""


def install(gate_dir: str) -> None:
    """Put the gate in front of this worker's ``warp_cut.batch.pool.run_scenario`` (a task
    names the function by module and name, so the worker calls the gated one)."""
    run = pool.run_scenario
    gate = Path(gate_dir)

    def gated(task: dict) -> dict:
        note = gate / f".started-{os.getpid()}"
        note.write_text(str(get_worker().get_current_task()))
        note.rename(gate / f"started-{os.getpid()}")
        deadline = time.monotonic() + GATE_TIMEOUT_S
        while not (gate / "open").exists():
            if time.monotonic() > deadline:
                raise TimeoutError(f"the gate {gate} was not opened")
            time.sleep(0.01)
        return run(task)

    pool.run_scenario = gated
