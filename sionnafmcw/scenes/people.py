r"""Several people in one scene, each on a track or an activity of its own, never in each other's way.

``people`` (registered in :mod:`sionnafmcw.scenes.registry`) puts ``num_people`` people in front of a radar, each doing
one activity (``activity`` for all, ``activities`` one per person, or ``mixed``: drawn per person):

==================  =========================================================================
activity            person
==================  =========================================================================
``walk``            the Boulic-Thalmann walker (:mod:`sionnafmcw.scenes.walking`) on a straight track, ``walk_speed``
``walk_circle``     the same walker on a circle of ``circle_radius`` (its centre the drawn position)
``run`` ...         the activity library's motion capture (:mod:`sionnafmcw.scenes.activities`: ``run``, ``sit_down``,
``squat``           ``stand_up``, ``wave``, ``jump``, ``fall``, ``pick_up``, ``jumping_jacks``, ``squat``), from
                    ``time_offset``
``clip``            ``clip``: a shipped clip's name or the path of any BVH file (from its frame 1);
                    labelled with the shipped clip's activity, else the file's name (:func:`~sionnafmcw.mocap.library.clip_label`)
``stand_still``     standing still: postural sway, breathing and heartbeat (:mod:`sionnafmcw.scenes.vitals`)
``vital_signs``     still in ``posture`` (sitting, lying, standing), breathing and heartbeat
==================  =========================================================================

Person :math:`i` is written under the prefix ``person<i>_`` (``person0_torso``, ...), so the run store's
``object`` axis tells the people apart, and the manifest's ``people`` entry (:mod:`sionnafmcw.animation.people`)
gives each one's objects, activity and keypoints per frame (:mod:`sionnafmcw.scenes.keypoints`): the run store's
``person`` coordinate.

Placement
---------
The radar stands at :math:`(0, 0, h_r)` looking along :math:`+x` (its boresight through the point
``radar_target_height`` high at mid-range). Each person gets a height (``person_height`` :math:`\pm`
``height_spread``, uniform), a build, a start position at range :math:`r \sim U(r_{min}, r_{max})` and
azimuth :math:`\varphi \sim U(-\varphi_{max}, \varphi_{max})` and a heading (uniform; the still people
face the radar within 30 degrees), all drawn from ``seed``; ``positions`` and ``headings`` fix them
instead. Every person's motion is computed once at the origin facing :math:`+x`; a placement
:math:`(x, y, \psi)` turns it by :math:`\psi` about the vertical and moves it to :math:`(x, y)`, which
moves its footprints (:mod:`sionnafmcw.scenes.layout`: a disc per frame holding the body's horizontal extent) the same
way. A draw is kept when, in every frame, every footprint centre lies in the sector (range and
azimuth within the bounds), every footprint inside the room (when there is one), and the people are
apart by at least ``person_clearance``:

* ``separation="tracks"`` (default): the swept footprints are disjoint -- no footprint of one person
  in any frame comes within the clearance of any footprint of another in any frame: the tracks never
  intersect;
* ``separation="frames"``: frame by frame -- people never touch, but one may later pass where another
  was.

Each person is drawn up to 200 times against those before; after 20 restarts of the whole draw the
builder gives up with an error naming what to change (fewer people, a larger sector, a smaller
clearance). Fixed ``positions`` that break the rules are an error.

The room (``room``, default on) spans the sector: from 0.5 m behind the radar to ``room_margin``
beyond the largest range, and ``room_margin`` beyond the sector's sides; its furniture
(:mod:`sionnafmcw.scenes.furniture`) keeps clear of every person's swept footprint and of the lines of sight.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import furniture as furniture_mod
from ..mocap.library import clip_label
from .activities import SWAY_DEFAULT, VITAL_SIGN_PARAMETERS, WINDOWS, mocap_person, still_person
from .body import MESH_EDGE, CircleTrack, LineTrack, WalkingPerson
from .layout import discs_apart
from .registry import Parameter, register
from .room import SURFACE_PARAMETERS

WALKS = ("walk", "walk_circle")
STILL = ("stand_still", "vital_signs")
MOCAP = tuple(WINDOWS)
#: The activities a person can do (``activity``, ``activities``).
ACTIVITIES = WALKS + MOCAP + STILL + ("clip",)
#: Draws per person, and restarts of the whole draw, before the placement gives up.
PERSON_TRIES, RESTARTS = 200, 20
#: Distance (m) between the radar and the wall behind it.
RADAR_WALL = 0.5
#: Still people face the radar within this angle (rad).
STILL_FACING = math.radians(30.0)


# ============================================================================ parameters
PARAMETERS = {
    "num_people": Parameter(3, int, "", "number of people", low=1, high=8),
    "activity": Parameter("walk", str, "", "what every person does (mixed: drawn per person among those that "
                          "fit the frames)", choices=ACTIVITIES + ("mixed",)),
    "activities": Parameter("", str, "", "one activity per person, comma-separated (overrides activity; "
                            "empty: activity for all)"),
    "clip": Parameter("08_10", str, "", "for activity clip: a shipped clip (08_10, 09_01, 111_10, 111_37, 75_10, "
                      "90_18, 115_06) or the path of a BVH file"),
    "posture": Parameter("sitting", str, "", "posture for vital_signs", choices=("sitting", "lying", "standing")),
    "positions": Parameter((), tuple, "m", "start positions x0, y0, x1, y1, ... (walk_circle: the circle's centre; "
                           "empty: drawn)"),
    "headings": Parameter((), tuple, "rad", "headings at frame 0, one per person (empty: drawn)"),
    "min_range": Parameter(1.5, float, "m", "nearest range of the people's footprint centres", low=0.5, high=50.0),
    "max_range": Parameter(6.0, float, "m", "farthest range of the people's footprint centres", low=0.6, high=50.0),
    "max_azimuth": Parameter(0.7, float, "rad", "largest azimuth of the people's footprint centres from the boresight",
                             low=0.0, high=math.pi / 2),
    "separation": Parameter("tracks", str, "", "tracks: swept footprints disjoint (tracks never intersect); frames: "
                            "apart in every frame", choices=("tracks", "frames")),
    "person_clearance": Parameter(0.3, float, "m", "least gap between two people's footprints", low=0.0, high=5.0),
    "person_height": Parameter(1.75, float, "m", "mean stature", low=1.4, high=2.1),
    "height_spread": Parameter(0.1, float, "m", "statures drawn uniformly within person_height +- height_spread "
                               "(kept within 1.4..2.1 m)", low=0.0, high=0.35),
    "build": Parameter("mixed", str, "", "girths of men or women (Heinz et al. 2003), or drawn per person",
                       choices=("male", "female", "mixed")),
    "walk_speed": Parameter(1.4, float, "m/s", "walking speed (walk, walk_circle)", low=0.2, high=3.0),
    "circle_radius": Parameter(1.0, float, "m", "radius of walk_circle", low=0.3, high=10.0),
    "time_offset": Parameter(0.0, float, "s", "clip seconds skipped at the start of a motion-capture activity",
                             low=0.0, high=10.0),
    "playback_rate": Parameter(1.0, float, "", "clip seconds per second", low=0.5, high=2.0),
    **VITAL_SIGN_PARAMETERS,
    "seed": Parameter(0, int, "", "seed of everything drawn: placements, activities (mixed), statures, builds, vital "
                      "signs, sway", low=0, high=2**31 - 1),
    "skin_scattering": Parameter(0.3, float, "", "diffuse scattering coefficient of the skin", low=0.0, high=1.0),
    "body_mesh_edge": Parameter(MESH_EDGE, float, "m", "largest triangle edge of the body meshes", low=0.002,
                                high=0.1),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.1, high=5.0),
    "radar_target_height": Parameter(1.0, float, "m", "height at mid-range of the point the boresight passes "
                                     "through (radar_height: level)", low=0.0, high=5.0),
    "room": Parameter(True, bool, "", "put the people and the radar in a closed room"),
    "room_margin": Parameter(1.0, float, "m", "free space between the sector and the walls", low=0.1, high=20.0),
    **SURFACE_PARAMETERS,
    **furniture_mod.PARAMETERS,
    "num_frames": Parameter(48, int, "", "number of frames", low=1, high=100_000),
    "fps": Parameter(24.0, float, "1/s", "frame rate", low=1.0, high=1000.0),
}


# ============================================================================ people
def _rotation(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [s, c]])


def activity_list(p: dict, rng) -> list[str]:
    """Each person's activity from the parameters ``p`` (``activities``, else ``activity``; ``mixed``
    drawn with ``rng`` among the activities whose motion lasts ``num_frames``)."""
    n = p["num_people"]
    if p["activities"].strip():
        acts = [a.strip() for a in p["activities"].split(",")]
        bad = [a for a in acts if a not in ACTIVITIES]
        if bad:
            raise ValueError(f"people: activities={p['activities']!r} holds {', '.join(map(repr, bad))}; each must be "
                             f"one of {', '.join(ACTIVITIES)}")
        if len(acts) != n:
            raise ValueError(f"people: activities={p['activities']!r} lists {len(acts)} activities for num_people={n}; "
                             "give one per person")
        return acts
    if p["activity"] != "mixed":
        return [p["activity"]] * n
    fits = [a for a in ACTIVITIES if a != "clip" and _frames_fit(a, p)]
    if not fits:
        raise ValueError(f"people: no activity lasts num_frames={p['num_frames']} at {p['fps']:g} fps; lower "
                         "num_frames")
    return [fits[int(rng.integers(len(fits)))] for _ in range(n)]


def _frames_fit(activity: str, p: dict) -> bool:
    if activity not in MOCAP:
        return True
    from ..mocap.library import load_clip

    clip_name, start, end = WINDOWS[activity]
    clip = load_clip(clip_name)
    lo = clip.frame_time if start is None else start
    hi = clip.duration if end is None else end
    room = hi - lo - p["time_offset"]
    return room >= 0 and int(math.floor(room * p["fps"] / p["playback_rate"] + 1e-6)) + 1 >= p["num_frames"]


def _load_clip(ref: str):
    from ..mocap.bvh import read_bvh
    from ..mocap.library import CLIPS, load_clip

    if ref in CLIPS:
        return load_clip(ref)
    path = Path(ref)
    if not path.is_file():
        raise ValueError(f"people: clip={ref!r} is neither a shipped clip ({', '.join(CLIPS)}) nor a BVH file")
    return read_bvh(path)


def make_person(activity: str, p: dict, height: float, build: str, seed: int, position=(0.0, 0.0),
                heading: float = 0.0):
    """Person doing ``activity`` with the builder's parameters ``p``, placed at ``position`` facing
    ``heading``; ``seed`` draws its gait phase, vital signs and sway. Returns ``(person, info)``:
    ``info`` the person's manifest fields (motion source, stature, build, ...)."""
    fps, n = p["fps"], p["num_frames"]
    rng = np.random.default_rng([int(seed), 7])
    common = {"person_height": height, "build": build, "x": float(position[0]), "y": float(position[1]),
              "heading": float(heading), "body_mesh_edge": p["body_mesh_edge"], "fps": fps, "num_frames": n,
              "time_offset": p["time_offset"], "playback_rate": p["playback_rate"]}
    info = {"height_m": height, "build": build}
    if activity in WALKS:
        phase0 = float(rng.uniform(0.0, 1.0))
        if activity == "walk":
            track = LineTrack((float(position[0]), float(position[1])), float(heading))
            info["track"] = {"kind": "line", "start": [float(position[0]), float(position[1])],
                             "heading": float(heading), "speed": p["walk_speed"]}
        else:
            r = p["circle_radius"]
            clockwise = bool(p.get("clockwise", False))
            # heading = start angle + pi/2 anticlockwise, - pi/2 clockwise
            start = float(heading) + (math.pi / 2 if clockwise else -math.pi / 2)
            track = CircleTrack((float(position[0]), float(position[1])), r, start, clockwise)
            info["track"] = {"kind": "circle", "centre": [float(position[0]), float(position[1])], "radius": r,
                             "start_angle": start, "clockwise": clockwise, "speed": p["walk_speed"]}
        walker = WalkingPerson(height=height, speed=p["walk_speed"], track=track, phase0=phase0,
                               mesh_edge=p["body_mesh_edge"])
        # Boulic's walker has no build: its girths are the round values of scenes.body
        info.update(motion_source="parametric: Boulic-Thalmann gait", gait_phase0=phase0, build="walker")
        from ..mocap.person import WalkerPerson

        return WalkerPerson(walker, fps, n), info
    if activity in MOCAP:
        clip, start, end = WINDOWS[activity]
        person = mocap_person(clip, common, start, end, reverse=activity == "sit_down")
        info.update(motion_source=f"CMU Graphics Lab Motion Capture Database, clip {clip}"
                    + (" played backwards" if activity == "sit_down" else ""), clip=clip, clip_start_s=person.start)
        return person, info
    if activity == "clip":
        from ..mocap.segments import leg_stature
        from ..mocap.skeleton import CMU_UNIT, ClipMotion

        clip = _load_clip(p["clip"])
        if leg_stature(ClipMotion(clip, CMU_UNIT)) is None:
            raise ValueError(f"people: clip={p['clip']!r} has no legs (UpLeg, Leg, Foot joints) to scale the body "
                             "to the person's stature from")
        person = mocap_person(clip, common)
        info.update(motion_source=f"BVH clip {p['clip']}", clip=p["clip"], clip_start_s=person.start)
        return person, info
    posture = "standing" if activity == "stand_still" else p["posture"]
    still = {**common, "seed": int(rng.integers(2**31)), "random_vitals": p["random_vitals"],
             **{k: p[k] for k in VITAL_SIGN_PARAMETERS if k != "random_vitals"}, "sway_rms": SWAY_DEFAULT[posture]}
    person, vitals = still_person(still, posture)
    info.update(motion_source=f"posture {posture}; parametric sway, breathing and heartbeat", posture=posture,
                vital_signs=vitals.to_dict())
    return person, info


