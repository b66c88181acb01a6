"""The stage runner: cache reuse, invalidation by config, upstream, code and library versions,
--force, missing inputs, damaged entries (recomputed, never used) and concurrent runs (locked)."""

import pickle
import threading
import time
import warnings
from dataclasses import dataclass

import pytest

from hmid.errors import HmidWarning
from hmid.pipeline import Pending, Runner, Stage
from hmid.pipeline.cache import read_entry


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
    names = sorted(p.name for p in tmp_path.iterdir() if p.is_file())
    assert len(names) == 2 and all(n.endswith(".pkl") for n in names)  # no temp leftovers


def test_a_stage_before_its_inputs_is_an_error(tmp_path):
    first, second = _stages([])
    with pytest.raises(ValueError, match="needs \\['first'\\]"):
        Runner(tmp_path).run((second, first), Cfg(1, 2))


def _entry(tmp_path, name):
    (path,) = tmp_path.glob(f"{name}-*.pkl")
    return path


@pytest.mark.parametrize(
    "damage",
    [
        pytest.param(lambda b: pickle.dumps(999) + b[-45:], id="altered but unpickles"),
        pytest.param(lambda b: pickle.dumps(999), id="plain pickle, no checksum"),
        pytest.param(lambda b: b[: len(b) // 2], id="truncated"),
        pytest.param(lambda b: b"", id="empty"),
        pytest.param(lambda b: bytes(range(256)) * 3, id="random bytes"),
    ],
)
def test_a_damaged_entry_is_recomputed_with_a_note_never_used(tmp_path, damage):
    calls = []
    Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    path = _entry(tmp_path, "first")
    path.write_bytes(damage(path.read_bytes()))
    calls.clear()
    runner = Runner(tmp_path)
    with pytest.warns(HmidWarning, match=r"first-.*\.pkl: cache entry .*recomputing stage 'first'"):
        out = runner.run(_stages(calls), Cfg(1, 2))
    assert out == {"first": 10, "second": 12}
    assert calls == ["first"]  # 'second' keeps its valid entry: same key, same input
    assert not runner.records["first"].cached
    assert read_entry(path) == ("first", 10)  # the entry is whole again, with its stage


def test_an_entry_copied_over_another_stages_is_recomputed_with_a_note(tmp_path):
    calls = []
    Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    first, second = _entry(tmp_path, "first"), _entry(tmp_path, "second")
    first.write_bytes(second.read_bytes())  # a valid checksum, another stage's content
    calls.clear()
    with pytest.warns(HmidWarning, match="holds 'second', not stage 'first'"):
        out = Runner(tmp_path).run(_stages(calls), Cfg(1, 2))
    assert out == {"first": 10, "second": 12} and calls == ["first"]


def test_the_key_covers_the_stage_wiring_and_the_computing_libraries(tmp_path, monkeypatch):
    import importlib.util
    from importlib import metadata

    from hmid.pipeline import runner as module

    base = module.code_fingerprint.__wrapped__()
    real_version = metadata.version
    monkeypatch.setattr(
        metadata, "version", lambda n: "0.0.1" if n == "statsmodels" else real_version(n)
    )
    assert module.code_fingerprint.__wrapped__() != base
    monkeypatch.setattr(metadata, "version", real_version)

    wiring = tmp_path / "pipelines"
    wiring.mkdir()
    (wiring / "__init__.py").write_text("")
    (wiring / "identify.py").write_text("STAGES = ()\n")
    real_spec = importlib.util.find_spec
    fake = importlib.machinery.ModuleSpec("pipelines", None, is_package=True)
    fake.submodule_search_locations = [str(wiring)]
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda n, *a: fake if n == "pipelines" else real_spec(n, *a)
    )
    first = module.code_fingerprint.__wrapped__()
    (wiring / "identify.py").write_text("STAGES = ('load',)\n")
    assert module.code_fingerprint.__wrapped__() != first


def test_a_second_run_waits_for_the_stage_being_computed_and_reuses_it(tmp_path):
    calls = []

    def slow(config):
        calls.append("slow")
        time.sleep(0.5)
        return config.a

    stages = (Stage("slow", slow, (), lambda c: {"a": c.a}),)
    results = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        threads = [
            threading.Thread(target=lambda: results.append(Runner(tmp_path).run(stages, Cfg(4, 0))))
            for _ in range(2)
        ]
        for t in threads:
            t.start()
            time.sleep(0.1)
        for t in threads:
            t.join()
    assert results == [{"slow": 4}, {"slow": 4}]
    assert calls == ["slow"]
    assert any("another run is computing stage 'slow'" in str(w.message) for w in caught)


def _started_stages(calls):
    """A stage begun (its work goes on) before a stage that does not read it, and one after
    that reads it."""

    def begun(config):
        calls.append("begun")
        return Pending(lambda: calls.append("finished") or config.a * 10,
                       lambda: calls.append("cancelled"))  # fmt: skip

    def between(config):
        calls.append("between")
        return config.b

    def reader(config, begun, between):
        calls.append("reader")
        return begun + between

    return (
        Stage("begun", begun, (), lambda c: {"a": c.a}, started=True),
        Stage("between", between, (), lambda c: {"b": c.b}),
        Stage("reader", reader, ("begun", "between")),
    )


def test_a_started_stage_is_finished_when_a_later_stage_reads_it_and_cached(tmp_path):
    calls = []
    runner = Runner(tmp_path)
    assert runner.run(_started_stages(calls), Cfg(1, 2)) == {"begun": 10, "between": 2,
                                                             "reader": 12}  # fmt: skip
    assert calls == ["begun", "between", "finished", "reader"]
    assert list(runner.records) == ["between", "begun", "reader"]  # recorded when finished
    assert runner.records["begun"].cached is False
    calls.clear()
    again = Runner(tmp_path)
    assert again.run(_started_stages(calls), Cfg(1, 2))["reader"] == 12
    assert calls == [] and again.records["begun"].cached


def test_a_started_stage_no_stage_reads_is_finished_at_the_end(tmp_path):
    calls = []
    stages = _started_stages(calls)[:2]
    assert Runner(tmp_path).run(stages, Cfg(1, 2), keep=("begun",)) == {"begun": 10}
    assert calls == ["begun", "between", "finished"]


def test_a_failure_after_a_started_stage_cancels_its_work_and_lets_its_lock_go(tmp_path):
    def fails(config):
        raise RuntimeError("later stage")

    calls = []
    stages = (*_started_stages(calls)[:1], Stage("fails", fails))
    with pytest.raises(RuntimeError, match="later stage"):
        Runner(tmp_path).run(stages, Cfg(1, 2))
    assert calls == ["begun", "cancelled"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a held lock would warn that another run computes it
        assert Runner(tmp_path).run(stages[:1], Cfg(1, 2)) == {"begun": 10}
