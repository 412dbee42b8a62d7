"""Files twip writes for its user (CSV tables, controller and robot files, reports): whole or
not at all. Each is written under a part name beside it and renamed when complete, so that
a Ctrl-C or a full disk never leaves a cut-short file under its name, nor destroys the file
that was there; an OS error names the file."""
from __future__ import annotations

import contextlib
import os
from pathlib import Path


def part_of(path) -> Path:
    """Where `path` is written until it is whole (hidden, beside it, one per process)."""
    path = Path(path)
    return path.with_name(f".{path.name}.part{os.getpid()}")


@contextlib.contextmanager
def writing(path, mode: str = "w", **open_options):
    """A file object for `path`: it appears under that name only when the block finishes."""
    path = Path(path)
    part = part_of(path)
    try:
        with open(part, mode, **open_options) as f:
            yield f
        os.replace(part, path)
    except OSError as e:  # "[Errno 28] No space left on device" alone named no file
        part.unlink(missing_ok=True)
        raise OSError(e.errno, e.strerror or str(e), str(path)) from e
    except BaseException:
        part.unlink(missing_ok=True)
        raise


def write_text(path, text: str, encoding: str = "utf-8") -> None:
    """`path.write_text(text)`, whole or not at all."""
    with writing(path, "w", encoding=encoding) as f:
        f.write(text)
