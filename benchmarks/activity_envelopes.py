"""Micro-Doppler envelope of every activity against its motion's truth.

    PYTHONPATH=. /work/main/.venv/bin/python benchmarks/activity_envelopes.py [ACTIVITY ...]

Each activity of ``sionnafmcw.scenes.activities`` is built with its defaults (radar in front at 1 m
height, looking level; ``body_mesh_edge`` 0.02 m; the still people 5 s), simulated with the path
engine (1e5 rays per source, depth 1, PO; no thermal noise: the envelope of the motion, not of a
noise floor) and ``walk-77ghz`` (Doppler bin 0.0715 m/s, unambiguous +-9.15 m/s; for ``run`` and
``jump``, whose limbs reach 8.3 and 11 m/s, its one-Tx variant: +-27.7 m/s, bin 0.217 m/s). The whole-CPI micro-Doppler spectrogram (clutter removed) gives per CPI the
envelope: the velocities whose power is within 25 dB of the column's peak (above the Hann window's
-31.5 dB sidelobes, with the 6 dB two equal lines can add). Printed per activity: the envelope's
lowest and highest radial velocity over the record, against the truth at the CPI starts: the
extremes of the segment centroids' radial velocities (the run store's truth) and of every surface
vertex's (the rigid field of each segment, from the radar's phase centre), in m/s and in bins.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sionnafmcw import PathEngine, RadarConfig, load_animation, processing, scenes, simulate
from sionnafmcw.geometry import radial_velocity, world_phase_centre

ACTIVITIES = ("run", "stand_up", "sit_down", "wave", "jump", "fall", "pick_up", "stand_still", "vital_signs")
EXTRA = {"stand_still": {"num_frames": 125}, "vital_signs": {"num_frames": 125}}
THRESHOLD_DB = 25.0


def radar_for(name):
    base = RadarConfig.preset("walk-77ghz")
    if name in ("run", "jump"):
        return base.replace(tx_positions=base.tx_positions[:1], tx_order=[0], name="walk-77ghz-1tx")
    return base


def measure(name, tmp):
    radar = radar_for(name)
    out = scenes.build(name, Path(tmp) / name, body_mesh_edge=0.02, **EXTRA.get(name, {}))
    anim = load_animation(out)
    t0 = time.perf_counter()
    run = simulate(anim, radar, engine=PathEngine(samples_per_src=100_000, max_depth=1), out=Path(tmp) / f"{name}.zarr",
                   progress=False, noise=False)
    wall = time.perf_counter() - t0
    ds = run.dataset
    times = ds.frame_time.values
    sg = processing.micro_doppler_spectrogram(ds.iq.values, radar, times)
    dv = float(sg.velocities[1] - sg.velocities[0])
    p = sg.power
    above = p >= p.max(axis=0) * 10 ** (-THRESHOLD_DB / 10)
    lower = np.array([sg.velocities[np.flatnonzero(c).min()] for c in above.T])
    upper = np.array([sg.velocities[np.flatnonzero(c).max()] for c in above.T])
    centroid = ds.truth_radial_velocity.values
    pose = anim.radar_pose
    centre = world_phase_centre(radar, pose.position, pose.orientation)
    vmin, vmax = np.inf, -np.inf
    for i in range(anim.num_frames):
        for n in anim.frame_xml(i).shapes:
            mesh = anim.mesh(i, n)
            vel = mesh.vertex_velocities
            if vel is None:
                vel = np.broadcast_to(anim.object_velocity(i, n), mesh.vertices.shape)
            vr = radial_velocity(mesh.vertices, vel, centre)
            vmin, vmax = min(vmin, float(vr.min())), max(vmax, float(vr.max()))
    return {"name": name, "radar": radar.name, "frames": anim.num_frames, "bin": dv, "wall": wall,
            "env": (float(lower.min()), float(upper.max())),
            "centroids": (float(centroid.min()), float(centroid.max())), "vertices": (vmin, vmax)}


def main(argv):
    names = argv or ACTIVITIES
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            r = measure(name, tmp)
            rows.append(r)
            e, c, v, b = r["env"], r["centroids"], r["vertices"], r["bin"]
            print(f"{r['name']:12s} {r['radar']:15s} {r['frames']:4d} frames ({r['wall']:.0f} s): envelope "
                  f"{e[0]:+6.2f}..{e[1]:+6.2f} m/s | centroids {c[0]:+6.2f}..{c[1]:+6.2f} | vertices "
                  f"{v[0]:+6.2f}..{v[1]:+6.2f} | envelope - vertices: {(e[0] - v[0]) / b:+6.1f} / "
                  f"{(e[1] - v[1]) / b:+6.1f} bins of {b:.4f} m/s", flush=True)
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
