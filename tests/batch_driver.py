"""``python batch_driver.py ACTION ARG warp-cut-args...``: runs ``warp-cut`` with an event at
a chosen point, for the batch tests (not a test module itself).

ACTION is one of
  kill-batch K    SIGKILL the batch and its pool workers (its process group, as kill -9 on a
                  session would) right after the K-th scenario is committed;
  kill-worker K   SIGKILL the pool's worker processes right after the K-th commit (the
                  next scenario is then running in one of them);
  poison TEXT     a pool worker SIGKILLs itself when its scenario's overrides mention TEXT
                  (a scenario that takes its worker down every time, as a crash would).
"""

import multiprocessing
import os
import signal
import sys

from warp_cut.batch import pool, store
from warp_cut.cli import main

ACTION, ARG = sys.argv[1], sys.argv[2]
_commit, _committed = store.BatchStore.commit, []
_run_scenario = pool.run_scenario


def _commit_then_act(self, scenario, outcome):
    record = _commit(self, scenario, outcome)
    _committed.append(scenario.id)
    if len(_committed) == int(ARG):
        if ACTION == "kill-batch":
            os.killpg(0, signal.SIGKILL)
        for child in multiprocessing.active_children():
            print(f"batch_driver: killing worker {child.pid}", file=sys.stderr, flush=True)
            os.kill(child.pid, signal.SIGKILL)
    return record


def _poisoned(task):
    if any(ARG in item for item in task["overrides"]):
        os.kill(os.getpid(), signal.SIGKILL)
    return _run_scenario(task)


if __name__ == "__main__":
    if ACTION in ("kill-batch", "kill-worker"):
        store.BatchStore.commit = _commit_then_act
    sys.exit(main(sys.argv[3:]))
elif ACTION == "poison":  # in a pool worker, which imports this file as __mp_main__ (spawn)
    pool.run_scenario = _poisoned
