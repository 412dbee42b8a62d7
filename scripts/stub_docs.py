"""Copies the docstrings of the compiled module into its stub, so an IDE shows them.

The Rust `///` comments are the one source: they become `__doc__` at runtime, and this
script writes each into python/twip/_core.pyi (classes, methods, properties, functions).
Run it after changing the bindings' docs; tests/test_stub.py fails while the two differ.

    python scripts/stub_docs.py          # rewrite the stub
    python scripts/stub_docs.py --check  # exit 1 if the stub is out of date
"""
from __future__ import annotations

import ast
import inspect
import sys
from pathlib import Path

STUB = Path(__file__).resolve().parents[1] / "python" / "twip" / "_core.pyi"


def runtime_doc(obj) -> str | None:
    """The docstring a stub entry should carry: its own, cleaned; None for inherited
    defaults (object's, Exception's) and dunders."""
    doc = getattr(obj, "__doc__", None)
    if not doc:
        return None
    if isinstance(obj, type) and doc in (object.__doc__, Exception.__doc__, ValueError.__doc__):
        return None
    return inspect.cleandoc(doc)


def _docstring(text: str, indent: str) -> list[str]:
    body = text.replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    lines = body.split("\n")
    if len(lines) == 1:
        return [f'{indent}"""{lines[0]}"""']
    return [f'{indent}"""{lines[0]}'] + [f"{indent}{line}" if line else "" for line in lines[1:]] + [f'{indent}"""']


def _entries(tree: ast.Module, module):
    """(node, runtime object) for every class, function and method of the stub."""
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and hasattr(module, node.name):
            cls = getattr(module, node.name)
            yield node, cls
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and not item.name.startswith("__"):
                    attr = inspect.getattr_static(cls, item.name, None)
                    if isinstance(attr, (staticmethod, classmethod)):
                        attr = attr.__func__
                    if attr is not None:
                        yield item, attr
        elif isinstance(node, ast.FunctionDef) and hasattr(module, node.name):
            yield node, getattr(module, node.name)


def documented(source: str, module) -> str:
    """The stub `source` with every entry's docstring set to the runtime one."""
    tree = ast.parse(source)
    lines = source.split("\n")
    edits = []  # (first line, last line, replacement lines), 0-based inclusive
    for node, obj in _entries(tree, module):
        doc = runtime_doc(obj)
        body = node.body
        indent = " " * (node.col_offset + 4)
        has_doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str)
        if has_doc:
            first, last = body[0].lineno - 1, body[0].end_lineno - 1
            new = _docstring(doc, indent) if doc else []
            if len(body) == 1 and not new:  # the docstring was the whole body
                new = [f"{indent}..."]
            edits.append((first, last, new))
        elif doc:
            # the line holding "..." or the first member (its decorators included)
            head_end = min([body[0].lineno] + [d.lineno for d in getattr(body[0], 'decorator_list', [])]) - 1
            line = lines[head_end]
            if line[:body[0].col_offset].strip():
                # `def f(...) -> X: ...`: the body shares the header's line; split them
                edits.append((head_end, head_end, [line[:body[0].col_offset].rstrip()] + _docstring(doc, indent)
                              + ([] if _is_ellipsis(body[0]) else [indent + line[body[0].col_offset:]])))
            else:
                edits.append((head_end, head_end - 1, _docstring(doc, indent)))
    # Bottom up; on one line, a replacement before an insertion above it.
    for first, last, new in sorted(edits, key=lambda e: (e[0], e[1] >= e[0]), reverse=True):
        lines[first:last + 1] = new
    return "\n".join(lines)


def _is_ellipsis(node) -> bool:
    return isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and node.value.value is Ellipsis


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(STUB.parents[1]))
    from twip import _core

    source = STUB.read_text()
    new = documented(source, _core)
    if "--check" in argv:
        if new != source:
            print(f"{STUB} is out of date: run python scripts/stub_docs.py")
            return 1
        return 0
    STUB.write_text(new)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
