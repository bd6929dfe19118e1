r"""``generate``: every item of a data set is one task on a Dask distributed cluster.

One task = one item, run in a worker process (1 thread per worker: Dr.Jit, Mitsuba and the
engine live in that process, which keeps its compiled kernels from item to item):

1. build the scene (:func:`sionnafmcw.scenes.build`) into ``out/items/<id>/scene`` unless
   ``scene.json`` says it is already built with these parameters (builds are atomic);
2. :func:`~sionnafmcw.simulate` it into ``out/items/<id>/run.zarr`` with the item's radar and
   noise seed; the run store resumes frame by frame, so a task cut off mid-item redoes only the
   frames it had not marked done;
3. read the labels back from the store (:func:`~sionnafmcw.dataset.index.store_labels`).

The driver (the process that calls :func:`generate`) runs no engine: it checks the spec,
skips complete items (store complete), submits the rest, records each result in
``items/<id>/item.json`` as it arrives and rewrites the index. A task that raises is recorded
as ``failed`` with its error and traceback and does not stop the others; a later
:func:`generate` with the same spec retries it.

Cost model (measured numbers: ``benchmarks/dataset.py``): with :math:`W` workers, :math:`N`
items of :math:`F` frames, per-frame engine + synthesis time :math:`t_f`, per-item fixed cost
:math:`t_0` (scene build, scene load, store creation) and one-off per-worker start-up
:math:`t_w` (process spawn, imports, first kernel compilation),

.. math::
    T \approx t_w + \left\lceil N / W \right\rceil (t_0 + F\,t_f)
    \quad\text{(each worker busy; tasks far longer than the scheduler's ~1 ms per task)}.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import socket
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

from .index import (INDEX_DIR, INDEX_FORMAT, SPEC_FILE, DatasetError, build_index, choose_label_object, item_dir,
                    read_json, store_labels, store_state, write_index, write_json_atomic)
from .spec import DatasetSpec, load_spec
from .. import _faults
from ..fs import process_alive
from ..interrupts import Interrupted, as_interrupted, handling_signals, is_interrupt

INDEX_INTERVAL = 10.0  # s between index rewrites while items finish (and once at the end)


class DatasetWarning(UserWarning):
    """Some items of a data set failed (the index and items/<id>/item.json say why)."""


class DatasetInterrupted(Interrupted):
    """:func:`generate` stopped by SIGINT / SIGTERM: ``done`` of ``total`` items complete; the folder
    is consistent (index written) and the same call resumes it."""

    def __init__(self, signum: int, done: int, total: int, out):
        super().__init__(signum, f"interrupted after {done} of {total} items; generate again with the same "
                                 "spec and folder to resume")
        self.done, self.total, self.out, self.unit = int(done), int(total), Path(out), "items"


# ===================================================================================== worker side
#: Seconds a task waits for another live process still writing its item's store (a worker of a
#: previous driver that outlived it) before it fails; it then resumes what that process left.
ITEM_WAIT = 3600.0


def worker_identity() -> str:
    """``"<dask worker name> <address> pid <pid>"`` of the Dask worker running this task, or
    ``"<host> pid <pid>"`` outside a worker: what the index's ``worker`` records."""
    try:
        from distributed import get_worker

        w = get_worker()
        return f"{w.name} {w.address} pid {os.getpid()}"
    except (ImportError, ValueError):
        return f"{socket.gethostname()} pid {os.getpid()}"


