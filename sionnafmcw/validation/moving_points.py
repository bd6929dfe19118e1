r"""Where a point cloud's moving points come from: their structure per frame, and for a simulated
recording their place relative to the person's truth.

A moving point is one beyond ``near_range`` whose signed Doppler bin :math:`k` is not 0
(:mod:`~sionnafmcw.validation.point_cloud_statistics`, the same definitions and the same Doppler grid).

**Structure per frame** (:func:`moving_point_structure`, no truth needed: simulated and real alike).
The xWR14xx demo's ``peakGrouping 1 0 1`` compares a CFAR detection with its Doppler neighbours only,
so a body whose echo fills :math:`n` consecutive range bins at one Doppler bin gives :math:`n` points.
Per frame, the moving points at one signed bin :math:`k` are cut into *groups* of consecutive range
bins (a gap of one empty bin or more starts a new group); the range bin of a point is the driver's
``range`` over its step :math:`\Delta R_\text{drv}` (the ROS driver writes ``range`` = bin
:math:`\times\,\Delta R_\text{drv}`). So the moving points per frame factor exactly as

.. math::
    \frac{\text{moving points}}{\text{frame}} = \frac{\text{frames with one}}{\text{frames}}
    \times \frac{\text{groups}}{\text{frame with one}} \times \frac{\text{range bins}}{\text{group}}
    \times \frac{\text{points}}{\text{range bin}},

the last factor above 1 by the ``multiObjBeamForming`` second points (a second point has the frame,
range bin and Doppler bin of an earlier one: the demo appends it at the same :math:`R, v`).

**Against the truth** (:func:`moving_points_against_truth`, a simulated recording whose ``frame`` is the
run's frame index, :func:`person_truth`). A point's :math:`x, y, z` (the ROS driver's axes: forward,
left, up) are the radar frame's (boresight :math:`+x`, :math:`y` left, :math:`z` up; design notes 2 and
8), so its world position is :math:`\mathbf p = \mathbf R(\text{yaw, pitch, roll})\,\mathbf q + \mathbf o`
(:func:`sionnafmcw.geometry.radar_to_world`) and its range :math:`\lVert\mathbf q\rVert` (the device's
range bin times its own step, not the driver's ``range`` field, which is on the driver's 6.6 % longer
grid). The body spans, per frame, the ranges :math:`[R_\text{min}, R_\text{max}]` of its keypoints and
segment centres (radar frame). A point is

* ``below_floor`` when its world :math:`z < 0` (the floor is :math:`z = 0`): a floor-bounce image of
  the body, whose path :math:`R_1 + R_2` puts it below the floor at the body's azimuth;
* else ``beyond_body`` when :math:`R > R_\text{max} + m`: a longer path than any straight one to the
  body, i.e. a multipath (wall, furniture) echo of it;
* else ``before_body`` when :math:`R < R_\text{min} - m`: nearer than the body's surface;
* else ``on_body``.

The margin :math:`m` (``surface_margin``, 0.2 m) is the body's half depth in front of and behind its
skeleton (a trunk 0.25-0.3 m deep: 0.15 m) plus a range bin (0.04 m): the surface of an arm or the
chest is nearer than its joints, so a smaller margin would call the body's own front ``before_body``.

Doppler: the trunk's own bin :math:`k_t = \operatorname{round}(v_t/\Delta v)` (:math:`v_t` the trunk's
radial velocity). A moving point at :math:`k = k_t` is the body's bulk translation; at
:math:`k \ne k_t` a limb moving relative to the trunk. Per frame the moving points are set against
:math:`|v_t|/\Delta v` (the bulk speed in Doppler bins: below 1/2 the trunk is in bin 0) and against
the trunk's range, the latter only over the frames where the trunk is at :math:`|k_t| \ge 1`, so that
the radar equation's :math:`R^{-4}` is not confounded with the walking speed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .point_cloud_statistics import NEAR_RANGE, doppler_grid, signed_doppler_bins

#: Body half depth (0.15 m) plus a range bin (0.04 m), added to the body's range span (module docstring).
SURFACE_MARGIN = 0.2
#: Classes of :math:`|v_t|/\Delta v`, the trunk's radial speed in Doppler bins.
BULK_SPEED_CLASSES = ((0.0, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.0), (1.0, 1.5), (1.5, np.inf))
#: Trunk range classes (m).
RANGE_CLASSES = ((0.5, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.5))
#: Points whose ``range`` is off the driver's grid by more than this share of a step are an error.
_GRID_TOLERANCE = 0.02
LOCATIONS = ("on_body", "before_body", "beyond_body", "below_floor")


def driver_range_step(recordings) -> float:
    """The ROS driver's range step of one recording or several pooled (m): the smallest difference
    between distinct ``range`` values beyond the origin (the driver writes ``range`` = bin x step;
    with as many points as a recording has, two neighbouring bins are always present).

    Raises ``ValueError`` naming the recording when a ``range`` is not a whole number of steps."""
    if not isinstance(recordings, (list, tuple)):
        recordings = [recordings]
    values = np.unique(np.concatenate([np.asarray(r.range, np.float64) for r in recordings]))
    values = values[values > 0]
    if values.size < 2:
        raise ValueError("fewer than two distinct ranges: the driver's range step cannot be told; give range_step")
    step = float(np.min(np.diff(values)))
    for r in recordings:
        bins = np.asarray(r.range, np.float64) / step
        off = np.abs(bins - np.rint(bins)) > _GRID_TOLERANCE
        if off.any():
            i = int(np.flatnonzero(off)[0])
            raise ValueError(f"{getattr(r, 'source', '') or 'recording'}: point {i} has range {r.range[i]:.6g} m, "
                             f"not a whole number of the driver's range steps ({step:.6g} m); give range_step")
    return step


def _moving(recording, grid, near_range):
    k = signed_doppler_bins(recording, grid)
    return k, (np.asarray(recording.range) >= near_range) & (k != 0)


def moving_point_structure(recordings, grid=None, near_range: float = NEAR_RANGE,
                           range_step: float | None = None) -> dict:
    """The moving points of one recording or several pooled, factored per frame (module docstring).

    Frames are those with at least one published point (as :func:`recording_statistics` counts them).
    Returns plain floats: ``frames``, ``moving_points_per_frame``, ``frames_with_moving`` (share),
    ``groups_per_moving_frame``, ``range_bins_per_group`` (mean), ``points_per_range_bin`` (>= 1: the
    second points), ``second_point_share`` (of the moving points), ``groups_of_3_or_more`` (share of
    groups), ``frames_with_two_bins`` (share of the frames with a moving point whose moving points lie
    at two or more signed Doppler bins), ``gaps_per_moving_frame`` (empty range bins splitting one
    Doppler bin's points, counted as splits).
    """
    if not isinstance(recordings, (list, tuple)):
        recordings = [recordings]
    grid = doppler_grid(recordings) if grid is None else grid
    step = driver_range_step(recordings) if range_step is None else float(range_step)
    frames = moving = moving_frames = groups = group_bins = second = big_groups = two_bins = gaps = 0
    for r in recordings:
        k, m = _moving(r, grid, near_range)
        frame = np.asarray(r.frame)
        frames += int(np.unique(frame).size)
        rbin = np.rint(np.asarray(r.range, np.float64) / step).astype(np.int64)
        moving += int(m.sum())
        for f in np.unique(frame[m]):
            s = m & (frame == f)
            moving_frames += 1
            ks = k[s]
            two_bins += int(np.unique(ks).size >= 2)
            for kv in np.unique(ks):
                b = rbin[s][ks == kv]
                u = np.unique(b)
                second += int(b.size - u.size)
                splits = int(np.count_nonzero(np.diff(u) > 1))
                sizes = np.diff(np.concatenate([[0], np.flatnonzero(np.diff(u) > 1) + 1, [u.size]]))
                groups += splits + 1
                gaps += splits
                group_bins += int(u.size)
                big_groups += int(np.count_nonzero(sizes >= 3))

    def ratio(a, b):
        return float(a) / b if b else float("nan")

    return {"frames": frames, "moving_points_per_frame": ratio(moving, frames),
            "frames_with_moving": ratio(moving_frames, frames),
            "groups_per_moving_frame": ratio(groups, moving_frames),
            "range_bins_per_group": ratio(group_bins, groups),
            "points_per_range_bin": ratio(group_bins + second, group_bins),
            "second_point_share": ratio(second, moving), "groups_of_3_or_more": ratio(big_groups, groups),
            "frames_with_two_bins": ratio(two_bins, moving_frames),
            "gaps_per_moving_frame": ratio(gaps, moving_frames)}


@dataclass(frozen=True)
class PersonTruth:
    """One person's truth per run frame, in the world frame, and the radar's pose.

    ``body_points`` ``[frame, point, 3]`` (m): keypoints and body-segment centres; ``trunk_radial_velocity``
    ``[frame]`` (m/s, + receding); ``radar_position`` ``[3]`` and ``radar_orientation`` (yaw, pitch, roll,
    rad) of a radar that does not move; ``source`` names the run for messages."""

    body_points: np.ndarray
    trunk_radial_velocity: np.ndarray
    radar_position: np.ndarray
    radar_orientation: np.ndarray
    source: str = ""

    @property
    def num_frames(self) -> int:
        return int(np.asarray(self.trunk_radial_velocity).shape[0])


def person_truth(store, person: str | None = None, trunk: str = "torso") -> PersonTruth:
    """:class:`PersonTruth` of ``person`` (default: the run's only one) from a run store: its keypoints
    and its segments' positions at the CPI starts, and the radial velocity of its segment ``trunk``."""
    from ..store import RunStoreError, open_run

    run = open_run(store)
    if not run.people:
        raise RunStoreError(f"{run.path}: the run has no people; the moving points cannot be set against a body")
    if person is None:
        if len(run.people) != 1:
            raise RunStoreError(f"{run.path}: {len(run.people)} people ({', '.join(run.people)}); name one")
        person = run.people[0]
    if run.radar_moves:
        raise RunStoreError(f"{run.path}: the radar moves; the moving points are set against a fixed radar only")
    segments = run.person_objects(person)
    if trunk not in segments:
        raise RunStoreError(f"{run.path}: {person} has no segment {trunk!r}; it has {', '.join(segments)}")
    joints = run.joint_positions(person)
    centres = np.stack([run.object_position(s) for s in segments], axis=1)
    pose = run.pose
    return PersonTruth(body_points=np.concatenate([joints, centres], axis=1),
                       trunk_radial_velocity=run.truth(trunk), radar_position=np.asarray(pose.position, float),
                       radar_orientation=np.asarray(pose.orientation, float), source=str(run.path))


def _classes(values, counts, classes) -> list:
    out = []
    for lo, hi in classes:
        s = (values >= lo) & (values < hi)
        out.append({"low": float(lo), "high": float(hi), "frames": int(s.sum()),
                    "moving_points_per_frame": float(counts[s].mean()) if s.any() else float("nan")})
    return out


def _against(recording, truth: PersonTruth, grid, near_range: float, surface_margin: float) -> tuple[dict, dict]:
    """Per moving point and per frame of one recording against its truth (module docstring)."""
    from ..geometry import radar_to_world, world_to_radar

    step = grid[0]
    k, moving = _moving(recording, grid, near_range)
    frame = np.asarray(recording.frame, np.int64)
    name = getattr(recording, "source", "") or "recording"
    if frame.size and (frame.min() < 0 or frame.max() >= truth.num_frames):
        raise ValueError(f"{name}: frame {int(frame.max())} is beyond the {truth.num_frames} frames of "
                         f"{truth.source or 'its truth'}; the recording's frames must be the run's frame indices")
    local = np.stack([recording.x, recording.y, recording.z], axis=1).astype(np.float64)
    world = radar_to_world(local, truth.radar_position, truth.radar_orientation)
    distance = np.linalg.norm(local, axis=1)
    body = world_to_radar(np.asarray(truth.body_points, float), truth.radar_position, truth.radar_orientation)
    body_range = np.linalg.norm(body, axis=-1)                       # [frame, point]
    r_min, r_max = np.nanmin(body_range, axis=1), np.nanmax(body_range, axis=1)
    v_t = np.asarray(truth.trunk_radial_velocity, float)
    trunk_bin = np.rint(v_t / step).astype(np.int64) if np.isfinite(step) else np.zeros(v_t.shape, np.int64)

    i = np.flatnonzero(moving)
    f = frame[i]
    location = np.full(i.size, "on_body", dtype=object)
    below = world[i, 2] < 0
    beyond = ~below & (distance[i] > r_max[f] + surface_margin)
    before = ~below & ~beyond & (distance[i] < r_min[f] - surface_margin)
    location[below], location[beyond], location[before] = "below_floor", "beyond_body", "before_body"
    offset = np.where(distance[i] > r_max[f], distance[i] - r_max[f],
                      np.where(distance[i] < r_min[f], distance[i] - r_min[f], 0.0))
    frames = np.unique(frame)
    points = {"frame": f, "k": k[i], "trunk_bin": trunk_bin[f], "range": distance[i], "offset": offset,
              "z": world[i, 2], "location": location}
    per_frame = {"frame": frames, "moving": np.array([np.count_nonzero(f == n) for n in frames], float),
                 "bulk_bins": np.abs(v_t[frames]) / step if np.isfinite(step) else np.zeros(frames.size),
                 "trunk_bin": trunk_bin[frames], "trunk_range": 0.5 * (r_min[frames] + r_max[frames])}
    return points, per_frame


def moving_points_against_truth(pairs, grid=None, near_range: float = NEAR_RANGE,
                                surface_margin: float = SURFACE_MARGIN) -> dict:
    """The moving points of simulated recordings against their person's truth, pooled (module docstring).

    ``pairs``: one ``(recording, truth)`` (:class:`PersonTruth`) or a list of them; ``grid`` the Doppler
    grid (default: the recordings' own, pooled). Returns ``points`` (per moving point: ``frame``, ``k``,
    ``trunk_bin``, ``range`` (m, radar frame), ``offset`` (m, outside the body's range span; 0 inside),
    ``z`` (world, m), ``location``), ``frames`` (per frame with a point: ``moving``, ``bulk_bins``
    :math:`|v_t|/\\Delta v`, ``trunk_bin``, ``trunk_range``) and ``summary``: the shares of
    :data:`LOCATIONS`, ``at_trunk_bin``, ``abs_bin``, the moving points per frame by bulk speed
    (``by_bulk_speed``) and, over the frames whose trunk is at :math:`|k_t| \\ge 1`, by trunk range
    (``by_trunk_range_walking``), and ``frames_trunk_moving`` (the share of those frames).
    """
    if isinstance(pairs, tuple):
        pairs = [pairs]
    grid = doppler_grid([r for r, _ in pairs]) if grid is None else grid
    parts = [_against(r, t, grid, near_range, surface_margin) for r, t in pairs]
    points = {key: np.concatenate([p[key] for p, _ in parts]) for key in parts[0][0]}
    frames = {key: np.concatenate([q[key] for _, q in parts]) for key in parts[0][1]}
    n, total = frames["frame"].size, max(points["k"].size, 1)
    magnitude = np.abs(points["k"])
    walking = np.abs(frames["trunk_bin"]) >= 1
    summary = {
        "frames": int(n), "moving_points": int(points["k"].size),
        "moving_points_per_frame": float(points["k"].size) / n if n else float("nan"),
        "location": {loc: float(np.count_nonzero(points["location"] == loc)) / total for loc in LOCATIONS},
        "at_trunk_bin": float(np.count_nonzero(points["k"] == points["trunk_bin"])) / total,
        "abs_bin": {"1": float(np.count_nonzero(magnitude == 1)) / total,
                    "2": float(np.count_nonzero(magnitude == 2)) / total,
                    "3_or_more": float(np.count_nonzero(magnitude >= 3)) / total},
        "by_bulk_speed": _classes(frames["bulk_bins"], frames["moving"], BULK_SPEED_CLASSES),
        "by_trunk_range_walking": _classes(frames["trunk_range"][walking], frames["moving"][walking], RANGE_CLASSES),
        "frames_trunk_moving": float(walking.mean()) if n else float("nan"),
    }
    return {"points": points, "frames": frames, "summary": summary}


# ------------------------------------------------------------------------------ the chain, changed
def chain_variants(processing) -> dict:
    """The xWR14xx chain of ``processing`` (:class:`~sionnafmcw.ti.processing.TiProcessing`) and three
    changes of one part each, for attribution only (none is a setting to use): ``peakGrouping`` along
    range as well (one point per moving reflector rather than per range bin), the CFAR threshold 6 dB
    higher (512 of the accelerator's log2 Q9 units, :math:`T = 512\\,T_\\text{dB}/6`), and no second
    points (``multiObjBeamForming`` off)."""
    pg, cfar = processing.peak_grouping, processing.cfar_range
    out = {"as run": processing}
    if pg is not None:
        out["peak grouping along range too"] = processing.replace(
            peak_grouping=dataclasses.replace(pg, in_range=True))
    out["CFAR threshold +6 dB"] = processing.replace(
        cfar_range=dataclasses.replace(cfar, threshold=cfar.threshold + 512))
    out["no second points"] = processing.replace(
        multi_object=dataclasses.replace(processing.multi_object, enabled=False))
    return out


def chain_attribution(stores, activity: str = "") -> dict:
    """Moving-point statistics of run stores through :func:`chain_variants` of each run's own ``.cfg``
    chain: ``{variant: {"moving": recording_statistics' moving, "structure": moving_point_structure}}``."""
    from ..store import open_run
    from ..ti.formats.radhar import recording_from_frames
    from ..ti.formats.ros_driver import DriverParams
    from ..ti.oob import run_point_clouds, run_processing
    from .point_cloud_statistics import recording_statistics

    recordings: dict = {}
    for store in stores:
        run = open_run(store)
        params = DriverParams.from_radar(run.radar)
        for name, processing in chain_variants(run_processing(run)).items():
            recordings.setdefault(name, []).append(recording_from_frames(
                run_point_clouds(store, processing), params, activity=activity, source=str(store)))
    grid = doppler_grid([r for recs in recordings.values() for r in recs])
    return {name: {"moving": recording_statistics(recs)["moving"],
                   "structure": moving_point_structure(recs, grid)} for name, recs in recordings.items()}


# ------------------------------------------------------------------------------------------ tables
def _fmt(value, digits=2) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def structure_table(sides: dict) -> str:
    """Markdown: :func:`moving_point_structure` of several sets side by side (``{label: result}``)."""
    rows = (("moving points a frame", "moving_points_per_frame"), ("frames with a moving point", "frames_with_moving"),
            ("groups per such frame", "groups_per_moving_frame"), ("range bins per group", "range_bins_per_group"),
            ("points per range bin (second points)", "points_per_range_bin"),
            ("groups of 3 range bins or more", "groups_of_3_or_more"),
            ("frames with two Doppler bins or more", "frames_with_two_bins"),
            ("gaps splitting a bin's points, per frame", "gaps_per_moving_frame"))
    head = "| | " + " | ".join(sides) + " |\n|---|" + "---|" * len(sides) + "\n"
    return head + "\n".join(f"| {label} | " + " | ".join(_fmt(s[key]) for s in sides.values()) + " |"
                            for label, key in rows)


def truth_tables(summary: dict) -> str:
    """Markdown: where the moving points lie and how their number goes with the trunk's speed and range."""
    loc = summary["location"]
    lines = ["| on the body | before it | beyond it (multipath) | below the floor | at the trunk's Doppler bin | "
             "abs bin 1 / 2 / >= 3 |", "|---|---|---|---|---|---|",
             f"| {_fmt(loc['on_body'], 3)} | {_fmt(loc['before_body'], 3)} | {_fmt(loc['beyond_body'], 3)} | "
             f"{_fmt(loc['below_floor'], 3)} | {_fmt(summary['at_trunk_bin'], 3)} | "
             f"{_fmt(summary['abs_bin']['1'], 3)} / {_fmt(summary['abs_bin']['2'], 3)} / "
             f"{_fmt(summary['abs_bin']['3_or_more'], 3)} |", "",
             "| trunk radial speed, Doppler bins | frames | moving points a frame |", "|---|---|---|"]
    lines += [f"| {c['low']:g}-{c['high']:g} | {c['frames']} | {_fmt(c['moving_points_per_frame'])} |"
              for c in summary["by_bulk_speed"]]
    lines += ["", "| trunk range (m), trunk at abs bin >= 1 | frames | moving points a frame |", "|---|---|---|"]
    lines += [f"| {c['low']:g}-{c['high']:g} | {c['frames']} | {_fmt(c['moving_points_per_frame'])} |"
              for c in summary["by_trunk_range_walking"]]
    return "\n".join(lines)


def chain_table(result: dict) -> str:
    """Markdown: :func:`chain_attribution`'s variants."""
    lines = ["| chain | moving points a frame | frames without | share at bin +-1 | at +-2 and beyond | "
             "range bins per group |", "|---|---|---|---|---|---|"]
    for name, r in result.items():
        m, s = r["moving"], r["structure"]
        lines.append(f"| {name} | {_fmt(m['points_per_frame'])} | {_fmt(m['frames_without'])} | "
                     f"{_fmt(m['share_bin_1'], 3)} | {_fmt(m['share_bin_2_or_more'], 3)} | "
                     f"{_fmt(s['range_bins_per_group'])} |")
    return "\n".join(lines)


def source_attribution(pairs, frames, grid, limb_gains=()) -> dict:
    """:func:`~sionnafmcw.validation.moving_cells.moving_cell_sources` of ``frames`` of each
    ``(recording, store)`` pooled, with every moving point also placed against its trunk's Doppler bin:
    ``{"all": {region: share}, "at_trunk_bin": {...}, "off_trunk_bin": {...}, "body_power": {...},
    "points": n, "items": [...], "frames": [...], "reproduction_error_max": e, "median_share": m}``; with
    ``limb_gains`` (dB) also ``"limb_gains"``: the moving points per frame, the frames with one and those
    with two Doppler bins or more, as run and with the arms' and legs' echoes scaled by each gain."""
    from .moving_cells import REGIONS, moving_cell_sources

    regions, at_trunk, body_power, shares, errors = [], [], [], [], []
    gains = {f"arms and legs {g:+g} dB": {"arms": g, "legs": g} for g in limb_gains}
    variant_rows: dict = {}
    for recording, store in pairs:
        result = moving_cell_sources(store, frames, gains=gains or None)
        for name, row in result["summary"].get("variants", {}).items():
            variant_rows.setdefault(name, []).append(row)
        truth = person_truth(store)
        trunk_bin = np.rint(np.asarray(truth.trunk_radial_velocity) / grid[0]).astype(np.int64)
        pts = result["points"]
        regions += pts["region"].tolist()
        at_trunk += (pts["k"] == trunk_bin[pts["frame"]]).tolist()
        shares += pts["share"].tolist()
        body_power.append(result["summary"]["body_power"])
        errors.append(float(np.max(result["frames"]["reproduction_error"])))
    regions, at_trunk = np.asarray(regions), np.asarray(at_trunk, bool)

    def split(mask):
        n = max(int(mask.sum()), 1)
        return {r: float(np.count_nonzero(regions[mask] == r)) / n for r in REGIONS} | {"points": int(mask.sum())}

    every = np.ones(regions.size, bool)
    return {"items": [Path(s).parent.name for _, s in pairs], "frames": list(frames), "points": int(regions.size),
            "all": split(every), "at_trunk_bin": split(at_trunk), "off_trunk_bin": split(~at_trunk),
            "body_power": {r: float(np.mean([b[r] for b in body_power])) for r in body_power[0]} if body_power else {},
            "median_share": float(np.median(shares)) if shares else float("nan"),
            "reproduction_error_max": max(errors) if errors else float("nan"),
            **({"limb_gains": {name: {key: float(np.nanmean([r[key] for r in rows])) for key in rows[0]}
                               for name, rows in variant_rows.items()}} if variant_rows else {})}


def sources_table(result: dict) -> str:
    """Markdown: :func:`source_attribution`."""
    regions = ("arms", "legs", "trunk and head", "room")
    lines = ["| moving points | points | " + " | ".join(regions) + " |", "|---|---|" + "---|" * len(regions)]
    for label, key in (("all", "all"), ("at the trunk's Doppler bin", "at_trunk_bin"),
                       ("at another bin", "off_trunk_bin")):
        row = result[key]
        lines.append(f"| {label} | {row['points']} | " + " | ".join(_fmt(row[r]) for r in regions) + " |")
    bp = result["body_power"]
    lines.append("| the body's echo power, share | | " + " | ".join(_fmt(bp.get(r, float('nan'))) for r in regions)
                 + " |")
    lines.append(f"\nitems {', '.join(result['items'])}, frames {', '.join(map(str, result['frames']))}; the source's "
                 f"median share of its cell {_fmt(result['median_share'])}; re-run frames reproduce the stored cubes "
                 f"to {result['reproduction_error_max']:.1e} (relative)")
    if "limb_gains" in result:
        lines += ["", "| echoes (attribution) | moving points a frame | frames with one | of those, two Doppler bins "
                  "or more |", "|---|---|---|---|"]
        lines += [f"| {name} | {_fmt(r['moving_points_per_frame'])} | {_fmt(r['frames_with_moving'])} | "
                  f"{_fmt(r['frames_with_two_bins'])} |" for name, r in result["limb_gains"].items()]
    return "\n".join(lines)


def _json(value):
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--synthetic", type=Path, required=True,
                        help="a RadHAR-format export of simulated items (<class>/<item id>.npz)")
    parser.add_argument("--items", type=Path, help="the data set's items folder (<item id>/run.zarr): the truth")
    parser.add_argument("--real", type=Path, help="RadHAR's folder of <class>/*.npz recordings")
    parser.add_argument("--activity", default="walk", help="the class folder to study (default walk)")
    parser.add_argument("--chain", action="store_true", help="re-run the TI chain on the items' run stores with "
                        "one part changed at a time (attribution, ~3 s a 60-frame item on 2 cores)")
    parser.add_argument("--sources", help="frames (comma-separated) at which to split the moving cells among the "
                        "objects whose echoes make them (sionnafmcw.validation.moving_cells: the engine re-run, "
                        "10-25 s a frame)")
    parser.add_argument("--source-items", help="the item ids (comma-separated) for --sources (default: all)")
    parser.add_argument("--limb-gains", help="with --sources: gains in dB (comma-separated, e.g. -6,-12) by which the "
                        "arms' and legs' echoes are scaled, frame synthesised again and run through the chain "
                        "(attribution, not a setting)")
    args = parser.parse_args(argv)
    if (args.chain or args.sources is not None) and args.items is None:
        parser.error("--chain and --sources work on the items' run stores: give --items too")
    if (args.limb_gains is not None or args.source_items is not None) and args.sources is None:
        parser.error("--limb-gains and --source-items go with --sources: give --sources FRAMES too")
    try:
        source_frames = [] if args.sources is None else [int(f) for f in args.sources.split(",")]
        limb_gains = [] if args.limb_gains is None else [float(g) for g in args.limb_gains.split(",")]
    except ValueError:
        print(f"error: --sources must be comma-separated frame indices and --limb-gains comma-separated dB, got "
              f"{args.sources!r} and {args.limb_gains!r}", file=sys.stderr)
        return 2
    from ..store import RunStoreError
    from ..engines.errors import EngineError
    from ..ti.formats.radhar import RadharFormatError, read_recording

    try:
        folder = args.synthetic / args.activity
        files = sorted(folder.glob("*.npz"))
        if not files:
            raise FileNotFoundError(f"{folder}: no <item id>.npz recordings; give --synthetic a RadHAR-format export")
        synthetic = [read_recording(p) for p in files]
        real = []
        if args.real is not None:
            real_folder = args.real / args.activity
            real_files = sorted(real_folder.glob("*.npz")) + sorted(real_folder.glob("*.txt"))
            if not real_files:
                raise FileNotFoundError(f"{real_folder}: no recordings; give --real RadHAR's split folder")
            real = [read_recording(p) for p in real_files]
        grid = doppler_grid(synthetic + real)
        metrics: dict = {"activity": args.activity, "doppler_step": grid[0]}
        sides = {f"simulated ({len(synthetic)})": moving_point_structure(synthetic, grid)}
        if real:
            sides[f"real ({len(real)})"] = moving_point_structure(real, grid)
        metrics["structure"] = dict(zip(("simulated", "real"), sides.values()))
        print(f"## {args.activity}: the moving points per frame, factored\n\n{structure_table(sides)}\n")
        if args.items is not None:
            stores = [args.items / p.stem / "run.zarr" for p in files]
            missing = [str(s) for s in stores if not s.is_dir()]
            if missing:
                raise FileNotFoundError(f"{missing[0]}: no run store for the exported item; give --items the "
                                        "data set's items folder the export was made from")
            against = moving_points_against_truth([(r, person_truth(s)) for r, s in zip(synthetic, stores)], grid)
            metrics["against_truth"] = against["summary"]
            print(f"## simulated {args.activity}: the moving points against the person's truth\n\n"
                  f"{truth_tables(against['summary'])}\n")
            if args.chain:
                chain = chain_attribution(stores, args.activity)
                metrics["chain"] = chain
                print(f"## simulated {args.activity}: the TI chain with one part changed (attribution)\n\n"
                      f"{chain_table(chain)}\n")
            if source_frames:
                chosen = None if args.source_items is None else set(args.source_items.split(","))
                unknown = sorted(chosen - {s.parent.name for s in stores}) if chosen is not None else []
                if unknown:
                    raise FileNotFoundError(f"--source-items: no exported {args.activity} item {', '.join(unknown)} "
                                            f"in {folder}")
                picked = [(r, s) for r, s in zip(synthetic, stores) if chosen is None or s.parent.name in chosen]
                sources = source_attribution(picked, source_frames, grid, limb_gains)
                metrics["sources"] = sources
                print(f"## simulated {args.activity}: which echoes make the moving cells\n\n{sources_table(sources)}\n")
    except (FileNotFoundError, ValueError, RunStoreError, RadharFormatError, EngineError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(json.dumps(_json(metrics)))
    return 0


__all__ = ["BULK_SPEED_CLASSES", "LOCATIONS", "PersonTruth", "RANGE_CLASSES", "SURFACE_MARGIN", "chain_attribution",
           "chain_table", "chain_variants", "driver_range_step", "main", "moving_point_structure",
           "moving_points_against_truth", "person_truth", "source_attribution", "sources_table", "structure_table",
           "truth_tables"]
