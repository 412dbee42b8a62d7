"""The Python package's layout rules: no module reads another module's private name, and a
file over ~600 lines says at its top why it is one file."""
import ast
import pathlib

import twip

PACKAGE = pathlib.Path(twip.__file__).parent
SOURCES = sorted(PACKAGE.rglob("*.py"))
#: The extension module is private to the package as a whole, not to one module.
SHARED = {"_core"}
LONG_FILE_LINES = 600
LONG_FILE_REASON = "One file because"


def _is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__") and name not in SHARED


def _private_reads(path: pathlib.Path):
    """(line, text) of each private name that `path` takes from another twip module."""
    tree = ast.parse(path.read_text(), filename=str(path))
    modules = set()  # local names bound to twip modules
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("twip"):
            for alias in node.names:
                if _is_private(alias.name):
                    found.append((node.lineno, f"from {node.module} import {alias.name}"))
                modules.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("twip"):
                    modules.add(alias.asname or alias.name.split(".")[0])
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _is_private(node.attr):
            base = node.value
            while isinstance(base, ast.Attribute):
                base = base.value
            if isinstance(base, ast.Name) and base.id in modules:
                found.append((node.lineno, ast.unparse(node)))
    return found


def test_the_rule_sees_a_private_read(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from twip import sweep\nfrom twip.plot import _STYLE\nx = sweep._target\n")
    assert [text for _, text in _private_reads(bad)] == ["from twip.plot import _STYLE", "sweep._target"]


def test_no_module_reads_another_modules_private_name():
    offences = [f"{p.relative_to(PACKAGE)}:{line}: {text}" for p in SOURCES for line, text in _private_reads(p)]
    assert offences == []


def test_long_files_state_why_they_are_one_file():
    silent = []
    for path in SOURCES:
        text = path.read_text()
        if text.count("\n") > LONG_FILE_LINES and LONG_FILE_REASON not in (ast.get_docstring(ast.parse(text)) or ""):
            silent.append(f"{path.relative_to(PACKAGE)} ({text.count(chr(10))} lines)")
    assert silent == []