def run_item(task: dict) -> dict:
    """Build, simulate and label one item (runs in a worker). Never raises: failures come back as a record.

    Crash safety: the store is created atomically and resumed frame by frame
    (:func:`~sionnafmcw.simulate`); a store another live process is still writing (a worker that
    outlived its driver) is waited for (:data:`ITEM_WAIT`) and then only completed, never redone.
    The worker that computes frames records itself in ``item.json`` first (status ``running``) and
    writes the finished record itself, so an item finished after its driver died is indexed with
    its worker by the next driver.
    """
    start, cpu = time.perf_counter(), time.process_time()
    me = worker_identity()
    result = {"id": task["item"]["id"], "worker": me}
    try:
        from .. import scenes
        from ..animation import RadarPose
        from ..engines.path import keep_static_blocks
        from ..radar import RadarConfig
        from ..simulation import simulate

        if multiprocessing.parent_process() is not None:
            # a worker process of its own: items that share their room and radar build its static block once
            keep_static_blocks()

        item = task["item"]
        spec = task["spec"]
        folder = Path(task["dir"])
        folder.mkdir(parents=True, exist_ok=True)
        scene = folder / "scene"
        marker = folder / "scene.json"
        wanted = {"scenario": spec["scenario"], "parameters": item["parameters"]}
        if read_json(marker) != wanted or not (scene / "animation.json").exists():
            if marker.exists():
                marker.unlink()
            for stale in folder.glob(".scene.*"):  # a build cut off by a kill (scenes.build is atomic)
                shutil.rmtree(stale, ignore_errors=True)
            scenes.build(spec["scenario"], scene, overwrite=True, **item["parameters"])
            write_json_atomic(marker, wanted)
        if spec.get("label_object"):  # check it before simulating, not after
            manifest = read_json(scene / "animation.json") or {}
            names = sorted({n for f in manifest.get("frames", []) for n in f.get("objects", {})})
            choose_label_object(names, spec["label_object"])
        pose = None
        if spec.get("radar_pose"):
            pose = RadarPose(np.asarray(spec["radar_pose"]["position"], float),
                             np.asarray(spec["radar_pose"]["orientation"], float))
        store = folder / "run.zarr"
        record_path = folder / "item.json"
        made_by = (read_json(record_path) or {}).get("worker", "")
        if not store_state(store, spec.get("frames"))["complete"]:
            write_json_atomic(record_path, {**(read_json(record_path) or {}), "status": "running", "worker": me})
            made_by = me
        simulate(scene, RadarConfig.from_dict(item["radar"]), engine=spec["engine"], out=store,
                 frames=spec.get("frames"), progress=False, radar_pose=pose, seed=item["noise_seed"],
                 noise=spec.get("noise", True), engine_options=spec.get("engine_options") or {},
                 wait=task.get("wait", ITEM_WAIT), threads=task.get("threads"))
        state = store_state(store, spec.get("frames"))
        if not state["complete"]:
            raise DatasetError(f"{store}: simulate returned but frames are not all marked done")
        _faults.point("item-simulated", item=item["id"])
        result.update(status="complete", error="", traceback="", worker=made_by or me,
                      labels=store_labels(store, spec.get("label_object")))
    except Exception as exc:  # noqa: BLE001 - an item's failure is data, not a crash
        result.update(status="failed", error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc())
    result["seconds"] = time.perf_counter() - start
    result["cpu_seconds"] = time.process_time() - cpu  # the whole worker process (all its threads)
    if result["status"] == "complete":
        try:
            path = Path(task["dir"]) / "item.json"
            write_json_atomic(path, {**(read_json(path) or {}), **task["item"], **result})
        except OSError:
            pass  # the driver writes the record too
    return result


# ===================================================================================== driver side
class _Lock:
    """``out/.lock``: one generation at a time per folder; a lock whose process is gone is taken over."""

    def __init__(self, out: Path):
        self.path = out / ".lock"
        self.me = {"host": socket.gethostname(), "pid": os.getpid()}

    def __enter__(self):
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                other = read_json(self.path) or {}
                if other.get("host") == self.me["host"] and other.get("pid") != self.me["pid"] \
                        and process_alive(other.get("pid")):
                    raise DatasetError(f"{self.path.parent} is being generated by process {other['pid']} on this "
                                       "machine; wait for it to finish (or stop it) before generating again") from None
                if other.get("host") not in (None, self.me["host"]):
                    raise DatasetError(f"{self.path.parent} is locked by process {other.get('pid')} on "
                                       f"{other.get('host')}; if that generation is dead, delete {self.path}") from None
                self.path.unlink(missing_ok=True)  # stale: its process is gone
                continue
            with os.fdopen(fd, "w") as f:
                json.dump(self.me, f)
            return self
        raise DatasetError(f"could not take the lock {self.path}")

    def __exit__(self, *exc):
        if read_json(self.path) == self.me:
            self.path.unlink(missing_ok=True)


