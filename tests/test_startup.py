"""Startup stays light: ``import hmid`` and ``hmid --help`` load no heavy dependency, and every
public name is still importable from where it was."""

import subprocess
import sys

import pytest

HEAVY = ("pandas", "pint", "jax", "scipy", "matplotlib")


def _heavy_loaded(code: str) -> list[str]:
    """The heavy packages in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    probe = f"{code}\nimport sys\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    # a fresh process: this test session has long since imported all of them
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120
    )
    return done.stdout.split()


def test_import_hmid_loads_no_heavy_dependency():
    assert _heavy_loaded("import hmid") == []


def test_cli_help_loads_no_heavy_dependency():
    code = (
        "import contextlib, io\n"
        "from hmid.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "    main(['--help'])\n"
    )
    assert _heavy_loaded(code) == []


@pytest.mark.parametrize(
    "command", ["simulate", "run", "summary", "sweep", "blind", "runs", "population"]
)
def test_each_command_help_loads_no_heavy_dependency(command):
    code = (
        "import contextlib, io\n"
        "from hmid.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        f"    main([{command!r}, '--help'])\n"
    )
    assert _heavy_loaded(code) == []


def test_public_names_still_import():
    import hmid
    import hmid.io

    for package in (hmid, hmid.io):
        for name in package.__all__:
            assert getattr(package, name) is not None, f"{package.__name__}.{name}"
    assert "Log" in dir(hmid) and "read_log" in dir(hmid.io)
    from hmid.io import read_log
    from hmid.io.read import read_log as direct

    assert read_log is direct


def test_an_unknown_name_is_still_an_attribute_error():
    import hmid
    import hmid.io

    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        hmid.nope  # noqa: B018
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        hmid.io.nope  # noqa: B018
    with pytest.raises(ImportError):
        from hmid.io import nope  # noqa: F401
