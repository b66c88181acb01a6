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


# -- function length: a function over 60 lines is several steps that want names ---------------
MAX_LINES = 60
#: Functions allowed to be longer, each with its reason.
LONG_ALLOWED = {
    "hmid/cli.py:build_parser",  # an argparse table: one line per option, nothing to name
}


def _functions(tree: ast.AST, prefix: str = ""):
    """``(qualified name, node)`` of every function in ``tree``, nested ones and methods too."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            name = f"{prefix}{node.name}"
            if not isinstance(node, ast.ClassDef):
                yield name, node
            yield from _functions(node, f"{name}.")
        else:
            yield from _functions(node, prefix)


def _long_functions(source: str, where: str) -> dict[str, int]:
    """``{where:qualified name: lines}`` of the functions of ``source`` over MAX_LINES lines
    (from ``def`` to the last line of the body, decorators not counted)."""
    found = {}
    for name, node in _functions(ast.parse(source)):
        assert node.end_lineno is not None
        lines = node.end_lineno - node.lineno + 1
        if lines > MAX_LINES:
            found[f"{where}:{name}"] = lines
    return found


def test_no_function_is_longer_than_60_lines():
    files = sorted([*ROOT.rglob("*.py"), *(ROOT.parent / "pipelines").rglob("*.py")])
    assert files
    found = {}
    for path in files:
        where = path.relative_to(ROOT.parent).as_posix()
        found.update(_long_functions(path.read_text(encoding="utf-8"), where))
    long = {name: lines for name, lines in found.items() if name not in LONG_ALLOWED}
    assert not long, f"split these into named steps (at most {MAX_LINES} lines each): {long}"
    assert not LONG_ALLOWED - set(found), "no longer long: drop from LONG_ALLOWED"


def test_the_length_check_sees_methods_and_nested_functions():
    body = "".join(f"        x{i} = {i}\n" for i in range(MAX_LINES))  # 60 lines of a body
    source = (
        f"class C:\n    def m(self):\n{body}\ndef f():\n    def g():\n{body}\ndef h():\n    pass\n"
    )
    assert _long_functions(source, "x.py") == {"x.py:C.m": 61, "x.py:f": 62, "x.py:f.g": 61}
