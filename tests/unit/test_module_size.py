"""Modules and functions stay small enough to read: no module of the package over MAX_LINES lines, no function
over MAX_FUNCTION_LINES (a failure names every one over, the longest first)."""

from __future__ import annotations

import ast
from pathlib import Path

import zenav

PACKAGE = Path(zenav.__file__).resolve().parent
MAX_LINES = 600  # a module's lines
MAX_FUNCTION_LINES = 100  # a function's lines, from its `def` to its last line (nested functions within it included)


def modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def function_lengths(path: Path, root: Path = PACKAGE.parent) -> list[tuple[int, str]]:
    """(lines, where and which) of every function and method in `path`, nested ones too."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(root)
    return [
        (node.end_lineno - node.lineno + 1, f"{where}:{node.lineno} {node.name}")
        for node in ast.walk(tree)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno is not None
    ]


def test_the_package_has_modules_to_check():
    found = modules()
    assert PACKAGE / "common" / "runtime.py" in found and len(found) > 50


def test_no_module_is_over_the_limit():
    over = sorted(((len(p.read_text(encoding="utf-8").splitlines()), p.relative_to(PACKAGE.parent)) for p in modules()), reverse=True)
    over = [(n, p) for n, p in over if n > MAX_LINES]
    assert not over, f"modules over {MAX_LINES} lines (split them by concern): " + ", ".join(f"{p} ({n})" for n, p in over)


def test_no_function_is_over_the_limit():
    lengths = sorted((length for p in modules() for length in function_lengths(p)), reverse=True)
    over = [f"{where} ({n} lines)" for n, where in lengths if n > MAX_FUNCTION_LINES]
    assert not over, f"functions over {MAX_FUNCTION_LINES} lines (split them): " + ", ".join(over)


def test_a_function_is_measured_from_def_to_its_last_line(tmp_path):
    src = tmp_path / "m.py"
    src.write_text(
        "def f():\n    x = 1\n\n    return x\n\n\nclass C:\n    async def g(self):\n        def h():\n            pass\n        return h\n"
    )
    assert sorted(function_lengths(src, root=tmp_path)) == [(2, "m.py:9 h"), (4, "m.py:1 f"), (4, "m.py:8 g")]
