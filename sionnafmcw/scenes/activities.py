r"""The activity library: a person doing what radar data sets are made to recognise, by name.

Every builder is registered in :mod:`.registry` with typed, bounded parameters (a data-set spec
draws them between their ``low`` and ``high``) and documents its motion source. The body is the
segment body of :mod:`sionnafmcw.mocap.segments` (tapered limbs and torso ellipsoids sized from the
skeleton, girths of Heinz et al. 2003), every segment a rigid skin object; the people are written by
:func:`sionnafmcw.mocap.scene.write_people`, whose per-person name prefix lets later builders put
several people in one scene.

==================  ======================================================================================
builder             motion source
==================  ======================================================================================
``circle_walk``,    parametric: the Boulic-Thalmann gait (:mod:`.walking`)
``straight_walk``
``run``             CMU ``09_01`` (run, subject 9), motion capture
``sit_down``        CMU ``111_10`` (get up from chair, subject 111) played backwards from 2.0 s: a captured
                    stand-up reversed in time, not a captured sit-down (a sit-down is slower at the end,
                    where the seat stops the body; the reversal keeps the stand-up's speeds)
``stand_up``        CMU ``111_10``, 0 to 2.0 s (seated, rises at about 0.9-1.5 s, stands)
``wave``            CMU ``111_37`` (wave, subject 111)
``jump``            CMU ``75_10`` (jump, subject 75): stands, one long jump forward
``fall``            CMU ``90_18`` (rug-pull fall, subject 90): stands, falls backwards, lies on the floor
``pick_up``         CMU ``115_06`` (picking a box up, bending the knees, subject 115)
``jumping_jacks``   CMU ``13_29`` frames 1-480 (subject 13): seven jumping jacks in 4 s
``squat``           CMU ``13_29`` frames 3800-4520 (subject 13): stands, two deep squats, stands
``jump_in_place``   keyframed: countermovement jumps in place, ballistic flight, the legs by inverse
                    kinematics, on subject 13's standing posture (:mod:`sionnafmcw.mocap.jumps`)
``boxing``          keyframed: straight punches of both fists in turn, minimum-jerk fist paths at a measured
                    peak fist speed, the arms by inverse kinematics, the pelvis and thorax turning toward
                    each punch, a weight shift and the stance bounce, on subject 13's standing posture
                    (:mod:`sionnafmcw.mocap.punches`; no boxing clip is shipped)
``mocap_clip``      any shipped CMU clip (``clip``)
``stand_still``     posture: CMU ``90_18`` at 0.2 s (standing); motion: parametric postural sway and the
                    chest wall's breathing and heartbeat (:mod:`sionnafmcw.scenes.vitals`)
``vital_signs``     posture: standing, sitting (CMU ``111_10`` at 0.3 s) or lying (CMU ``90_18`` at
                    3.2 s); motion: breathing and heartbeat drawn per item within the physiological
                    ranges, and a small postural sway
==================  ======================================================================================

The captured clips are scaled uniformly so that the skeleton's stature (from its legs,
:func:`~sionnafmcw.mocap.segments.leg_stature`) is ``person_height``: lengths and speeds scale with it,
the timing does not. ``mirror`` plays the clip left for right (:mod:`sionnafmcw.mocap.mirror`: the
reflection of the skeleton, so the body stays a body). The person starts at ``(x, y)`` facing ``heading``; the radar stands
``radar_distance`` metres from that point in the direction ``heading + radar_azimuth``
(``radar_azimuth`` = 0: in front, pi: behind), ``radar_height`` up, its boresight through the point
``radar_target_height`` above the start position (level by default; lower for a radar looking down
from a wall or the ceiling, as fall detectors do). For ``stand_still`` and ``vital_signs`` the radar
looks at the chest instead, from ``radar_distance`` along the chest's outward normal (in front of a
sitting or standing person, above a lying one). Acknowledgement for the CMU clips:
:data:`sionnafmcw.mocap.library.ACKNOWLEDGEMENT`.

With ``room`` the person and the radar stand in a closed room, furnished by the furniture
parameters (``tables``, ``chairs``, ``sofas``, ``shelves``, ``cabinets``, ``doors``, ``monitors``,
:mod:`.furniture`), placed clear of the person's swept footprint. The manifest labels the person
(``people``: activity and keypoints per frame, :mod:`sionnafmcw.animation.people`).
"""