def _spec_diff(old: dict, new: dict) -> list[str]:
    """Field names (``parameters.speed`` one level down) where two canonical specs differ."""
    diff = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if a == b:
            continue
        if isinstance(a, dict) and isinstance(b, dict) and key in ("parameters", "engine_options"):
            diff += [f"{key}.{k}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
        else:
            diff.append(key)
    return diff


def _check_folder(out: Path, spec: DatasetSpec) -> None:
    """Store the spec in a new folder, or check it against the stored one."""
    from .. import __version__

    path = out / SPEC_FILE
    new = json.loads(json.dumps(spec.to_dict()))  # as it reads back from spec.json (tuples -> lists)
    if path.exists():
        stored = read_json(path)
        if not isinstance(stored, dict) or stored.get("format") != INDEX_FORMAT or "spec" not in stored:
            raise DatasetError(f"{path} is not a sionnafmcw data-set spec; generate into a new folder")
        old = stored["spec"]
        if old != new:
            raise DatasetError(
                f"{out} holds data set {old.get('name')!r} generated from a different spec (differs in: "
                f"{', '.join(_spec_diff(old, new))}); a data set has one spec: generate into a new folder, "
                f"or delete {out} to start over")
        return
    leftovers = [p.name for p in out.iterdir() if p.name != ".lock"]
    if leftovers:
        raise DatasetError(f"{out} is not empty and holds no {SPEC_FILE} ({', '.join(sorted(leftovers)[:5])}...): "
                           "it is not a data set folder; generate into a new or empty folder")
    write_json_atomic(path, {"format": INDEX_FORMAT, "spec": new, "source": spec.source,
                             "sionnafmcw_version": __version__})


def _record(out: Path, spec: DatasetSpec, item) -> dict:
    """The item's record at start: from item.json and the state of its store on disk."""
    from ..scenes.registry import resolve

    folder = item_dir(out, item.id)
    old = read_json(folder / "item.json") or {}
    num_frames = resolve(spec.scenario, item.parameters).get("num_frames")
    record = {**item.to_dict(), "status": "pending", "error": old.get("error", ""),
              "traceback": old.get("traceback", ""), "attempts": int(old.get("attempts", 0)),
              "seconds": old.get("seconds"), "cpu_seconds": old.get("cpu_seconds"), "worker": old.get("worker", ""),
              "ran": False,
              "num_frames": int(num_frames) if num_frames is not None else 0, "labels": None}
    state = store_state(folder / "run.zarr", spec.frames)
    if state["complete"]:
        record["status"] = "complete"
        record["error"] = record["traceback"] = ""
        labels = old.get("labels") if old.get("status") == "complete" else None
        record["labels"] = labels or store_labels(folder / "run.zarr", spec.label_object)
    else:
        if old.get("status") == "failed":
            record["status"] = "failed"
        if state["frame_done"].any():
            record["labels"] = _partial_labels(folder / "run.zarr", spec.label_object)
    if state["complete"] and old.get("status") != "complete":
        _save_record(out, record)  # finished after its driver died (the worker outlived it): recorded now
    record["frames_done"] = int(state["frame_done"].sum())
    if state["num_frames"]:
        record["num_frames"] = state["num_frames"]
    return record


def _partial_labels(store: Path, label_object):
    try:
        return store_labels(store, label_object)
    except Exception:  # noqa: BLE001 - a store cut off too early to read: no labels yet
        return None


def _summary(spec, records, elapsed) -> str:
    complete = sum(r["status"] == "complete" for r in records)
    failed = [r for r in records if r["status"] == "failed"]
    ran_ok = sum(r["ran"] and r["status"] == "complete" for r in records)
    skipped = sum(r["status"] == "complete" and not r["ran"] for r in records)
    pending = len(records) - complete - len(failed)
    line = (f"data set {spec.name!r}: {complete}/{len(records)} items complete ({ran_ok} generated now, "
            f"{skipped} already done), {len(failed)} failed" + (f", {pending} pending" if pending else "")
            + f", {elapsed:.1f} s")
    for r in failed[:5]:
        line += f"\n  item {r['id']} failed: {r['error'].splitlines()[0] if r['error'] else '?'}"
    if len(failed) > 5:
        line += f"\n  ... and {len(failed) - 5} more (see the index's 'error')"
    return line


def generate(spec, out, scheduler=None, workers: int | None = None, progress: bool = True, retries: int = 0,
             cluster_options: dict | None = None, item_threads: int | None = None):
    """Generate (or resume) the data set ``spec`` in the folder ``out``; returns the index (``xarray.Dataset``).

    Parameters
    ----------
    spec : path of a YAML/JSON spec, a dict, or a :class:`DatasetSpec` (see :mod:`.spec`)
    out : folder of the data set; created if missing. The spec is stored in it; running again
        with the same spec skips complete items and redoes the others, a different spec is refused.
    scheduler : None (default): a new ``distributed.LocalCluster`` on this machine (processes,
        1 thread each), closed at the end; a scheduler address (``"tcp://host:8786"``) or a
        ``distributed.Client``: use that cluster (left running). Its workers need sionnafmcw
        installed and ``out`` at the same path (a shared file system).
    workers : number of local worker processes (default: ``min(cores, items to do)``); local cluster only
    progress : tqdm bar over items and a summary line on stderr
    retries : Dask retries of a task whose worker died (an exception inside an item is not retried)
    cluster_options : extra ``LocalCluster`` keyword arguments (e.g. ``memory_limit``)
    item_threads : CPU threads of each item's run (``simulate``'s ``threads``: Dr.Jit gets one fewer,
        BLAS one, :mod:`sionnafmcw.threads`); default ``cores // workers`` on the local cluster, the
        worker machine's cores with ``scheduler=``

    Notes
    -----
    A local cluster spawns worker processes that re-import the calling script: call this from
    under ``if __name__ == "__main__":`` in a script. Failed items are in the index
    (``status == "failed"``, ``error``), in the summary, and raise a :class:`DatasetWarning`.
    """
    spec = load_spec(spec)
    if item_threads is not None and (isinstance(item_threads, bool) or int(item_threads) < 1):
        raise ValueError(f"generate: item_threads must be an integer >= 1, got {item_threads!r}")
    t_start = time.perf_counter()
    out = Path(out).expanduser().resolve()
    out.mkdir(parents=True, exist_ok=True)
    items = spec.items()
    records: list = []
    try:
        with handling_signals(), _Lock(out):
            summary, index = _generate_locked(spec, out, items, records, scheduler, workers, progress, retries,
                                              cluster_options, item_threads, t_start)
    except BaseException as exc:
        if is_interrupt(exc):
            complete = sum(r["status"] == "complete" for r in records)
            raise DatasetInterrupted(as_interrupted(exc).signum, complete, len(items), out) from None
        raise
    if progress:
        print(summary, file=sys.stderr)
    if any(r["status"] == "failed" for r in records):
        warnings.warn(summary, DatasetWarning, stacklevel=2)
    return index


def _generate_locked(spec, out, items, records, scheduler, workers, progress, retries, cluster_options,
                     item_threads, t_start):
    """The body of :func:`generate` under the folder's lock; fills ``records`` in place (the caller
    counts the complete items when interrupted). Returns ``(summary, index)``."""
    _check_folder(out, spec)
    for stale in out.glob(f".{INDEX_DIR}.*"):  # left by a killed index write
        shutil.rmtree(stale, ignore_errors=True)
    for it in items:
        records.append(_record(out, spec, it))
    todo = [it for it, r in zip(items, records) if r["status"] != "complete"]
    write_index(out, build_index(spec, records, "generation started"))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(items), initial=len(items) - len(todo), desc=f"generate {spec.name}", unit="item")
    summary = "generation interrupted"
    try:
        if todo:
            from .cluster import connect

            _run_on_cluster(spec, out, todo, {r["id"]: r for r in records}, bar,
                            connect(scheduler, workers, len(todo), cluster_options), item_threads, retries)
        summary = _summary(spec, records, time.perf_counter() - t_start)
    finally:
        if bar is not None:
            bar.close()
        index = build_index(spec, records, summary)
        write_index(out, index)
    return summary, index


