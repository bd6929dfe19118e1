r"""Where a short data-set item's first frame goes, stage by stage: wall and CPU seconds, A against B.

What it measures: :func:`sionnafmcw.simulation.simulate` of a short item (``--frames``, default 2)
with the path engine's defaults, for two scenes:

* ``radhar``: :func:`sionnafmcw.scenes.build` ``("radhar", ...)`` with the parameters
  :func:`sionnafmcw.dataset.randomisation.radhar_spec` draws (one fixed draw, :data:`RADHAR_ITEM`:
  the middle of each range), simulated with the radar of RadHAR's IWR1443 ``.cfg`` (its processing
  lines left out, as :mod:`frame_cost` does);
* ``circle_walk``: the walk of the paper with radar ``walk-77ghz``.

Each run is a subprocess (``--worker``) that imports ``sionnafmcw`` from its tree (``--tree-a`` /
``--tree-b``, e.g. ``git archive 39034ed | tar -x -C /tmp/ff/treeA``), A and B alternating
(``--repeats`` pairs). The worker wraps the functions behind each stage (:data:`TIMED`) with timers
of wall seconds, the calling thread's CPU seconds and the process's CPU seconds (user + system, all
threads: Dr.Jit's and finufft's pools included), outermost call per stage. A stage met inside the
static block's build (``StaticPO.build``) is named ``static.<stage>``, elsewhere ``<stage>``:

* ``load``: scene load and engine set-up; ``static``: the static block (the static surfaces' PO
  renders, ``static.render`` the first bounce, ``static.bounces`` the multi-bounce rule's further
  bounces and refinements, ``static.po_integral`` the PO integral, ``static.merge`` the merge) and
  Sionna's trace of the static scene (the engine's ``static_seconds`` figure covers both);
* ``trace``: Sionna's trace of the frame (the engine's figure); ``render``, ``reflect``, ``po_integral``,
  ``merge``: the frame's own PO stage;
* ``filter``: the receiver's IF chain over echoes; ``nufft``: the beat synthesis's type-3 NUFFTs,
  each call with its contribution count (the first frame's largest is the static block's);
* ``store_open``: the run store's creation; ``store_write``: the frame writes.

Only events that end before the first frame's store write ends count as frame 0's. In a run with
several frames, the synthesis and store of a frame run on a worker thread while the engine works
on the next, so the process CPU of overlapping stages double counts; the thread CPU does not.
Dr.Jit kernels: launched and compiled (found in neither cache) in the first frame, and with
``--cold`` one extra B run whose Dr.Jit on-disk cache (``DRJIT_CACHE_DIR``) is a fresh directory
(every kernel compiled).

    python benchmarks/first_frame.py --tree-a /tmp/ff/treeA [--scenes radhar circle_walk] [--frames 2]
        [--repeats 1] [--cold] [--out DIR] [--json PATH]

Measured
--------
2-core AMD EPYC shared with other sessions and a data-set generation (load average 6-9: wall
seconds are stretched 1-4x and move between runs; the thread CPU seconds are the figures to
compare). A: main at 96945cb (``git archive 96945cb | tar -x -C /tmp/ff/treeA``), B: this tree.
Items of 2 frames; ``radhar`` 444k static PO samples + 7.9k static paths (452k contributions after
the IF chain's input), the circle walk 740k + 7.9k (747k)::

    python benchmarks/first_frame.py --tree-a /tmp/ff/treeA --frames 2 --out /tmp/ff/out --cold

First frame, thread CPU seconds per stage (A -> B with the neighbour search and chain ids, before
the chunked static synthesis)::

    stage                       radhar A   radhar B   walk A   walk B
    static block (StaticPO.build) 4.83       3.95      7.60     6.34
      of it the bounce rule        4.04       3.18      6.34     4.96
      first-bounce render          0.26       0.16      0.20     0.21
      PO integral / merge          0.27/0.20  0.28/0.20 0.47/0.47 0.47/0.48
    Sionna trace of the static scene (engine's static figure minus the above, wall): ~0.6-0.9 s
    static synthesis (1 NUFFT)     1.78       1.73      2.91     2.49
    IF chain (filter, both parts)  1.29       1.39      -        -     (0.8 s of it: scipy.signal's import)
    load (scene, surfaces, Mitsuba) 0.60      0.63      0.53     0.52
    the frame's own PO + trace    ~0.7       ~0.7      ~0.6     ~0.6
    store creation / first write  0.01/0.00  0.01/0.00 0.01/0.00 0.01/0.00
    item (2 frames) process CPU   11.2       10.3      13.1     11.8   (B/A 0.92, 0.91)
    peak RSS MiB                  1847       1662      2362     2057

Dr.Jit kernels: 421 (radhar) / 438 (walk) launched in the first frame, none compiled with the
shared on-disk cache warm; with an empty cache (``--cold``) 35 / 36 compiled, +1.7 / +1.0 CPU-s on
the item (the PO kernel's compilation: ``static.po_integral`` 0.99 against 0.28 CPU-s).

The same command after the static block's cube in chunks (``--frames 2``, no ``--cold``, the machine
at load 9 with a data-set benchmark running beside it)::

    radhar: static NUFFT 1.89 CPU-s in one call -> 4 x 0.37 = 1.48; IF chain 1.30 -> 0.81;
            peak RSS 1843 -> 1316 MiB (B/A 0.714); item CPU B/A 0.895
    walk:   static NUFFT 2.63 -> 6 x 0.41 = 2.46; peak RSS 2358 -> 1621 MiB (B/A 0.687); item CPU B/A 0.967

What is left of a first frame (B, radhar, ~8 CPU-s against ~1-1.5 a steady frame) and what would
remove it: the bounce rule on the static block (3.2 CPU-s: per round the k-d tree neighbour search
over all first-bounce tubes, 1.0-1.3 s in a profile, the quartered tubes' renders and the joins;
keeping the neighbours of the tubes that were not split from one round to the next would leave
only the new quarters to search); the static NUFFT (1.5 CPU-s for 452k contributions, the cost of
the type-3 spreading per contribution and Taylor term); scipy.signal's import on the first IF chain
(0.8 CPU-s, once per worker process, not per item); the scene load (0.6).
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import tempfile
import time
from pathlib import Path

import circle_walk
import frame_cost

REPO = Path(__file__).resolve().parents[1]

#: One draw of :func:`~sionnafmcw.dataset.randomisation.radhar_spec`'s ranges (the middle of each),
#: the ``jump`` activity (the costliest body motion of the five classes in ``benchmarks/frame_cost.py``).
RADHAR_ITEM = {"activity": "jump", "person_range": 2.0, "person_azimuth": 0.0, "heading_offset": 0.0,
               "person_height": 1.75, "build": "male", "playback_rate": 0.95, "jump_height": 0.19,
               "crouch": 0.14, "jump_rate": 0.6, "radar_height": 1.15, "radar_tilt": 0.05,
               "room_margin": 1.75, "room_height": 2.85, "fps": 30.0}

#: (module, attribute, stage): functions the worker times; a method is "Class.method".
TIMED = [
    ("sionnafmcw.engines.loaded_scene", "load_radar_scene", "load"),
    ("sionnafmcw.engines.loaded_scene", "LoadedScene.load", "load"),
    ("sionnafmcw.engines.path", "PathEngine._load", "load"),
    ("sionnafmcw.engines.static_scene", "StaticPO.build", "static_po"),
    ("sionnafmcw.engines.po_render", "render", "render"),
    ("sionnafmcw.engines.po_render", "reflect", "reflect"),
    ("sionnafmcw.engines.bounce_sampling", "resolved_bounces", "bounces"),
    ("sionnafmcw.engines.po_kernel", "element_pair_po", "po_integral"),
    ("sionnafmcw.engines.po_merge", "merge_contributions", "merge"),
    ("sionnafmcw.receiver", "filter_echoes", "filter"),
    ("sionnafmcw.synthesis", "beat_nufft", "nufft"),
    ("sionnafmcw.synthesis.nufft", "beat_nufft", "nufft"),
    ("sionnafmcw.store", "RunStore.open", "store_open"),
    ("sionnafmcw.store", "RunStore.write_frame", "store_write"),
]


def process_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def install_timers(events: list) -> None:
    """Wrap every :data:`TIMED` function the tree has: each outermost call of a stage appends
    ``(stage, start, end, wall, thread_cpu, process_cpu, contributions)`` to ``events`` (times from
    ``time.perf_counter``; ``contributions``: of an echoes argument, else None)."""
    import threading

    local = threading.local()

    def wrap(fn, stage):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            depth = getattr(local, stage, 0)
            setattr(local, stage, depth + 1)
            inside_static = getattr(local, "static_po", 0) > 0 and stage != "static_po"
            t0, c0, p0 = time.perf_counter(), time.thread_time(), process_cpu()
            try:
                return fn(*args, **kwargs)
            finally:
                setattr(local, stage, depth)
                if depth == 0:
                    t1 = time.perf_counter()
                    n = next((getattr(a, "num_contributions") for a in args if hasattr(a, "num_contributions")),
                             None)
                    events.append((("static." if inside_static else "") + stage, t0, t1, t1 - t0,
                                   time.thread_time() - c0, process_cpu() - p0, n))
        timed._first_frame_timer = True
        return timed

    # the same function reached through two modules: wrapped once
    frame_cost.wrap_stages(TIMED, wrap, skip=lambda fn: getattr(fn, "_first_frame_timer", False))
    # callers that imported the function by name before it was wrapped
    import sionnafmcw.synthesis as synthesis
    import sionnafmcw.synthesis.nufft as nufft
    synthesis.beat_nufft = nufft.beat_nufft


def worker(spec: dict) -> dict:
    t0 = time.perf_counter()
    p0 = process_cpu()
    circle_walk.limit_heap()
    from sionnafmcw import engines, sionna_rt  # noqa: F401
    from sionnafmcw.simulation import simulate

    events: list = []
    install_timers(events)
    import_wall, import_cpu = time.perf_counter() - t0, process_cpu() - p0
    animation, radar, frames, engine, store = circle_walk.run_setup(spec, clear_store=True)
    import tracemalloc
    tracemalloc.start() if spec.get("tracemalloc") else None
    p0, t0 = process_cpu(), time.perf_counter()
    simulate(animation, radar, engine=engine, out=store, frames=frames, progress=False, seed=0, noise=True)
    wall, cpu = time.perf_counter() - t0, process_cpu() - p0
    stats = list(engine.stats)
    writes = sorted(e[2] for e in events if e[0] == "store_write")
    first_end = writes[0] if writes else float("inf")
    first: dict = {}
    nufft_calls = []
    for stage, start, end, w, tc, pc, n in events:
        if end > first_end:
            continue
        s = first.setdefault(stage, [0.0, 0.0, 0.0, 0])
        s[0] += w
        s[1] += tc
        s[2] += pc
        s[3] += 1
        if stage == "nufft":
            nufft_calls.append([n, w, tc, pc])
    import resource
    return {
        "frames": len(frames), "import_wall": import_wall, "import_cpu": import_cpu,
        "wall": wall, "cpu": cpu, "first_frame_wall": first_end - t0,
        "first_engine_seconds": stats[0].seconds,
        "steady_engine_seconds": [s.seconds for s in stats[1:]],
        "first_stage_figures": {k[:-8]: v for k, v in stats[0].figures.items() if k.endswith("_seconds")},
        "counts": {k: stats[0].figures.get(k) for k in ("static_po_samples", "static_paths", "po_samples",
                                                         "po_contributions")},
        "kernels_launched_first": stats[0].kernels_launched, "kernels_compiled_first": stats[0].kernels_compiled,
        "kernels_compiled_rest": int(sum(s.kernels_compiled for s in stats[1:])),
        "first": first, "nufft_calls": nufft_calls,
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def scene_and_radar(name: str, out: Path, frames: int, cfg: Path) -> tuple[Path, str]:
    """The scene directory (built under ``out`` once) and the radar of the item ``name``."""
    from sionnafmcw.scenes import build

    scene = out / f"{name}_{frames}"
    if name == "radhar":
        if not (scene / "animation.json").is_file():
            build("radhar", scene, num_frames=frames, **RADHAR_ITEM)
        return scene, str(frame_cost.radar_copy(cfg, out / "radar_rf.cfg"))
    if not (scene / "animation.json").is_file():
        build("circle_walk", scene)
    return scene, "walk-77ghz"


def print_runs(name: str, runs: list[dict]) -> None:
    stages = sorted({k for r in runs for k in r["first"]})
    print(f"\n== {name}: first frame per stage, wall s / thread CPU s / process CPU s (calls)")
    for r in runs:
        print(f"{r['label']}: item {r['frames']} frames wall {r['wall']:.1f} s, CPU {r['cpu']:.1f} s; first frame "
              f"wall {r['first_frame_wall']:.2f} s (engine {r['first_engine_seconds']:.2f} s; steady engine "
              f"{', '.join(f'{s:.2f}' for s in r['steady_engine_seconds'])}); import {r['import_wall']:.1f} s; "
              f"kernels first frame {r['kernels_launched_first']} launched, {r['kernels_compiled_first']} compiled; "
              f"peak RSS {r['peak_rss_mib']:.0f} MiB")
        figures = r["first_stage_figures"].items()
        print("   engine figures (first frame): " + ", ".join(f"{k} {v:.2f}" for k, v in figures)
              + "; " + ", ".join(f"{k} {v}" for k, v in r["counts"].items()))
        for k in stages:
            if k in r["first"]:
                w, tc, pc, n = r["first"][k]
                print(f"   {k:<20} {w:7.2f} {tc:7.2f} {pc:7.2f} ({n})")
        print("   nufft calls (contributions: wall, thread CPU, process CPU): "
              + "; ".join(f"{n}: {w:.2f}, {tc:.2f}, {pc:.2f}" for n, w, tc, pc in r["nufft_calls"]))
    pairs: dict = {}
    for r in runs:
        pairs.setdefault(r["pair"], {})[r["method"]] = r
    for i, p in sorted(pairs.items()):
        if "A" in p and "B" in p:
            a, b = p["A"], p["B"]
            print(f"pair {i}: first frame wall B/A {b['first_frame_wall'] / a['first_frame_wall']:.3f}; item wall B/A "
                  f"{b['wall'] / a['wall']:.3f}, CPU B/A {b['cpu'] / a['cpu']:.3f}; peak RSS B/A "
                  f"{b['peak_rss_mib'] / a['peak_rss_mib']:.3f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", choices=("radhar", "circle_walk"), default=["radhar", "circle_walk"])
    p.add_argument("--frames", type=int, default=2, help="frames of the item (first frame + steady ones)")
    p.add_argument("--repeats", type=int, default=1, help="A/B pairs, alternated")
    p.add_argument("--out", default="out/bench_first_frame")
    p.add_argument("--cfg", default=str(frame_cost.RADHAR_CFG), help="TI .cfg of the radhar item's radar")
    p.add_argument("--only", choices=("A", "B"), default=None)
    p.add_argument("--cold", action="store_true", help="also a B run with an empty Dr.Jit kernel cache")
    p.add_argument("--json", default=None)
    circle_walk.add_tree_and_worker_arguments(p)
    args = p.parse_args(argv)
    if circle_walk.ran_as_worker(args, worker):
        return 0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    cfg = Path(args.cfg)
    if not cfg.is_file():
        p.error(f"--cfg {cfg}: no such file")
    trees = circle_walk.tree_environments(p, args)
    results = {}
    for name in args.scenes:
        scene, radar = scene_and_radar(name, out, args.frames, cfg)
        runs = []
        for i in range(args.repeats):
            for method in ("A", "B") if args.only is None else (args.only,):
                label = f"{name}-{method}{i + 1}"
                print(f"-- run {label}", file=sys.stderr)
                spec = {"label": label, "scene": str(scene), "radar": radar, "frames": args.frames, "options": {},
                        "store": str(out / f"run_{label}.zarr")}
                runs.append(circle_walk.launch(spec, trees.get(method), __file__)
                            | {"method": method, "pair": i + 1, "label": label})
        if args.cold:
            with tempfile.TemporaryDirectory() as cache:
                label = f"{name}-Bcold"
                spec = {"label": label, "scene": str(scene), "radar": radar, "frames": args.frames, "options": {},
                        "store": str(out / f"run_{label}.zarr")}
                env = (trees.get("B") or {}) | {"DRJIT_CACHE_DIR": cache}
                runs.append(circle_walk.launch(spec, env, __file__) | {"method": "Bcold", "pair": 0, "label": label})
        print_runs(name, runs)
        results[name] = runs
    if args.json:
        Path(args.json).write_text(json.dumps({"trees": trees, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
