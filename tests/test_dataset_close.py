r"""A data-set run that succeeds prints no traceback; an item that fails is reported once, in one line.

* The race (:mod:`sionnafmcw.dataset.cluster`): a Dask worker whose heartbeat is still waiting
  for the scheduler's answer when the worker closes its connections logs the heartbeat's
  ``CommClosedError`` with a traceback. Here it is made certain rather than left to the load of
  the machine: a scheduler plugin answers every heartbeat :data:`DELAY` late and asks for the
  next one 10 ms after, so a heartbeat is in flight a fraction
  :math:`0.3 / 0.31 \approx 97\,\%` of the time. Workers of a plain ``LocalCluster`` then log
  the traceback when the cluster closes (the control: the harness reproduces the race);
  :func:`~sionnafmcw.dataset.generate`'s own cluster closes clean. A heartbeat that closes
  its own worker (the scheduler answered "missing") is not waited for by that close.
* The guide's ``people`` spec (docs/guide/datasets.md: 3 items, walk/wave/fall, ``chairs``,
  4 frames, ``ti-iwr6843isk``) through ``sionnafmcw dataset``, twice on a local cluster and
  twice on a ``dask scheduler`` with two ``dask worker`` processes, the first run of each on an
  empty Dr.Jit kernel cache (``DRJIT_CACHE_DIR``): stderr holds no traceback and no
  ``distributed`` ERROR or WARNING record (slow).
* A failing item (a plate that would pass through the radar) is reported once, as one line
  naming the item and the builder's error, with and without ``--quiet``, and no traceback.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from distributed import SchedulerPlugin

from faults import sionnafmcw, wait_for
from sionnafmcw import dataset

DELAY = 0.3  # s, the scheduler's answer to a heartbeat
#: Heartbeats answered that show the race is set up: after its first answer a worker asks again 10 ms
#: later and waits DELAY, so a heartbeat is in flight 0.3/0.31 of the time; two per worker on average
#: (a run of two short items answered 8 on a quiet machine, the 2 s naps more than 10).
MIN_ANSWERED = 4
RADAR = {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64}
PLATES = {"name": "plates", "scenario": "moving_plate", "count": 2, "seed": 4, "radar": RADAR,
          "engine_options": {"samples_per_src": 2000},
          "parameters": {"speed": {"uniform": [-2.0, -0.5]}, "start_range": 3.0, "num_frames": 2}}
GUIDE_SPEC = """\
name: people
scenario: people
count: 3
seed: 1
radar: ti-iwr6843isk
parameters:
  activity: {cycle: [walk, wave, fall]}
  chairs: [0, 2]
  num_frames: 4
"""
DASK = str(Path(sys.executable).parent / "dask")
#: What a clean stderr must not hold: a traceback, a closed comm, a ``distributed`` ERROR or
#: WARNING record (``distributed.worker - ERROR - ...``), an unresponsive event loop.
NOISE = re.compile(r"Traceback|CommClosedError|StreamClosedError|distributed(\.\w+)* - (ERROR|WARNING|CRITICAL)"
                   r"|Failed to communicate|unresponsive")


def noise(text: str) -> list[str]:
    return [line for line in text.replace("\r", "\n").splitlines() if NOISE.search(line)]


class SlowHeartbeats(SchedulerPlugin):
    """Scheduler plugin: answer each ``heartbeat_worker`` after ``delay`` seconds and ask for the next
    one 10 ms later; ``answered`` counts the heartbeats."""

    name = "slow-heartbeats"

    def __init__(self, delay: float = DELAY):
        self.delay, self.answered = delay, 0

    async def start(self, scheduler):
        answer = scheduler.handlers["heartbeat_worker"]

        async def slow(*args, **kwargs):
            await asyncio.sleep(self.delay)
            reply = answer(*args, **kwargs)
            if asyncio.iscoroutine(reply):
                reply = await reply
            self.answered += 1
            return {**reply, "heartbeat-interval": 0.01}

        scheduler.handlers["heartbeat_worker"] = slow


def _nap(seconds):
    time.sleep(seconds)
    return seconds


def test_local_cluster_closes_without_heartbeat_traceback(tmp_path, capfd):
    from distributed import Client, LocalCluster

    # control: plain workers, a heartbeat in flight at close -> the traceback of the issue
    plugin = SlowHeartbeats()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR, scheduler_kwargs={"plugins": [plugin]}) as cluster:
        with Client(cluster) as client:
            assert client.gather(client.map(_nap, [2.0, 2.0])) == [2.0, 2.0]
    assert plugin.answered >= MIN_ANSWERED, "the workers hardly sent heartbeats: the race was not set up"
    control = capfd.readouterr().err
    assert "Failed to communicate with scheduler during heartbeat" in control, \
        "plain distributed workers no longer race their heartbeat at close (HeartbeatDrain may be dropped)"
    assert "ConnectionPool.heartbeat_worker" in control

    # generate's own local cluster, same scheduler: no heartbeat of a closing worker is cut off
    plugin = SlowHeartbeats()
    index = dataset.generate(PLATES, tmp_path / "plates", workers=2, progress=False,
                             cluster_options={"scheduler_kwargs": {"plugins": [plugin]}})
    assert list(index.status.values) == ["complete", "complete"]
    assert plugin.answered >= MIN_ANSWERED, "the workers hardly sent heartbeats: the race was not set up"
    err = capfd.readouterr().err
    assert noise(err) == [], err[-3000:]


def test_a_heartbeat_that_closes_its_worker_is_not_waited_for():
    """The scheduler answers a heartbeat with "missing" (it forgot the worker): the worker closes
    from inside that heartbeat, and the drain (given 10 s here) must not wait for the heartbeat
    that is running the close, or the close would take the whole 10 s."""
    from distributed import Scheduler, Worker

    from sionnafmcw.dataset.cluster import HeartbeatDrain

    async def scenario():
        async with Scheduler(dashboard_address=":0", port=0) as scheduler:
            async with Worker(scheduler.address, nthreads=1) as worker:
                await worker.plugin_add(HeartbeatDrain(timeout=10.0), name=HeartbeatDrain.name)
                forgot = []

                async def missing(*args, **kwargs):
                    forgot.append(time.monotonic())
                    return {"status": "missing"}

                scheduler.handlers["heartbeat_worker"] = missing
                await asyncio.wait_for(worker.finished(), timeout=30)
                return time.monotonic() - forgot[0], worker.status.name

    seconds, status = asyncio.run(scenario())
    assert status == "closed"
    assert seconds < 5.0, f"the close waited {seconds:.1f} s for the heartbeat that ran it"


@pytest.fixture(scope="module")
def scheduler():
    """The address of a LocalCluster in this process (one worker thread): the command-line runs
    below reach it with --scheduler and skip starting worker processes of their own."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        yield cluster.scheduler_address