def _run_on_cluster(spec, out, todo, by_id, bar, connection, item_threads, retries) -> None:
    """Submit one task per item in ``todo``; record every result as it arrives (item.json, index)."""
    from distributed import as_completed

    client, close, threads = connection
    if item_threads is not None:
        threads = int(item_threads)
    spec_dict = spec.to_dict()
    futures = {}
    try:
        for it in todo:
            task = {"spec": spec_dict, "item": it.to_dict(), "dir": str(item_dir(out, it.id)), "threads": threads}
            key = f"sionnafmcw-item-{spec.name}-{it.id}-{os.urandom(4).hex()}"
            futures[client.submit(run_item, task, key=key, pure=False, retries=retries)] = it.id
        last_write = time.monotonic()
        for fut in as_completed(futures):
            record = by_id[futures[fut]]
            try:
                result = fut.result()
            except Exception as exc:  # the worker died (KilledWorker) or the task was lost
                result = {"status": "failed", "error": f"{type(exc).__name__}: {exc}",
                          "traceback": traceback.format_exc(), "seconds": None, "worker": ""}
            record.update(status=result["status"], error=result.get("error", ""),
                          traceback=result.get("traceback", ""), seconds=result.get("seconds"),
                          cpu_seconds=result.get("cpu_seconds"), worker=result.get("worker", ""), ran=True,
                          attempts=record["attempts"] + 1, labels=result.get("labels"))
            store = item_dir(out, record["id"]) / "run.zarr"
            state = store_state(store, spec.frames)
            if record["labels"] is None and state["frame_done"].any():  # a partial store: label its done frames
                record["labels"] = _partial_labels(store, spec.label_object)
            record["frames_done"] = int(state["frame_done"].sum())
            if state["num_frames"]:
                record["num_frames"] = state["num_frames"]
            _save_record(out, record)
            _faults.point("item-recorded", item=record["id"])
            if bar is not None:
                bar.update(1)
                bar.set_postfix(failed=sum(r["status"] == "failed" for r in by_id.values()), refresh=False)
            if time.monotonic() - last_write > INDEX_INTERVAL:
                write_index(out, build_index(spec, list(by_id.values()), "generation running"))
                last_write = time.monotonic()
    finally:
        for fut in futures:
            if not fut.done():
                fut.cancel()
        close()


def _save_record(out: Path, record: dict) -> None:
    folder = item_dir(out, record["id"])
    folder.mkdir(parents=True, exist_ok=True)
    write_json_atomic(folder / "item.json", record)


__all__ = ["DatasetInterrupted", "DatasetWarning", "generate", "run_item", "worker_identity"]
