"""Every ```python block of the README runs as written (in a temporary folder, headless).

A block that must not run here would be marked by a first line `# not run: <why>`; none is.
"""
from __future__ import annotations

import re
import sys
import types
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks() -> list[tuple[str, str]]:
    """(the heading above it, code) of every python block, in order."""
    text = README.read_text()
    out = []
    for m in re.finditer(r"```python\n(.*?)```", text, re.S):
        heading = re.findall(r"^## (.+)$", text[: m.start()], re.M)
        out.append((heading[-1] if heading else "top", m.group(1)))
    return out


BLOCKS = _blocks()


def test_the_readme_has_its_examples():
    headings = [h for h, _ in BLOCKS]
    assert {"Use", "Your controller", "Your robot", "Design a controller for your robot"} <= set(headings), headings


@pytest.mark.parametrize("heading, code", BLOCKS, ids=[f"{i}:{h}" for i, (h, _) in enumerate(BLOCKS)])
def test_the_readme_block_runs(heading, code, tmp_path, monkeypatch, capsys):
    if code.startswith("# not run:"):
        pytest.skip(code.splitlines()[0])
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    # A module of its own, as a script would be: its classes pickle for a sweep's workers.
    module = types.ModuleType("readme_example")
    monkeypatch.setitem(sys.modules, "readme_example", module)
    exec(compile(code, f"README.md: {heading}", "exec"), module.__dict__)
    out = capsys.readouterr().out
    if "print(" in code:  # the examples print a run's outcome first
        assert out.startswith("completed"), out
    for name in re.findall(r'"([\w.]+\.(?:png|gif|toml))"', code):
        assert (tmp_path / name).stat().st_size > 0, name
