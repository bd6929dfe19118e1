r"""RadHAR's five activities on the mocap body (``sionnafmcw.scenes.radhar``, ``jumping_jacks``, ``squat``,
``boxing``) and the mirror of a clip.

* Every class builds in the radar's frame: the person's start point (a walk's middle) at the range and
  azimuth asked, the manifest labelled with the class; a user's BVH file plays for any class; a walk
  that would run into the radar is an error. A walk on a loop: its pelvis circles ``walk_radius`` (a
  least-squares circle, to the walker's lateral sway :math:`a_l` = 3.2 cm) at ``walk_speed`` (the angle
  swept times the radius, to 2 %: the sway moves each end's angle by up to :math:`a_l/R` = 0.04 rad, 1.2 %
  of the 6.7 rad swept in 9 s at 0.6 m/s on 0.8 m), anticlockwise seen from above unless mirrored, and
  heads along ``walk_direction`` at the middle frame (to 5 degrees: twice the sway's
  :math:`a_l/R` = 2.3 degrees of position angle).
* Jumping jacks: the hands rise above the head once per jack, and a jack is two hops (feet apart, feet
  together), so the wrists' period is twice the pelvis's; the playback rate divides both.
* Squats: two of them, each a deep squat: at the bottom the hip joint is no higher than the knee (the
  thigh at or below horizontal), so the pelvis drops by at least the thigh's length times its sine, and
  at least by half of it.
* Boxing: the fists' tips (the hand's far end, straight along the forearm) peak at ``fist_speed`` (the
  minimum-jerk stroke's peak :math:`15D/(8T)`; the slerp between the keyframes at 480 per s and the
  960 fps differences leave < 0.5 %, measured to converge as :math:`h^2`), no vertex of the forearm and
  hand moves faster (to 1.5 %: between keyframes the slerped arcs run up to 0.65 % faster than the
  chords, measured), the wrist moves slower; the punches alternate sides, every fist reaches ``REACH``
  of its arm.
* Jumps in place: in flight the pelvis falls freely (its second difference is :math:`-g` to 1e-5 m/s^2:
  at 240 fps every frame falls on a keyframe, where the root's height is the ballistic formula's), rises ``jump_height`` above standing, and the feet leave the floor for
  :math:`2\sqrt{2h/g}`; on the floor the ankles do not move.
* Mirror: joint :math:`j` of the mirrored clip is at :math:`\mathbf M\mathbf o_{\bar j}` of the original
  (:math:`\mathbf M` = diag(-1, 1, 1), BVH axes), its world rotation :math:`\mathbf M\mathbf R_{\bar j}\mathbf M`.
"""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from sionnafmcw import load_animation, scenes
from sionnafmcw.mocap import library
from sionnafmcw.mocap.mirror import MIRROR, counterpart, mirrored
from sionnafmcw.mocap.punches import FIST_SPEED_RANGE, REACH
from sionnafmcw.mocap.skeleton import ClipMotion
from sionnafmcw.mocap.jumps import G
from sionnafmcw.scenes.activities import boxing_person, jump_in_place_person, mocap_person
from sionnafmcw.scenes.keypoints import KEYPOINTS
from sionnafmcw.scenes.radhar import CLASSES

K = KEYPOINTS.index


def _params(name, **over):
    return {**{k: v.default for k, v in scenes.parameters(name).items()}, "body_mesh_edge": 0.06, **over}


