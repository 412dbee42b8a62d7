"""Files twip writes for its user (CSV tables, controller and robot files, reports): whole or
not at all. Each is written under a part name beside it and renamed when complete, so that
a Ctrl-C or a full disk never leaves a cut-short file under its name, nor destroys the file
that was there; an OS error names the file."""
from __future__ import annotations

import contextlib
import os
from pathlib import Path


def part_of(path, pid=None) -> Path:
    """Where `path` is written until it is whole: hidden, beside it, one per process (`pid`,
    default this one's; "*" makes a glob of every process's), its extension kept (a figure's
    format follows it)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.part{os.getpid() if pid is None else pid}{path.suffix}")


@contextlib.contextmanager
def replacing(path):
    """The path to write `path` under: renamed to `path` when the block finishes, removed
    when it does not; an OS error names `path` ("[Errno 28] No space left on device" alone
    named no file)."""
    path = Path(path)
    part = part_of(path)
    try:
        yield part
        os.replace(part, path)
    except OSError as e:
        raise OSError(e.errno, e.strerror or str(e), str(path)) from e
    finally:
        part.unlink(missing_ok=True)


@contextlib.contextmanager
def writing(path, mode: str = "w", **open_options):
    """A file object for `path`: it appears under that name only when the block finishes."""
    with replacing(path) as part, open(part, mode, **open_options) as f:
        yield f


def write_text(path, text: str, encoding: str = "utf-8") -> None:
    """`path.write_text(text)`, whole or not at all."""
    with writing(path, "w", encoding=encoding) as f:
        f.write(text)
