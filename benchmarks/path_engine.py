"""Path engine: steady-state time per frame and peak memory against a bare Sionna PathSolver call.

Scene: a 6 x 5 x 3 m room (concrete walls, floor and ceiling) and a ~10k-triangle
body proxy (skin ellipsoid, 0.5 x 0.3 x 1.7 m) walking across it; radar walk-77ghz (3 Tx x 4 Rx)
at 1 m height on one wall, max_depth 2, 1e5 samples per source, specular + diffuse.

Per frame, in the same process:

* ``sionna``: the bare ``PathSolver()(scene, synthetic_array=False, ...)`` on the same Sionna
  scene, after moving the body through the scene parameters the same way (the baseline);
* ``engine``: ``PathEngine.echoes(animation, radar, frame)`` (geometry update from the frame's
  PLY, trace, per-element Echoes with labels and vertex Doppler).

Prints steady-state seconds per frame (median over frames after two warm-up frames), the ratio
engine / sionna, new kernels (not launched before) after warm-up, and peak RSS. ``--frames`` sets the count.

    python benchmarks/path_engine.py [--frames 8] [--samples 100000]
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


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--samples", type=int, default=100_000)
    args = parser.parse_args(argv)
    radar = RadarConfig.preset("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        animation = load_animation(write_room_person(Path(tmp) / "room", args.frames))
        engine = PathEngine(max_depth=2, samples_per_src=args.samples)
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