def _period(signal, fps) -> float:
    """The period (s) of ``signal``: the lag of the autocorrelation's highest peak after its first zero."""
    x = signal - signal.mean()
    ac = np.correlate(x, x, "full")[x.size - 1:]
    first_zero = int(np.argmax(ac < 0))
    lag = first_zero + int(np.argmax(ac[first_zero:x.size // 2]))
    # parabolic refinement of the peak
    a, b, c = ac[lag - 1], ac[lag], ac[lag + 1]
    return (lag + 0.5 * (a - c) / (a - 2 * b + c)) / fps


@pytest.mark.parametrize("activity", CLASSES)
def test_every_radhar_class_builds_in_the_radars_frame(tmp_path, activity):
    r, phi = 2.5, 0.3
    n = 5
    out = scenes.build("radhar", tmp_path / activity, activity=activity, num_frames=n, body_mesh_edge=0.06,
                       person_range=r, person_azimuth=phi, room=False)
    manifest = json.loads((out / "animation.json").read_text())
    assert manifest["activity"]["name"] == activity
    person = manifest["people"]["persons"][0]
    assert person["activity"] == activity
    assert np.allclose(manifest["radar"]["position"], [0.0, 0.0, 1.0])
    pelvis = np.asarray(person["keypoints"])[:, K("pelvis"), :2]
    if activity == "walk":      # the walk's middle at (r, phi), heading toward the radar there
        assert np.allclose(pelvis[n // 2], [r * math.cos(phi), r * math.sin(phi)], atol=1e-5)
        assert person["heading"] == pytest.approx(phi + math.pi)
    else:                       # the root starts over its ground point, facing the radar
        assert np.allclose(person["start"], [r * math.cos(phi), r * math.sin(phi)])
        assert np.allclose(pelvis[0], person["start"], atol=1e-5)
        assert person["heading"] == pytest.approx(phi + math.pi)
    load_animation(out).check_frequency(77e9)


def test_a_user_bvh_plays_for_any_class(tmp_path):
    path = tmp_path / "my_squat.bvh"
    shutil.copy(library.clip_info("13_29_squats").path, path)
    out = scenes.build("radhar", tmp_path / "s", activity="boxing", bvh=str(path), num_frames=2,
                       body_mesh_edge=0.06, room=False)
    manifest = json.loads((out / "animation.json").read_text())
    assert manifest["activity"]["name"] == "boxing" and "my_squat.bvh" in manifest["activity"]["motion_source"]
    with pytest.raises(ValueError, match="bvh="):
        scenes.build("radhar", tmp_path / "t", bvh=str(tmp_path / "none.bvh"), num_frames=2, room=False)
    with pytest.raises(ValueError, match=r"the walk passes 0\.\d\d m from the radar"):
        scenes.build("radhar", tmp_path / "w", activity="walk", person_range=0.5, heading_offset=math.pi / 2,
                     num_frames=60, room=False, body_mesh_edge=0.06)


@pytest.mark.parametrize("direction, mirror", [("toward", False), ("left", True), ("away", True), ("right", False)])
def test_a_walk_on_a_loop_circles_its_radius_at_its_speed(direction, mirror):
    from sionnafmcw.scenes.radhar import _WALK_HEADING, radhar_person

    radius, speed, fps, n, phi = 0.8, 0.6, 30.0, 271, 0.2      # 9 s: more than a loop (8.4 s)
    person, info = radhar_person(_params("radhar", activity="walk", walk_radius=radius, walk_speed=speed,
                                         walk_direction=direction, mirror=mirror, num_frames=n, fps=fps,
                                         person_range=2.5, person_azimuth=phi))
    xy = person.keypoints()[:, K("pelvis"), :2]
    # least-squares circle: x^2 + y^2 = 2 a x + 2 b y + c
    A = np.column_stack([2 * xy, np.ones(n)])
    a, b, c = np.linalg.lstsq(A, (xy ** 2).sum(1), rcond=None)[0]
    fitted = math.sqrt(c + a * a + b * b)
    assert fitted == pytest.approx(radius, abs=0.032)
    angle = np.unwrap(np.arctan2(xy[:, 1] - b, xy[:, 0] - a))
    swept = angle[-1] - angle[0]
    assert abs(swept) * radius / ((n - 1) / fps) == pytest.approx(speed, rel=0.02)
    assert (swept < 0) == mirror                                # clockwise when mirrored
    tangent = np.sign(swept) * np.array([-(xy[n // 2, 1] - b), xy[n // 2, 0] - a])
    heading = math.atan2(tangent[1], tangent[0])
    want = phi + _WALK_HEADING[direction]
    assert abs(math.remainder(heading - want, 2 * math.pi)) < math.radians(5)
    assert np.allclose(xy[n // 2], [2.5 * math.cos(phi), 2.5 * math.sin(phi)], atol=1e-5)


@pytest.mark.parametrize("rate", [1.0, 1.5])
def test_jumping_jacks_hands_above_the_head_once_per_two_hops(rate):
    fps = 60.0
    person = mocap_person("13_29_jacks", _params("jumping_jacks", fps=fps, playback_rate=rate))
    kp = person.keypoints()
    hands = np.maximum(kp[:, K("left_wrist"), 2], kp[:, K("right_wrist"), 2]) - kp[:, K("head"), 2]
    pelvis = kp[:, K("pelvis"), 2]
    t_hands, t_pelvis = _period(hands, fps), _period(pelvis, fps)
    assert t_hands == pytest.approx(2 * t_pelvis, abs=2.0 / fps)            # two frames of the two estimates
    assert t_pelvis * rate == pytest.approx(0.55, abs=2.0 / fps * rate)   # the README's root peaks: 66 frames at 120 fps
    above = hands > 0.0
    rises = np.flatnonzero(above[1:] & ~above[:-1])
    assert len(rises) >= 3                                                # above the head and back, again and again
    assert np.diff(rises).mean() / fps == pytest.approx(t_hands, abs=2.0 / fps)


def test_squats_drop_the_pelvis_twice_below_the_knees():
    person = mocap_person("13_29_squats", _params("squat"))
    kp = person.keypoints()
    pelvis = kp[:, K("pelvis"), 2]
    thigh = np.linalg.norm(kp[0, K("left_hip")] - kp[0, K("left_knee")])
    mid = 0.5 * (pelvis.max() + pelvis.min())
    below = pelvis < mid
    assert np.count_nonzero(below[1:] & ~below[:-1]) == 2                  # two squats
    low = int(np.argmin(pelvis))
    for side in ("left", "right"):
        assert kp[low, K(f"{side}_hip"), 2] <= kp[low, K(f"{side}_knee"), 2]     # thigh at or below horizontal
    assert pelvis[0] - pelvis[low] >= 0.5 * thigh


def test_boxing_fists_peak_at_the_measured_speed():
    from sionnafmcw.mocap.anatomy import WINTER

    fps = 960.0
    speed = 7.2
    p = _params("boxing", fps=fps, num_frames=int(2.0 * fps), fist_speed=speed)
    person, punches = boxing_person(p)
    kp = person.keypoints()
    assert FIST_SPEED_RANGE[0] <= speed <= FIST_SPEED_RANGE[1]
    assert punches.sides[:4] == ["left", "right", "left", "right"]
    hand = WINTER["hand"] * p["person_height"]
    for side in ("left", "right"):
        wrist, elbow, shoulder = (kp[:, K(f"{side}_{j}")] for j in ("wrist", "elbow", "shoulder"))
        forearm = wrist - elbow
        tip = wrist + hand * forearm / np.linalg.norm(forearm, axis=1, keepdims=True)   # the fist's tip
        v_tip = np.linalg.norm(np.diff(tip, axis=0), axis=1) * fps
        v_wrist = np.linalg.norm(np.diff(wrist, axis=0), axis=1) * fps
        assert v_tip.max() == pytest.approx(speed, rel=0.005)
        assert v_wrist.max() < v_tip.max()
        arm = np.linalg.norm(shoulder[0] - elbow[0]) + np.linalg.norm(forearm[0]) + hand
        assert np.linalg.norm(tip - shoulder, axis=1).max() == pytest.approx(REACH * arm, rel=0.01)
        # no surface of the arm moves faster than the fist's tip (around its fastest instant)
        k = int(np.argmax(v_tip))
        seg = f"{side}_lower_arm"
        verts = np.array([person.world_vertices(i)[seg] for i in range(k - 3, k + 5)])
        v_mesh = np.linalg.norm(np.diff(verts, axis=0), axis=2).max(axis=1) * fps
        assert v_mesh.max() <= speed * 1.015        # the slerped arcs between keyframes: 0.65 % measured
    with pytest.raises(ValueError, match="fist_speed"):
        boxing_person(_params("boxing", fist_speed=20.0))


def test_jumps_in_place_fly_ballistically():
    fps, h = 240.0, 0.2
    person = jump_in_place_person(_params("jump_in_place", fps=fps, num_frames=int(3.0 * fps), jump_height=h))
    kp = person.keypoints().astype(float)
    pelvis = kp[:, K("pelvis"), 2]
    ankles = kp[:, [K("left_ankle"), K("right_ankle")], 2]
    standing = pelvis[0]
    assert pelvis.max() - standing == pytest.approx(h, abs=1e-3)            # apex: the frame grid within 1 mm
    air = ankles.min(axis=1) > ankles[0].min() + 1e-6
    rises = np.flatnonzero(air[1:] & ~air[:-1])
    falls = np.flatnonzero(~air[1:] & air[:-1])
    assert len(rises) == len(falls) == 2                                   # two jumps in 3 s at 0.75/s
    flight = 2 * math.sqrt(2 * h / G)
    for a, b in zip(rises, falls):
        assert (b - a) / fps == pytest.approx(flight, abs=1.5 / fps)        # a frame at each end
        acc = np.diff(pelvis[a + 2:b - 1], 2) * fps**2
        assert np.allclose(acc, -G, rtol=0, atol=1e-5)                     # 240 fps falls on the keyframes
    ground = ~air
    assert np.ptp(ankles[ground], axis=0).max() < 1e-6                     # feet flat and still on the floor


def test_mirror_reflects_the_skeleton_left_for_right():
    clip = library.load_clip("13_29_jacks")
    mir = mirrored(clip)
    times = np.array([0.1, 0.5, 1.3])
    rot, org = ClipMotion(clip, unit=1.0, axes=np.eye(3)).joint_frames(times)
    rot_m, org_m = ClipMotion(mir, unit=1.0, axes=np.eye(3)).joint_frames(times)
    for j, name in enumerate(clip.names):
        k = clip.names.index(counterpart(name)) if counterpart(name) in clip.names else j
        assert np.allclose(org_m[:, j], org[:, k] @ MIRROR, atol=1e-9), name
        assert np.allclose(rot_m[:, j], MIRROR @ rot[:, k] @ MIRROR, atol=1e-9), name
    assert counterpart("LHipJoint") == "RHipJoint" and counterpart("Spine") == "Spine"
    # a mirrored person's left wrist does what the right one did, on the other side of the body
    p = _params("jumping_jacks", num_frames=20)
    a, b = mocap_person("13_29_jacks", p).keypoints(), mocap_person("13_29_jacks", {**p, "mirror": True}).keypoints()
    assert np.allclose(a[:, K("right_wrist"), 2], b[:, K("left_wrist"), 2], atol=1e-3)


def _boxer(fps, seconds, **over):
    p = _params("boxing", fps=fps, num_frames=int(seconds * fps), **over)
    person, punches = boxing_person(p)
    return p, person, punches


def test_boxing_thorax_turns_rigidly_toward_each_punch():
    """The shoulders and the neck ride on the thorax: the horizontal vector from the neck to a shoulder turns by
    the thorax's axial rotation :math:`\\psi_t(t)` of the punch schedule, and moves at :math:`r\\dot\\psi_t`
    (:math:`r` its horizontal length, closed form of a rigid turn about the vertical); a cross turns the trunk
    toward the punching side, at a peak rate of several hundred deg/s."""
    fps = 960.0
    p, person, punches = _boxer(fps, 2.0, fist_speed=7.2)
    kp = person.keypoints()
    t = np.arange(len(kp)) / fps
    psi = punches.thorax_rotation(t)
    rate = np.gradient(psi, t)
    assert 200.0 < np.degrees(np.abs(rate).max()) < 1000.0          # "several hundred deg/s"
    for side in ("left", "right"):
        d = kp[:, K(f"{side}_shoulder")] - kp[:, K("neck")]
        angle = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
        # the scene's z is up and the person faces the radar (a turn toward the left is + about z, as in BVH)
        np.testing.assert_allclose(angle - angle[0], psi - psi[0], atol=1e-3)
        # on the keyframes (every other frame at 960 fps; between them the clip is slerped at constant rate)
        dk, tk = d[::2], t[::2]
        speed = np.linalg.norm(np.diff(dk, axis=0), axis=1) / np.diff(tk)
        r = np.linalg.norm(dk[:, :2], axis=1)
        mid = 0.5 * (tk[1:] + tk[:-1])
        mid_rate = (punches.thorax_rotation(mid + 1e-6) - punches.thorax_rotation(mid - 1e-6)) / 2e-6
        fast = np.abs(mid_rate) > 0.5 * np.abs(rate).max()
        np.testing.assert_allclose(speed[fast], (r[1:] * np.abs(mid_rate))[fast], rtol=0.01)
    crosses = [k for k, s in enumerate(punches.sides) if s == "right"]
    assert all(punches.thorax[k] > 0 for k in crosses) and all(punches.thorax[k] < 0 for k in range(len(punches.sides))
                                                                if k not in crosses)


def test_boxing_pelvis_bounces_and_the_skeleton_stays_connected():
    """The pelvis's height is the stance bounce :math:`-\\tfrac{b}{2}(1 - \\cos 2\\pi f_b t)` (the trunk's turn is
    about the vertical, the weight shift horizontal); bones keep their lengths and the feet stay planted."""
    from sionnafmcw.mocap.punches import bounce_height

    fps = 960.0
    p, person, punches = _boxer(fps, 2.0)
    kp = person.keypoints()
    t = np.arange(len(kp)) / fps
    z = kp[:, K("pelvis"), 2]
    np.testing.assert_allclose(z - z[0], bounce_height(t, p["bounce"], p["bounce_rate"]), atol=1e-5)
    assert np.ptp(z) == pytest.approx(p["bounce"], rel=0.01)
    bones = [("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"), ("right_shoulder", "right_elbow"),
             ("right_elbow", "right_wrist"), ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
             ("right_hip", "right_knee"), ("right_knee", "right_ankle"), ("pelvis", "left_hip"),
             ("pelvis", "right_hip"), ("neck", "left_shoulder"), ("neck", "right_shoulder"), ("neck", "head")]
    for a, b in bones:
        length = np.linalg.norm(kp[:, K(a)] - kp[:, K(b)], axis=1)
        np.testing.assert_allclose(length, length[0], rtol=1e-6, err_msg=f"{a}-{b}")
    for side in ("left", "right"):
        ankle = kp[:, K(f"{side}_ankle")]
        # on the keyframes (every other frame) exactly; the slerp between them strays by micrometres
        np.testing.assert_allclose(ankle[::2], np.broadcast_to(ankle[0], ankle[::2].shape), atol=1e-9)
        np.testing.assert_allclose(ankle, np.broadcast_to(ankle[0], ankle.shape), atol=1e-4)


def test_boxing_trunk_moves_a_doppler_bin_and_no_faster_than_its_turn_allows():
    """The trunk's segments (pelvis, abdomen, thorax) reach a radial speed of at least one Doppler bin of RadHAR's
    IWR1443 .cfg towards a radar in front of the boxer, and no vertex of them moves faster than a rigid chain of
    vertical-axis turns allows: :math:`|\\mathbf v| \\le |\\mathbf v_{\\rm pelvis}| + \\omega_{\\max}(r + 2\\sum_k
    a_k)`, :math:`r` the vertex's horizontal distance from the pelvis joint, :math:`a_k` the horizontal lengths of
    the spine's links (triangle inequality), :math:`\\omega_{\\max}` the fastest turn of the pelvis or thorax."""
    from sionnafmcw.mocap.keyframes import HeldPosture
    from sionnafmcw.mocap.library import load_clip
    from sionnafmcw.mocap.punches import SPINE
    from sionnafmcw.mocap.segments import leg_stature
    from sionnafmcw.mocap.skeleton import CMU_UNIT
    from sionnafmcw.scenes.activities import BOXING_POSTURE

    fps = 240.0
    p, person, punches = _boxer(fps, 1.2)
    base = load_clip(BOXING_POSTURE[0])
    unit = CMU_UNIT * p["person_height"] / leg_stature(ClipMotion(base, CMU_UNIT))
    pose = HeldPosture(base, BOXING_POSTURE[1], 1)
    chain = [pose.world_origins[0]] + [pose.world_origins[pose.joint(n)] for n, _ in SPINE]
    links = sum(np.hypot(*(b - a)[[0, 2]]) for a, b in zip(chain[:-1], chain[1:])) * unit
    tt = np.arange(0.0, 1.2, 1e-4)
    omega = max(np.abs(np.gradient(punches.thorax_rotation(tt), tt)).max(),
                np.abs(np.gradient(punches.pelvis_rotation(tt), tt)).max())
    frames = np.arange(int(1.2 * fps) - 1)
    verts = [person.world_vertices(i) for i in frames]
    pelvis = person.keypoints(frames)[:, K("pelvis")]
    v_pelvis = np.linalg.norm(np.diff(pelvis, axis=0), axis=1).max() * fps
    radar = np.array([p["x"] + p["radar_distance"], p["y"], p["radar_height"]])    # in front (heading 0: +x)
    # RadHAR's .cfg: chirps of 7 us idle + 57.14 us ramp at 77 GHz, 16 loops of 3 Tx (design notes, section 8)
    bin_v = 299792458.0 / (2 * 77e9 * 16 * 3 * 64.14e-6)
    for seg in ("pelvis", "abdomen", "torso"):
        x = np.array([v[seg] for v in verts])                                  # [frame, vertex, 3]
        rng = np.linalg.norm(x - radar, axis=2)
        v_r = np.abs(np.diff(rng, axis=0)) * fps
        speed = np.linalg.norm(np.diff(x, axis=0), axis=2) * fps
        r = np.linalg.norm((x - pelvis[:, None])[..., :2], axis=2).max()
        assert v_r.max() >= bin_v, seg
        assert speed.max() <= v_pelvis + omega * (r + 2 * links), seg
