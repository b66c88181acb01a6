"""What ``hmid run`` shows while it works: one line per stage in a log, bars in a terminal."""

import io

from hmid.progress import VARIABLE, Progress, bars_wanted


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_one_line_per_stage_and_no_bars():
    out = io.StringIO()
    progress = Progress(stream=out).stages(["load", "fit"])
    assert progress.bars is False
    for name in ("load", "fit"):
        progress.started(name)
        progress.done(name, 1.25, cached=name == "fit")
    with progress.count("figures", 3) as step:
        step()
    progress.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("hmid run: load 1.2 s [")
    assert lines[1].startswith("hmid run: fit 1.2 s (cached) [")


def test_quiet_says_nothing():
    out = io.StringIO()
    progress = Progress(stream=out, quiet=True).stages(["load"])
    progress.done("load", 0.1, None)
    assert out.getvalue() == ""


def test_a_terminal_gets_bars_and_the_stage_lines():
    out = _Terminal()
    progress = Progress(stream=out).stages(["load", "fit"])
    assert progress.bars is True
    progress.started("load")
    progress.done("load", 0.5, None)
    with progress.count("figures", 2) as step:
        step()
        step()
    progress.close()
    text = out.getvalue()
    assert "hmid run: load 0.5 s" in text and "stages" in text and "figures" in text


def test_workers_learn_from_the_environment(monkeypatch):
    monkeypatch.delenv(VARIABLE, raising=False)
    assert not bars_wanted()
    monkeypatch.setenv(VARIABLE, "1")
    assert bars_wanted()
