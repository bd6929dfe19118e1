"""The paper's circle walk end to end, path engine "before" (A) against "after" (B): time, memory, accuracy.

What it measures: ``make demo`` (``validation/circle_walk.py --engine path``) without the plots.
The ``circle_walk`` scene (one 3 m lap in 100 frames) is simulated with radar ``walk-77ghz``
into a Zarr store (``validation.common.run_engine`` = ``simulate``, noise seed 0) and analysed
as the validation does (``validation.circle_walk.analyse``: e_velo, median error, share of
CPIs within one Doppler bin), for two path-engine settings:

* A, "before": ``PathEngine(static_scene=False)``: every frame traced and PO-rendered whole;
* B, "after": the engine's defaults (``static_scene=True``: the static room's paths and PO
  cached per radar pose).

How: for every solver seed (``--seeds``, engine option ``seed``) the A and B runs follow each
other (same machine load), each in its own subprocess (``--worker``), so that its peak RSS
(``ru_maxrss`` of the worker, children reported apart) is its own. The worker creates the engine
itself (``sionnafmcw.engines.create("path", **options)``) and reads ``engine.stats``: per run the
total ``simulate`` seconds (imports, animation load and engine creation reported apart; the
scene is built beforehand), its CPU seconds (``cpu s``: user + system of the worker, all threads;
on a shared machine a steadier measure of the work than the wall time, which other tenants
stretch), seconds per frame, every ``*_seconds`` figure of the engine summed over
frames (``po_seconds``, ``trace_seconds``, ``adapt_seconds``, ``static_seconds``, whatever is
present), synthesis + store (simulate minus engine), the first frame apart (scene load, kernel
compilation: ``kernels_compiled``, ``reloaded``) from the steady state (median of frames >= 1).

``--cold``: one extra pair of short runs (``--cold-frames``, method B, first seed) with Dr.Jit's
on-disk kernel cache in a fresh temporary directory: the first run compiles every kernel (cold),
the second reuses that directory (warm). Dr.Jit reads the cache directory from the environment
variable ``DRJIT_CACHE_DIR`` when it initialises (default ``$HOME/.drjit``, files
``<hash>.llvm.v6.bin``), so the worker gets it in its environment before ``drjit`` is imported.

    python benchmarks/circle_walk.py [--frames 100] [--seeds 1 2 3] [--scene DIR] [--cold] [--json PATH]
    python benchmarks/circle_walk.py --frames 4 --seeds 1 --scene /tmp/cw8 --method-a '{}'
    git worktree add /tmp/before HEAD~1 && python benchmarks/circle_walk.py --method-a '{}' --tree-a /tmp/before

``--tree-a`` / ``--tree-b``: the run imports ``sionnafmcw`` from that checkout (``PYTHONPATH``),
so that a code change is measured against the code before it, interleaved, with the same options.
``--scene-a`` / ``--scene-b``: each method's own scene (default ``--scene`` for both), for a change
of the scene format (rigid parts stored once: the walk written a PLY per segment and frame before, once per segment
with a transform per frame after; each tree reads the scene its own builder wrote).

Measured
--------
``python benchmarks/circle_walk.py --frames 100 --seeds 1 2 3 --scene /tmp/cw8 --cold`` on the
2-core machine with nothing else running (the 8 mm circle-walk scene built beforehand; seconds
over the 100 frames; ``synth+st`` is ``simulate`` minus the engine: the synthesis of frame n runs
on a worker thread while the engine computes frame n + 1, so only what does not overlap shows)::

    run      total s s/frame first s steady engine s synth+st  adapt    po static trace e_velo median <1 bin peak MiB
    A mean     236.9    2.37     4.0   2.30    230.1      6.8    3.0 205.8      -   7.5  0.489  0.102    42%     1934
    B mean      91.5    0.92     3.7   0.81     84.5      7.1    1.6  58.2    2.9   7.2  0.489  0.102    42%     1513

time B/A 0.378 / 0.394 / 0.388 (seeds 1 / 2 / 3), mean 0.386; peak memory B/A 0.78; e_velo
0.485 / 0.522 / 0.459 m/s for both (identical to four decimals: the static split changes the
echoes only by the PO merge error). Kernel cache: first frame 4.1 s cold (23 kernels compiled),
3.3 s warm (1). The engine's PO of the moving body (some 4e4 first-bounce samples at the
resolution rule's 3.5 mm, and their second bounces) is now 64 % of the run.

The PO integral as Dr.Jit kernels (``engines/po_kernel.py``), the numpy around it trimmed and
the per-frame beat sum given 90 % of the error budget, against the code before (a ``git worktree``
of that commit, same options: the defaults), on a 2-core AMD EPYC (slower than the machine
above)::

    python benchmarks/circle_walk.py --frames 100 --seeds 1 2 3 --scene /tmp/cw8 --method-a '{}' \
        --tree-a /tmp/headtree --cold

    run      total s s/frame first s steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean     125.2    1.25     4.6   1.12    115.7      9.4   3.0        -  77.2    3.3  13.4  0.489     1521
    B mean      88.4    0.88     3.5   0.76     80.7      7.7   2.5     11.2  46.5    2.4  11.4  0.489     1617

time B/A 0.745 / 0.731 / 0.649 (seeds 1 / 2 / 3), mean 0.706; peak memory B/A 1.063; e_velo
0.485 / 0.522 / 0.459 m/s for both. Kernel cache: first frame 4.4 s cold (26 kernels compiled),
3.0 s warm (1). ``geometry`` (new figure: Mitsuba's parameter update, which rebuilds the BVH of
the 191k-triangle body) and Sionna's ``trace`` are 0.11 s per frame each: 22.6 s of the 88.4 s.

The second-order in-sample phase of the PO samples (``physical_optics.footprint_factor``: range
curvature and the surface's shape operator; the samples' size unchanged), against the code
before it (a ``git worktree`` of that commit), same command without ``--cold``, on a day when
the same machine ran the code before in 120 s instead of 125 s::

    run      total s s/frame first s steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean     119.9    1.20     4.7   1.06    110.7      9.2   3.5     14.1  64.6    3.3  16.3  0.489     1624
    B mean     129.1    1.29     4.5   1.16    121.0      8.1   3.7     14.1  75.3    3.2  16.6  0.427     1636

time B/A 1.078 / 1.075 / 1.075 (mean 1.076); peak memory B/A 1.007; e_velo 0.485 / 0.522 / 0.459
(A) against 0.414 / 0.450 / 0.418 m/s (B), 0.04-0.07 m/s lower on every seed. The PO stage costs
0.11 s per frame more: the shape operator of every hit and the factor's three sincos per
element pair and sample.

Less CPU per frame (the synthesis's numpy, complex64 up to twice the unambiguous Doppler, the
truth centroids before the first frame, PLY faces, the room's flat-shaded normals), against the
code before it (a ``git worktree`` of that commit), same command, with the new ``cpu s``
column::

    run      total s   cpu s s/frame first s  steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean     124.1   220.2    1.24     4.9    1.12    116.2      7.8   3.4     13.9  71.5    3.4  15.9  0.427     1627
    B mean     115.9   207.1    1.16     4.8    1.07    112.1      3.8   3.5     13.6  67.6    3.3  15.9  0.427     1511

time B/A 0.916 / 0.916 / 0.974 (mean 0.934), CPU B/A 0.922 / 0.920 / 0.982 (mean 0.940), peak
memory B/A 0.928; e_velo 0.414 / 0.450 / 0.418 m/s for both. ``synth+st`` halves (the truth
centroids of 13 segments x 100 frames, computed before the first frame, took 7-8 s); the run
stays CPU-bound: 207 CPU-s in 116 s on two cores.

Rigid parts stored once (32 mm body on its smooth PO surface, Sionna on the stored proxy) against
main before them as A with its own 8 mm per-frame scene (460 MB), B the new builder's scene (2.4 MB)::

    python benchmarks/circle_walk.py --frames 100 --seeds 1 2 3 --scene-a /tmp/cw_base \
        --scene-b /tmp/cw_quad --tree-a /work/main --tree-b /tmp/snap24 --method-a '{}'

    run      total s   cpu s s/frame first s  steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean      45.2    83.5    0.45     1.6    0.41     43.9      1.3   1.2      6.6  26.3    1.1   5.2  0.427     1535
    B mean      40.9    77.5    0.41     1.2    0.38     40.1      0.8   1.1      1.4  30.2    0.6   6.0  0.461     1553

time B/A 0.925 / 0.873 / 0.921 (mean 0.906), CPU B/A 0.929, peak memory B/A 1.012; e_velo 0.414 /
0.450 / 0.418 (A) against 0.474 / 0.458 / 0.452 m/s (B). ``geometry`` (the body's BVH) falls from
6.6 to 1.4 s; the PO stage rises by 3.9 s (the smooth-surface samples' positions and normals), so
the 30 s target is not reached: what is left per frame is the PO render and integral (0.30 s),
Sionna's full re-trace of the room (0.06 s) and the synthesis in parallel.

The same A (``/tmp/treeA``: main at fe4d965, its 8 mm scene) against the run's threads set for its
two stages (:mod:`sionnafmcw.threads`) and, as ``make demo``'s entry point does first, one glibc
arena (:func:`sionnafmcw.heap.limit_arenas`, called by this worker when the tree has it;
``--tree-b`` a copy of that tree), seeds 1-3::

    run      total s   cpu s s/frame first s  steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean      44.7    82.5    0.45     1.6    0.40     43.5      1.1   1.2      6.6  26.3    1.1   5.2  0.427     1442
    B mean      36.4    54.6    0.36     1.4    0.34     35.8      0.6   1.0      1.7  25.6    0.7   5.9  0.461     1402

time B/A 0.785 / 0.828 / 0.831 (mean 0.814), CPU B/A 0.650 / 0.666 / 0.671 (mean 0.662), peak memory
B/A 0.973 / 0.969 / 0.973 (mean 0.972). Without the arena limit (the worker before it called
``limit_arenas``: the library's defaults alone) B took 37.3 s, time B/A 0.809, CPU 0.651, peak
memory 0.994 / 1.000 / 1.003. B's e_velo is the previous B's to the last digit (the threads change
no sum: ``tests/test_simulate.py`` holds the cube bit for bit). Seeds 4-6, the previous B (before
the threads) against A: e_velo A 0.469 / 0.428 / 0.482, B 0.492 / 0.447 / 0.432; over the six seeds
A 0.443 (sd 0.028), B 0.459 (sd 0.021), B - A +0.016 m/s (se 0.015, paired t-test p = 0.34): within
the seeds' spread. The run is CPU-bound: 54.6 CPU-s in 36.4 s on 2 cores, so even a perfect overlap
of the stages leaves some 28 s; the PO stage is 0.26 s a frame over the lap.

The geometry of the hits on the body's refined surfaces in one Dr.Jit kernel
(``engines/hit_geometry.py``), the PO kernel frozen (``dr.freeze``), the normal gradients per
triangle, the merge's cell keys column by column, the spheres' test at once, the spherical basis
without angles, bounce 1's image maps as broadcasts, and the run's stages rebalanced (the synthesis
on ``threads // 2`` plans, all threads while it is behind, two frames queued:
:mod:`sionnafmcw.threads`, :data:`sionnafmcw.simulation.PENDING_FRAMES`), same command as above::

    run      total s   cpu s s/frame first s  steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean      44.5    82.3    0.45     1.7    0.40     43.4      1.1   1.2      6.5  26.3    1.1   5.2  0.427     1430
    B mean      29.0    48.2    0.29     1.2    0.25     27.1      1.9   0.8      1.7  17.4    0.5   5.8  0.461     1440

B 28.8 / 29.0 / 29.3 s (seeds 1 / 2 / 3): time B/A 0.640 / 0.666 / 0.651 (mean 0.652), CPU 0.586,
peak memory 0.998 / 1.016 / 1.008 (A's own peak moves by 40-100 MiB from run to run); e_velo
0.474 / 0.458 / 0.452, the previous B's to the digit. With the surfaces' arrays then views of the
kernel's tables (one copy), the same command an hour later, on a machine 7 % slower (A 47.7 s):
B 31.3 s, time B/A 0.645 / 0.659 / 0.665 (0.656), peak memory B/A 1.002 / 0.988 / 0.952 (0.980;
B 1403 MiB, A 1431).

The PO render's curvature classes (``engines/po_render.py``: each class of an object's triangles on
the grid its own curvature needs; the walker's body 3 % fewer PO contributions) and the static block
filtered once, against main before them (39034ed, ``git archive`` into ``/tmp/fc/treeA``), on the
2-core machine shared with other sessions (load average 6-11: the wall times are not comparable)::

    python benchmarks/circle_walk.py --frames 100 --seeds 1 2 3 --out /tmp/fc/cwout --method-a '{}' \
        --tree-a /tmp/fc/treeA

    run      total s   cpu s s/frame first s  steady engine s synth+st adapt geometry    po static trace e_velo peak MiB
    A mean     149.5    72.9    1.49     5.3    1.40    144.6      4.9   4.9      6.3  95.5     3.1  31.5  0.461     1407
    B mean     177.3    68.4    1.77     7.1    1.63    172.7      4.6   6.0      7.8 109.9     4.1  41.1  0.439     1376

CPU B/A 0.922 / 0.950 / 0.943 (mean 0.938), peak memory B/A 0.978; e_velo A 0.474 / 0.458 / 0.452
(the B above to the digit), B 0.429 / 0.426 / 0.462 m/s: B - A -0.044 / -0.031 / +0.010 (mean
-0.022, sd 0.028), within the seeds' spread (six seeds before: sd 0.021-0.028 m/s).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import walk_frames

METHODS = {"A": {"static_scene": False}, "B": {}}
LABELS = {"A": "before", "B": "after"}
REPO = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------- worker (one run)
def limit_heap() -> None:
    """What make demo's entry point does first: one glibc arena for the run's threads (a tree without
    ``sionnafmcw.heap`` did not)."""
    try:
        from sionnafmcw.heap import limit_arenas
    except ImportError:
        pass
    else:
        limit_arenas(1)


def run_setup(spec: dict, clear_store: bool = False) -> tuple:
    """``(animation, radar, frames, engine, store)`` of a worker's ``spec`` (its ``scene``, ``radar``,
    ``frames``, engine ``options`` and ``store``); ``clear_store`` removes a store left by an earlier run."""
    from sionnafmcw import engines
    from sionnafmcw.animation import load_animation
    from sionnafmcw.radar import RadarConfig

    animation = load_animation(spec["scene"])
    radar = RadarConfig.resolve(spec["radar"])
    frames = list(range(min(spec["frames"], animation.num_frames)))
    try:
        engine = engines.create("path", **spec["options"])
    except (TypeError, ValueError, engines.EngineError) as exc:
        raise SystemExit(f"engine options {spec['options']}: {exc}") from None
    store = Path(spec["store"])
    if clear_store and store.exists():
        import shutil
        shutil.rmtree(store)
    return animation, radar, frames, engine, store


def worker(spec: dict) -> dict:
    t0 = time.perf_counter()
    limit_heap()
    import numpy as np

    from sionnafmcw import engines, sionna_rt  # noqa: F401  (Dr.Jit, Mitsuba and Sionna imported here)
    from sionnafmcw.validation.circle_walk import analyse
    from sionnafmcw.validation.common import run_engine

    t_import = time.perf_counter() - t0
    t0 = time.perf_counter()
    animation, radar, frames, engine, store = run_setup(spec)
    t_setup = time.perf_counter() - t0
    cpu0 = walk_frames.cpu_seconds()
    run, seconds = run_engine(animation, radar, engine, store, frames=frames, seed=0, progress=False)
    cpu_seconds = walk_frames.cpu_seconds() - cpu0
    stats = list(engine.stats)
    t0 = time.perf_counter()
    result = analyse(run, frames=frames)
    t_analysis = time.perf_counter() - t0
    if not spec.get("keep"):
        import shutil
        shutil.rmtree(store, ignore_errors=True)

    per_frame = np.array([s.seconds for s in stats])
    keys = sorted({k for s in stats for k in s.figures if k.endswith("_seconds")})
    stage = {k: float(sum(s.figures.get(k, 0.0) for s in stats)) for k in keys}
    first = stats[0]
    rest = stats[1:]
    ru_self = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    ru_child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return {
        "options": spec["options"], "engine_settings": engine.settings(), "frames": len(frames),
        "import_seconds": t_import, "setup_seconds": t_setup, "analysis_seconds": t_analysis,
        "total_seconds": seconds, "seconds_per_frame": seconds / len(frames), "cpu_seconds": cpu_seconds,
        "engine_seconds": float(per_frame.sum()), "synthesis_store_seconds": seconds - float(per_frame.sum()),
        "stage_seconds": stage,
        "first_frame": {"seconds": first.seconds, "kernels_compiled": first.kernels_compiled,
                        "kernels_launched": first.kernels_launched, "reloaded": first.reloaded,
                        "stage_seconds": {k: float(first.figures.get(k, 0.0)) for k in keys}},
        "steady": {"engine_seconds_median": float(np.median(per_frame[1:])) if rest else None,
                   "stage_seconds_median": {k: float(np.median([s.figures.get(k, 0.0) for s in rest]))
                                            for k in keys} if rest else {},
                   "kernels_compiled": int(sum(s.kernels_compiled for s in rest))},
        "kernels_compiled": int(sum(s.kernels_compiled for s in stats)),
        "metrics": {k: result[k] for k in ("e_velo", "e_velo_cpi_centre", "median_abs_error", "max_abs_error",
                                           "bias", "fraction_within_one_bin", "velocity_bin", "num_cpis")},
        "peak_rss_mib": ru_self, "peak_rss_children_mib": ru_child,
    }


# ----------------------------------------------------------------------------- parent
def launch(spec: dict, env_extra: dict | None = None, script: str | Path | None = None) -> dict:
    """Run one worker subprocess on ``spec``; its JSON result (its output goes to our stderr).
    ``script``: the benchmark whose ``--worker`` runs it (default this one)."""
    with tempfile.NamedTemporaryFile("r", suffix=".json", delete=False) as fh:
        result_path = fh.name
    env = os.environ | (env_extra or {})
    cmd = [sys.executable, str(Path(script or __file__).resolve()), "--worker", json.dumps(spec), "--result", result_path]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, cwd=REPO, stdout=sys.stderr, stderr=sys.stderr)
    wall = time.perf_counter() - t0
    try:
        text = Path(result_path).read_text()
    finally:
        os.unlink(result_path)
    if proc.returncode != 0 or not text:
        raise SystemExit(f"worker {spec['label']} failed (exit status {proc.returncode}); its output is above")
    return json.loads(text) | {"process_wall_seconds": wall}


def fmt_row(name: str, r: dict, keys: list[str]) -> str:
    m = r["metrics"]
    steady = r["steady"]["engine_seconds_median"]
    cells = [f"{name:<12}", f"{r['total_seconds']:8.1f}", f"{r.get('cpu_seconds', float('nan')):7.1f}",
             f"{r['seconds_per_frame']:7.2f}",
             f"{r['first_frame']['seconds']:7.1f}", f"{steady if steady is not None else float('nan'):7.2f}",
             f"{r['engine_seconds']:8.1f}", f"{r['synthesis_store_seconds']:8.1f}"]
    cells += [f"{r['stage_seconds'][k]:{max(len(k) - 8, 7)}.1f}" if k in r["stage_seconds"]
              else f"{'-':>{max(len(k) - 8, 7)}}" for k in keys]
    cells += [f"{m['e_velo']:7.3f}", f"{m['median_abs_error']:7.3f}", f"{100 * m['fraction_within_one_bin']:5.0f}%",
              f"{r['peak_rss_mib']:8.0f}"]
    return " ".join(cells)


def print_table(runs: list[dict], seeds: list[int]) -> dict:
    keys = sorted({k for r in runs for k in r["stage_seconds"]})
    head = (f"{'run':<12} {'total s':>8} {'cpu s':>7} {'s/frame':>7} {'first s':>7} {'steady':>7} {'engine s':>8} "
            f"{'synth+st':>8} " + "".join(f"{k[:-8]:>{max(len(k) - 8, 7)}} " for k in keys)
            + f"{'e_velo':>7} {'median':>7} {'<1 bin':>6} {'peak MiB':>8}")
    print(head)
    print("-" * len(head))
    by = {(r["method"], r["seed"]): r for r in runs}
    summary = {"per_seed": {}, "mean": {}}
    for seed in seeds:
        for method in ("A", "B"):
            print(fmt_row(f"{method} s{seed}", by[method, seed], keys))
        a, b = by["A", seed], by["B", seed]
        summary["per_seed"][seed] = {
            "time_ratio_b_over_a": b["total_seconds"] / a["total_seconds"],
            "cpu_ratio_b_over_a": b["cpu_seconds"] / a["cpu_seconds"],
            "peak_rss_ratio_b_over_a": b["peak_rss_mib"] / a["peak_rss_mib"],
            "abs_delta_e_velo": abs(b["metrics"]["e_velo"] - a["metrics"]["e_velo"])}
    mean = lambda xs: sum(xs) / len(xs)  # noqa: E731
    for method in ("A", "B"):
        rs = [by[method, s] for s in seeds]
        summary["mean"][method] = {
            "total_seconds": mean([r["total_seconds"] for r in rs]),
            "cpu_seconds": mean([r["cpu_seconds"] for r in rs]),
            "seconds_per_frame": mean([r["seconds_per_frame"] for r in rs]),
            "first_frame_seconds": mean([r["first_frame"]["seconds"] for r in rs]),
            "steady_engine_seconds": mean([r["steady"]["engine_seconds_median"] or 0.0 for r in rs]),
            "engine_seconds": mean([r["engine_seconds"] for r in rs]),
            "synthesis_store_seconds": mean([r["synthesis_store_seconds"] for r in rs]),
            "stage_seconds": {k: mean([r["stage_seconds"][k] for r in rs]) for k in keys
                              if all(k in r["stage_seconds"] for r in rs)},
            "e_velo": mean([r["metrics"]["e_velo"] for r in rs]),
            "median_abs_error": mean([r["metrics"]["median_abs_error"] for r in rs]),
            "fraction_within_one_bin": mean([r["metrics"]["fraction_within_one_bin"] for r in rs]),
            "peak_rss_mib": mean([r["peak_rss_mib"] for r in rs])}
    if len(seeds) > 1:
        for method in ("A", "B"):
            mm = summary["mean"][method]
            row = {"total_seconds": mm["total_seconds"], "cpu_seconds": mm["cpu_seconds"],
                   "seconds_per_frame": mm["seconds_per_frame"],
                   "first_frame": {"seconds": mm["first_frame_seconds"]},
                   "steady": {"engine_seconds_median": mm["steady_engine_seconds"]},
                   "engine_seconds": mm["engine_seconds"], "synthesis_store_seconds": mm["synthesis_store_seconds"],
                   "stage_seconds": mm["stage_seconds"], "peak_rss_mib": mm["peak_rss_mib"],
                   "metrics": {k: mm[k] for k in ("e_velo", "median_abs_error", "fraction_within_one_bin")}}
            print(fmt_row(f"{method} mean", row, keys))
    print()
    for seed, s in summary["per_seed"].items():
        print(f"seed {seed}: time B/A {s['time_ratio_b_over_a']:.3f}, CPU B/A {s['cpu_ratio_b_over_a']:.3f}, "
              f"peak memory B/A "
              f"{s['peak_rss_ratio_b_over_a']:.3f}, |e_velo B - e_velo A| {s['abs_delta_e_velo']:.4f} m/s")
    ma, mb = summary["mean"]["A"], summary["mean"]["B"]
    summary["mean"]["time_ratio_b_over_a"] = mb["total_seconds"] / ma["total_seconds"]
    summary["mean"]["cpu_ratio_b_over_a"] = mb["cpu_seconds"] / ma["cpu_seconds"]
    summary["mean"]["peak_rss_ratio_b_over_a"] = mb["peak_rss_mib"] / ma["peak_rss_mib"]
    summary["mean"]["abs_delta_e_velo"] = mean([s["abs_delta_e_velo"] for s in summary["per_seed"].values()])
    print(f"mean over {len(seeds)} seed(s): time B/A {summary['mean']['time_ratio_b_over_a']:.3f}, CPU B/A "
          f"{summary['mean']['cpu_ratio_b_over_a']:.3f}, peak memory "
          f"B/A {summary['mean']['peak_rss_ratio_b_over_a']:.3f}, |e_velo B - e_velo A| "
          f"{summary['mean']['abs_delta_e_velo']:.4f} m/s")
    return summary


def json_dict(text: str, flag: str) -> dict:
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{flag}: not JSON ({exc})") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"{flag}: expected a JSON object of engine options, got {text!r}")
    return value


def add_tree_and_worker_arguments(p, help_a: str = "run A on the sionnafmcw of this checkout") -> None:
    """``--tree-a``/``--tree-b`` (the checkout each method's subprocess imports ``sionnafmcw`` from) and the hidden
    ``--worker``/``--result`` of the subprocess itself (:func:`launch`)."""
    p.add_argument("--tree-a", default=None, help=help_a)
    p.add_argument("--tree-b", default=None, help="as --tree-a, for B")
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--result", default=None, help=argparse.SUPPRESS)


def ran_as_worker(args, worker) -> bool:
    """In a subprocess of :func:`launch` (``--worker``): run ``worker`` on its spec, write its result, True."""
    if args.worker is None:
        return False
    Path(args.result).write_text(json.dumps(worker(json.loads(args.worker))))
    return True


def tree_environments(p, args) -> dict:
    """``{method: {"PYTHONPATH": tree}}`` of ``--tree-a``/``--tree-b``; a parser error for a folder without the
    package."""
    trees = {}
    for method, tree in (("A", args.tree_a), ("B", args.tree_b)):
        if tree is not None:
            if not (Path(tree) / "sionnafmcw" / "__init__.py").is_file():
                p.error(f"--tree-{method.lower()} {tree}: no sionnafmcw package there "
                        "(expected a checkout of this repository)")
            trees[method] = {"PYTHONPATH": str(Path(tree).resolve())}
    return trees


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=100, help="frames per run (default 100: the whole lap)")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3], help="path solver seeds (default 1 2 3)")
    p.add_argument("--scene", default=None, help="existing circle_walk animation directory (default: build one)")
    p.add_argument("--scene-a", default=None, help="A's own scene (default --scene)")
    p.add_argument("--scene-b", default=None, help="B's own scene (default --scene)")
    p.add_argument("--out", default="out/bench_circle_walk", help="scene and temporary run stores")
    p.add_argument("--radar", default="walk-77ghz")
    p.add_argument("--method-a", type=lambda s: json_dict(s, "--method-a"), default=METHODS["A"],
                   help=f"engine options of A, JSON (default {json.dumps(METHODS['A'])})")
    p.add_argument("--method-b", type=lambda s: json_dict(s, "--method-b"), default=METHODS["B"],
                   help=f"engine options of B, JSON (default {json.dumps(METHODS['B'])}: the engine's defaults)")
    p.add_argument("--cold", action="store_true", help="also first-frame time with a cold vs warm kernel cache")
    p.add_argument("--cold-frames", type=int, default=3)
    p.add_argument("--keep-stores", action="store_true", help="keep the run stores under --out")
    p.add_argument("--json", default=None, help="write every figure to this JSON file")
    add_tree_and_worker_arguments(p, "run A on the sionnafmcw of this checkout (e.g. a git worktree of the previous "
                                     "commit: before/after a code change, same options); default: this checkout")
    args = p.parse_args(argv)

    if ran_as_worker(args, worker):
        return 0
    if args.frames < 2:
        p.error("--frames must be >= 2 (the steady state is frames >= 1)")
    if args.cold and args.cold_frames < 1:
        p.error("--cold-frames must be >= 1")
    for opts in (args.method_a, args.method_b):
        if "seed" in opts:
            p.error("the solver seed comes from --seeds; leave 'seed' out of --method-a/--method-b")

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if args.scene:
        scene = Path(args.scene)
        if not (scene / "animation.json").is_file():
            p.error(f"--scene {scene}: no animation.json there")
    elif args.scene_a and args.scene_b:
        scene = Path(args.scene_b)
    else:
        from sionnafmcw.validation.common import build_scene
        scene = build_scene("circle_walk", out / "scene")
    scene_seconds = time.perf_counter() - t0
    methods = {"A": args.method_a, "B": args.method_b}
    trees = tree_environments(p, args)
    print(f"scene {scene} ({scene_seconds:.1f} s), {args.frames} frames, seeds {args.seeds}, "
          f"A = {json.dumps(methods['A'])} {args.tree_a or ''}, B = {json.dumps(methods['B'])} {args.tree_b or ''}",
          file=sys.stderr)

    scenes = {"A": Path(args.scene_a) if args.scene_a else scene, "B": Path(args.scene_b) if args.scene_b else scene}
    for method, path in scenes.items():
        if not (path / "animation.json").is_file():
            p.error(f"--scene-{method.lower()} {path}: no animation.json there")

    def spec(method, seed, frames, tag=""):
        label = f"{method}{tag}_s{seed}"
        return {"label": label, "scene": str(scenes[method]), "radar": args.radar, "frames": frames,
                "options": methods[method] | {"seed": seed}, "store": str(out / f"run_{label}.zarr"),
                "keep": args.keep_stores}

    runs = []
    for seed in args.seeds:
        for method in ("A", "B"):
            print(f"-- run {method} ({LABELS[method]}), seed {seed}", file=sys.stderr)
            runs.append(launch(spec(method, seed, args.frames), trees.get(method)) | {"method": method, "seed": seed})
    summary = print_table(runs, args.seeds)

    cold_warm = None
    if args.cold:
        with tempfile.TemporaryDirectory(prefix="drjit-cache-") as cache:
            env = {"DRJIT_CACHE_DIR": cache}
            cold = launch(spec("B", args.seeds[0], args.cold_frames, "cold"), env)
            warm = launch(spec("B", args.seeds[0], args.cold_frames, "warm"), env)
        cold_warm = {"frames": args.cold_frames, "method": "B", "seed": args.seeds[0], "cold": cold, "warm": warm}
        print(f"\nkernel cache (B, {args.cold_frames} frames, DRJIT_CACHE_DIR fresh): first frame cold "
              f"{cold['first_frame']['seconds']:.1f} s ({cold['first_frame']['kernels_compiled']} kernels compiled), "
              f"warm {warm['first_frame']['seconds']:.1f} s ({warm['first_frame']['kernels_compiled']} compiled)")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "scene": str(scene), "scene_seconds": scene_seconds, "radar": args.radar, "frames": args.frames,
            "seeds": args.seeds, "noise_seed": 0, "methods": methods, "trees": {"A": args.tree_a, "B": args.tree_b},
            "runs": runs, "summary": summary,
            "cold_warm": cold_warm}, indent=1))
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