def test_a_failed_item_is_one_line_without_traceback(tmp_path, scheduler):
    """One item, a plate 0.21 m away approaching at 0.5-2 m/s: the builder refuses it (it would pass
    0.2 m between the two frames). The second run (--quiet) retries it and reports it the same way."""
    spec = tmp_path / "plates.json"
    spec.write_text(json.dumps({**PLATES, "count": 1, "parameters": {**PLATES["parameters"], "start_range": 0.21}}))
    out = tmp_path / "plates"
    for quiet in ((), ("-q",)):
        proc = sionnafmcw(*quiet, "dataset", spec, "--out", out, "--scheduler", scheduler, timeout=300)
        assert proc.returncode == 1, proc.stderr
        lines = [line for line in proc.stderr.replace("\r", "\n").splitlines() if "failed:" in line]
        assert len(lines) == 1, proc.stderr
        assert re.fullmatch(r"\s*item 000000 failed: ValueError: moving_plate: with start_range=0.21 m .*into the "
                            r"radar.*", lines[0]), lines
        assert "Traceback" not in proc.stderr and "DatasetWarning" not in proc.stderr, proc.stderr
        assert noise(proc.stderr) == [], proc.stderr
        assert "0/1 items complete" in proc.stderr
        assert proc.stdout.strip().endswith(": 1 failed"), proc.stdout


# ============================================================================ the guide's spec
def _run_guide_spec(tmp_path, name, *extra, cache=None, monkeypatch=None):
    spec = tmp_path / "people.yaml"
    spec.write_text(GUIDE_SPEC)
    if cache is not None:
        monkeypatch.setenv("DRJIT_CACHE_DIR", str(cache))
    proc = sionnafmcw("dataset", spec, "--out", tmp_path / name, *extra, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "3 complete" in proc.stdout and "3/3 items complete" in proc.stderr
    return proc


@pytest.mark.slow
def test_guide_spec_on_the_local_cluster_prints_no_traceback(tmp_path, monkeypatch):
    cold = tmp_path / "kernel-cache"
    cold.mkdir()
    for run in ("cold", "warm"):
        proc = _run_guide_spec(tmp_path, run, cache=cold, monkeypatch=monkeypatch)
        assert noise(proc.stderr) == [], proc.stderr[-3000:]
        if run == "cold":
            assert any(cold.iterdir()), "the first run compiled no kernel into the empty cache"


@pytest.fixture
def external_cluster(tmp_path):
    """``(address, logs)``: ``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (nannies,
    1 thread each), the workers on an empty Dr.Jit kernel cache."""
    if not Path(DASK).exists():
        pytest.skip("the dask command is not installed")
    logs, cache = tmp_path / "logs", tmp_path / "worker-kernel-cache"
    logs.mkdir()
    cache.mkdir()
    env = {**{k: v for k, v in os.environ.items() if not k.startswith("SIONNAFMCW_FAULT")}, "DRJIT_CACHE_DIR": str(cache)}
    file = tmp_path / "scheduler.json"
    procs = []

    def start(name, argv, cwd=None):
        with open(logs / f"{name}.log", "w") as log:
            procs.append(subprocess.Popen(argv, cwd=cwd, env=env, stdout=log, stderr=subprocess.STDOUT,
                                          start_new_session=True))

    try:
        start("scheduler", [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                            "--scheduler-file", str(file)])
        wait_for(file.exists, 60, "the scheduler file")
        address = json.loads(file.read_text())["address"]
        for name in ("w1", "w2"):
            workdir = tmp_path / "workers" / name
            workdir.mkdir(parents=True)
            start(name, [DASK, "worker", address, "--name", name, "--nthreads", "1", "--no-dashboard",
                         "--local-directory", str(workdir / "dask")], cwd=workdir)
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, logs, cache
    finally:
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


@pytest.mark.slow
def test_guide_spec_on_an_external_cluster_prints_no_traceback(tmp_path, external_cluster):
    address, logs, cache = external_cluster
    for run in ("cold", "warm"):
        proc = _run_guide_spec(tmp_path, run, "--scheduler", address)
        assert noise(proc.stderr) == [], proc.stderr[-3000:]
        if run == "cold":
            assert any(cache.iterdir()), "the first run compiled no kernel into the workers' empty cache"
    for name in ("scheduler", "w1", "w2"):  # the cluster's own logs, while it served both runs
        text = (logs / f"{name}.log").read_text()
        assert [line for line in noise(text) if "unresponsive" not in line] == [], (name, text[-3000:])
