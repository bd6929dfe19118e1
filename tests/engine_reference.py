r"""Fixed engine cases whose echoes are stored in ``tests/data/engine_reference.npz``.

The reference was first written by the code *before* the engine-family redesign and
regenerated, with ``python tests/engine_reference.py``, when the path engine's echoes changed on
purpose: one trace for the whole array (``array_model="coherent"``, every element pair
from the interaction points; coincident specular paths removed), and again, for the path engine
only (``python tests/engine_reference.py --only path``, the pixel arrays kept as stored), for
its PO direct echo, ray-tube PO multi-bounce and random-phase diffuse paths; and, both
engines, for the walker as 13 rigid segments of 32 mm edges stored once with a
transform per frame, its PO samples on the smooth surface and the worth-first PO merge.
``tests/test_engine_reference.py``
recomputes the same cases with today's code and asserts that every array is identical, bit for
bit. Regenerate it only for a change that is meant to alter the echoes, and say so in the commit.

Both engines' arrays (a PO echo of a room has ~1e5 contributions per element pair) are stored as
their SHA-256 digest with their shape and dtype (:func:`digest`), which is just as bit-for-bit
and keeps the file small. The pixel engine's were regenerated (``--only pixel``) for its PO
default and random-phase diffuse pixels.

Bit for bit holds on one machine only: Dr.Jit compiles its kernels (Sionna's trace, the renders'
ray casts) for the host CPU, and another instruction set rounds differently, which flips the hits
of rays within rounding of a triangle edge. The file records the platform it was written on
(:func:`platform_tag`: CPU model and vector flags, Dr.Jit and LLVM versions); on that platform
the test compares the digests, elsewhere the summaries stored with them (``#count``: the
number of contributions, ``#power``: :math:`\sum_p|a_{mnp}|^2` per element pair) within what a
geometric change of 1 µm (:math:`\lambda/3900`, far below anything physical and far above
rounding) moves them: measured on these cases by shifting the radar by 1 µm
(``python tests/engine_reference.py --perturb``): at most 30 of 7.4e5 contributions (4e-5) and
0.0055 dB of power per pair; the tolerances are ten times that, :data:`COUNT_TOLERANCE` and
:data:`POWER_TOLERANCE_DB`.

Cases (small, deterministic):
* ``walk``: two frames of the circle walk (a body of rigid segments turning in every frame, skin,
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


#: Off the recording platform: contributions per frame within this share of the stored count ...
COUNT_TOLERANCE = 4e-4
#: ... and the power per element pair within this many dB (module docstring).
POWER_TOLERANCE_DB = 0.055


def platform_tag() -> str:
    """What Dr.Jit's kernels depend on: CPU model, its vector instruction flags, Dr.Jit and LLVM versions."""
    import platform

    import sionnafmcw.sionna_rt  # noqa: F401  (the LLVM set-up)
    import drjit as dr

    model, flags = platform.machine(), ""
    try:
        info = Path("/proc/cpuinfo").read_text()
        model = next((line.split(":", 1)[1].strip() for line in info.splitlines() if line.startswith("model name")),
                     model)
        words = next((line.split(":", 1)[1].split() for line in info.splitlines() if line.startswith("flags")), [])
        flags = " ".join(sorted(w for w in words if w.startswith(("avx", "fma", "sse", "f16c", "amx"))))
    except OSError:
        pass
    return f"{model} | {flags} | drjit {dr.__version__} | llvm {'.'.join(map(str, dr.detail.llvm_version()))}"


def stored_form(arrays: dict) -> dict:
    """``arrays`` as written to the file: those of :data:`DIGEST_ENGINES` replaced by their digest,
    shape and dtype, with the summaries ``#count`` (contributions, on the ``a`` key) and ``#power``
    (``sum |a|^2`` per element pair) that are compared off the recording platform."""
    out = {}
    for key, value in arrays.items():
        value = np.asarray(value)
        if key.split("/")[1].rstrip("0123456789") in DIGEST_ENGINES:
            out[f"{key}#sha256"] = digest(value)
            out[f"{key}#shape"] = np.asarray(value.shape, dtype=np.int64)
            out[f"{key}#dtype"] = np.asarray(value.dtype.str)
            if key.endswith("/a"):
                out[f"{key}#count"] = np.asarray(value.shape[-1], dtype=np.int64)
                out[f"{key}#power"] = np.sum(np.abs(value) ** 2, axis=-1)
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


def perturbation(workdir, shift: float = 1e-6) -> None:
    """Print how much the summaries move when the radar moves by ``shift`` m (frame 0 of every case)."""
    from sionnafmcw import RadarConfig, engines
    from sionnafmcw.animation import load_animation
    from sionnafmcw.scenes import registry

    radar = RadarConfig.preset(RADAR)
    for case, (scenario, params) in CASES.items():
        animation = load_animation(registry.build(scenario, Path(workdir) / case, overwrite=True, **params))
        pose = animation.radar_pose
        for k, (name, options) in enumerate(ENGINES[case]):
            runs = []
            for d in (0.0, shift):
                engine = engines.create(name, track_kernels=False, **options)
                e = engine.echoes(animation, radar, 0, radar_pose=(np.asarray(pose.position) + d, pose.orientation))
                runs.append((e.num_contributions, np.sum(np.abs(e.a) ** 2, axis=-1)))
                engine.close()
            (n0, p0), (n1, p1) = runs
            print(f"{case}/{name}{k}: contributions {n0} -> {n1} ({abs(n1 - n0) / n0:.1e}), power per pair "
                  f"{np.max(np.abs(10 * np.log10(p1 / p0))):.4f} dB at most")


if __name__ == "__main__":
    import tempfile

    if "--perturb" in sys.argv:
        with tempfile.TemporaryDirectory() as tmp:
            perturbation(tmp)
        sys.exit(0)
    only = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv else None
    with tempfile.TemporaryDirectory() as tmp:
        arrays = compute(tmp, only)
    if only is not None:
        # keep the other engines' arrays as stored (written on the same platform only)
        stored = np.load(REFERENCE)
        if str(stored["#platform"]) != platform_tag():
            sys.exit(f"{REFERENCE} was written on another platform ({stored['#platform']}); regenerate all engines "
                     "(no --only) so that its digests are of one platform")
        kept = {key: stored[key] for key in stored.files
                if key != "#platform" and key.split("/")[1].rstrip("0123456789") != only}
        arrays = kept | arrays
    arrays["#platform"] = np.asarray(platform_tag())
    REFERENCE.parent.mkdir(exist_ok=True)
    np.savez_compressed(REFERENCE, **arrays)
    print(f"wrote {REFERENCE}: {len(arrays)} arrays, {REFERENCE.stat().st_size / 1e6:.2f} MB", file=sys.stderr)
