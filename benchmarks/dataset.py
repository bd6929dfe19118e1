r"""Data-set generation throughput: items per minute with 1 and with 2 Dask workers on this machine.

For each worker count W the script starts a ``distributed.LocalCluster`` of W processes (1
thread each), warms it with one item per worker (process start, imports, first kernel
compilation: the one-off cost :math:`t_w`), then times :func:`sionnafmcw.dataset.generate` of a
fresh ``--items``-item data set on the warm cluster (CPU threads per item = cores // W: simulate's threads).
The warm-up items have at most ``--warm-frames`` frames (4): what they warm does not grow with an
item's length. It prints items/minute, the ratio to the 1-worker baseline measured in the same
process, the mean per-item wall time inside a worker and its CPU time (from the index), the scheduler
overhead per task (:math:`t_s`, from a burst of no-op tasks) and the bytes each item writes
(:math:`S`).

Estimate for a cluster of :math:`M` machines of :math:`C` cores, one single-threaded worker per
core (a shared file system holding ``out``, one scheduler), with :math:`t_1` the CPU time of one
item (core-seconds, from the 1-worker run: CPU time is not stretched by other users' load the
way wall time is):

.. math::
    T(N) \approx t_w + \left\lceil \frac{N}{M C} \right\rceil t_1,\qquad
    \text{throughput} \approx \min\left(\frac{M C}{t_1},\ \frac{1}{t_s},\ \frac{B}{S}\right)

where :math:`B` is the file system's aggregate write bandwidth. The scheduler handles a task in
:math:`t_s` (about a millisecond on an idle machine), so it limits only when :math:`M C > t_1/t_s`;
storage limits when :math:`M C S / t_1` approaches :math:`B`. Items are independent (no data
moves between workers), so nothing else grows with :math:`M`.

Caveat: this machine has 2 cores shared with other users; the load average is printed with the
numbers.

    python benchmarks/dataset.py [--items 8] [--frames 4] [--chirps 64] [--scenario moving_plate]
        [--engine-options '{"static_scene": false}']

Measured
--------
The run's threads (:mod:`sionnafmcw.threads`: an item of a 1-worker cluster on 2 cores runs its
engine with one Dr.Jit worker and BLAS at one thread, before with two Dr.Jit workers and BLAS at
two) against main before them (3cca147), each tree from its own copy (``PYTHONPATH``), alternated
twice, ``--scenario straight_walk --items 4 --frames 4 --workers 1``: t_1 = 10.64 / 10.75
core-s/item before, 9.58 / 9.71 after (0.90 of before; about 670 and 745 items an hour on the 2
cores); 3.35 MB/item both.

The hit geometry kernel, the frozen PO kernel and the rebalanced stages against
main before them (edb4aac), the same way and command: t_1 = 9.62 / 9.54 core-s/item before, 8.80 /
8.62 after (0.91; about 750 and 825 items an hour on the 2 cores; t_1 read from the printed
estimate, 160 workers x 60 / items per minute); 3.35 MB/item both.

The PO render's curvature classes and the static block filtered once against main
before them (39034ed), each tree from its own copy, once each, the same command, the machine
shared with other sessions (load average 6-8): t_1 = 11.91 core-s/item before, 11.15 after (0.94;
about 600 and 650 items an hour on the 2 cores); 3.35 MB/item both. The walker of
``straight_walk`` has no flattened hands and ``walk-77ghz`` no IF chain, so little changes here;
the data-set frame of ``benchmarks/frame_cost.py`` (a jumping person in a room, RadHAR's IWR1443)
drops to 0.57-0.61 of its CPU.

Short items of the RadHAR-like data sets (the first-frame work: the bounce rule's neighbour
search and chain ids, the static block's cube in chunks) against main at 96945cb (A, ``git archive
96945cb | tar -x -C /tmp/ff/treeA``, ``PYTHONPATH`` set to each tree, this script for both), A then
B, the machine shared with a data-set generation (load average 6-9), 4-frame items, 1 worker::

    PYTHONPATH=/tmp/ff/treeA python benchmarks/dataset.py --scenario radhar --items 3 --frames 4 --workers 1
    PYTHONPATH=/tmp/ff/treeA python benchmarks/dataset.py --scenario people --people 3 --items 3 --frames 4 \
        --workers 1

    scenario            A cpu s/item  B cpu s/item  B/A    (A, B items/min, wall: load-bound)
    radhar (1 person)   32.21         32.95         1.02   0.9, 0.8 (B beside a benchmark run)
    people (3 people)   36.04         36.95         1.03   1.4, 1.4
    radhar, again (B first, then A, load 7 falling to 2)
                        33.69         35.24         1.05   1.6, 1.5

8-9 core-seconds a frame, 100-110 items an hour on one core. The first-frame savings
(``benchmarks/first_frame.py``: 1-1.5 CPU-s of a 2-frame item's 10-13 CPU-s) are 3-5 % of an item,
and these pairs do not show them: A's two radhar runs differ by 5 %, B's by 7 %, and B's mean is
3 % above A's (not resolved at this load). 300-frame items were not run.

Against the frame-cost baseline 96e6099 (A, ``/tmp/fc/treeA``), short and long items of people walking
circles in a room (``--scenario people --activity walk_circle``: the same room for every item, the
people drawn per item), RadHAR's ``.cfg`` read by each tree itself (:func:`radar_fields`), one worker,
2-core AMD EPYC with AVX-512, the trees in turn, each command with ``PYTHONPATH`` set to the tree::

    python benchmarks/dataset.py --scenario people --people 1 --activity walk_circle --items 3 --frames 4 --workers 1
    python benchmarks/dataset.py --scenario people --people 3 --activity walk_circle --items 3 --frames 4 --workers 1
    python benchmarks/dataset.py --scenario people --people 1 --activity walk_circle --items 1 --frames 300 --workers 1
    python benchmarks/dataset.py --scenario people --people 3 --activity walk_circle --separation frames --items 1 \
        --frames 300 --workers 1

    item                      A 96e6099     B fe1d74b     C c54a091     D 728adc4    CPU-s an item (a frame)
    1 person, 4 frames        10.65 (2.66)  21.30 (5.32)  20.18 (5.05)   6.86 (1.72)
    3 people, 4 frames        20.20 (5.05)  30.32 (7.58)  29.92 (7.48)  16.29 (4.07)
    1 person, 300 frames     477.98 (1.59) 411.15 (1.37)
    3 people, 300 frames     (672 s wall)                               1077.51 (3.59), 614 s wall

B: main at the start of this measurement: the short items cost twice A's, all of it the first frame
(``benchmarks/frame_cost.py --profile``: the room's static block, 10 s of which the bounce rule of
:mod:`sionnafmcw.engines.bounce_sampling` takes 7, which A did not have: the room's corner echoes, 2.5-7.8
dB low before it). C: the blocked static samples taken from the block where the merge merged nothing (a
RadHAR item's steady frame engine 0.86x of B's CPU, engine and synthesis 0.90x; the jump scene's CPU
0.93-0.97x). D: the worker process keeps
the static block of its last item (:func:`sionnafmcw.engines.path.keep_static_blocks`) and ``simulate``
its cube: every item of this set after the first takes the room's block instead of building it; short
items cost 0.34x (1 person) and 0.54x (3 people) of C, 0.64x and 0.81x of A; items a minute on
the two cores 3.3 -> 11.0 (1 person). The first item of a worker builds it (here the warm-up item).
B's short runs and the 1-person 300-frame runs shared the machine with other work at times (their CPU
seconds are stretched a little by it); C's and D's short runs did not.
A's 3-people 300-frame item took 672 s of wall, but the index holds 35 s and 52 CPU-s for it: the time of
a last attempt that resumed the store, so its worker did not finish the first one (A's CPU a frame is not
measured; D's 614 s of wall is 0.91 of A's). Long items gain little from the kept block (one first frame in
300): one person 1.59 (A) and 1.37 (B) CPU-s a frame, three people 3.59 (D).
A spec that draws the room or the radar per item (``radhar_spec``) builds it for every item::

    python benchmarks/dataset.py --scenario radhar --items 3 --frames 4 --workers 1     # D: 28.05 CPU-s an item
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


#: RadHAR's own IWR1443 ``.cfg`` (the radar of ``--scenario radhar`` and ``people``).
RADHAR_CFG = "/work/shared/realdata/radhar/1443es1_short_range_3d.cfg"


def make_spec(name, scenario, count, frames, chirps, seed, samples, engine_options=None, people=3, cfg=RADHAR_CFG,
              activity="walk", separation="tracks"):
    """The data-set spec of ``scenario``: ``moving_plate`` and ``straight_walk`` with ``walk-77ghz`` at
    ``chirps`` chirps and ``samples_per_src`` ``samples``; ``radhar`` (one person in a furnished room,
    every range of :func:`~sionnafmcw.dataset.randomisation.radhar_spec` drawn per item) and ``people``
    (``people`` people doing ``activity`` in a room, kept ``separation`` apart) with the radar of the TI
    ``.cfg`` ``cfg`` and the engine's defaults."""
    if scenario == "radhar":
        from sionnafmcw.dataset.randomisation import radhar_spec

        return radhar_spec(name, count=count, seed=seed, radar=cfg, engine_options=engine_options or None,
                           num_frames=frames)
    params = {"num_frames": frames}
    if scenario == "people":
        return {"name": name, "scenario": "people", "count": count, "seed": seed, "radar": radar_fields(cfg),
                "engine_options": dict(engine_options or {}),
                "parameters": {"num_frames": frames, "fps": 30.0, "num_people": people, "room": True,
                               "activity": activity, "separation": separation}}
    if scenario == "moving_plate":
        params.update(speed={"uniform": [-3.0, 3.0]}, start_range={"uniform": [2.0, 6.0]})
    return {"name": name, "scenario": scenario, "count": count, "seed": seed,
            "radar": {"preset": "walk-77ghz", "num_chirps": chirps},
            "engine_options": {"samples_per_src": samples, **(engine_options or {})}, "parameters": params}


