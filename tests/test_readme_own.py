"""The README's "Your own controller" and "Your own robot" examples run as written."""
from __future__ import annotations

import re
import sys
import types
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _block(heading: str) -> str:
    text = README.read_text()
    section = text.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.mark.parametrize("heading", ["Your own controller", "Your own robot"])
def test_the_readme_example_runs(heading, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    # A module of its own, as a script would be: its classes pickle for a sweep's workers.
    module = types.ModuleType("readme_example")
    monkeypatch.setitem(sys.modules, "readme_example", module)
    code = _block(heading)
    assert len(code.strip().splitlines()) <= 16
    exec(compile(code, f"README.md: {heading}", "exec"), module.__dict__)
    out = capsys.readouterr().out
    assert out.startswith("completed"), out
