"""The library's layers: model families and models say what they compute and what to draw; the
runner (hmid.pipeline, hmid.workers, the command line) decides where and when it runs. No module
under hmid/models or hmid/families imports the runner, even inside a function."""

import ast
from pathlib import Path

import pytest

import hmid

ROOT = Path(hmid.__file__).parent
RUNNER = ("hmid.workers", "hmid.pipeline", "hmid.cli")


def imported(source: str, package: str) -> set[str]:
    """Every module ``source`` imports (at its top or inside a function), as absolute names;
    ``from a import b`` counts as ``a`` and ``a.b`` (b may be a module)."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the file's package up
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def _runner(name: str) -> bool:
    return any(name == r or name.startswith(f"{r}.") for r in RUNNER)


@pytest.mark.parametrize("layer", ["models", "families"])
def test_models_and_families_do_not_import_the_runner(layer):
    files = sorted((ROOT / layer).rglob("*.py"))
    assert files
    found = []
    for path in files:
        package = ".".join(path.relative_to(ROOT.parent).parent.parts)
        names = imported(path.read_text(encoding="utf-8"), package)
        found += [f"{path.relative_to(ROOT.parent)}: {n}" for n in sorted(names) if _runner(n)]
    assert not found, found


@pytest.mark.parametrize(
    "source",
    [
        "def f():\n    from hmid.workers import Tasks\n",
        "import hmid.pipeline.reporting\n",
        "from hmid import cli\n",
        "from ... import workers\n",
    ],
)
def test_the_check_sees_every_form_of_import(source):
    assert any(_runner(n) for n in imported(source, "hmid.families.sub"))
