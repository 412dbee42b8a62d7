"""The hand-written type stub python/twip/_core.pyi matches the compiled module."""
import subprocess
import sys

import pytest


def test_stub_matches_the_native_module():
    pytest.importorskip("mypy")
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "twip._core", "--ignore-disjoint-bases"],
        capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_stub_docstrings_are_the_runtime_ones():
    """The stub carries the Rust docs (scripts/stub_docs.py writes them; rerun it after
    changing a `///` comment of the bindings)."""
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "scripts" / "stub_docs.py"
    run = subprocess.run([sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr


def test_one_export_list():
    """`twip.__all__` is exactly what `twip/__init__.py` imports or defines in public, and
    every public class of the core is re-exported (the stub's `__all__` is the core's:
    stubtest checks that)."""
    import ast
    from pathlib import Path

    import twip
    from twip import _core

    tree = ast.parse(Path(twip.__file__).read_text())
    bound = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("twip"):
            bound |= {a.asname or a.name for a in node.names}
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            bound.add(node.name)
    bound |= set(getattr(twip, "_LAZY", {}))  # names loaded on first use (twip.identify: scipy)
    modules = {"interop", "scenarios"}  # subpackages imported for `twip.x.y` access
    public = {n for n in bound if not n.startswith("_") or n == "__version__"} - modules
    assert sorted(twip.__all__) == sorted(public)
    assert len(twip.__all__) == len(set(twip.__all__))
    core_classes = {n for n in _core.__all__ if isinstance(getattr(_core, n), type)}
    assert core_classes <= set(twip.__all__), core_classes - set(twip.__all__)
    for name in twip.__all__:
        assert getattr(twip, name) is not None
