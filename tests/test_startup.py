"""Startup stays light: ``import hmid`` and ``hmid --help`` load no heavy dependency, and every
public name is still importable from where it was."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from hmid import __file__ as hmid_file
from hmid._startup import DEFERRED

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
    "command", ["simulate", "run", "summary", "sweep", "blind", "runs", "control", "population"]
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


# -- imports inside functions: only where a start-up cost or a cycle says so ------------------
ROOT = Path(hmid_file).parent


def _modules() -> dict[str, Path]:
    found = {}
    for path in [*ROOT.rglob("*.py"), *(ROOT.parent / "pipelines").rglob("*.py")]:
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


MODULES = _modules()


def _targets(node: ast.Import | ast.ImportFrom, package: str) -> list[str]:
    """The modules an import statement loads (``from a import b``: ``a.b`` where it is one)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    base = node.module or ""
    if node.level:
        parts = package.split(".")[: len(package.split(".")) - node.level + 1]
        base = ".".join([*parts, base] if base else parts)
    subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in MODULES]
    return subs or [base]


def _type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def _imports(name: str) -> tuple[list[str], list[tuple[int, str]]]:
    """(imports at the module's top, (line, import) inside functions) of hmid module ``name``."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top: list[str] = []
    inner: list[tuple[int, str]] = []

    def walk(node: ast.AST, nested: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if _type_checking(child):
                continue
            if isinstance(child, ast.Import | ast.ImportFrom):
                names = _targets(child, package)
                if nested:
                    inner.extend((child.lineno, n) for n in names)
                else:
                    top.extend(names)
            walk(child, nested or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef))

    walk(tree, False)
    return top, inner


def _loaded(name: str) -> set[str]:
    """What importing ``name`` loads at module tops, its parent packages included."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        current = todo.pop()
        parts = current.split(".")
        for i in range(1, len(parts) + 1):
            module = ".".join(parts[:i])
            if module in seen:
                continue
            seen.add(module)
            if module in MODULES:
                todo.extend(_imports(module)[0])
    return seen


def _heavy(name: str) -> bool:
    return any(m.split(".")[0] in DEFERRED for m in _loaded(name))


def _reason(module: str, target: str) -> str | None:
    """Why ``target`` may be imported inside a function of ``module`` (None: it may not)."""
    if target.split(".")[0] in DEFERRED:
        return "deferred library"
    if target in MODULES and _heavy(target):
        return "loads a deferred library"
    if module in _loaded(target):
        return "cycle"
    return None


def test_imports_inside_functions_are_deferred_libraries_or_cycles():
    found = []
    for module in sorted(MODULES):
        for line, target in _imports(module)[1]:
            if _reason(module, target) is None:
                found.append(f"{MODULES[module].relative_to(ROOT.parent)}:{line}: {target}")
    assert not found, "import these at the module's top:\n" + "\n".join(found)


def test_the_heavy_list_is_the_deferred_one():
    assert set(HEAVY) <= set(DEFERRED)
