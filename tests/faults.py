"""Test helpers for crash safety: run the ``sionnafmcw`` command with a fault point armed
(:mod:`sionnafmcw._faults`), compare stores bit for bit, and list what a killed writer left.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import zarr

#: The arrays a run store holds per frame (and the done flags), compared bit for bit.
STORE_ARRAYS = ("iq", "frame_time", "frame_done", "truth_position", "truth_velocity", "truth_radial_velocity")


def sionnafmcw(*argv, fault: str | None = None, signal: str = "KILL", once: Path | None = None,
               log: Path | None = None, cwd=None, timeout: float = 600.0) -> subprocess.CompletedProcess:
    """Run ``python -m sionnafmcw.cli ARGV`` in a new process; ``fault`` arms a fault point
    (``NAME[@COUNT]``) that sends the process ``signal`` (KILL, INT or TERM)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("SIONNAFMCW_FAULT")}
    if fault:
        env.update(SIONNAFMCW_FAULT=fault, SIONNAFMCW_FAULT_SIGNAL=signal)
    if once:
        env["SIONNAFMCW_FAULT_ONCE"] = str(once)
    if log:
        env["SIONNAFMCW_FAULT_LOG"] = str(log)
    env.setdefault("PYTHONWARNINGS", "default")  # un-awaited coroutines and the like would show on stderr
    return subprocess.run([sys.executable, "-m", "sionnafmcw.cli", *map(str, argv)], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


def stderr_lines(proc) -> list[str]:
    return [line for line in proc.stderr.splitlines() if line.strip()]


def assert_same_store(a, b) -> None:
    """Every array of two run stores equal bit for bit (NaN where NaN), and the same attributes
    (but the scene path and the version)."""
    ga, gb = zarr.open_group(str(a), mode="r"), zarr.open_group(str(b), mode="r")
    for name in STORE_ARRAYS:
        x, y = np.asarray(ga[name][:]), np.asarray(gb[name][:])
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert np.array_equal(x.view(np.uint8), y.view(np.uint8)), f"{name} differs between {a} and {b}"
    skip = {"scene", "sionnafmcw_version"}
    assert {k: v for k, v in ga.attrs.items() if k not in skip} == {k: v for k, v in gb.attrs.items() if k not in skip}


def leftovers(store) -> list[Path]:
    """What a killed writer of ``store`` can leave: temporary stores and the lock beside it,
    ``*.partial`` chunk files inside it."""
    store = Path(store)
    beside = [p for p in store.parent.glob(f".{store.name}.*")]
    inside = list(store.rglob("*.partial")) if store.exists() else []
    return sorted(beside + inside)


def fault_log(path) -> list[dict]:
    """The lines of a ``SIONNAFMCW_FAULT_LOG`` file as dicts (``point`` and its ``key=value`` fields)."""
    out = []
    if not Path(path).exists():
        return out
    for line in Path(path).read_text().splitlines():
        name, *fields = line.split()
        out.append({"point": name, **dict(f.split("=", 1) for f in fields)})
    return out


def wait_for(predicate, timeout: float, what: str) -> None:
    """Poll ``predicate`` every 0.2 s until it is true; AssertionError naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}")
