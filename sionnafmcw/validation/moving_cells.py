r"""Which objects' echoes make a simulated run's moving points: the engine re-run with its labels, the
beat signal synthesised per object, each moving cell's power split among them.

A run store keeps the sum of the echoes, not the echoes. The path engine is deterministic and labels
every contribution with the object its wave hits first (``label="first"``, the data sets' setting), so
re-running it on the run's scene with the run's engine settings gives the same echoes; this is checked,
not assumed: the frame's cube is synthesised again with the run's noise seed (``[seed, frame]``, as
:func:`sionnafmcw.simulate` draws it) and must match the stored one to ``tolerance`` (relative norm).

The echoes are then split into groups :math:`g`: every segment of the run's people on its own, and
``room`` for everything else (walls, floor, furniture, and paths whose first hit is one of them: a
floor bounce up to the body is ``room``). Each group's noise-free cube :math:`x_g` goes through the
on-chip chain's linear part without its integer rounding: the fired-order ADC words, the Blackman
range FFT and the Hanning Doppler FFT of :mod:`sionnafmcw.ti.oob` (their Q17 windows and FFT sizes),
giving :math:`X_g[d, v, r]` (Doppler bin, virtual antenna, range bin); by linearity
:math:`\sum_g X_g` is the noise-free spectrum of the frame. A moving point of the stored frame's point
cloud (:func:`sionnafmcw.ti.oob.run_point_clouds`; beyond ``near_range``, Doppler bin :math:`k \ne 0`)
sits in the cell :math:`(r, d)` of its range and unsigned Doppler index; its *source* is the group with
the largest :math:`P_g = \sum_v |X_g[d, v, r]|^2` there, and its *share* :math:`P_g / \sum_{g'} P_{g'}`
(the groups' powers, cross terms left out). The demo's detection matrix is a sum over the antennas of
:math:`\log_2|X|`, monotonic in each antenna's magnitude, so the group that dominates :math:`P` is the one
that makes the detection.

Segments are gathered into body regions for the summary: ``arms`` (names with ``arm`` or ``hand``),
``legs`` (``leg``, ``foot``), ``trunk and head`` (the other segments) and ``room``.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from .point_cloud_statistics import NEAR_RANGE

#: Relative norm within which the re-run frame must reproduce the stored cube.
REPRODUCTION_TOLERANCE = 1e-3
#: The group of every echo whose first hit is not a person's segment.
ROOM = "room"
REGIONS = ("arms", "legs", "trunk and head", ROOM)


class MovingCellsError(ValueError):
    """The run cannot be re-run as it was (its scene moved or changed, or the engine gives other echoes)."""


def body_region(group: str) -> str:
    """The body region of a group name (module docstring)."""
    if group == ROOM:
        return ROOM
    name = group.lower()
    if "arm" in name or "hand" in name:
        return "arms"
    if "leg" in name or "foot" in name:
        return "legs"
    return "trunk and head"


def cell_spectrum(cube: np.ndarray, radar, sdk: int = 2) -> np.ndarray:
    r"""The chain's linear range-Doppler spectrum of a cube ``[chirp, tx, rx, sample]``, without rounding:
    ``[Doppler bin, virtual antenna, range bin]`` in the demo's units (module docstring): the chain's own
    :func:`~sionnafmcw.ti.oob.range_spectra` and :func:`~sionnafmcw.ti.oob.doppler_fft` (SDK ``sdk``)
    with ``rounded=False``."""
    from ..ti.oob import doppler_fft, range_spectra

    ranged = range_spectra(cube, radar, rounded=False)
    return doppler_fft(ranged.reshape(ranged.shape[0], -1, ranged.shape[-1]), sdk, rounded=False)


def _engine_of(run):
    from .. import engines

    settings = dict(run.engine)
    name = settings.pop("engine", None)
    if name is None:
        raise MovingCellsError(f"{run.path}: the run does not say which engine made it")
    valid = engines.options(name)
    engine = engines.create(name, **{k: v for k, v in settings.items() if k in valid})
    if getattr(engine, "label", "first") != "first":
        raise MovingCellsError(f"{run.path}: the run's engine labels paths by {engine.label!r}; this needs 'first'")
    return engine


def _frame_counts(points, near_range: float) -> tuple[int, int]:
    """Moving points beyond ``near_range`` of one frame's :class:`DetectedPoints`, and their distinct Doppler bins."""
    k = np.asarray(points.doppler_index)
    moving = (k != 0) & (points.range >= near_range)
    return int(moving.sum()), int(np.unique(k[moving]).size)


