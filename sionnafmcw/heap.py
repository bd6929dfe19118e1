r"""Freed heap memory handed back to the operating system between frames.

A run allocates and frees the same large numpy temporaries every frame on two threads (the
engine's and the synthesis worker's, :func:`~sionnafmcw.simulation.simulate`) and on the finufft
pool's. glibc's allocator serves each thread from an arena of its own, and after the first large
``free`` it raises its mmap threshold (up to 32 MiB), so later arrays of that size come from the
arenas instead of fresh mappings. Freed space inside an arena is kept for reuse, and with arrays
whose sizes change from frame to frame (the number of PO samples follows the body) the arenas
fragment: the resident size of the circle walk crept up by 118 MiB over its 100 frames (1343 MiB
after the first frame, 1461 MiB at the end), flat at 1305 MiB with a single arena
(``MALLOC_ARENA_MAX=1``). :func:`release_free_memory` calls glibc's ``malloc_trim(0)``, which
returns the free pages of every arena to the OS (``madvise``); :func:`simulate` calls it on the
synthesis worker after each frame is written, off the engine's path: 9.6 ms a frame (18.6 ms at
most) on 2 cores, and the walk's resident size then rose by 18 MiB over the 100 frames (1354 to
1372 MiB). Peak memory of the whole walk against the code before issue 22: ``benchmarks/circle_walk.py``
(its docstring: B/A 0.942 over three seeds).

On a C library without ``malloc_trim`` (macOS, musl) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools


@functools.lru_cache(maxsize=1)
def _malloc_trim():
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


def release_free_memory() -> bool:
    """Return the allocator's free pages to the OS (glibc ``malloc_trim(0)``); True when some were,
    False when none were or the C library has no such call (module docstring)."""
    trim = _malloc_trim()
    return bool(trim(0)) if trim is not None else False


__all__ = ["release_free_memory"]
