"""Files and directories that appear whole or not at all (numpy-free: the Blender exporter uses it too).

A directory is built in a hidden sibling of its target and renamed into place when complete:
a rename inside one file system is atomic, so a reader (or a later run) sees either the old
directory, nothing, or the finished new one, whatever instant the writer is killed at. What a
killed writer leaves is a hidden sibling named ``.<name>.partial-<token>`` (or
``.<name>.old-<token>`` during the swap), which :func:`sweep_leftovers` removes.

* :func:`atomic_directory` -- a context manager yielding the temporary directory to fill.
* :func:`atomic_write_text` / :func:`atomic_write_bytes` -- one file through a temporary sibling.
* :func:`sweep_leftovers` -- remove what killed writers left beside a target.
"""

from __future__ import annotations

import os
import shutil
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


__all__ = ["atomic_directory", "atomic_write_bytes", "atomic_write_text", "leftovers", "sweep_leftovers"]
