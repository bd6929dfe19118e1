"""Fixed engine cases whose echoes are stored in ``tests/data/engine_reference.npz``.

The reference was first written by the code *before* the engine-family redesign (issue 10) and
regenerated, with ``python tests/engine_reference.py``, when the path engine's echoes changed on
purpose: issue 11 (one trace for the whole array, ``array_model="coherent"``, every element pair
from the interaction points; coincident specular paths removed), and again, for the path engine
only (``python tests/engine_reference.py --only path``, the pixel arrays kept as stored), for
issue 11's PO direct echo, ray-tube PO multi-bounce and random-phase diffuse paths. ``tests/test_engine_reference.py``
recomputes the same cases with today's code and asserts that every array is identical, bit for
bit. Regenerate it only for a change that is meant to alter the echoes, and say so in the commit.

Both engines' arrays (a PO echo of a room has ~1e5 contributions per element pair) are stored as
their SHA-256 digest with their shape and dtype (:func:`digest`), which is just as bit-for-bit
and keeps the file small. The pixel engine's were regenerated (``--only pixel``) for its PO
default and random-phase diffuse pixels (issue 11).

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
#: Engines whose arrays are stored as a digest (key + "#sha256", uint8 [32]) and their shape and
#: dtype (key + "#shape", key + "#dtype").
DIGEST_ENGINES = ("path", "pixel")


def digest(array) -> np.ndarray:
    """SHA-256 of ``array``'s dtype, shape and bytes (C order) as uint8 ``[32]``."""
    import hashlib

    array = np.ascontiguousarray(array)
    h = hashlib.sha256(f"{array.dtype.str}{array.shape}".encode())
    h.update(array.tobytes())
    return np.frombuffer(h.digest(), dtype=np.uint8)


def stored_form(arrays: dict) -> dict:
    """``arrays`` as written to the file: those of :data:`DIGEST_ENGINES` replaced by their digest,
    shape and dtype."""
    out = {}
    for key, value in arrays.items():
        value = np.asarray(value)
        if key.split("/")[1].rstrip("0123456789") in DIGEST_ENGINES:
            out[f"{key}#sha256"] = digest(value)
            out[f"{key}#shape"] = np.asarray(value.shape, dtype=np.int64)
            out[f"{key}#dtype"] = np.asarray(value.dtype.str)
        else:
            out[key] = value
    return out

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


def compute(workdir, only: str | None = None) -> dict:
    """Every reference array, keyed ``{case}/{engine}{k}/f{frame}/{a,tau,doppler,labels}``
    (``only``: just the engine of that registry name), in the form stored (:func:`stored_form`)."""
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
            if only is not None and name != only:
                continue
            engine = engines.create(name, track_kernels=False, **options)
            for frame in range(animation.num_frames):
                e = engine.echoes(animation, radar, frame)
                key = f"{case}/{name}{k}/f{frame}"
                out[f"{key}/a"] = np.asarray(e.a)
                out[f"{key}/tau"] = np.asarray(e.tau)
                out[f"{key}/doppler"] = np.asarray(e.doppler)
                out[f"{key}/labels"] = np.asarray(e.labels).astype(str)
            engine.close()
    return stored_form(out)


if __name__ == "__main__":
    import tempfile

    only = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv else None
    with tempfile.TemporaryDirectory() as tmp:
        arrays = compute(tmp, only)
    if only is not None:
        # keep the other engines' arrays as stored
        stored = np.load(REFERENCE)
        kept = {key: stored[key] for key in stored.files if key.split("/")[1].rstrip("0123456789") != only}
        arrays = kept | arrays
    REFERENCE.parent.mkdir(exist_ok=True)
    np.savez_compressed(REFERENCE, **arrays)
    print(f"wrote {REFERENCE}: {len(arrays)} arrays, {REFERENCE.stat().st_size / 1e6:.2f} MB", file=sys.stderr)