def placed_footprints(reference, position, heading):
    """Footprints ``(centres [T, 2], radii [T])`` of a person whose motion at the origin facing +x has
    footprints ``reference``, turned by ``heading`` and moved to ``position``."""
    centres, radii = reference
    return centres @ _rotation(heading).T + np.asarray(position, float), radii


def room_box(p: dict):
    """``(lo, hi)`` of the room around the sector (module docstring)."""
    y = p["max_range"] * math.sin(min(p["max_azimuth"], math.pi / 2)) + p["room_margin"]
    return (np.array([-RADAR_WALL, -y, 0.0]), np.array([p["max_range"] + p["room_margin"], y, p["room_height"]]))


def _valid(foot, p, box) -> bool:
    centres, radii = foot
    r = np.linalg.norm(centres, axis=1)
    az = np.abs(np.arctan2(centres[:, 1], centres[:, 0]))
    if np.any(r < p["min_range"] - 1e-9) or np.any(r > p["max_range"] + 1e-9) or np.any(az > p["max_azimuth"] + 1e-9):
        return False
    if box is not None:
        lo, hi = box[0][:2], box[1][:2]
        if np.any(centres - radii[:, None] < lo) or np.any(centres + radii[:, None] > hi):
            return False
    return True


def place_people(references, activities, p: dict, box=None, rng=None):
    """Start positions and headings ``[(x, y, heading), ...]`` of the people whose footprints at the origin
    facing +x are ``references`` (module docstring: sector, room, separation)."""
    n = len(references)
    same_frame = p["separation"] == "frames"
    gap = p["person_clearance"]
    fixed_pos, fixed_head = p["positions"], p["headings"]
    if fixed_pos and len(fixed_pos) != 2 * n:
        raise ValueError(f"people: positions has {len(fixed_pos)} numbers; num_people={n} needs {2 * n} (x0, y0, "
                         "x1, y1, ...)")
    if fixed_head and len(fixed_head) != n:
        raise ValueError(f"people: headings has {len(fixed_head)} values; num_people={n} needs {n}")
    if p["min_range"] >= p["max_range"]:
        raise ValueError(f"people: min_range={p['min_range']} m must be below max_range={p['max_range']} m")
    rng = rng if rng is not None else np.random.default_rng()

    def draw(i):
        if fixed_pos:
            xy = np.array(fixed_pos[2 * i:2 * i + 2], float)
        else:
            r = rng.uniform(p["min_range"], p["max_range"])
            a = rng.uniform(-p["max_azimuth"], p["max_azimuth"])
            xy = np.array([r * math.cos(a), r * math.sin(a)])
        if fixed_head:
            psi = float(fixed_head[i])
        elif activities[i] in STILL:   # facing the radar within STILL_FACING
            psi = math.atan2(-xy[1], -xy[0]) + rng.uniform(-STILL_FACING, STILL_FACING)
        else:
            psi = rng.uniform(-math.pi, math.pi)
        return xy, psi

    for _ in range(RESTARTS if not (fixed_pos and fixed_head) else 1):
        placed, feet = [], []
        for i in range(n):
            for _ in range(PERSON_TRIES if not (fixed_pos and fixed_head) else 1):
                xy, psi = draw(i)
                foot = placed_footprints(references[i], xy, psi)
                if _valid(foot, p, box) and all(discs_apart(*foot, *other, gap, same_frame) for other in feet):
                    placed.append((float(xy[0]), float(xy[1]), float(psi)))
                    feet.append(foot)
                    break
            else:
                break
        if len(placed) == n:
            return placed, feet
    if fixed_pos and fixed_head:
        i = len(placed)
        raise ValueError(f"people: the fixed positions and headings put person {i} ({activities[i]})"
                         f" outside the sector ({p['min_range']}..{p['max_range']} m, +-{p['max_azimuth']:.3f} rad)"
                         f"{' or the room' if box is not None else ''} or within {gap} m of another person's "
                         f"{'footprint' if same_frame else 'track'}; move it")
    raise ValueError(f"people: cannot place {n} people ({', '.join(activities)}) in the sector {p['min_range']}.."
                     f"{p['max_range']} m, +-{p['max_azimuth']:.3f} rad, {gap} m apart "
                     f"({'frame by frame' if same_frame else 'tracks never intersecting'}) after {RESTARTS} "
                     f"restarts of {PERSON_TRIES} draws per person; lower num_people or num_frames, widen the sector "
                     "(max_range, max_azimuth), lower person_clearance or use separation=frames")


