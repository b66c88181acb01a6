"""The stage runner: cache reuse, invalidation by config and upstream, --force, missing inputs."""

from dataclasses import dataclass

import pytest

from hmid.pipeline import Runner, Stage


@dataclass(frozen=True)
class Cfg:
    a: int
    b: int


def _stages(calls):
    def first(config):
        calls.append("first")
        return config.a * 10

    def second(config, first):
        calls.append("second")
        return first + config.b

    return (
        Stage("first", first, (), lambda c: {"a": c.a}),
        Stage("second", second, ("first",), lambda c: {"b": c.b}),
    )


def test_second_run_reads_everything_from_the_cache(tmp_path):
    calls = []
    out1 = Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    runner = Runner(tmp_path)
    out2 = runner.run(_stages(calls), Cfg(1, 2))
    assert out1 == out2 == {"first": 10, "second": 12}
    assert calls == ["first", "second"]
    assert all(r.cached for r in runner.records.values())


def test_changing_a_downstream_section_recomputes_only_downstream(tmp_path):
    calls = []
    Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    calls.clear()
    runner = Runner(tmp_path)
    assert runner.run(_stages(calls), Cfg(1, 5))["second"] == 15
    assert calls == ["second"]
    assert runner.records["first"].cached and not runner.records["second"].cached


def test_changing_an_upstream_section_recomputes_everything_after_it(tmp_path):
    calls = []
    Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    calls.clear()
    assert Runner(tmp_path).run(_stages(calls), Cfg(3, 2))["second"] == 32
    assert calls == ["first", "second"]


def test_force_recomputes_all(tmp_path):
    calls = []
    Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    calls.clear()
    Runner(tmp_path, force=True).run(_stages(calls), Cfg(1, 2))
    assert calls == ["first", "second"]


def test_cache_files_are_complete_or_absent(tmp_path):
    Runner(tmp_path).run(_stages([]), Cfg(1, 2))
    names = sorted(p.name for p in tmp_path.iterdir())
    assert len(names) == 2 and all(n.endswith(".pkl") for n in names)  # no temp leftovers


def test_a_stage_before_its_inputs_is_an_error(tmp_path):
    first, second = _stages([])
    with pytest.raises(ValueError, match="needs \\['first'\\]"):
        Runner(tmp_path).run((second, first), Cfg(1, 2))
