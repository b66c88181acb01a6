"""The sweep's process pool replaces a worker after a bounded number of runs, so that what a
run leaves behind in a worker (JAX's caches) cannot grow without bound over a long suite."""

import os

from hmid.sweep import ExecutorSection
from hmid.sweep._execute import RUNS_PER_WORKER, open_executor


def test_a_worker_is_replaced_after_its_share_of_runs():
    with open_executor(ExecutorSection(workers=1)) as pool:
        pids = [pool.submit(os.getpid).result() for _ in range(RUNS_PER_WORKER + 1)]
    assert len(set(pids[:RUNS_PER_WORKER])) == 1
    assert pids[-1] != pids[0]
