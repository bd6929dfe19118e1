"""Path engine: time per frame against bare Sionna, and the coherent array model against per-element tracing.

Two benchmarks (``--bench``; ``all`` runs both).

``coherence``: the circle walk (``sionnafmcw.scenes.registry.build("circle_walk")``,
radar walk-77ghz) through ``simulate`` with ``PathEngine(array_model="coherent")`` and
``PathEngine(array_model="per-element")``, same rays (samples per source, seed, depth), the two
engines interleaved frame by frame in one process (which goes first alternates) so that both
see the same machine load. Per frame and model: the range-azimuth map of the run's cube
(``processing.range_azimuth_map``, Bartlett on a 0.25 degree grid, static clutter removed), the
torso peak (strongest cell within 0.3 m of the torso's true range, from
``open_run(...).truth_in_radar_frame``), its azimuth error against the truth, its -3 dB
beamwidth (contiguous azimuths within 3 dB of the peak in its range bin) and the engine's time
for the frame (``engine.stats``: trace + adapter) and the whole ``simulate`` call. Prints a
table and the medians (warm-up frame left out of the times).

Measured (``--bench coherence --frames 8``, 1e5 rays per source, depth 2, 2 shared CPU cores):
torso |azimuth error| median 0.41 degrees (rms 1.64) coherent vs 3.86 (rms 4.77) per-element;
-3 dB width of the torso peak median 9.9 degrees (the 12-element array's own width) vs 20.5
(the per-element Tx blocks add with scrambled phases and the peak smears); engine 0.30 vs 0.94
s per frame (simulate 1.35 vs 1.93 s), 8.0k traced paths shared by the 12 element pairs vs
96k (8k per pair).

``sionna`` (the original benchmark):

Scene: a 6 x 5 x 3 m room (concrete walls, floor and ceiling) and a ~10k-triangle
body proxy (skin ellipsoid, 0.5 x 0.3 x 1.7 m) walking across it; radar walk-77ghz (3 Tx x 4 Rx)
at 1 m height on one wall, max_depth 2, 1e5 samples per source, specular + diffuse.

Per frame, in the same process:

* ``sionna``: the bare ``PathSolver()(scene, synthetic_array=False, ...)`` on the same Sionna
  scene, with the engine's devices (the coherent model: one source at the Tx centre, one target
  at the Rx centre), after moving the body through the scene parameters the same way (the
  baseline);
* ``engine``: ``PathEngine.echoes(animation, radar, frame)`` (geometry update from the frame's
  PLY, trace, per-element Echoes from the interaction points, labels and vertex Doppler).

Prints steady-state seconds per frame (median over frames after two warm-up frames), the ratio
engine / sionna, new kernels (not launched before) after warm-up, and peak RSS. ``--frames`` sets the count.

    python benchmarks/path_engine.py --bench coherence [--frames 8] [--samples 100000]
    python benchmarks/path_engine.py --bench sionna [--frames 8] [--samples 100000]
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from sionnafmcw import PathEngine, RadarConfig, load_animation
from sionnafmcw.animation import write_animation, write_ply

ROOM = (6.0, 5.0, 3.0)


def ellipsoid(center, radii, n_theta=50, n_phi=100):
    """Closed UV ellipsoid, about 2 * n_theta * n_phi triangles."""
    t = np.linspace(0, np.pi, n_theta + 1)
    p = np.linspace(0, 2 * np.pi, n_phi, endpoint=False)
    tt, pp = np.meshgrid(t[1:-1], p, indexing="ij")
    v = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    v = np.vstack([[0, 0, 1], v, [0, 0, -1]]) * radii + center
    faces = []
    ring = lambda i, j: 1 + i * n_phi + (j % n_phi)  # noqa: E731
    for j in range(n_phi):
        faces.append((0, ring(0, j), ring(0, j + 1)))
        faces.append((len(v) - 1, ring(n_theta - 2, j + 1), ring(n_theta - 2, j)))
    for i in range(n_theta - 2):
        for j in range(n_phi):
            faces.append((ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)))
            faces.append((ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)))
    return v, np.array(faces)


def box_faces(lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    f = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
         (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return v, np.array(f)


def write_room_person(root: Path, num_frames: int, fps=24.0, speed=1.2):
    root.mkdir(parents=True, exist_ok=True)
    (root / "frames").mkdir(exist_ok=True)
    w, d, h = ROOM
    walls = {"floor": box_faces((0, 0, -0.1), (w, d, 0)), "ceiling": box_faces((0, 0, h), (w, d, h + 0.1)),
             "wall_back": box_faces((w, 0, 0), (w + 0.1, d, h)), "wall_left": box_faces((0, -0.1, 0), (w, 0, h)),
             "wall_right": box_faces((0, d, 0), (w, d + 0.1, h)), "wall_front": box_faces((-0.1, 0, 0), (0, d, h))}
    mats = {n: "walls-concrete" for n in walls}  # floorboard: see the note in the issue (load-time frequency)
    for name, (v, f) in walls.items():
        write_ply(root / "meshes" / f"{name}.ply", v, f)
    frames = []
    for i in range(num_frames):
        t = i / fps
        center = np.array([2.0 + speed * t, 1.0 + 0.6 * speed * t, 0.9])
        v, f = ellipsoid(center, (0.25, 0.15, 0.85))
        write_ply(root / "meshes" / f"person_{i:04d}.ply", v, f)
        shapes = [f'<shape type="ply" id="mesh-{n}"><string name="filename" value="../meshes/{n}.ply"/>'
                  f'<ref id="{mats[n]}"/></shape>' for n in walls]
        shapes.append(f'<shape type="ply" id="mesh-person"><string name="filename" '
                      f'value="../meshes/person_{i:04d}.ply"/><ref id="mat-skin"/></shape>')
        xml = ('<scene version="2.1.0">'
               '<bsdf type="itu-radio-material" id="walls-concrete"><string name="type" value="concrete"/>'
               '<float name="scattering_coefficient" value="0.2"/></bsdf>'
               '<bsdf type="itu-radio-material" id="floor-floorboard"><string name="type" value="floorboard"/>'
               '<float name="scattering_coefficient" value="0.2"/></bsdf>'
               '<bsdf type="radio-material" id="mat-skin"/>' + "".join(shapes) + "</scene>")
        (root / "frames" / f"{i:04d}.xml").write_text(xml)
        frames.append({"xml": f"frames/{i:04d}.xml", "objects": {"person": [speed, 0.6 * speed, 0.0]}})
    write_animation(root, frames, fps, ((0.05, d / 2, 1.0), (0.0, 0.0, 0.0)))
    return root


def bare_sionna(animation, radar, engine, frames, samples):
    """The same scene object, traced with Sionna's own PathSolver call per frame."""
    from sionnafmcw.sionna_rt import PathSolver, mi

    scene = engine.scene
    params = mi.traverse(scene.mi_scene)
    key = next(k for k in params.keys() if "person" in k and k.endswith("vertex_positions"))
    solver = PathSolver()
    times = []
    for f in frames:
        t0 = time.perf_counter()
        params[key] = mi.Float(animation.mesh(f, "person").vertices.astype(np.float32).ravel())
        params.update()
        paths = solver(scene, max_depth=engine.max_depth, samples_per_src=samples, los=False,
                       specular_reflection=True, diffuse_reflection=True, synthetic_array=False, seed=engine.seed)
        np.asarray(paths.a[0])  # force evaluation
        times.append(time.perf_counter() - t0)
    return times