from __future__ import annotations

import math

import numpy as np

from .body import MESH_EDGE
from . import furniture
from .registry import Parameter, register
from .room import SURFACE_PARAMETERS
from .vitals import (BREATHING_AMPLITUDE, BREATHING_RATE, HEART_AMPLITUDE, HEART_RATE, PosturalSway, VitalSigns,
                     chest_wall)

#: Clip windows (clip seconds) of the activities: ``{activity: (clip, start, end)}``; None: the clip's ends.
WINDOWS = {"run": ("09_01", None, None), "stand_up": ("111_10", None, 2.0), "sit_down": ("111_10", None, 2.0),
           "wave": ("111_37", None, None), "jump": ("75_10", None, None), "fall": ("90_18", None, None),
           "pick_up": ("115_06", None, None), "jumping_jacks": ("13_29_jacks", None, None),
           "squat": ("13_29_squats", None, None)}
#: The standing posture the keyframed activities (``boxing``, ``jump_in_place``) animate: ``(clip, clip time s)``, subject 13
#: as the jumping jacks and the squats.
BOXING_POSTURE = ("13_29_squats", 0.05)

_PERSON = {
    "person_height": Parameter(1.75, float, "m", "stature; the motion is scaled uniformly to it (lengths and speeds)",
                               low=1.4, high=2.1),
    "build": Parameter("male", str, "", "girths of men or women (Heinz et al. 2003)", choices=("male", "female")),
    "x": Parameter(0.0, float, "m", "start position of the person, x", low=-20.0, high=20.0),
    "y": Parameter(0.0, float, "m", "start position of the person, y", low=-20.0, high=20.0),
    "heading": Parameter(0.0, float, "rad", "facing direction at frame 0 (from +x towards +y)",
                         low=-2 * math.pi, high=2 * math.pi),
    "skin_scattering": Parameter(0.3, float, "", "diffuse scattering coefficient of the skin", low=0.0, high=1.0),
    "body_mesh_edge": Parameter(MESH_EDGE, float, "m", "largest triangle edge of the body meshes",
                                low=0.002, high=0.1),
}
_RADAR = {
    "radar_azimuth": Parameter(0.0, float, "rad", "direction of the radar from the person, from the heading "
                               "(0: in front, pi: behind)", low=-2 * math.pi, high=2 * math.pi),
    "radar_height": Parameter(1.0, float, "m", "radar height above the floor", low=0.1, high=5.0),
    "radar_target_height": Parameter(1.0, float, "m", "height above the start position of the point the boresight "
                                     "passes through (equal to radar_height: level; lower: looking down)",
                                     low=0.0, high=5.0),
}
_ROOM = {
    "room": Parameter(False, bool, "", "put the person and the radar in a closed room (walls, floor, ceiling)"),
    "room_margin": Parameter(1.0, float, "m", "free space between the scene and the walls", low=0.1, high=20.0),
    **SURFACE_PARAMETERS,
    **furniture.PARAMETERS,
}
_CLIP_TIME = {
    "time_offset": Parameter(0.0, float, "s", "clip seconds skipped at the start of the activity's window",
                             low=0.0, high=10.0),
    "playback_rate": Parameter(1.0, float, "", "clip seconds per second (speeds scale with it)", low=0.5, high=2.0),
    "num_frames": Parameter(0, int, "", "number of frames (0: all the activity's window holds)", low=0, high=100_000),
    "fps": Parameter(30.0, float, "1/s", "frame rate", low=1.0, high=1000.0),
    "mirror": Parameter(False, bool, "", "mirror the motion left for right (sionnafmcw.mocap.mirror): the other "
                        "side of the body leads"),
}


