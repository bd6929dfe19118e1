"""Files and directories that appear whole or not at all (numpy-free: the Blender exporter uses it too).

A directory is built in a hidden sibling of its target and renamed into place when complete:
a rename inside one file system is atomic, so a reader (or a later run) sees either the old
directory, nothing, or the finished new one, whatever instant the writer is killed at. What a
killed writer leaves is a hidden sibling named ``.<name>.partial-<token>`` (or
``.<name>.old-<token>`` during the swap), which :func:`sweep_leftovers` removes.

* :func:`atomic_directory` -- a context manager yielding the temporary directory to fill.
* :func:`atomic_write_text` / :func:`atomic_write_bytes` -- one file through a temporary sibling.
* :func:`sweep_leftovers` -- remove what killed writers left beside a target.
* :class:`LockFile` -- one writer at a time for a path (``.<name>.lock`` beside it); a lock whose
  process is gone (same host: its pid is dead; another host: not refreshed for
  :data:`STALE_AFTER` seconds) is stale and taken over.
* :func:`sweep_partial_files` -- remove the ``*.partial`` temporary files a killed writer left
  inside a directory tree (Zarr writes each chunk as ``<chunk>.<token>.partial`` and renames it).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import time
import uuid
from contextlib import contextmanager
from pathlib import Path

PARTIAL = "partial"
OLD = "old"


def _sibling(path: Path, kind: str) -> Path:
    return path.parent / f".{path.name}.{kind}-{uuid.uuid4().hex[:12]}"


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except FileNotFoundError:
            pass


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_directory(path, replace: bool = False):
    """Yield a new empty temporary directory; on a normal exit it becomes ``path``.

    ``replace=False``: ``path`` must not exist (or be an empty directory) when the block ends,
    else :class:`FileExistsError`. ``replace=True``: an existing ``path`` is swapped out (renamed
    aside, then removed) only after the new one is complete. On an exception (KeyboardInterrupt
    included) the temporary directory is removed and ``path`` is left as it was.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    tmp = _sibling(path, PARTIAL)
    tmp.mkdir()
    try:
        yield tmp
        _fsync_dir(tmp)
        old = None
        if path.exists() or path.is_symlink():
            if path.is_dir() and not path.is_symlink() and not any(path.iterdir()):
                path.rmdir()
            elif replace:
                old = _sibling(path, OLD)
                os.rename(path, old)
            else:
                raise FileExistsError(f"{path} exists; not replacing it")
        os.rename(tmp, path)
        _fsync_dir(parent)
        if old is not None:
            _remove(old)
    except BaseException:
        _remove(tmp)
        raise


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary sibling, fsync and rename (never half-written)."""
    path = Path(path)
    tmp = _sibling(path, PARTIAL)
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise
    _fsync_dir(path.parent)
    return path


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> Path:
    """:func:`atomic_write_bytes` for text."""
    return atomic_write_bytes(path, text.encode(encoding))


def leftovers(path) -> list[Path]:
    """The hidden siblings (``.<name>.partial-*``, ``.<name>.old-*``) that killed writers of ``path`` left."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        return []
    found = []
    for kind in (PARTIAL, OLD):
        found.extend(sorted(parent.glob(f".{path.name}.{kind}-*")))
    return found


def sweep_leftovers(path) -> list[Path]:
    """Remove :func:`leftovers` of ``path``; returns what was removed.

    Call it only when no other process is writing ``path`` (a writer holds its lock, or the
    caller is the only writer).
    """
    removed = leftovers(path)
    for p in removed:
        _remove(p)
    return removed


def sweep_partial_files(root) -> list[Path]:
    """Remove every ``*.partial`` file under the directory ``root`` (a killed writer's temporary files).

    Call it only while holding the writer's lock of ``root``: a live writer's ``.partial`` is about
    to be renamed into place.
    """
    removed = []
    for dirpath, _dirs, files in os.walk(root):
        for name in files:
            if name.endswith(".partial"):
                p = Path(dirpath) / name
                _remove(p)
                removed.append(p)
    return removed


#: Seconds after which a lock held from another host counts as stale unless its holder refreshed it.
STALE_AFTER = 600.0


class LockBusy(RuntimeError):
    """The lock is held by a live process: ``holder`` is its ``{"host", "pid"}``."""

    def __init__(self, path: Path, holder: dict):
        where = "this machine" if holder.get("host") == socket.gethostname() else f"host {holder.get('host')}"
        super().__init__(f"{path} is held by process {holder.get('pid')} on {where}")
        self.path, self.holder = path, holder


class LockFile:
    """``.<name>.lock`` beside ``path``: one writer of ``path`` at a time.

    The lock file holds ``{"host", "pid"}`` of its holder and is created with ``O_EXCL``. A lock of
    this process is re-entrant. A lock is *stale* when its holder is gone: on this host, no process
    has its pid; on another host, the file was not refreshed (:meth:`refresh`) for
    :data:`STALE_AFTER` s. A stale lock is taken over. ``wait`` (s): how long :meth:`acquire` waits
    for a live holder before raising :class:`LockBusy`.
    """

    def __init__(self, path, wait: float = 0.0, poll: float = 0.5):
        path = Path(path)
        self.target = path
        self.path = path.parent / f".{path.name}.lock"
        self.me = {"host": socket.gethostname(), "pid": os.getpid()}
        self.wait, self.poll = float(wait), float(poll)
        self.held = False
        self.took_over: dict | None = None  # the stale holder this lock replaced

    def holder(self) -> dict | None:
        try:
            return json.loads(self.path.read_text())
        except (OSError, ValueError):
            return None

    def _stale(self, other: dict | None) -> bool:
        if not isinstance(other, dict):  # half-written by a killed process: stale once it is old
            try:
                return time.time() - self.path.stat().st_mtime > 5.0
            except FileNotFoundError:
                return True
        if other.get("host") == self.me["host"]:
            return not process_alive(other.get("pid"))
        try:
            return time.time() - self.path.stat().st_mtime > STALE_AFTER
        except FileNotFoundError:
            return True

    def acquire(self) -> "LockFile":
        deadline = time.monotonic() + self.wait
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                other = self.holder()
                if other == self.me:
                    self.held = True
                    return self
                if self._stale(other):
                    self.took_over = other or {}
                    self.path.unlink(missing_ok=True)
                    continue
                if time.monotonic() >= deadline:
                    raise LockBusy(self.target, other) from None
                time.sleep(self.poll)
                continue
            with os.fdopen(fd, "w") as fh:
                fh.write(json.dumps(self.me))
            self.held = True
            return self

    def refresh(self) -> None:
        """Touch the lock file (a holder on another host shows it is alive)."""
        if self.held:
            try:
                os.utime(self.path)
            except OSError:
                pass

    def release(self) -> None:
        if self.held and self.holder() == self.me:
            self.path.unlink(missing_ok=True)
        self.held = False

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()


def process_alive(pid) -> bool:
    """True while process ``pid`` of this machine runs (a zombie, killed but not reaped, counts as gone)."""
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:  # a killed process its parent has not reaped yet (a zombie) is gone too
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


__all__ = ["LockBusy", "LockFile", "STALE_AFTER", "atomic_directory", "atomic_write_bytes", "atomic_write_text",
           "leftovers", "process_alive", "sweep_leftovers", "sweep_partial_files"]
