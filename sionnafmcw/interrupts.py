"""Ctrl-C and ``kill`` (SIGINT, SIGTERM) as a clean stop: :class:`Interrupted`, raised where it is safe.

* :func:`handling_signals` installs handlers (main thread only; elsewhere it does nothing) that
  raise :class:`Interrupted` -- a :class:`KeyboardInterrupt` that remembers the signal, so a
  command exits with 128 + signal number (130 for SIGINT, 143 for SIGTERM).
* :func:`deferred` is a critical section: a signal that arrives inside it is held and raised when
  the section ends. Writes to a store are such sections, so a store is never left with a Zarr
  write cut in half or an un-awaited coroutine of Zarr's I/O loop.
* :func:`is_interrupt` recognises an interrupt after it crossed C++: Dr.Jit re-raises a
  ``KeyboardInterrupt`` from a Python callback as a ``RuntimeError`` (its cause, context or message
  names it); a signal seen by the handler during the call counts too.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

#: Exit status of a command stopped by ``signum``: the shell's convention 128 + n.
def exit_status(signum: int) -> int:
    return 128 + int(signum)


class Interrupted(KeyboardInterrupt):
    """Stopped by a signal (``signum``: SIGINT for Ctrl-C, SIGTERM for ``kill``)."""

    def __init__(self, signum: int = signal.SIGINT, message: str = ""):
        super().__init__(message or signal.Signals(signum).name)
        self.signum = int(signum)
        self.message = message

    @property
    def exit_status(self) -> int:
        return exit_status(self.signum)



_state = {"depth": 0, "pending": None, "received": None, "installed": 0, "previous": {}}
_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _handler(signum, frame):
    _state["received"] = signum
    if _state["depth"] > 0:
        if _state["pending"] is None:
            _state["pending"] = signum
        return
    raise Interrupted(signum)


@contextmanager
def handling_signals():
    """SIGINT and SIGTERM raise :class:`Interrupted` inside the block (nestable; main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if _state["installed"] == 0:
        _state["previous"] = {s: signal.getsignal(s) for s in _SIGNALS}
        for s in _SIGNALS:
            signal.signal(s, _handler)
    _state["installed"] += 1
    try:
        yield
    finally:
        _state["installed"] -= 1
        if _state["installed"] == 0:
            for s, previous in _state["previous"].items():
                signal.signal(s, previous if previous is not None else signal.SIG_DFL)
            _state["received"] = None


@contextmanager
def deferred():
    """A critical section: a signal arriving inside is raised (as :class:`Interrupted`) when it ends."""
    if threading.current_thread() is not threading.main_thread() or _state["installed"] == 0:
        yield
        return
    _state["depth"] += 1
    try:
        yield
    finally:
        _state["depth"] -= 1
        pending = _state["pending"]
        if _state["depth"] == 0 and pending is not None:
            _state["pending"] = None
            raise Interrupted(pending)


def received() -> int | None:
    """The last signal the handlers saw while installed (None: none)."""
    return _state["received"]


def is_interrupt(exc: BaseException) -> bool:
    """True for a :class:`KeyboardInterrupt`, also wrapped by Dr.Jit in a ``RuntimeError``."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, KeyboardInterrupt):
            return True
        if isinstance(exc, RuntimeError) and "KeyboardInterrupt" in str(exc):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def as_interrupted(exc: BaseException) -> Interrupted:
    """The :class:`Interrupted` an interrupt ``exc`` stands for (its signal when known)."""
    if isinstance(exc, Interrupted):
        return exc
    return Interrupted(received() or signal.SIGINT)


__all__ = ["Interrupted", "as_interrupted", "deferred", "exit_status", "handling_signals", "is_interrupt",
           "received"]