def moving_cell_sources(store, frames, scene=None, processing=None, near_range: float = NEAR_RANGE,
                        threads: int | None = 1, tolerance: float = REPRODUCTION_TOLERANCE,
                        gains: dict | None = None) -> dict:
    """The sources of the moving points of ``frames`` of a run store (module docstring).

    ``scene``: the animation directory (default: the one the store names); ``processing``: the chain
    (default: the run's own ``.cfg``, :func:`sionnafmcw.ti.oob.run_processing`); ``threads``: CPU threads
    of the engine. Returns ``points`` (per moving point: ``frame``, ``k``, ``range_index``, ``source``,
    ``region``, ``share``), ``frames`` (per frame: ``frame``, ``reproduction_error``, ``moving``) and
    ``summary`` (``moving_points``, the share of the points by ``source`` and by ``region``, the median
    ``share`` of the source in its cell, and ``body_power``: each body region's share of the body's echo
    power summed over every cell of the frames, to set the sources against).

    ``gains`` (``{variant: {region: dB}}``): for attribution only, each variant's frame is synthesised
    again with the echoes of the named regions (:data:`REGIONS`) scaled by their gain (the same noise
    draw) and run through the chain; ``summary["variants"]`` then holds, for ``"as run"`` and every
    variant, ``moving_points_per_frame``, ``frames_with_moving`` and ``frames_with_two_bins`` (the share
    of the frames with a moving point whose moving points lie at two or more Doppler bins). Raises
    :class:`MovingCellsError` when a frame is not reproduced or ``gains`` names an unknown region.
    """
    from ..animation import load_animation
    from ..echoes import Echoes
    from ..store import open_run
    from ..synthesis import synthesize
    from ..threads import run_threads
    from ..ti.oob import dc_range_signature, detect, range_spectra, run_point_clouds, run_processing

    gains = dict(gains or {})
    for name, gain in gains.items():   # bad input first, before any work
        unknown = [r for r in gain if r not in REGIONS]
        if unknown:
            raise MovingCellsError(f"gains[{name!r}]: unknown region {', '.join(unknown)}; "
                                   f"choose from {', '.join(REGIONS)}")
    run = open_run(store)
    radar = run.radar
    processing = run_processing(run, processing)
    scene = run.scene if scene is None else Path(scene)
    if scene is None or not Path(scene).is_dir():
        raise MovingCellsError(f"{run.path}: its scene {scene} is not on this machine; give scene=")
    animation = load_animation(scene)
    engine = _engine_of(run)
    frames = [int(f) for f in np.asarray(frames).reshape(-1)]
    segments = set()
    for person in run.people:
        segments.update(run.person_objects(person))
    seed, noise = int(run.attrs.get("seed", 0)), bool(run.attrs.get("noise", True))
    leakage = run.attrs.get("leakage_db")
    clouds = {p.frame_number - 1: p for p in run_point_clouds(store, processing, frames=frames)}
    times = run.frame_times
    columns: dict = {"frame": [], "k": [], "range_index": [], "source": [], "region": [], "share": []}
    per_frame: dict = {"frame": [], "reproduction_error": [], "moving": []}
    region_power = {r: 0.0 for r in REGIONS}
    counts = {name: [] for name in ["as run", *gains]}
    signature = None
    if gains and processing.dc_calibration.enabled and run.done_frames.size:
        needed = max(1, -(-processing.dc_calibration.num_average_chirps // (radar.num_chirps * radar.num_tx)))
        signature = dc_range_signature(np.concatenate([range_spectra(run.cube(int(d)), radar)
                                                       for d in run.done_frames[:needed]]), processing)
    with run_threads(threads):
        for f in frames:
            echoes = engine.echoes(animation, radar, f, radar_pose=run.pose_at(f))
            again = synthesize(echoes, radar, frame_time=float(times[f]), noise=noise,
                               rng=np.random.default_rng([seed, f]), leakage_db=leakage)
            stored = run.cube(f)
            error = float(np.linalg.norm(again - stored) / max(np.linalg.norm(stored), 1e-300))
            if not error <= tolerance:
                raise MovingCellsError(f"{run.path}: frame {f} re-run differs from the stored cube by {error:.2g} "
                                       f"(relative, tolerance {tolerance:g}): the scene {scene} or the engine changed "
                                       "since the run")
            labels = np.asarray(echoes.labels)[0, 0] if echoes.labels is not None else \
                np.zeros(echoes.num_contributions, dtype=str)
            groups = np.where(np.isin(labels, list(segments)), labels, ROOM)
            power = {}
            for g in sorted(set(groups.tolist())):
                idx = np.flatnonzero(groups == g)
                rate = None if echoes.doppler_rate is None else echoes.doppler_rate[..., idx]
                part = Echoes(echoes.a[..., idx], echoes.tau[..., idx], echoes.doppler[..., idx], doppler_rate=rate)
                cube = synthesize(part, radar, frame_time=float(times[f]), noise=False, phase_noise=False)
                # [Doppler bin, range bin]
                power[g] = (np.abs(cell_spectrum(cube, radar, processing.sdk)) ** 2).sum(axis=1)
            for g, p in power.items():
                region_power[body_region(g)] += float(p.sum())
            cloud = clouds[f]
            counts["as run"].append(_frame_counts(cloud, near_range))
            regions = np.array([body_region(g) for g in groups.tolist()])
            for name, gain in gains.items():
                scale = np.ones(regions.size)
                for region, db in gain.items():
                    scale[regions == region] = 10.0 ** (float(db) / 20.0)
                scaled = Echoes(echoes.a * scale, echoes.tau, echoes.doppler, doppler_rate=echoes.doppler_rate)
                cube = synthesize(scaled, radar, frame_time=float(times[f]), noise=noise,
                                  rng=np.random.default_rng([seed, f]), leakage_db=leakage)
                counts[name].append(_frame_counts(detect(cube, radar, processing, frame_number=f + 1,
                                                         time=float(times[f]), dc_signature=signature), near_range))
            n_doppler = next(iter(power.values())).shape[0]
            moving = np.flatnonzero((np.asarray(cloud.doppler_index) != 0) & (cloud.range >= near_range))
            for i in moving:
                r, k = int(cloud.range_index[i]), int(cloud.doppler_index[i])
                cell = {g: float(p[k % n_doppler, r]) for g, p in power.items()}
                source = max(cell, key=cell.get)
                total = sum(cell.values())
                columns["frame"].append(f), columns["k"].append(k), columns["range_index"].append(r)
                columns["source"].append(source), columns["region"].append(body_region(source))
                columns["share"].append(cell[source] / total if total > 0 else float("nan"))
            per_frame["frame"].append(f), per_frame["reproduction_error"].append(error)
            per_frame["moving"].append(int(moving.size))
    dtypes = {"frame": np.int64, "k": np.int64, "range_index": np.int64, "source": str, "region": str, "share": float}
    points = {key: np.asarray(value, dtypes[key]) for key, value in columns.items()}
    n = max(points["source"].size, 1)
    body = sum(v for r, v in region_power.items() if r != ROOM) or float("nan")
    by_source = Counter(points["source"].tolist())
    by_region = Counter(points["region"].tolist())
    summary = {"moving_points": int(points["source"].size),
               "source": {s: c / n for s, c in by_source.most_common()},
               "region": {r: by_region.get(r, 0) / n for r in REGIONS},
               "median_share": float(np.median(points["share"])) if points["share"].size else float("nan"),
               "body_power": {r: region_power[r] / body for r in REGIONS if r != ROOM}}
    if gains:
        summary["variants"] = {}
        for name, rows in counts.items():
            c = np.asarray(rows, float).reshape(-1, 2)
            with_moving = c[:, 0] > 0
            summary["variants"][name] = {
                "moving_points_per_frame": float(c[:, 0].mean()) if c.size else float("nan"),
                "frames_with_moving": float(with_moving.mean()) if c.size else float("nan"),
                "frames_with_two_bins": float(np.mean(c[with_moving, 1] >= 2)) if with_moving.any() else float("nan")}
    return {"points": points, "frames": {k: np.asarray(v) for k, v in per_frame.items()}, "summary": summary}


__all__ = ["MovingCellsError", "REGIONS", "REPRODUCTION_TOLERANCE", "ROOM", "body_region", "cell_spectrum",
           "moving_cell_sources"]