TORSO_DEPTH = 0.3  # m: the torso peak is searched within this distance of the torso's true range


def torso_peak(ram, truth_range, truth_azimuth):
    """Azimuth error (rad) and -3 dB beamwidth (rad) of the strongest cell within TORSO_DEPTH of the torso's range."""
    near = np.abs(ram.ranges - truth_range) <= TORSO_DEPTH
    power = np.where(near[:, None], ram.power, 0.0)
    row, col = np.unravel_index(np.argmax(power), power.shape)
    profile = ram.power[row]
    half = profile >= profile[col] / 2
    lo, hi = col, col
    while lo > 0 and half[lo - 1]:
        lo -= 1
    while hi < len(profile) - 1 and half[hi + 1]:
        hi += 1
    return float(ram.azimuths[col] - truth_azimuth), float(ram.azimuths[hi] - ram.azimuths[lo])


def coherence_benchmark(args):
    """Coherent vs per-element PathEngine on the circle walk: torso azimuth error, beamwidth, time per frame."""
    from sionnafmcw import open_run, processing, simulate
    from sionnafmcw.scenes import registry

    radar = RadarConfig.preset("walk-77ghz")
    frames = [int(f) for f in np.linspace(0, 99, args.frames)]
    grid = np.deg2rad(np.arange(-60.0, 60.0 + 1e-9, 0.25))
    models = ("per-element", "coherent")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        animation = load_animation(registry.build("circle_walk", Path(tmp) / "walk"))
        # the traced paths alone (no PO direct echo, deterministic diffuse phases), as measured below
        engines = {m: PathEngine(max_depth=args.depth, samples_per_src=args.samples, array_model=m,
                                 max_num_paths_per_src=max(1_000_000, 4 * args.samples),
                                 physical_optics=False, random_phase=False) for m in models}
        for k, frame in enumerate(frames):
            for model in (models if k % 2 == 0 else models[::-1]):
                out = Path(tmp) / f"{model}.zarr"
                t0 = time.perf_counter()
                simulate(animation, radar, engine=engines[model], out=out, frames=[frame], progress=False, seed=1)
                total = time.perf_counter() - t0
                run = open_run(out)
                ranges, azimuths = run.truth_in_radar_frame(frame)
                torso = run.objects.index("torso")
                ram = processing.range_azimuth_map(run.cube(frame), radar, method="bartlett", azimuths=grid)
                error, width = torso_peak(ram, ranges[torso], azimuths[torso])
                stats = engines[model].last_stats
                rows.append({"frame": frame, "model": model, "torso_range_m": float(ranges[torso]),
                             "torso_azimuth_deg": float(np.rad2deg(azimuths[torso])),
                             "azimuth_error_deg": float(np.rad2deg(error)), "beamwidth_deg": float(np.rad2deg(width)),
                             "engine_s": stats.seconds, "simulate_s": total, "num_traced_paths": stats.num_traced_paths})
                print(f"frame {frame:3d} {model:12s} torso {ranges[torso]:.2f} m {np.rad2deg(azimuths[torso]):+7.2f} deg: "
                      f"error {np.rad2deg(error):+6.2f} deg, -3 dB width {np.rad2deg(width):5.2f} deg, engine "
                      f"{stats.seconds:.2f} s, simulate {total:.2f} s, traced paths {stats.num_traced_paths}", flush=True)
    summary = {}
    for model in models:
        mine = [r for r in rows if r["model"] == model]
        warm = [r for r in mine if r["frame"] != frames[0]] or mine
        summary[model] = {
            "median_abs_azimuth_error_deg": float(np.median([abs(r["azimuth_error_deg"]) for r in mine])),
            "rms_azimuth_error_deg": float(np.sqrt(np.mean([r["azimuth_error_deg"] ** 2 for r in mine]))),
            "median_beamwidth_deg": float(np.median([r["beamwidth_deg"] for r in mine])),
            "median_engine_s_per_frame": float(np.median([r["engine_s"] for r in warm])),
            "median_simulate_s_per_frame": float(np.median([r["simulate_s"] for r in warm])),
            "median_traced_paths": float(np.median([r["num_traced_paths"] for r in mine])),
        }
        s_ = summary[model]
        print(f"{model:12s}: |azimuth error| median {s_['median_abs_azimuth_error_deg']:.2f} deg "
              f"(rms {s_['rms_azimuth_error_deg']:.2f}), -3 dB width median {s_['median_beamwidth_deg']:.2f} deg, "
              f"engine {s_['median_engine_s_per_frame']:.2f} s/frame, simulate {s_['median_simulate_s_per_frame']:.2f} "
              f"s/frame, traced paths {s_['median_traced_paths']:.0f}")
    print(json.dumps({"frames": frames, "samples_per_src": args.samples, "max_depth": args.depth,
                      "summary": summary, "rows": rows}))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", choices=("coherence", "sionna", "all"), default="all")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--samples", type=int, default=100_000)
    parser.add_argument("--depth", type=int, default=2, help="max_depth of the coherence benchmark")
    args = parser.parse_args(argv)
    if args.bench in ("coherence", "all"):
        coherence_benchmark(args)
    if args.bench in ("sionna", "all"):
        sionna_benchmark(args)