@register("people", "Several people, each on its own track or activity, never in each other's way (counting, "
          "tracking, activity data sets).", PARAMETERS)
def people(out, **p):
    """People placed at random in the radar's sector (module docstring), in a furnished room."""
    from ..mocap.library import ACKNOWLEDGEMENT
    from ..mocap.scene import write_people
    from .writer import look_at_orientation

    rng = np.random.default_rng([p["seed"], 0x50])
    acts = activity_list(p, rng)
    lo_h, hi_h = max(1.4, p["person_height"] - p["height_spread"]), min(2.1, p["person_height"] + p["height_spread"])
    heights = [float(rng.uniform(lo_h, hi_h)) if hi_h > lo_h else float(lo_h) for _ in acts]
    builds = [p["build"] if p["build"] != "mixed" else ("male", "female")[int(rng.integers(2))] for _ in acts]
    seeds = [int(rng.integers(2**31)) for _ in acts]
    box = room_box(p) if p["room"] else None
    references = [make_person(a, p, h, b, s)[0].footprints() for a, h, b, s in zip(acts, heights, builds, seeds)]
    placement, feet = place_people(references, acts, p, box, rng)
    persons, infos = [], []
    for i, (a, h, b, s, (x, y, psi)) in enumerate(zip(acts, heights, builds, seeds, placement)):
        person, info = make_person(a, p, h, b, s, (x, y), psi)
        persons.append((person, f"person{i}_"))
        infos.append({**info, "start": [x, y], "heading": psi})
    radar = np.array([0.0, 0.0, p["radar_height"]])
    target = np.array([0.5 * (p["min_range"] + p["max_range"]), 0.0, p["radar_target_height"]])
    pieces = []
    if furniture_mod.wants_furniture(p):
        if box is None:
            raise ValueError("people: furniture (tables, chairs, sofas, shelves, cabinets, doors, monitors) needs "
                             "room=true")
        keep = furniture_mod.people_keep_out(feet, radar[:2], p["furniture_clear_view"])
        pieces = furniture_mod.place_furniture(furniture_mod.counts_of(p), box[0], box[1], keep, p["furniture_seed"],
                                               p["furniture_clearance"])
    opts = {k: p[k] for k in ("wall_material", "floor_material", "ceiling_material", "wall_scattering",
                              "furniture_scattering")}
    extra = {"acknowledgement": ACKNOWLEDGEMENT} if any(a in MOCAP + STILL for a in acts) else {}
    labels = [clip_label(p["clip"]) if a == "clip" else a for a in acts]
    write_people(out, persons, radar, look_at_orientation(radar, target), p["skin_scattering"], box, opts, extra,
                 activities=labels, furniture=pieces, person_info=infos)


__all__ = ["ACTIVITIES", "PARAMETERS", "activity_list", "make_person", "people", "place_people",
           "placed_footprints", "room_box"]
