"""Fixed engine cases whose echoes are stored in ``tests/data/engine_reference.npz``.

The reference was first written by the code *before* the engine-family redesign (issue 10) and
regenerated, with ``python tests/engine_reference.py``, when the path engine's echoes changed on
purpose: issue 11 (one trace for the whole array, ``array_model="coherent"``, every element pair
from the interaction points; coincident specular paths removed). ``tests/test_engine_reference.py``
recomputes the same cases with today's code and asserts that every array is identical, bit for
bit. Regenerate it only for a change that is meant to alter the echoes, and say so in the commit.

Cases (small, deterministic):
* ``walk``: two frames of the circle walk (a deforming body with per-vertex velocities, skin,
  a diffuse room), path engine (deterministic candidate generator, depth 2) and pixel engine
  (both array models);
* ``corners``: two moving metal trihedrals in a concrete room, path engine depth 3 (multi-bounce).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REFERENCE = Path(__file__).parent / "data" / "engine_reference.npz"

CASES = {
    "walk": ("circle_walk", {"num_frames": 2, "room_margin": 0.5}),
    "corners": ("corner_reflectors", {"num_frames": 2, "ranges": (2.0, 3.0), "azimuths": (-0.2, 0.25),
                                      "speeds": (1.0, -0.5), "room": True, "scattering_coefficient": 0.3}),
}

ENGINES = {
    "walk": [("path", {"samples_per_src": 20_000, "max_depth": 2, "deterministic": True}),
             ("pixel", {"n_az": 64, "n_el": 32, "array_model": "exact"}),
             ("pixel", {"n_az": 48, "n_el": 24, "array_model": "plane-wave"})],
    "corners": [("path", {"samples_per_src": 20_000, "max_depth": 3, "deterministic": True})],
}

RADAR = "walk-77ghz"


def compute(workdir) -> dict:
    """Every reference array, keyed ``{case}/{engine}{k}/f{frame}/{a,tau,doppler,labels}``."""
    from sionnafmcw import RadarConfig
    from sionnafmcw.animation import load_animation
    from sionnafmcw.scenes import registry
    from sionnafmcw import engines

    radar = RadarConfig.preset(RADAR)
    out = {}
    for case, (scenario, params) in CASES.items():
        path = registry.build(scenario, Path(workdir) / case, overwrite=True, **params)
        animation = load_animation(path)
        for k, (name, options) in enumerate(ENGINES[case]):
            engine = engines.create(name, track_kernels=False, **options)
            for frame in range(animation.num_frames):
                e = engine.echoes(animation, radar, frame)
                key = f"{case}/{name}{k}/f{frame}"
                out[f"{key}/a"] = np.asarray(e.a)
                out[f"{key}/tau"] = np.asarray(e.tau)
                out[f"{key}/doppler"] = np.asarray(e.doppler)
                out[f"{key}/labels"] = np.asarray(e.labels).astype(str)
            engine.close()
    return out


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        arrays = compute(tmp)
    REFERENCE.parent.mkdir(exist_ok=True)
    np.savez_compressed(REFERENCE, **arrays)
    print(f"wrote {REFERENCE}: {len(arrays)} arrays, {REFERENCE.stat().st_size / 1e6:.2f} MB", file=sys.stderr)
