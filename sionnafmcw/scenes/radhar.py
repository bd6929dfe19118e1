r"""RadHAR's five activities in a room, placed in the radar's own frame: the scenario data sets randomise.

``radhar`` (registered in :mod:`.registry`) writes one person doing one of the five activities of the
RadHAR data set (Singh et al., mmNets 2019) in front of a radar:

=================  ========================================================================================
``activity``       motion
=================  ========================================================================================
``boxing``         keyframed straight punches (:func:`sionnafmcw.scenes.activities.boxing_person`)
``jumping_jacks``  CMU ``13_29`` frames 1-480 (``jumping_jacks``)
``jump``           ``jump_style``: ``in_place`` keyframed countermovement jumps (``jump_in_place``),
                   ``forward`` CMU ``75_10``, one long jump (``jump``)
``squat``          CMU ``13_29`` frames 3800-4520, two deep squats (``squat``)
``walk``           ``walk_source``: ``boulic`` the Boulic-Thalmann walker at ``walk_speed`` on a loop
                   (``walk_path`` ``circle``, ``walk_radius``; clockwise when ``mirror``) or a straight
                   track; ``clip`` CMU ``08_10`` (straight, 3.7 m in 2.29 s, subject 8)
=================  ========================================================================================

``bvh`` (the path of any BVH file) replaces the class's motion by the file's, from its frame 1, and
keeps ``activity`` as the label: any capture for any class. Every motion takes ``time_offset``,
``playback_rate``, ``mirror``, ``person_height`` and ``build`` (:mod:`.activities`).

Placement (the radar's frame)
-----------------------------
The radar stands at :math:`(0, 0, h)`, ``radar_height`` :math:`h`, its boresight along :math:`+x`
tilted down by ``radar_tilt`` :math:`\beta` (boresight :math:`(\cos\beta, 0, -\sin\beta)`). The person
starts at range ``person_range`` :math:`r` (on the floor) and azimuth ``person_azimuth`` :math:`\varphi`,
at :math:`(r\cos\varphi, r\sin\varphi)`, and faces the radar turned by ``heading_offset``
:math:`\delta`: heading :math:`\varphi + \pi + \delta` (:math:`\delta = 0`: facing the radar). A walk
heads along ``walk_direction`` at its middle frame: ``toward`` the radar (heading
:math:`\varphi + \pi + \delta`), ``away`` (:math:`\varphi + \delta`), to the radar's ``left``
(:math:`\varphi + \pi/2 + \delta`) or ``right`` (:math:`\varphi - \pi/2 + \delta`); :math:`(r,
\varphi)` places its middle (the pelvis at the middle frame). On a loop the heading turns by
:math:`v t / R` in time :math:`t`, so the window sees the radial speed swing as RadHAR's walkers did:
they walked small loops in front of the sensor. A walk whose pelvis comes nearer the radar than
:data:`MIN_CLEARANCE` is an error. With
``room`` the room encloses the person's motion and the radar with ``room_margin`` on every side (its
size), walls, floor and ceiling of the surface materials, and the furniture counts
(:mod:`.furniture`), placed clear of the person and of the line of sight. The physical ranges a data
set draws these from are in the guide (``docs/guide/datasets.md``, domain randomisation).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .activities import (WINDOWS, _BOXING, _CLIP_TIME, _JUMP, _PERSON, _ROOM, boxing_person, jump_in_place_person,
                         mocap_person, _room_box)
from .registry import Parameter, register

#: Least ground distance (m) of a walker's pelvis from the radar.
MIN_CLEARANCE = 0.5

#: A walk's direction and its heading relative to :math:`\varphi` (module docstring).
WALK_DIRECTIONS = ("toward", "away", "left", "right")
_WALK_HEADING = {"toward": math.pi, "away": 0.0, "left": math.pi / 2, "right": -math.pi / 2}

#: The RadHAR classes, in the data set's order (its folder names: boxing, jack, jump, squats, walk).
CLASSES = ("boxing", "jumping_jacks", "jump", "squat", "walk")
#: The RadHAR folder name of each class.
RADHAR_FOLDERS = {"boxing": "boxing", "jumping_jacks": "jack", "jump": "jump", "squat": "squats", "walk": "walk"}

PARAMETERS = {
    "activity": Parameter("walk", str, "", "the RadHAR class", choices=CLASSES),
    "bvh": Parameter("", str, "", "path of a BVH file whose motion replaces the class's (empty: the class's own)"),
    "jump_style": Parameter("in_place", str, "", "jump: in place (keyframed countermovement jumps) or forward "
                            "(CMU clip 75_10, one long jump)", choices=("in_place", "forward")),
    "walk_source": Parameter("boulic", str, "", "walk: the Boulic-Thalmann walker or CMU clip 08_10",
                             choices=("boulic", "clip")),
    "walk_speed": Parameter(0.5, float, "m/s", "walk with walk_source=boulic: walking speed", low=0.3, high=2.0),
    "walk_path": Parameter("circle", str, "", "walk with walk_source=boulic: a loop of walk_radius or a straight "
                           "track", choices=("circle", "straight")),
    "walk_radius": Parameter(0.75, float, "m", "walk on a loop: its radius", low=0.3, high=10.0),
    "walk_direction": Parameter("toward", str, "", "walk: heading at the middle frame, toward the radar, away from "
                                "it, or across its line of sight to its left or right (heading_offset turns it)",
                                choices=WALK_DIRECTIONS),
    "person_range": Parameter(2.0, float, "m", "ground range of the person's start point from the radar",
                              low=0.5, high=10.0),
    "person_azimuth": Parameter(0.0, float, "rad", "azimuth of the person's start point from the boresight "
                                "(+: the radar's left)", low=-1.2, high=1.2),
    "heading_offset": Parameter(0.0, float, "rad", "the person's facing direction relative to facing the radar",
                                low=-2 * math.pi, high=2 * math.pi),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.1, high=3.0),
    "radar_tilt": Parameter(0.0, float, "rad", "downward tilt of the boresight (0: level)", low=-0.5, high=1.0),
    **{k: v for k, v in _PERSON.items() if k not in ("x", "y", "heading")},
    **{**_CLIP_TIME, "num_frames": Parameter(60, int, "", "number of frames (RadHAR's classifier windows: 60)",
                                             low=1, high=100_000)},
    **{**_ROOM, "room": Parameter(True, bool, "", "put the person and the radar in a closed room"),
       "room_margin": Parameter(1.5, float, "m", "free space between the scene and the walls (the room's size)",
                                low=0.1, high=20.0)},
    **_BOXING,
    **_JUMP,
}


def radhar_person(p: dict):
    """``(person, info)`` of the parameters ``p`` of ``radhar`` (module docstring), placed in the radar's frame."""
    phi = p["person_azimuth"]
    r = p["person_range"]
    q = {**p, "x": r * math.cos(phi), "y": r * math.sin(phi), "heading": phi + math.pi + p["heading_offset"]}
    act = p["activity"]
    info = {"height_m": p["person_height"], "build": p["build"]}
    if p["bvh"]:
        from ..mocap.bvh import read_bvh

        path = Path(p["bvh"])
        if not path.is_file():
            raise ValueError(f"radhar: bvh={p['bvh']!r} is not a file; give the path of a BVH file or leave it empty")
        person = mocap_person(read_bvh(path), q)
        info.update(motion_source=f"BVH clip {path.name}", clip=str(path))
    elif act == "boxing":
        person, punches = boxing_person(q)
        info.update(motion_source="keyframed straight punches (sionnafmcw.mocap.punches)",
                    punches=punches.to_dict())
    elif act == "jump" and p["jump_style"] == "in_place":
        person = jump_in_place_person(q)
        info.update(motion_source="keyframed countermovement jumps in place (sionnafmcw.mocap.jumps)")
    elif act == "walk":
        q["heading"] = phi + _WALK_HEADING[p["walk_direction"]] + p["heading_offset"]
        person, extra = _walker(p, q)
        mid = person.keypoints([person.num_frames // 2])[0, 0, :2]        # the pelvis half-way
        q["x"], q["y"] = q["x"] + r * math.cos(phi) - mid[0], q["y"] + r * math.sin(phi) - mid[1]
        person, extra = _walker(p, q)
        pelvis = person.keypoints()[:, 0, :2]
        nearest = float(np.min(np.hypot(pelvis[:, 0], pelvis[:, 1])))
        if nearest < MIN_CLEARANCE:
            raise ValueError(f"radhar: the walk passes {nearest:.2f} m from the radar (person_range={r:g} m, "
                             f"{person.num_frames} frames); raise person_range or lower num_frames")
        info.update(extra)
    else:
        clip = "08_10" if act == "walk" else WINDOWS[act][0]
        start, end = (None, None) if act == "walk" else WINDOWS[act][1:]
        person = mocap_person(clip, q, start, end)
        info.update(motion_source=f"CMU Graphics Lab Motion Capture Database, clip {clip}", clip=clip,
                    clip_start_s=person.start)
    info.update(start=[q["x"], q["y"]], heading=q["heading"], mirror=bool(p["mirror"]))
    return person, info


def _walker(p: dict, q: dict):
    """``(person, info)`` of the walk from ``q``'s start point and heading."""
    if p["walk_source"] == "boulic":
        from .people import make_person

        if p["walk_path"] == "straight":
            return make_person("walk", {**q, "walk_speed": p["walk_speed"]}, p["person_height"], p["build"],
                               p["seed"], (q["x"], q["y"]), q["heading"])
        # a loop whose track passes (x, y) at the middle frame heading q["heading"]
        radius, speed, clockwise = p["walk_radius"], p["walk_speed"], bool(p["mirror"])
        sign = -1.0 if clockwise else 1.0
        t_mid = (p["num_frames"] // 2) / p["fps"]
        angle_mid = q["heading"] - sign * math.pi / 2             # polar angle of the track point at t_mid
        centre = (q["x"] - radius * math.cos(angle_mid), q["y"] - radius * math.sin(angle_mid))
        heading0 = q["heading"] - sign * speed * t_mid / radius
        return make_person("walk_circle", {**q, "walk_speed": speed, "circle_radius": radius,
                                           "clockwise": clockwise}, p["person_height"], p["build"], p["seed"],
                           centre, heading0)
    person = mocap_person("08_10", q)
    return person, {"motion_source": "CMU Graphics Lab Motion Capture Database, clip 08_10", "clip": "08_10",
                    "clip_start_s": person.start}


@register("radhar", "One person doing a RadHAR activity (boxing, jumping jacks, jump, squat, walk) in a room, placed "
          "by range and azimuth in the radar's frame (CMU mocap 13_29, 75_10, 08_10; keyframed boxing).", PARAMETERS)
def radhar(out, **p):
    """A RadHAR activity in the radar's frame (module docstring)."""
    from ..mocap.library import ACKNOWLEDGEMENT
    from ..mocap.scene import write_people
    from .writer import look_at_orientation

    person, info = radhar_person(p)
    radar = np.array([0.0, 0.0, p["radar_height"]])
    beta = p["radar_tilt"]
    orientation = look_at_orientation(radar, radar + [math.cos(beta), 0.0, -math.sin(beta)])
    box, opts, pieces = _room_box([(person, "")], radar, p)
    extra = {"activity": {"name": p["activity"], "radhar_folder": RADHAR_FOLDERS[p["activity"]],
                          "motion_source": info["motion_source"], "person_range_m": p["person_range"],
                          "person_azimuth_rad": p["person_azimuth"], "radar_tilt_rad": beta,
                          "stature_m": person.body.height, "acknowledgement": ACKNOWLEDGEMENT}}
    write_people(out, [(person, "")], radar, orientation, p["skin_scattering"], box, opts, extra,
                 activities=[p["activity"]], furniture=pieces, person_info=[info])


__all__ = ["CLASSES", "WALK_DIRECTIONS", "PARAMETERS", "RADHAR_FOLDERS", "radhar", "radhar_person"]