def radar_fields(cfg) -> dict:
    """The RadarConfig fields of the TI ``.cfg`` ``cfg`` as the running tree reads them (its RF lines only:
    ``frame_cost.radar_copy``), so that a tree from before data-set specs took a ``.cfg`` runs the same radar."""
    from frame_cost import radar_copy

    from sionnafmcw.radar import RadarConfig

    with tempfile.TemporaryDirectory() as tmp:
        return RadarConfig.resolve(str(radar_copy(Path(cfg), Path(tmp) / "radar_rf.cfg"))).to_dict()


def folder_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def run(workers: int, args, root: Path) -> dict:
    from distributed import Client, LocalCluster

    from sionnafmcw.dataset import generate

    cores = os.cpu_count() or 1
    threads = max(1, cores // workers)
    t0 = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        t_cluster = time.perf_counter() - t0
        warm = make_spec(f"warm{workers}", args.scenario, workers, min(args.frames, args.warm_frames), args.chirps,
                         100 + workers, args.samples,
                         args.engine_options, args.people, args.cfg,
                     args.activity, args.separation)
        generate(warm, root / f"warm{workers}", scheduler=client, progress=False, item_threads=threads)
        t_warm = time.perf_counter() - t0
        # scheduler overhead: a burst of no-op tasks
        n_noop = 500
        ts = time.perf_counter()
        client.gather(client.map(lambda i: i, range(n_noop), pure=False))
        t_sched = (time.perf_counter() - ts) / n_noop
        spec = make_spec(f"bench{workers}", args.scenario, args.items, args.frames, args.chirps, 7, args.samples,
                         args.engine_options, args.people, args.cfg,
                     args.activity, args.separation)
        ts = time.perf_counter()
        index = generate(spec, root / f"bench{workers}", scheduler=client, progress=False, item_threads=threads)
        elapsed = time.perf_counter() - ts
    ok = int((index.status.values == "complete").sum())
    size = np.mean([folder_bytes(root / f"bench{workers}" / "items" / i) for i in index.item.values])
    return {"workers": workers, "cluster_s": t_cluster, "warm_s": t_warm, "elapsed_s": elapsed, "complete": ok,
            "items_per_min": 60.0 * ok / elapsed, "item_s": float(np.nanmean(index.seconds.values)),
            "item_cpu_s": float(np.nanmean(index.cpu_seconds.values)),
            "sched_ms": 1e3 * t_sched, "bytes": float(size), "threads": threads}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--items", type=int, default=8)
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--warm-frames", type=int, default=4,
                        help="frames of the warm-up items (process start, imports, first compilation: their length "
                             "does not matter; at most --frames)")
    parser.add_argument("--chirps", type=int, default=64, help="chirps per Tx of walk-77ghz (128 samples)")
    parser.add_argument("--samples", type=int, default=20_000, help="PathEngine samples_per_src")
    parser.add_argument("--scenario", default="moving_plate",
                        choices=["moving_plate", "straight_walk", "radhar", "people"],
                        help="radhar: one person in a furnished room, people: --people in a room (both with --cfg's "
                             "radar and the engine's defaults)")
    parser.add_argument("--people", type=int, default=3, help="people of --scenario people")
    parser.add_argument("--activity", default="walk",
                        help="what the people of --scenario people do (long items: walkers need room for their "
                             "tracks; jump stays in place)")
    parser.add_argument("--separation", default="tracks", choices=("tracks", "frames"),
                        help="people of --scenario people: swept tracks apart, or apart in every frame (long items "
                             "of several walkers)")
    parser.add_argument("--cfg", default=RADHAR_CFG, help="TI .cfg of --scenario radhar and people")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--keep", help="folder to keep the data sets in (default: a temporary one)")
    parser.add_argument("--engine-options", type=json.loads, default={},
                        help='more path-engine options as JSON, e.g. \'{"static_scene": false}\' (before/after runs)')
    args = parser.parse_args(argv)

    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="sionnafmcw-bench-"))
    radar = (f"radar {args.cfg}" + (f", {args.people} people" if args.scenario == "people" else "")
             if args.scenario in ("radhar", "people") else
             f"walk-77ghz with {args.chirps} chirps, samples_per_src={args.samples}")
    print(f"{args.items} items x {args.frames} frames of {args.scenario}, {radar}, engine options "
          f"{args.engine_options}; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    rows = []
    try:
        for w in args.workers:
            rows.append(run(w, args, root))
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    if not all(r["complete"] for r in rows):
        raise SystemExit("no item completed in some run (the data set's warnings above say why)")
    base = rows[0]["items_per_min"]
    print(f"{'workers':>7} {'start s':>8} {'warm s':>7} {'items':>6} {'time s':>7} {'items/min':>10} {'ratio':>6} "
          f"{'t_1 s':>6} {'cpu s':>6} {'cpu s/frame':>11} {'sched ms':>9} {'MB/item':>8}")
    for r in rows:
        print(f"{r['workers']:>7} {r['cluster_s']:>8.1f} {r['warm_s']:>7.1f} {r['complete']:>6} {r['elapsed_s']:>7.1f} "
              f"{r['items_per_min']:>10.1f} {r['items_per_min'] / base:>6.2f} {r['item_s']:>6.2f} "
              f"{r['item_cpu_s']:>6.2f} {r['item_cpu_s'] / args.frames:>11.3f} {r['sched_ms']:>9.2f} "
              f"{r['bytes'] / 1e6:>8.2f}")
    print(f"load average after: {os.getloadavg()[0]:.2f}  (t_1: wall time of one item in a worker; cpu: its "
          "worker's CPU time meanwhile; ratio: items/min against the first row)")

    # ---- the cluster estimate: per-item cost from the 1-worker row (CPU time: what an item costs a
    # dedicated core), scheduler overhead and item size measured above
    r1 = rows[0]
    t1 = r1["item_cpu_s"]  # core-seconds per item: unaffected by the other users' load, unlike wall time
    ts = min(r["sched_ms"] for r in rows) / 1e3
    size = rows[-1]["bytes"]
    tw = max(r["warm_s"] for r in rows)
    print(f"\nestimate for M machines of C cores, one worker per core (t_1 = {t1:.2f} core-s/item from the "
          f"1-worker run, t_s = {ts * 1e3:.2f} ms/task, S = {size / 1e6:.2f} MB/item, t_w = {tw:.0f} s start-up):")
    for m, c in ((1, 2), (1, 16), (10, 16), (100, 16), (1000, 16)):
        compute = m * c / t1
        rate = min(compute, 1.0 / ts)  # items/s, capped by the scheduler
        hours = (tw + max(math.ceil(1e5 / (m * c)) * t1, 1e5 * ts)) / 3600
        print(f"  M={m:>4} x C={c:>2}: compute {60 * compute:>9.0f} items/min, with the scheduler cap "
              f"{60 * rate:>8.0f} items/min, writes {rate * size / 1e6:>7.1f} MB/s; 10^5 items in {hours:>6.2f} h")
    print("  (t_s measured here on a loaded 2-core machine; a dedicated scheduler core does ~1 ms/task)")
    print(f"  limits: one scheduler handles ~{60 / ts:,.0f} tasks/min (1/t_s), so it caps the cluster only when "
          f"M*C > t_1/t_s = {t1 / ts:,.0f} workers; a file system of B MB/s caps it at B/S = B/{size / 1e6:.2f} "
          f"items/s, i.e. at M*C = B * t_1 / S = {t1 / (size / 1e6):.2f} * B workers.")


if __name__ == "__main__":
    main()
