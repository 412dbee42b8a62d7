"""A sweep's checkpoint folder, which cannot lie about what it holds.

- `lock`: one writer at a time. The lock is an OS file lock (released by the kernel when
  its process dies); the file names the holder's pid and host, so a second writer is told
  who holds it, and a lock left by a process that is gone (or a file that names no
  sweep) is noticed, named in a warning and taken over.
- `manifest.json`: the sweep's configuration and its fingerprint (`fingerprint`, the one
  function the API and the CLI share); another configuration in the folder is refused.
- `shard-<start>.npz`: one per finished shard, written under a temporary name and renamed
  when complete. Each carries the fingerprint and a SHA-256 of its arrays: a shard from
  another sweep, or a corrupt or truncated one, is named in a warning and recomputed.

The folder's writability is checked (by taking the lock) before any sample runs.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import signal
import socket
import threading
import warnings
from pathlib import Path
from typing import Dict, Iterator, Optional

import numpy as np

from twip import _core

LOCK = "lock"
MANIFEST = "manifest.json"
#: Config keys that say how the sweep was asked for, not what it computes: left out of
#: the fingerprint, so that a sweep by name (API) and by Scenario object (CLI) agree.
HOW_GIVEN = ("by_name", "options")
#: Arrays of a shard that are bookkeeping, not metrics.
_STAMP = ("fingerprint", "checksum")


def _bad(message: str) -> Exception:
    return _core.InvalidParameterError(message)


class CheckpointWriteError(OSError):
    """A checkpoint file that could not be written (a full disk, a file system gone
    read-only): names the file and keeps the OS error's errno. What was written before it
    stays, so the same sweep resumes from there."""

    def __init__(self, message: str, errno_: Optional[int] = None):
        super().__init__(message)
        self.errno = errno_


class CheckpointReadError(_core.TwipError):
    """A finished shard that a sweep's result reads its samples from is missing or damaged:
    its numbers cannot be given (rather than a summary of fewer samples)."""


def checkpoint_folder(path) -> Path:
    """`path` (a str or os.PathLike) as the checkpoint folder; an empty one, which is the
    working directory, is refused (it would fill it with the sweep's lock, manifest and shards)."""
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise TypeError(f"checkpoint must be a folder path (str or os.PathLike), got {path!r} ({type(path).__name__})")
    if not os.fspath(path):
        raise _bad("checkpoint = '': an empty path is the working directory; pass a folder for the sweep's shards")
    return Path(path)


def fingerprint(config: dict, shard_size: int) -> str:
    """The SHA-256 of what a sweep computes (its configuration and shard size)."""
    significant = {k: v for k, v in config.items() if k not in HOW_GIVEN}
    text = json.dumps({"config": significant, "shard_size": int(shard_size)}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def checksum(arrays: Dict[str, np.ndarray]) -> str:
    """SHA-256 over the arrays' names, dtypes, shapes and bytes, in name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


class Checkpoint:
    """A locked checkpoint folder for the sweep `config` in shards of `shard` samples.
    Call `close()` (or use it as a context manager) to release the lock."""

    def __init__(self, path, config: dict, shard: int):
        self.dir = checkpoint_folder(path)
        self.fingerprint = fingerprint(config, shard)
        self._fd: Optional[int] = None
        if self.dir.exists() and not self.dir.is_dir():
            raise _bad(f"checkpoint = {str(path)!r} is not a folder")
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise _bad(f"checkpoint = {str(path)!r}: cannot create the folder ({e.strerror or e})") from None
        self._lock()
        try:
            self._manifest(config, shard)
        except BaseException:
            self.close()
            raise

    @staticmethod
    def shard_size_of(path, config: dict) -> Optional[int]:
        """The shard size of the sweep `config` in folder `path`, when the folder holds that
        sweep (so that a resume keeps the size it began with), else None."""
        try:
            old = json.loads((Path(path) / MANIFEST).read_text())
            shard = int(old["manifest"]["shard_size"])
        except (OSError, ValueError, KeyError, TypeError):
            return None
        return shard if old.get("fingerprint") == fingerprint(config, shard) else None

    # ------------------------------------------------------------------ the lock
    def _lock(self):
        path = self.dir / LOCK
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise _bad(f"checkpoint folder {self.dir} is not writable ({e.strerror or e}); "
                       "pass a folder you can write to") from None
        try:
            locked = _flock(fd)
        except OSError:
            holder = self._holder(fd)
            os.close(fd)
            raise self._in_use(holder) from None
        previous = self._holder(fd)
        host = socket.gethostname()
        if "unreadable" in previous:
            # Not a sweep's record (a sweep writes its pid and host): no holder to wait for.
            warnings.warn(f"checkpoint {self.dir}: the lock file {path} held {previous['unreadable']!r}, not a "
                          "sweep's pid and host; took it over", stacklevel=3)
        elif previous.get("pid") is not None:
            # A pid left in the file: its holder ended without releasing (killed, crashed).
            # Without OS locks, a live holder on this host is still in charge.
            pid = int(previous["pid"])
            if not locked and previous.get("host") == host and pid != os.getpid() and _alive(pid):
                os.close(fd)
                raise self._in_use(previous)
            warnings.warn(f"checkpoint {self.dir}: took over the lock left by pid {pid} on host "
                          f"{previous.get('host', '?')}, which ended without releasing it", stacklevel=3)
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps({"pid": os.getpid(), "host": host}).encode(), 0)
        except OSError as e:  # a full disk: said before any sample runs
            os.close(fd)
            raise CheckpointWriteError(f"checkpoint: cannot write the lock file {path} ({e.strerror or e}); "
                                       "free space or use another folder", e.errno) from e
        self._fd = fd

    def _in_use(self, holder: dict) -> Exception:
        return _bad(f"checkpoint {self.dir} is in use by another sweep: pid {holder.get('pid', '?')} on host "
                    f"{holder.get('host', '?')}; wait for it to finish or use another folder")

    @staticmethod
    def _holder(fd: int) -> dict:
        """The lock file's record, {"pid": int, "host": str} as a sweep writes it; {} when
        empty (a clean release); {"unreadable": its text} for anything else."""
        try:
            text = os.pread(fd, 4096, 0).decode(errors="replace")
            record = json.loads(text) if text.strip() else {}
        except OSError:
            return {}
        except ValueError:
            record = None
        if record == {}:
            return record
        pid = record.get("pid") if isinstance(record, dict) else None
        # A pid os.kill takes as one process: not a bool, not 0 or negative (a group), not past pid_t.
        if isinstance(pid, bool) or not isinstance(pid, int) or not 0 < pid < 2**31 \
                or not isinstance(record.get("host"), str):
            return {"unreadable": text[:200]}
        return record

    def close(self):
        """Releases the lock (the file stays, empty: a clean release)."""
        if self._fd is not None:
            try:
                os.ftruncate(self._fd, 0)
            finally:
                os.close(self._fd)  # closing drops the OS lock
                self._fd = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------------ the manifest
    def _manifest(self, config, shard):
        path = self.dir / MANIFEST
        if path.exists():
            try:
                old = json.loads(path.read_text())
            except (OSError, ValueError) as e:
                raise _bad(f"checkpoint {path} cannot be read ({e}); use a new folder") from None
            manifest = old.get("manifest") if isinstance(old, dict) else None
            before, old_shard = (manifest.get("config"), manifest.get("shard_size")) if isinstance(manifest, dict) \
                else (None, None)
            if not (isinstance(before, dict) and before and isinstance(old_shard, int)
                    and not isinstance(old_shard, bool) and old_shard > 0):
                raise _bad(f"checkpoint {path} cannot be read (not a sweep's manifest: it needs "
                           "{\"manifest\": {\"config\": {...}, \"shard_size\": N}}); use a new folder")
            if fingerprint(before, old_shard) != self.fingerprint:
                diff = [k for k in {**before, **config} if k not in HOW_GIVEN and before.get(k) != config.get(k)]
                if old_shard != shard:
                    diff.append("shard_size")
                raise _bad(
                    f"checkpoint {self.dir} holds a sweep with a different configuration "
                    f"(differs in: {', '.join(diff) or 'unknown'}); use a new folder or the same arguments"
                )
        else:
            manifest = {"config": config, "shard_size": shard}
            # Options may hold objects (fuzzy sets): the manifest names them by their repr.
            # They are how the sweep was asked for, outside the fingerprint (HOW_GIVEN); the
            # controller's own fingerprint holds what they set.
            text = json.dumps({"fingerprint": self.fingerprint, "manifest": manifest}, indent=1, default=repr)
            self._write(path, text.encode())

    @staticmethod
    def _write(path: Path, data: bytes):
        tmp = path.with_name(path.name + f".tmp{os.getpid()}")
        try:
            with open(tmp, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException as e:  # Ctrl-C or a full disk mid-write: no half-written file left
            tmp.unlink(missing_ok=True)
            if isinstance(e, OSError):  # the bare "[Errno 28] No space left on device" named no file
                raise CheckpointWriteError(
                    f"checkpoint: cannot write {path} ({e.strerror or e}); the shards written before it are kept "
                    f"in {path.parent}: free space (or fix the folder) and run the same sweep again to resume",
                    e.errno) from e
            raise

    # ------------------------------------------------------------------ shards
    def shard_path(self, start: int) -> Path:
        return self.dir / f"shard-{start:012d}.npz"

    def save(self, start: int, raw: dict):
        arrays = {k: np.asarray(v) for k, v in raw.items() if k not in ("kernel", "interrupted")}
        stamp = {"fingerprint": np.array(self.fingerprint), "checksum": np.array(checksum(arrays))}
        buf = io.BytesIO()
        np.savez(buf, **arrays, **stamp)
        self._write(self.shard_path(start), buf.getvalue())

    def read(self, start: int, count: int, verify: bool = True) -> Optional[dict]:
        """Shard `start` (of `count` samples) as arrays, or None when it is missing; a
        foreign, corrupt or truncated shard is named in a warning and None returned (so
        that it is recomputed)."""
        arrays, why = self._load(start, count, verify)
        if why:
            warnings.warn(f"checkpoint shard {self.shard_path(start)} {why}; recomputing it", stacklevel=2)
        return arrays

    def _load(self, start: int, count: int, verify: bool):
        """(arrays, "") for a good shard; (None, why) for a foreign, corrupt or truncated
        one; (None, "") when it is missing."""
        path = self.shard_path(start)
        if not path.exists():
            return None, ""
        try:
            with open(path, "rb") as f, np.load(f) as data:  # np.load left a truncated file open
                arrays = {k: data[k] for k in data.files}
        except Exception as e:  # zip, pickle or I/O errors of a damaged file
            return None, f"is unreadable (truncated or corrupt: {type(e).__name__}: {e})"
        if str(arrays.get("fingerprint", "")) != self.fingerprint:
            return None, "belongs to another sweep (its configuration fingerprint differs)"
        stamp = str(arrays.pop("checksum", ""))
        arrays.pop("fingerprint")
        if verify and checksum(arrays) != stamp:
            return None, "is corrupt (its checksum does not match its contents)"
        index = arrays.get("index")
        if index is None or len(index) != count or (count and int(index[0]) != start):
            return None, f"does not hold samples {start}..{start + count - 1}"
        return arrays, ""

    def shards(self, layout, verify: bool = True) -> Iterator[dict]:
        """The stored shards of `layout` [(start, count)], one at a time (bounded memory).
        They are finished shards a result is read from: one that is missing or damaged
        raises CheckpointReadError (a summary of the others would be silently wrong)."""
        for start, count in layout:
            arrays, why = self._load(start, count, verify)
            if arrays is None:
                raise CheckpointReadError(
                    f"checkpoint shard {self.shard_path(start)} (samples {start}..{start + count - 1}) "
                    f"{why or 'is missing'}; this sweep's result reads its samples from it: run the same sweep "
                    "again (with this checkpoint) to recompute it")
            yield arrays


def _flock(fd: int) -> bool:
    """Takes the OS lock of `fd` without waiting: True if taken, False where the OS has
    no file locks; OSError if another process holds it."""
    try:
        import fcntl
    except ImportError:
        return False
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return True


@contextlib.contextmanager
def ctrl_c_held():
    """Holds a Ctrl-C (SIGINT) that arrives inside the block until the block is done, then
    delivers it to the handler that was in place. Keeping a finished shard (writing it, and
    counting it as finished) must not be cut in half: a KeyboardInterrupt inside numpy's
    zip writer left a ValueError and no partial result. Python runs signal handlers in the
    main thread only, so elsewhere the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            signal.raise_signal(signal.SIGINT)
