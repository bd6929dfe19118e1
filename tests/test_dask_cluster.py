"""A data set on a cluster run as a user runs one: a ``dask scheduler`` process and two ``dask worker``
processes on 127.0.0.1, each worker in its own working directory, the data-set folder on the shared
file system; the driver is the ``sionnafmcw dataset --scheduler ADDRESS`` command.

Worker ``w1`` is killed (SIGKILL, its own fault point) between a chunk write and the frame's done
flag of its first item. Dask reruns that item on ``w2``; the data set completes in the same
command, no frame is marked done twice, the index names the worker that made each item (``w2``
for the item ``w1`` died in), and every item store equals the one a clean run writes bit for bit.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from faults import assert_same_store, fault_log, leftovers, sionnafmcw, wait_for
from sionnafmcw import dataset

RADAR = {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64}
SPEC = {"name": "plates", "scenario": "moving_plate", "count": 4, "seed": 4, "radar": RADAR, "engine": "pixel",
        "engine_options": {"scattering_coefficient": 0.5},
        "parameters": {"speed": {"uniform": [0.5, 2.0]}, "start_range": 3.0, "num_frames": 2}}
DASK = str(Path(sys.executable).parent / "dask")


@pytest.fixture
def cluster(tmp_path):
    """``(address, {name: Popen})``: a scheduler and workers w1 (armed to kill itself once) and w2."""
    if not Path(DASK).exists():
        pytest.skip("the dask command is not installed")
    file = tmp_path / "scheduler.json"
    env = {k: v for k, v in os.environ.items() if not k.startswith("SIONNAFMCW_FAULT")}
    log = tmp_path / "faults.log"
    procs = {}
    logs = tmp_path / "logs"
    logs.mkdir()

    def start(name, argv, extra_env=None, cwd=None):
        out = open(logs / f"{name}.log", "w")
        procs[name] = subprocess.Popen(argv, cwd=cwd, env={**env, **(extra_env or {})}, stdout=out,
                                       stderr=subprocess.STDOUT, start_new_session=True)

    try:
        start("scheduler", [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                            "--scheduler-file", str(file)])
        wait_for(file.exists, 60, "the scheduler file")
        address = json.loads(file.read_text())["address"]
        for name in ("w1", "w2"):
            workdir = tmp_path / "workers" / name
            workdir.mkdir(parents=True)
            armed = {"SIONNAFMCW_FAULT": "chunk-written@2", "SIONNAFMCW_FAULT_SIGNAL": "KILL",
                     "SIONNAFMCW_FAULT_ONCE": str(tmp_path / "fired")} if name == "w1" else {}
            start(name, [DASK, "worker", address, "--name", name, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                         "--local-directory", str(workdir / "dask")],
                  {**armed, "SIONNAFMCW_FAULT_LOG": str(log)}, cwd=workdir)
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, procs, log
    finally:
        for name in ("w1", "w2", "scheduler"):
            p = procs.get(name)
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs.values():
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


@pytest.mark.slow
def test_worker_killed_mid_item_on_a_real_cluster(tmp_path, cluster):
    address, procs, log = cluster
    spec_file = tmp_path / "plates.json"
    spec_file.write_text(json.dumps(SPEC))
    out = tmp_path / "shared" / "data"
    proc = sionnafmcw("-q", "dataset", spec_file, "--out", out, "--scheduler", address, timeout=300)
    assert proc.returncode == 0, proc.stderr + (tmp_path / "logs" / "w1.log").read_text()[-3000:]
    assert (tmp_path / "fired").exists(), "w1 never reached its fault point"
    assert procs["w1"].wait(timeout=30) == -signal.SIGKILL
    index = dataset.open_index(out)
    assert (index.status.values == "complete").all()

    events = fault_log(log)
    killed_in = {Path(e["store"]).parent.name for e in events if e["point"] == "chunk-written"
                 and int(e["pid"]) == procs["w1"].pid}
    done = [(Path(e["store"]).parent.name, e["frame"]) for e in events if e["point"] == "frame-done"]
    assert len(done) == len(set(done)) == 4 * 2, sorted(done)          # every frame once, none twice
    workers = dict(zip(index.item.values, index.worker.values))
    assert all(w.split()[0] in ("w1", "w2") for w in workers.values()), workers
    # the item w1 died in was finished by w2, which resumed it (frame 0 was done by w1)
    last = [e for e in events if e["point"] == "chunk-written" and int(e["pid"]) == procs["w1"].pid][-1]
    item = Path(last["store"]).parent.name
    assert item in killed_in and workers[item].startswith("w2 ")
    assert any(e["point"] == "frame-done" and Path(e["store"]).parent.name == item and e["frame"] == "0"
               and int(e["pid"]) == procs["w1"].pid for e in events)

    # a clean run on the surviving worker writes the same stores
    clean = tmp_path / "shared" / "clean"
    assert sionnafmcw("-q", "dataset", spec_file, "--out", clean, "--scheduler", address).returncode == 0
    for it in index.item.values:
        assert_same_store(clean / "items" / it / "run.zarr", out / "items" / it / "run.zarr")
        assert leftovers(out / "items" / it / "run.zarr") == []
    assert not (out / ".lock").exists()
