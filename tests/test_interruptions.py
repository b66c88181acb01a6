"""``hmid run`` stopped by a signal while a posterior is sampled: Ctrl-C (SIGINT to the whole
process group, as a terminal sends it) and SIGTERM (to the program, as ``kill`` sends it, or to
its group) end in one line on stderr, exit status 128 + the signal's number, the run folder
marked failed, and no process left behind (the workers ignore Ctrl-C; the program stops them)."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

#: A stage's line in a log (stderr is a pipe here): what ``hmid run`` says as it works.
STAGE_LINE = re.compile(r"hmid run: \w+ \d+\.\d s( \(cached\))? \[\d+ s\]")

ROOT = Path(__file__).resolve().parents[1]


def _config(tmp_path: Path) -> Path:
    """The demo with a long MCMC posterior (sampled first, so that a worker may be sampling it
    when the signal comes) and no loop."""
    config = yaml.safe_load((ROOT / "configs/demo.yaml").read_text())
    for entry in config["logs"]:
        for key in ("path", "columns"):
            entry[key] = str((ROOT / "configs" / entry[key]).resolve())
    sls = {"family": "sls", "spring": "cubic", "noise": "iid", "stride": 4}
    config["models"] = [
        sls | {"posterior": "mcmc", "max_steps": 200_000},
        {"family": "polynomial", "variants": ["quadratic_xv"]},
    ]
    del config["loop"]
    path = tmp_path / "demo.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def _gone(group: int, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.slow
@pytest.mark.parametrize(
    ("signum", "to_group", "said"),
    [
        (signal.SIGINT, True, "interrupted (Ctrl-C)"),
        (signal.SIGTERM, False, "terminated (SIGTERM)"),
        (signal.SIGTERM, True, "terminated (SIGTERM)"),
    ],
    ids=["ctrl-c", "kill", "kill group"],
)
def test_a_signal_during_sampling_is_one_line_and_the_run_is_marked_failed(
    tmp_path, signum, to_group, said
):
    results = tmp_path / "results"
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = os.environ | {"PYTHONPATH": path, "HMID_WORKERS": "1"}  # a worker, whatever the cores
    program = [sys.executable, "-c", "from hmid.cli import entry; entry()"]
    process = subprocess.Popen(
        [*program, "run", str(_config(tmp_path)), "--results", str(results)],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )
    try:
        deadline = time.monotonic() + 300
        while not list(results.glob("demo/.cache/sls-chain-*.h5")):  # sampling has begun
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "the sampler did not start"
            time.sleep(0.1)
        time.sleep(1.0)
        if to_group:
            os.killpg(process.pid, signum)
        else:
            process.send_signal(signum)
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == 128 + signum, err
    lines = [line for line in err.strip().splitlines() if not STAGE_LINE.fullmatch(line)]
    assert len(lines) == 1 and lines[0].startswith(f"hmid run: {said}; a run folder"), err
    (manifest,) = results.glob("demo/*/manifest.json")
    record = json.loads(manifest.read_text())
    assert record["status"] == "failed" and record["error"] == said
    assert _gone(process.pid, 10.0), "a worker outlived the program"