def sionna_benchmark(args):
    """The engine (coherent model) against a bare Sionna PathSolver call per frame (per-element, as Sionna does)."""
    radar = RadarConfig.preset("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        animation = load_animation(write_room_person(Path(tmp) / "room", args.frames))
        # the tracing overhead against bare Sionna: without the PO render (its cost is measured by
        # benchmarks/circle_walk_physics.py)
        engine = PathEngine(max_depth=2, samples_per_src=args.samples, physical_optics=False)
        engine_times, paths = [], []
        for f in range(args.frames):
            t0 = time.perf_counter()
            echoes = engine.echoes(animation, radar, f)
            engine_times.append(time.perf_counter() - t0)
            paths.append(int(np.count_nonzero(echoes.a[0, 0])))
        compiled_after_warmup = sum(s.new_kernel_hashes for s in engine.stats[2:])
        sionna_times = bare_sionna(animation, radar, engine, range(args.frames), args.samples)
    steady_engine = float(np.median(engine_times[2:]))
    steady_sionna = float(np.median(sionna_times[2:]))
    result = {
        "frames": args.frames, "samples_per_src": args.samples, "paths_per_link_median": int(np.median(paths)),
        "engine_s_per_frame": steady_engine, "sionna_s_per_frame": steady_sionna,
        "ratio_engine_over_sionna": steady_engine / steady_sionna,
        "kernels_compiled_after_frame_2": int(compiled_after_warmup),
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    print(f"engine {steady_engine:.3f} s/frame, bare Sionna {steady_sionna:.3f} s/frame, "
          f"ratio {steady_engine / steady_sionna:.2f}, compiled after warm-up {compiled_after_warmup}, "
          f"paths/link {result['paths_per_link_median']}, peak RSS {result['peak_rss_mib']:.0f} MiB")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
