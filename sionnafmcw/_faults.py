"""Test-only fault points: stop the process at a named instant (does nothing unless asked).

The crash-safety tests (``tests/test_crash_safety.py``) kill ``simulate`` and ``dataset`` at
exact instants instead of after a guessed sleep. The code calls :func:`point` at each instant
worth killing at; it returns at once unless the environment names that point:

``SIONNAFMCW_FAULT=NAME[@COUNT]``
    fire at the ``COUNT``-th time (1-based, default 1) point ``NAME`` is reached in this process;
``SIONNAFMCW_FAULT_SIGNAL``
    ``KILL`` (default), ``INT`` or ``TERM``: the signal the process sends itself;
``SIONNAFMCW_FAULT_ONCE=FILE``
    fire only if ``FILE`` can be created (so a restarted process, or a rerun of a task on another
    worker, goes on);
``SIONNAFMCW_FAULT_LOG=FILE``
    append one line ``NAME key=value ...`` per point reached (what was written, by whom).

Points: ``store-created`` (the store is complete in its temporary folder, not yet renamed into
place), ``chunk-written`` (a frame's cube and truth are written, its done flag not yet),
``frame-done`` (the done flag is written), ``item-simulated`` (a data-set item's store is
complete, its ``item.json`` not yet written), ``item-recorded`` (the driver wrote an item's
record).
"""

from __future__ import annotations

import os

_counts: dict[str, int] = {}


def point(name: str, **context) -> None:
    """Reached fault point ``name`` (see the module docstring); ``context`` goes to the log."""
    log = os.environ.get("SIONNAFMCW_FAULT_LOG")
    if log:
        fields = " ".join(f"{k}={v}" for k, v in context.items())
        with open(log, "a") as fh:
            fh.write(f"{name} pid={os.getpid()} {fields}\n")
    wanted = os.environ.get("SIONNAFMCW_FAULT")
    if not wanted:
        return
    target, _, count = wanted.partition("@")
    if target != name:
        return
    _counts[name] = _counts.get(name, 0) + 1
    if _counts[name] != int(count or 1):
        return
    once = os.environ.get("SIONNAFMCW_FAULT_ONCE")
    if once:
        try:
            os.close(os.open(once, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return
    import signal

    sig = getattr(signal, "SIG" + os.environ.get("SIONNAFMCW_FAULT_SIGNAL", "KILL").upper())
    os.kill(os.getpid(), sig)
    if sig != signal.SIGKILL:
        import time

        time.sleep(0.01)  # let the handler run here, at this point
