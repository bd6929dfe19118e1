"""Pixel engine: steady-state time per frame against a bare Mitsuba ray cast of the same pixels.

Scene: the paper's ``circle_walk`` (room + 13-segment walking person, per-vertex velocities),
radar ``walk-77ghz`` (3 Tx x 4 Rx) at its default pose. Per frame, in the same process:

* ``mitsuba``: ``scene.mi_scene.ray_intersect`` (a full surface interaction) of the same pixel
  rays from the phase centre, on the engine's own scene after its geometry update: the baseline;
* ``engine``: ``PixelEngine.echoes(animation, radar, frame)`` (geometry update, cast, per-pixel
  range, velocity field, Fresnel/Lambertian strength, per-element delays and Doppler; with
  ``--model physical-optics``, the default, also the per-object PO render and its echoes);
* ``synthesis``: ``synthesize`` of the frame's echoes (NUFFT), for scale.

Prints the median seconds per frame after two warm-up frames, the ratios engine / mitsuba and
synthesis / engine, hits per frame, PO rays and samples per frame, kernels compiled after warm-up
and the peak RSS, as JSON.

    python benchmarks/pixel_engine.py [--frames 8] [--n-az 128] [--n-el 64] [--array-model exact]
                                      [--model physical-optics|lambertian]
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--n-az", type=int, default=128)
    parser.add_argument("--n-el", type=int, default=64)
    parser.add_argument("--array-model", choices=("plane-wave", "exact"), default="plane-wave")
    parser.add_argument("--model", choices=("physical-optics", "lambertian"), default="physical-optics")
    args = parser.parse_args(argv)

    from sionnafmcw import PixelEngine, RadarConfig, load_animation, scenes, synthesize
    from sionnafmcw.array import phase_centre
    from sionnafmcw.geometry import rotation_matrix
    from sionnafmcw.sionna_rt import dr, mi

    radar = RadarConfig.preset("walk-77ghz")
    with tempfile.TemporaryDirectory() as tmp:
        # the full 100-frame lap (the walking speed follows from the lap time), of which frames are timed
        animation = load_animation(scenes.build("circle_walk", Path(tmp) / "scene"))
        engine = PixelEngine(n_az=args.n_az, n_el=args.n_el, array_model=args.array_model, model=args.model)
        pose = animation.radar_pose
        rot = rotation_matrix(pose.orientation)
        origin = pose.position + rot @ phase_centre(radar)
        directions = engine._directions @ rot.T
        o = mi.Point3f(*[mi.Float(np.full(len(directions), origin[i], dtype=np.float32)) for i in range(3)])
        d = mi.Vector3f(*[mi.Float(np.ascontiguousarray(directions[:, i], dtype=np.float32)) for i in range(3)])
        times = {"engine": [], "mitsuba": [], "synthesis": []}
        hits, po_rays, po_samples = [], [], []
        for f in range(min(args.frames + 2, animation.num_frames)):
            t0 = time.perf_counter()
            echoes = engine.echoes(animation, radar, f)
            t1 = time.perf_counter()
            si = engine.scene.mi_scene.ray_intersect(mi.Ray3f(o, d))
            dr.eval(si.t, si.p, si.n, si.prim_index)
            _ = si.t.numpy()
            t2 = time.perf_counter()
            synthesize(echoes, radar, frame_time=animation.frames[f].time, noise=False)
            t3 = time.perf_counter()
            if f >= 2:
                times["engine"].append(t1 - t0)
                times["mitsuba"].append(t2 - t1)
                times["synthesis"].append(t3 - t2)
                hits.append(echoes.num_contributions)
                po_rays.append(engine.last_stats.num_po_rays)
                po_samples.append(engine.last_stats.num_po_samples)
        med = {k: float(np.median(v)) for k, v in times.items()}
        result = {
            "scene": "circle_walk", "pixels": args.n_az * args.n_el, "array_model": args.array_model,
            "model": args.model,
            "frames_timed": len(hits),
            "seconds_per_frame": med,
            "ratio_engine_over_mitsuba": med["engine"] / med["mitsuba"],
            "ratio_synthesis_over_engine": med["synthesis"] / med["engine"],
            "contributions_per_frame": float(np.mean(hits)),
            "po_rays_per_frame": float(np.mean(po_rays)), "po_samples_per_frame": float(np.mean(po_samples)),
            "kernels_compiled_after_warmup": int(sum(s.kernels_compiled for s in engine.stats[2:])),
            "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        }
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
