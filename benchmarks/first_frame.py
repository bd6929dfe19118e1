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
    import importlib
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

    for module_name, attr, stage in TIMED:
        try:
            module = importlib.import_module(module_name)
        except ImportError:
            continue
        owner, name = module, attr
        if "." in attr:
            cls, name = attr.split(".")
            owner = getattr(module, cls, None)
        if owner is None or not hasattr(owner, name):
            continue
        fn = owner.__dict__[name] if isinstance(owner, type) else getattr(owner, name)
        if getattr(getattr(fn, "__func__", fn), "_first_frame_timer", False):
            continue   # the same function reached through two modules: wrapped once
        if isinstance(fn, classmethod):
            setattr(owner, name, classmethod(wrap(fn.__func__, stage)))
        elif isinstance(fn, staticmethod):
            setattr(owner, name, staticmethod(wrap(fn.__func__, stage)))
        else:
            setattr(owner, name, wrap(fn, stage))
    # callers that imported the function by name before it was wrapped
    import sionnafmcw.synthesis as synthesis
    import sionnafmcw.synthesis.nufft as nufft
    synthesis.beat_nufft = nufft.beat_nufft


def worker(spec: dict) -> dict:
    t0 = time.perf_counter()
    p0 = process_cpu()
    try:
        from sionnafmcw.heap import limit_arenas
    except ImportError:
        pass
    else:
        limit_arenas(1)
    from sionnafmcw import engines, sionna_rt  # noqa: F401
    from sionnafmcw.animation import load_animation
    from sionnafmcw.radar import RadarConfig
    from sionnafmcw.simulation import simulate

    events: list = []
    install_timers(events)
    import_wall, import_cpu = time.perf_counter() - t0, process_cpu() - p0
    animation = load_animation(spec["scene"])
    radar = RadarConfig.resolve(spec["radar"])
    frames = list(range(min(spec["frames"], animation.num_frames)))
    engine = engines.create("path", **spec["options"])
    store = Path(spec["store"])
    if store.exists():
        import shutil
        shutil.rmtree(store)
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
    p.add_argument("--tree-a", default=None, help="run A on the sionnafmcw of this checkout")
    p.add_argument("--tree-b", default=None, help="as --tree-a, for B (default: this tree)")
    p.add_argument("--only", choices=("A", "B"), default=None)
    p.add_argument("--cold", action="store_true", help="also a B run with an empty Dr.Jit kernel cache")
    p.add_argument("--json", default=None)
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--result", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker is not None:
        Path(args.result).write_text(json.dumps(worker(json.loads(args.worker))))
        return 0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    cfg = Path(args.cfg)
    if not cfg.is_file():
        p.error(f"--cfg {cfg}: no such file")
    trees = {}
    for method, tree in (("A", args.tree_a), ("B", args.tree_b)):
        if tree is not None:
            if not (Path(tree) / "sionnafmcw" / "__init__.py").is_file():
                p.error(f"--tree-{method.lower()} {tree}: no sionnafmcw package there")
            trees[method] = {"PYTHONPATH": str(Path(tree).resolve())}
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