def _radar_distance(distance: float) -> Parameter:
    return Parameter(float(distance), float, "m", "distance of the radar from the person's start position",
                     low=0.3, high=50.0)


def _room_box(people, radar_position, p):
    """``(box, room options, furniture pieces)`` of an activity's room (``None, None, []`` without one)."""
    from ..mocap.scene import room_around

    if not p["room"]:
        if furniture.wants_furniture(p):
            raise ValueError("furniture (tables, chairs, sofas, shelves, cabinets, doors, monitors) needs room=true")
        return None, None, []
    pts = []
    for person, _ in people:
        step = max(1, person.num_frames // 8)
        for i in list(range(0, person.num_frames, step)) + [person.num_frames - 1]:
            pts.append(np.concatenate(list(person.world_vertices(i).values()))[::53])
    box = room_around(np.vstack(pts + [np.asarray(radar_position, float)[None]]), p["room_margin"], p["room_height"])
    opts = {k: p[k] for k in ("wall_material", "floor_material", "ceiling_material", "wall_scattering",
                              "furniture_scattering")}
    pieces = []
    if furniture.wants_furniture(p):
        keep = furniture.people_keep_out([person.footprints() for person, _ in people], radar_position,
                                         p["furniture_clear_view"])
        pieces = furniture.place_furniture(furniture.counts_of(p), box[0], box[1], keep, p["furniture_seed"],
                                           p["furniture_clearance"])
    return box, opts, pieces


def mocap_person(clip_name, p: dict, start=None, end=None, reverse: bool = False, unit: float | None = None,
                 keyframed: bool = False):
    """The :class:`~sionnafmcw.mocap.person.MocapPerson` of an activity's parameters ``p`` on the shipped
    clip ``clip_name`` (or a parsed :class:`~sionnafmcw.mocap.bvh.BvhClip`) between clip times ``start``
    and ``end`` (None: the clip's usable ends); ``unit`` (m per file unit) defaults to the one that makes
    the skeleton ``person_height`` tall; ``keyframed``: the clip's frame 0 is motion, not a T-pose."""
    from ..mocap.bvh import BvhClip
    from ..mocap.segments import leg_stature
    from ..mocap.library import load_clip
    from ..mocap.person import MocapPerson
    from ..mocap.skeleton import CMU_UNIT, ClipMotion

    if isinstance(clip_name, BvhClip):
        clip, clip_name = clip_name, str(clip_name.path or "BVH clip")
    else:
        clip = load_clip(clip_name)
    if p.get("mirror", False):
        from ..mocap.mirror import mirrored

        clip = mirrored(clip)
    if unit is None:
        unit = CMU_UNIT * p["person_height"] / leg_stature(ClipMotion(clip, CMU_UNIT))
    lo = (0.0 if keyframed else clip.frame_time) if start is None else float(start)
    hi = clip.duration if end is None else float(end)
    rate = p["playback_rate"]
    t0 = (hi - p["time_offset"]) if reverse else (lo + p["time_offset"])
    if not lo <= t0 <= hi:
        raise ValueError(f"time_offset={p['time_offset']} s leaves nothing of the clip window {lo:.3f}..{hi:.3f} s "
                         f"of {clip_name}; choose at most {hi - lo:.3f} s")
    room = (t0 - lo) if reverse else (hi - t0)
    available = int(math.floor(room * p["fps"] / rate + 1e-6)) + 1
    n = p["num_frames"] or available
    if n > available:
        raise ValueError(f"num_frames={n} at {p['fps']:g} fps (playback rate {rate:g}) runs past the clip window "
                         f"{lo:.3f}..{hi:.3f} s of {clip_name}: at most {available} frames from time_offset="
                         f"{p['time_offset']} s")
    return MocapPerson(clip, unit=unit, fps=p["fps"], num_frames=n, start=t0, playback_rate=rate,
                       position=(p["x"], p["y"]), heading=p["heading"], height=p["person_height"], build=p["build"],
                       mesh_edge=p["body_mesh_edge"], reverse=reverse, skip_first_frame=not keyframed)


def _write_mocap(out, activity, clip_name, p, reverse=False, start=None, end=None):
    from ..mocap.library import ACKNOWLEDGEMENT, CLIPS
    from ..mocap.scene import radar_in_front, radar_orientation, write_people

    person = mocap_person(clip_name, p, start, end, reverse)
    radar, target = radar_in_front((p["x"], p["y"]), p["heading"] + p["radar_azimuth"], p["radar_distance"],
                                   p["radar_height"])
    target[2] = p["radar_target_height"]
    box, opts, pieces = _room_box([(person, "")], radar, p)
    extra = {"activity": {"name": activity, "motion_source": f"CMU Graphics Lab Motion Capture Database, clip "
                          f"{clip_name}" + (" played backwards" if reverse else ""),
                          "clip": clip_name, "clip_start_s": person.start, "reverse": reverse,
                          "mirror": bool(p.get("mirror", False)),
                          "playback_rate": person.playback_rate, "stature_m": person.body.height,
                          "acknowledgement": ACKNOWLEDGEMENT}}
    label = CLIPS[clip_name].activity if activity == "mocap_clip" else activity
    write_people(out, [(person, "")], radar, radar_orientation(radar, target), p["skin_scattering"], box, opts, extra,
                 activities=[label], furniture=pieces,
                 person_info=[{"height_m": person.body.height, "build": p["build"], "clip": clip_name}])


def _mocap_params(radar_distance: float) -> dict:
    return {**_PERSON, "radar_distance": _radar_distance(radar_distance), **_RADAR, **_CLIP_TIME, **_ROOM}


def _register_mocap(name, doc, radar_distance, reverse=False):
    clip, start, end = WINDOWS[name]

    @register(name, doc, _mocap_params(radar_distance))
    def builder(out, **p):
        _write_mocap(out, name, clip, p, reverse=reverse, start=start, end=end)

    builder.__name__ = name
    builder.__doc__ = doc
    return builder


run = _register_mocap("run", "A person running towards the radar (CMU mocap 09_01).", 7.0)
stand_up = _register_mocap("stand_up", "A person getting up from a chair (CMU mocap 111_10; the chair is not "
                           "modelled).", 3.0)
sit_down = _register_mocap("sit_down", "A person sitting down: CMU mocap 111_10 (get up from chair) played "
                           "backwards.", 3.0, reverse=True)
wave = _register_mocap("wave", "A person standing and waving (CMU mocap 111_37).", 3.0)
jump = _register_mocap("jump", "A person jumping forward towards the radar (CMU mocap 75_10).", 6.0)
fall = _register_mocap("fall", "A person falling backwards to the floor, a rug pulled away (CMU mocap 90_18).", 3.0)
pick_up = _register_mocap("pick_up", "A person bending the knees to pick a box up (CMU mocap 115_06).", 3.0)
jumping_jacks = _register_mocap("jumping_jacks", "A person doing jumping jacks, seven in 4 s (CMU mocap 13_29, "
                                "frames 1-480).", 2.5)
squat = _register_mocap("squat", "A person doing two deep squats (CMU mocap 13_29, frames 3822-4108 and "
                        "4193-4474).", 2.5)

_BOXING = {
    "fist_speed": Parameter(6.3, float, "m/s", "peak fist speed of a straight punch (measured 6.3 +- 0.4 m/s for a "
                            "junior boxer's jab, 9.3 +- 2.1 m/s for maximal punches: sionnafmcw.mocap.punches)",
                            low=3.0, high=11.0),
    "punch_rate": Parameter(2.0, float, "1/s", "punches per second, the two fists in turn", low=0.5, high=4.0),
    "retraction_ratio": Parameter(1.5, float, "", "time to pull a fist back, in units of its extension time",
                                  low=1.0, high=3.0),
    "trunk_rotation": Parameter(0.6, float, "rad", "thorax axial rotation of a rear-hand straight toward the punch "
                                "(a jab turns 0.35 of it, the pelvis 0.6 of the thorax; tens of degrees measured: "
                                "sionnafmcw.mocap.punches)", low=0.0, high=1.0),
    "weight_shift": Parameter(0.05, float, "m", "forward shift of the pelvis in a rear-hand straight (assumed)",
                              low=0.0, high=0.15),
    "bounce": Parameter(0.03, float, "m", "peak-to-peak vertical bounce of the pelvis in the stance (assumed)",
                        low=0.0, high=0.08),
    "bounce_rate": Parameter(2.5, float, "Hz", "rate of the stance bounce (assumed)", low=0.0, high=5.0),
    "seed": Parameter(0, int, "", "seed of the punches' timing (each start jittered by +-20 % of the period)",
                      low=0, high=2**31 - 1),
}


def boxing_person(p: dict):
    """``(MocapPerson, Punches)`` of shadow boxing (:func:`sionnafmcw.mocap.punches.boxing_clip`) with the
    parameters ``p`` of the ``boxing`` builder: the posture :data:`BOXING_POSTURE`, ``num_frames`` at ``fps``
    (0: 4 s), the fists at ``fist_speed``, mirrored with ``mirror`` (a southpaw: the right fist leads)."""
    from ..mocap.library import load_clip
    from ..mocap import anatomy
    from ..mocap.punches import boxing_clip
    from ..mocap.segments import leg_stature
    from ..mocap.skeleton import CMU_UNIT, ClipMotion

    clip_name, t = BOXING_POSTURE
    base = load_clip(clip_name)
    unit = CMU_UNIT * p["person_height"] / leg_stature(ClipMotion(base, CMU_UNIT))
    n = p["num_frames"] or int(round(4.0 * p["fps"]))
    duration = p["time_offset"] + (n - 1) * p["playback_rate"] / p["fps"] + 0.5
    hand = anatomy.WINTER["hand"] * p["person_height"]          # the segment body's hand, beyond the wrist
    clip, punches = boxing_clip(base, t, unit, duration, fist_speed=p["fist_speed"], punch_rate=p["punch_rate"],
                                retraction_ratio=p["retraction_ratio"], seed=p["seed"], hand_length=hand,
                                trunk_rotation=p["trunk_rotation"], weight_shift=p["weight_shift"], bounce=p["bounce"],
                                bounce_rate=p["bounce_rate"])
    person = mocap_person(clip, {**p, "num_frames": n}, unit=unit, keyframed=True)
    return person, punches


_JUMP = {
    "jump_height": Parameter(0.15, float, "m", "apex rise of the pelvis in flight (0.05 m a hop, 0.45 m a maximal "
                             "countermovement jump)", low=0.05, high=0.45),
    "crouch": Parameter(0.15, float, "m", "depth of the countermovement and of the landing", low=0.05, high=0.35),
    "jump_rate": Parameter(0.75, float, "1/s", "jumps per second", low=0.2, high=1.5),
}


def jump_in_place_person(p: dict):
    """The :class:`~sionnafmcw.mocap.person.MocapPerson` of jumps in place
    (:func:`sionnafmcw.mocap.jumps.jump_clip`) with the parameters ``p`` of ``jump_in_place``: the posture
    :data:`BOXING_POSTURE`, ``num_frames`` at ``fps`` (0: 4 s)."""
    from ..mocap.jumps import jump_clip
    from ..mocap.library import load_clip
    from ..mocap.segments import leg_stature
    from ..mocap.skeleton import CMU_UNIT, ClipMotion

    clip_name, t = BOXING_POSTURE
    base = load_clip(clip_name)
    unit = CMU_UNIT * p["person_height"] / leg_stature(ClipMotion(base, CMU_UNIT))
    n = p["num_frames"] or int(round(4.0 * p["fps"]))
    duration = p["time_offset"] + (n - 1) * p["playback_rate"] / p["fps"] + 0.5
    clip = jump_clip(base, t, unit, duration, jump_height=p["jump_height"], crouch=p["crouch"],
                     jump_rate=p["jump_rate"])
    return mocap_person(clip, {**p, "num_frames": n}, unit=unit, keyframed=True)


@register("jump_in_place", "A person jumping in place: countermovement jumps with ballistic flight, keyframed on "
          "the CMU skeleton of subject 13 (no capture of a jump in place is shipped).", {**_mocap_params(2.5), **_JUMP})
def jump_in_place(out, **p):
    """Countermovement jumps in place on a standing posture (:mod:`sionnafmcw.mocap.jumps`)."""
    from ..mocap.library import ACKNOWLEDGEMENT
    from ..mocap.scene import radar_in_front, radar_orientation, write_people

    person = jump_in_place_person(p)
    radar, target = radar_in_front((p["x"], p["y"]), p["heading"] + p["radar_azimuth"], p["radar_distance"],
                                   p["radar_height"])
    target[2] = p["radar_target_height"]
    box, opts, pieces = _room_box([(person, "")], radar, p)
    extra = {"activity": {"name": "jump_in_place", "motion_source": "keyframed countermovement jumps (ballistic "
                          f"flight, leg inverse kinematics) on the standing posture of CMU clip {BOXING_POSTURE[0]} "
                          f"at {BOXING_POSTURE[1]} s", "jump_height_m": p["jump_height"], "crouch_m": p["crouch"],
                          "jump_rate_hz": p["jump_rate"], "stature_m": person.body.height,
                          "acknowledgement": ACKNOWLEDGEMENT}}
    write_people(out, [(person, "")], radar, radar_orientation(radar, target), p["skin_scattering"], box, opts, extra,
                 activities=["jump"], furniture=pieces,
                 person_info=[{"height_m": person.body.height, "build": p["build"], "clip": BOXING_POSTURE[0]}])


@register("boxing", "A person shadow boxing: straight punches, fists in turn, keyframed on the CMU skeleton of "
          "subject 13 (no boxing clip is shipped).", {**_mocap_params(2.5), **_BOXING})
def boxing(out, **p):
    """Straight punches from a guard on a standing posture (:mod:`sionnafmcw.mocap.punches`)."""
    from ..mocap.library import ACKNOWLEDGEMENT
    from ..mocap.scene import radar_in_front, radar_orientation, write_people

    person, punches = boxing_person(p)
    radar, target = radar_in_front((p["x"], p["y"]), p["heading"] + p["radar_azimuth"], p["radar_distance"],
                                   p["radar_height"])
    target[2] = p["radar_target_height"]
    box, opts, pieces = _room_box([(person, "")], radar, p)
    extra = {"activity": {"name": "boxing", "motion_source": "keyframed straight punches (minimum-jerk fist paths, "
                          "inverse kinematics of the arms and legs, trunk rotation, weight shift and stance bounce) on the standing posture of CMU clip "
                          f"{BOXING_POSTURE[0]} at {BOXING_POSTURE[1]} s", "fist_speed_m_s": p["fist_speed"],
                          "punches": punches.to_dict(), "playback_rate": p["playback_rate"],
                          "mirror": bool(p["mirror"]), "stature_m": person.body.height,
                          "acknowledgement": ACKNOWLEDGEMENT}}
    write_people(out, [(person, "")], radar, radar_orientation(radar, target), p["skin_scattering"], box, opts, extra,
                 activities=["boxing"], furniture=pieces,
                 person_info=[{"height_m": person.body.height, "build": p["build"], "clip": BOXING_POSTURE[0]}])


@register("mocap_clip", "Any shipped motion-capture clip (CMU database) on the segment body.", {
    "clip": Parameter("08_10", str, "", "shipped clip (sionnafmcw.mocap.library.CLIPS: 08_10 walk, 09_01 run, "
                      "111_10 stand up, 111_37 wave, 75_10 jump, 90_18 fall, 115_06 pick up, 13_29_jacks "
                      "jumping jacks, 13_29_squats squats)",
                      choices=("08_10", "09_01", "111_10", "111_37", "75_10", "90_18", "115_06", "13_29_jacks",
                               "13_29_squats")),
    "reverse": Parameter(False, bool, "", "play the clip backwards"),
    **_mocap_params(6.0),
})
def mocap_clip(out, clip, reverse, **p):
    """The whole clip (frame 0, CMU's T-pose, skipped), forwards or backwards."""
    _write_mocap(out, "mocap_clip", clip, p, reverse=reverse)


# ============================================================================ still people
#: A still person's breathing and heartbeat (every builder with still people: these and the people scenario).
VITAL_SIGN_PARAMETERS = {
    "random_vitals": Parameter(True, bool, "", "draw the rates, amplitudes and phases of breathing and heartbeat "
                               "from seed (uniform within the physiological ranges) instead of the values below"),
    "breathing_rate": Parameter(0.25, float, "Hz", "breathing rate", low=BREATHING_RATE[0], high=BREATHING_RATE[1]),
    "breathing_amplitude": Parameter(0.006, float, "m", "peak-to-peak chest-wall displacement of breathing",
                                     low=BREATHING_AMPLITUDE[0], high=BREATHING_AMPLITUDE[1]),
    "heart_rate": Parameter(1.2, float, "Hz", "heart rate", low=HEART_RATE[0], high=HEART_RATE[1]),
    "heart_amplitude": Parameter(0.0003, float, "m", "peak-to-peak chest-wall displacement of the heartbeat",
                                 low=HEART_AMPLITUDE[0], high=HEART_AMPLITUDE[1]),
}
_VITALS = {
    "random_vitals": VITAL_SIGN_PARAMETERS["random_vitals"],
    "seed": Parameter(0, int, "", "seed of the vital signs (random_vitals) and of the sway", low=0, high=2**31 - 1),
    **{k: v for k, v in VITAL_SIGN_PARAMETERS.items() if k != "random_vitals"},
}
_STILL_TIME = {
    "num_frames": Parameter(750, int, "", "number of frames (default 30 s)", low=1, high=1_000_000),
    "fps": Parameter(25.0, float, "1/s", "frame rate: the chest's phase is sampled once per frame and must turn by "
                     "less than pi between frames to be unwrapped (breathing at 0.5 Hz and 12 mm needs > 19.3 fps at "
                     "77 GHz)", low=1.0, high=1000.0),
}
#: Default postural sway (m RMS at the centre of mass) per posture (:mod:`sionnafmcw.scenes.vitals`).
SWAY_DEFAULT = {"standing": 0.004, "sitting": 0.001, "lying": 0.0}


def still_person(p: dict, posture: str):
    """``(PosedPerson, VitalSigns)`` of a still person's parameters ``p`` (``stand_still``, ``vital_signs``)."""
    from ..mocap.segments import leg_stature
    from ..mocap.library import POSTURES, load_clip
    from ..mocap.person import PosedPerson
    from ..mocap.skeleton import CMU_UNIT, ClipMotion

    clip_name, t = POSTURES[posture]
    clip = load_clip(clip_name)
    unit = CMU_UNIT * p["person_height"] / leg_stature(ClipMotion(clip, CMU_UNIT))
    rng = np.random.default_rng([p["seed"], 1])
    if p["random_vitals"]:
        vitals = VitalSigns.draw(rng)
    else:
        vitals = VitalSigns(p["breathing_rate"], p["breathing_amplitude"], p["heart_rate"], p["heart_amplitude"])
    person = PosedPerson(clip, t, fps=p["fps"], num_frames=p["num_frames"], unit=unit, position=(p["x"], p["y"]),
                         heading=p["heading"], height=p["person_height"], build=p["build"],
                         mesh_edge=p["body_mesh_edge"])
    body, posture_pose = person.body, person.posture
    root_rot = posture_pose["pelvis"][0]
    fwd = root_rot @ body.forward
    fwd[2] = 0.0
    if np.linalg.norm(fwd) < 1e-6:
        fwd = root_rot @ body.up
        fwd[2] = 0.0
    fwd /= np.linalg.norm(fwd)
    left = np.cross([0.0, 0.0, 1.0], fwd)
    sway_rms = p["sway_rms"]
    if sway_rms > 0:
        joints = person.still.joint_positions([0.0])[0]
        names = person.still.motion.skeleton.names
        H = body.height
        if posture == "standing":
            feet = [joints[names.index(n)] for n in ("LeftFoot", "RightFoot")]
            pivot, lever, segments = np.mean(feet, axis=0), 0.55 * H, None
        else:
            pivot = posture_pose["pelvis"][1]
            lever, segments = 0.3 * H, ("abdomen", "torso", "head", "left_upper_arm", "left_lower_arm",
                                        "right_upper_arm", "right_lower_arm")
        person.movements.append(PosturalSway(pivot, fwd, left, sway_rms, lever, seed=np.random.default_rng(
            [p["seed"], 2]), segments=segments))
    person.movements.append(chest_wall(vitals, body.forward, "torso"))
    return person, vitals


def _write_still(out, activity, posture, p):
    from ..mocap.library import ACKNOWLEDGEMENT, POSTURES
    from ..mocap.scene import write_people
    from .writer import look_at_orientation

    person, vitals = still_person(p, posture)
    r, c = person.posture["torso"][0], person.posture["torso"][1]
    centroid = r @ person._centroids()["torso"] + c
    normal = r @ person.body.forward
    if posture != "lying":
        normal[2] = 0.0
    normal /= np.linalg.norm(normal)
    radar = centroid + p["radar_distance"] * normal
    orientation = look_at_orientation(radar, centroid)
    box, opts, pieces = _room_box([(person, "")], radar, p)
    extra = {"activity": {"name": activity, "posture": posture,
                          "motion_source": f"posture: CMU clip {POSTURES[posture][0]} at {POSTURES[posture][1]} s; "
                                           "motion: parametric sway and chest-wall breathing and heartbeat",
                          "vital_signs": vitals.to_dict(), "sway_rms_m": p["sway_rms"],
                          "stature_m": person.body.height, "acknowledgement": ACKNOWLEDGEMENT}}
    write_people(out, [(person, "")], radar, orientation, p["skin_scattering"], box, opts, extra,
                 activities=[activity], furniture=pieces,
                 person_info=[{"height_m": person.body.height, "build": p["build"], "posture": posture,
                               "vital_signs": vitals.to_dict()}])


def _still_params(sway_default, radar_distance):
    return {**_PERSON, "radar_distance": Parameter(radar_distance, float, "m", "distance of the radar from the "
                                                   "thorax's centroid along the chest's outward normal",
                                                   low=0.3, high=20.0),
            "sway_rms": Parameter(sway_default, float, "m", "postural sway, RMS at the centre of mass (0: none)",
                                  low=0.0, high=0.05),
            **_VITALS, **_STILL_TIME, **_ROOM}


@register("stand_still", "A person standing still: postural sway, breathing and heartbeat (posture: CMU 90_18).",
          _still_params(SWAY_DEFAULT["standing"], 2.0))
def stand_still(out, **p):
    """Standing posture of CMU ``90_18`` at 0.2 s; sway about the ankles; chest-wall vital signs."""
    _write_still(out, "stand_still", "standing", p)


@register("vital_signs", "A still person (sitting, lying or standing) breathing, heart beating, for vital-sign "
          "radar (postures: CMU 111_10, 90_18).", {
              "posture": Parameter("sitting", str, "", "posture (lying: on the back on the floor, radar above)",
                                   choices=("sitting", "lying", "standing")),
              **_still_params(SWAY_DEFAULT["sitting"], 1.0)})
def vital_signs(out, posture, **p):
    """Breathing and heartbeat on the thorax (drawn per item with ``random_vitals``), a small sway."""
    _write_still(out, "vital_signs", posture, p)


__all__ = ["BOXING_POSTURE", "SWAY_DEFAULT", "WINDOWS", "boxing", "boxing_person", "fall", "jump", "jump_in_place", "jump_in_place_person", "jumping_jacks",
           "mocap_clip", "mocap_person", "pick_up", "run", "sit_down", "squat",
           "stand_still", "stand_up", "still_person", "vital_signs", "wave"]
