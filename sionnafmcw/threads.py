r"""CPU threads of a run: how the engine and the synthesis stage share the machine's cores.

:func:`~sionnafmcw.simulation.simulate` runs two stages at once: the engine computes frame
:math:`n + 1` on the calling thread while frame :math:`n` is synthesised and written on a worker
thread (its finufft plans on a pool of their own, :mod:`sionnafmcw.synthesis.nufft`). Each stage
alone would use every core; together they oversubscribe them, and the threads that wait do not
sleep at once: OpenBLAS's and Dr.Jit's (nanothread) workers spin for their next task. So a run
sets, for its duration (:func:`run_threads`; restored afterwards):

* **BLAS: one thread.** The pipeline's BLAS calls are skinny products (points ``[K, 3]`` times a
  ``3 x 3`` rotation, a few ``[K, 3]`` dot products): memory-bound, no faster on two threads,
  while the idle OpenBLAS workers spin on the core the synthesis needs.
* **Dr.Jit: ``threads - 1`` workers (at least one).** The engine's kernels (ray casts, the PO
  integral, Sionna's trace) alternate with numpy on the calling thread, so the engine is about one
  core's work, and the synthesis stage keeps the other busy.
* **Synthesis: ``threads // 2`` finufft plans at once (at least one)**
  (:func:`synthesis_threads`, the default pool of :func:`~sionnafmcw.synthesis.nufft.beat_nufft`
  within a run; outside one, every core). On 2 cores the synthesis stage then runs on one thread
  beside the engine instead of contending with it for both. While it falls behind -- a frame's
  echoes already wait behind the one it synthesises, so the engine is about to wait for it -- it
  takes all the run's threads for that frame (:func:`synthesis_catching_up`, set by
  :func:`~sionnafmcw.simulation.simulate`): a frame whose sum needs a second Taylor term and double
  precision (the walk's faster limbs, frames 60-99 of the lap) costs 2.6-2.9 times the CPU of a plain
  one (``benchmarks/walk_synthesis.py --scene <walk> --tree-a . --frames 30``, then ``--frames 80``:
  0.14 against 0.37-0.41 CPU-s on two threads). Each
  plan runs on one thread either way, so the cube does not depend on how many run at once (bit for
  bit; finufft's own threads would change the order of its sums).

Measured on 2 cores, interleaved, 98 steady frames of the circle walk at the path engine's
defaults (``python benchmarks/run_resources.py --scene /tmp/cw_quad --frames 98 --rounds 2``): one
BLAS thread takes the CPU time to 0.90-0.93 of what it was, one Dr.Jit worker on top to 0.67-0.69,
and the wall time to 0.86 (the undisturbed round; 0.34 s a frame); the cubes are identical bit for
bit. The pixel engine (``--engine pixel --frames 30 --settings blas1 default``): the same wall time
with one Dr.Jit worker as with two (0.984-1.007), 9 % less CPU. A kernel-bound run, the path engine
with ``static_scene=False`` (the whole room traced and rendered every frame;
``--engine-options '{"static_scene": false}' --frames 8 --settings blas1 default``): 1-3 % slower
with one worker, 10 % less CPU; pass ``threads=cores + 1`` where the wall time of such runs is
what counts. The synthesis stage (``--settings arena1 synthesis2 nocatchup``, after the engine's
PO geometry kernel made the engine 0.22 s a frame alone): its plans on all threads
throughout (``synthesis2``) 0.7 % slower than on ``threads // 2`` with the catching up; on
``threads // 2`` without the catching up (``nocatchup``) 3.6-4.1 % slower. ``threads`` defaults to the
cores this process may run on (:func:`available_cores`);
a Dask worker of a data set passes its share (``cores // workers``,
:mod:`sionnafmcw.dataset.generate`).
"""

from __future__ import annotations

import os
import threading
from numbers import Integral
from contextlib import contextmanager


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity where the OS tells it, else ``os.cpu_count()``)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def engine_threads(threads: int) -> int:
    """Dr.Jit's worker threads for a run of ``threads`` CPU threads: ``threads - 1``, at least 1 (module docstring)."""
    return max(1, int(threads) - 1)


def synthesis_threads(threads: int) -> int:
    """finufft plans the synthesis stage runs at once in a run of ``threads`` CPU threads: ``threads // 2``,
    at least 1 (module docstring)."""
    return max(1, int(threads) // 2)


#: The threads and the synthesis pool of the run in progress (:func:`run_threads`); None outside a run.
_run_threads: int | None = None
_run_synthesis_threads: int | None = None
_catching_up = threading.local()


def synthesis_pool() -> int:
    """Threads of the synthesis's finufft pool now: the run's :func:`synthesis_threads` within
    :func:`run_threads` (all the run's threads on a thread inside :func:`synthesis_catching_up`),
    else :func:`available_cores`. Each plan runs on one thread, so the cube does not depend on how
    many run at once (bit for bit)."""
    if _run_synthesis_threads is None:
        return available_cores()
    if getattr(_catching_up, "active", False):
        return _run_threads
    return _run_synthesis_threads


@contextmanager
def synthesis_catching_up(active: bool = True):
    """Within the block, on the calling thread: :func:`synthesis_pool` is all the run's threads when
    ``active`` (the synthesis stage is behind the engine, module docstring)."""
    before = getattr(_catching_up, "active", False)
    _catching_up.active = bool(active)
    try:
        yield
    finally:
        _catching_up.active = before


def check_threads(threads, where: str = "simulate", error=ValueError) -> int | None:
    """``threads`` as an int (None stays None), or ``error`` naming ``where`` and what to pass."""
    if threads is None:
        return None
    if isinstance(threads, bool) or not isinstance(threads, Integral) or threads < 1:
        raise error(f"{where}: threads must be an integer >= 1 (CPU threads of the run) or None (the "
                         f"process's cores), got {threads!r}")
    return int(threads)


@contextmanager
def run_threads(threads: int | None = None):
    """Within the block: Dr.Jit's pool at :func:`engine_threads` of ``threads`` (default
    :func:`available_cores`), BLAS at one thread and the synthesis pool (:func:`synthesis_pool`) at
    :func:`synthesis_threads` (module docstring); all restored on exit. Yields the Dr.Jit thread
    count used."""
    global _run_synthesis_threads, _run_threads
    from threadpoolctl import threadpool_limits

    from .sionna_rt import dr, set_thread_count

    threads = available_cores() if threads is None else check_threads(threads, "run_threads")
    wanted = engine_threads(threads)
    before = dr.thread_count()
    before_synthesis = _run_synthesis_threads, _run_threads
    if before != wanted:
        set_thread_count(wanted)
    _run_synthesis_threads, _run_threads = synthesis_threads(threads), threads
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            yield wanted
    finally:
        _run_synthesis_threads, _run_threads = before_synthesis
        if dr.thread_count() != before:
            set_thread_count(before)


__all__ = ["available_cores", "check_threads", "engine_threads", "run_threads", "synthesis_catching_up", "synthesis_pool",
           "synthesis_threads"]
