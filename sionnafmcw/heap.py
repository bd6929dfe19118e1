r"""The C heap of a process that simulates: one glibc arena for all its threads.

A run allocates and frees the same large numpy temporaries every frame on several threads (the
engine's, the synthesis worker's, the finufft pool's, :func:`~sionnafmcw.simulation.simulate`).
glibc's allocator gives each thread an arena of its own (up to eight per core), and after the
first large ``free`` it raises its mmap threshold (up to 32 MiB), so arrays of that size then come
from the arenas rather than from fresh mappings. Every arena keeps its freed space for reuse, and
with arrays whose sizes change from frame to frame (the number of PO samples follows the body)
each thread's arena grows to its own high-water mark.

:func:`limit_arenas` sets glibc's ``M_ARENA_MAX`` to one, so that the threads created afterwards
share the one heap and its free space. It is process-wide and works only before other threads
have arenas (a new thread takes a freed arena of an ended thread whatever the limit: set on entering
:func:`~sionnafmcw.simulation.simulate`, after an earlier run in the same process, it lowered
nothing, a measurement of this module's first version), so the command line sets it first
thing (``sionnafmcw``, :func:`~sionnafmcw.cli.main`); a Python program that wants it calls it
before it starts threads (or sets ``MALLOC_ARENA_MAX=1`` in the environment). Measured on the
circle walk, 98 steady frames (``python benchmarks/run_resources.py --scene /tmp/cw_quad --frames 98
--rounds 2``): ``simulate``'s defaults peaked at 1442 MiB and grew by 77-85 MiB over the frames;
with the limit set first thing (setting ``arena1``) 1321-1324 MiB, growth 11-13 MiB, at the same
time per frame (0.333-0.354 against 0.340-0.349 s). Handing the free pages back to the OS after
every frame instead (``malloc_trim(0)``, setting ``trimmed``) gave 1373-1378 MiB but 0.379-0.382 s a
frame (the next frame faults every page in again), so it is not used.

On a C library without ``mallopt`` (macOS, musl) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util

#: glibc's ``M_ARENA_MAX`` option of ``mallopt``.
M_ARENA_MAX = -8


def limit_arenas(count: int = 1) -> bool:
    """At most ``count`` glibc arenas in this process from now on (module docstring); True where the C
    library took the setting, False where it has no ``mallopt``."""
    name = ctypes.util.find_library("c")
    try:
        mallopt = ctypes.CDLL(name or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_ARENA_MAX, int(count)))


__all__ = ["M_ARENA_MAX", "limit_arenas"]
