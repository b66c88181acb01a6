"""Run folders: a manifest from the first moment, complete or failed at the end (Ctrl-C too),
and ``hmid runs`` to list them and remove the failed ones."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from hmid.cli import main
from hmid.runs import list_runs, open_run


def _open(tmp_path, results, name="exp"):
    config = tmp_path / "c.yaml"
    config.write_text("name: exp\n")
    return open_run(results, name, config, '{"name": "exp"}', 1, [])


def _manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


@pytest.mark.parametrize("error", [ValueError("bad  thing\nhappened"), KeyboardInterrupt()])
def test_a_run_that_fails_says_so_in_its_manifest(tmp_path, error):
    results = tmp_path / "results"
    with pytest.raises(type(error)), _open(tmp_path, results) as folder:
        assert _manifest(folder.path)["status"] == "running"  # said before any work
        raise error
    record = _manifest(folder.path)
    assert record["status"] == "failed" and record["finished"]
    expected = "bad thing happened" if isinstance(error, ValueError) else "interrupted (Ctrl-C)"
    assert record["error"] == expected


def test_runs_lists_every_status_and_removes_only_failed_and_stale(tmp_path, capsys):
    results = tmp_path / "results"
    with _open(tmp_path, results) as done:
        pass
    with pytest.raises(RuntimeError), _open(tmp_path, results) as failed:
        raise RuntimeError("no")
    with _open(tmp_path, results) as killed:
        gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True, check=True)  # fmt: skip
        record = _manifest(killed.path)
        record["status"], record["process"]["pid"] = "running", int(gone.stdout)
        frozen = json.dumps(record)
    (killed.path / "manifest.json").write_text(frozen)  # as if SIGKILLed mid-run
    statuses = {e.path: e.status for e in list_runs(results)}
    assert statuses == {done.path: "complete", failed.path: "failed", killed.path: "stale"}

    assert main(["runs", str(results), "--failed"]) == 0
    listed = {line.split()[2]: line.split()[0] for line in capsys.readouterr().out.splitlines()}
    assert listed == {str(failed.path): "failed", str(killed.path): "stale"}
    assert main(["runs", str(results), "--remove-failed"]) == 0
    assert "removed 2" in capsys.readouterr().out
    assert done.path.is_dir() and not failed.path.exists() and not killed.path.exists()


def test_runs_of_a_missing_folder_is_one_line(tmp_path, capsys):
    assert main(["runs", str(tmp_path / "nowhere")]) == 2
    assert "not a folder of results" in capsys.readouterr().err
