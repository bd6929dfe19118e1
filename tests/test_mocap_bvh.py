r"""BVH files (``sionnafmcw.mocap.bvh``) and the forward kinematics of ``sionnafmcw.mocap.skeleton``.

* Bad files: each defect gets a :class:`BvhError` naming the file and the line, and saying what is
  wrong (unknown channel, wrong count of values on a motion line, missing MOTION, zero frame time,
  a joint declared twice, unbalanced braces, truncated motion).
* The shipped CMU clips: byte for byte the files of the clip README (sha256 prefixes), 96 channels,
  120 fps, and the parse agrees with Blender's importer on what a channel line means (tested through
  the routes in ``test_mocap_routes.py``).
* Euler convention: ``Zrotation Yrotation Xrotation`` values :math:`(a, b, c)` give
  :math:`\mathbf R_z(a)\mathbf R_y(b)\mathbf R_x(c)` (intrinsic, in the listed order), and a different
  order gives the product in that order; checked on a two-joint chain against matrices written out.
* Our gait as BVH: the Boulic-Thalmann walker's joints (hips, knees, ankles, shoulders, elbows,
  written with 6 decimals of metres and degrees) come back from the forward kinematics to 1e-6 m
  and 1e-6 in every rotation entry (the text's rounding, :math:`10^{-6}` deg = 1.7e-8 rad, times
  lever arms below 2 m, is far below that).
* Interpolation between frames: slerp turns at a constant rate about a fixed axis (exact for the
  spinning arm), and nlerp deviates from it by at most :math:`0.00401\,\delta^3` (:math:`\delta^3|g(u)|/4`).
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from sionnafmcw.mocap import library
from sionnafmcw.mocap.bvh import BvhError, bvh_text, parse_bvh, read_bvh, write_bvh
from sionnafmcw.mocap.skeleton import (CMU_UNIT, ClipMotion, Skeleton, axis_rotation, matrix_from_quat,
                                       nlerp_deviation, nlerp_slerp_bound, quat_from_matrix, rotation_angle, slerp)
from sionnafmcw.mocap.synthetic import gait_clip, spinning_arm_clip, zyx_angles

GOOD = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
\tJOINT Arm
\t{
\t\tOFFSET 1 0 0
\t\tCHANNELS 3 Zrotation Yrotation Xrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -2 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.0083333
0 1 0 0 0 0 0 0 0
0 1 0 0 0 0 90 0 0
"""


def _lines(text):
    return text.splitlines()


def _edit(line_no, new):
    lines = _lines(GOOD)
    lines[line_no - 1] = new
    return "\n".join(lines) + "\n"


def test_good_file_parses(tmp_path):
    clip = parse_bvh(GOOD, "good.bvh")
    assert clip.names == ["Hips", "Arm"] and clip.num_frames == 2 and clip.num_channels == 9
    assert clip.frame_time == pytest.approx(0.0083333) and clip.joints[1].parent == 0
    assert np.allclose(clip.joints[1].end_site, [0, -2, 0])
    path = write_bvh(tmp_path / "again.bvh", clip)
    again = read_bvh(path)
    assert again.names == clip.names and np.allclose(again.motion, clip.motion)
    # CRLF and CR line endings count lines the same way
    assert parse_bvh(GOOD.replace("\n", "\r\n")).num_frames == 2
    with pytest.raises(BvhError, match=r"crlf.bvh:6: unknown channel 'Wrotation'"):
        parse_bvh(_edit(6, "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Wrotation")
                  .replace("\n", "\r\n"), "crlf.bvh")


@pytest.mark.parametrize("line, new, match", [
    (5, "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Wrotation",
     r"bad.bvh:5: unknown channel 'Wrotation'; valid channels: Xposition"),
    (5, "\tCHANNELS 5 Xposition Yposition Zposition Zrotation Yrotation Xrotation",
     r"bad.bvh:5: CHANNELS 5 lists 6 channel names"),
    (5, "\tCHANNELS 3 Xrotation Xrotation Zrotation", r"bad.bvh:5: channel Xrotation is listed twice"),
    (18, "Frame Time: 0", r"bad.bvh:18: Frame Time: 0 s; the time between frames must be > 0"),
    (18, "Frame Time: -0.01", r"bad.bvh:18: Frame Time: -0.01 s"),
    (20, "0 1 0 0 0 0 90 0", r"bad.bvh:20: frame 1 has 8 values; the hierarchy declares 9 channels"),
    (19, "0 1 0 0 0 0 0 0 0 7", r"bad.bvh:19: frame 0 has 10 values"),
    (19, "0 1 0 0 0 0 zero 0 0", r"bad.bvh:19: frame 0: 'zero' is not a number"),
    (17, "Frames: 3", r"bad.bvh:20: only 2 motion lines for 'Frames: 3' \(line 17\)"),
    (17, "Frames: 1", r"bad.bvh:20: more motion lines than 'Frames: 1'"),
    (17, "Frames: 0", r"bad.bvh:17: Frames: 0; a clip needs at least one frame"),
    (16, "MOTIONS", r"bad.bvh:16: unexpected 'MOTIONS' in the hierarchy"),
    (6, "\tJOINT Hips", r"bad.bvh:6: joint 'Hips' is declared twice \(first at line 2\).*cycle"),
    (4, "\tOFFSET 0 0", r"bad.bvh:4: OFFSET needs 3 numbers, found 2"),
    (1, "HIERARCH", r"bad.bvh:1: expected HIERARCHY"),
    (3, "(", r"bad.bvh:3: expected '\{' to open the block of joint 'Hips'"),
    (15, "", r"bad.bvh:16: MOTION before the hierarchy's blocks are closed \(1 '\{' without '\}'\)"),
    (14, "\t}\n\t}", r"bad.bvh:16: '\}' closes no block \(unbalanced braces\)"),
])
def test_bad_files_name_the_line(line, new, match):
    with pytest.raises(BvhError, match=match):
        parse_bvh(_edit(line, new), "bad.bvh")


def test_missing_motion_and_empty_files(tmp_path):
    head = GOOD.split("MOTION")[0]
    with pytest.raises(BvhError, match=r"nomotion.bvh:15: no MOTION section after the hierarchy"):
        parse_bvh(head, "nomotion.bvh")
    with pytest.raises(BvhError, match=r"empty.bvh: the file is empty"):
        parse_bvh("\n\n", "empty.bvh")
    with pytest.raises(BvhError, match=r"missing.bvh: no such file"):
        read_bvh(tmp_path / "missing.bvh")
    with pytest.raises(BvhError, match=r"two.bvh:16: a second ROOT"):
        parse_bvh(head + head.split("\n", 1)[1], "two.bvh")


@pytest.mark.parametrize("name", sorted(library.CLIPS))
def test_shipped_clips(name):
    info = library.clip_info(name)
    assert hashlib.sha256(info.path.read_bytes()).hexdigest()[:16] == info.sha256_prefix
    clip = library.load_clip(name)
    assert clip.num_channels == 96 and len(clip.joints) == 31
    assert clip.fps == pytest.approx(120.0, rel=1e-5)
    assert clip.names[0] == "Hips" and clip.joints[0].channels[:3] == ("Xposition", "Yposition", "Zposition")
    assert (library.CLIP_DIR / "ACKNOWLEDGEMENT").read_text().startswith(library.ACKNOWLEDGEMENT.split(". ")[0])
    assert library.ACKNOWLEDGEMENT in (library.CLIP_DIR / "README.md").read_text().replace("\n", " ")


def test_euler_order_is_intrinsic_in_the_listed_order():
    """Joint ``Arm`` (channels Z Y X, then X Z Y) at (30, -20, 50) degrees against matrices written out."""
    a, b, c = np.radians([30.0, -20.0, 50.0])
    text = GOOD.replace("0 1 0 0 0 0 90 0 0", "0 1 0 0 0 0 30 -20 50")
    clip = parse_bvh(text)
    sk = Skeleton(clip)
    expected = axis_rotation(2, a) @ axis_rotation(1, b) @ axis_rotation(0, c)
    assert np.allclose(sk.local_rotations[1, 1], expected, atol=1e-12)
    assert np.allclose(zyx_angles(expected), [30.0, -20.0, 50.0])
    clip2 = parse_bvh(text.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 3 Xrotation Zrotation Yrotation"))
    sk2 = Skeleton(clip2)
    assert np.allclose(sk2.local_rotations[1, 1], axis_rotation(0, a) @ axis_rotation(2, b) @ axis_rotation(1, c))
    # world: the end site hangs 2 units below the arm joint; turned 30 deg about z (BVH axes) it swings to +x
    m = ClipMotion(clip, unit=1.0, axes=np.eye(3))
    rot, org = m.joint_frames([clip.frame_time])
    tip = org[0, 1] + rot[0, 1] @ clip.joints[1].end_site
    assert np.allclose(org[0, 1], [1.0, 1.0, 0.0])
    assert np.allclose(tip, org[0, 1] + expected @ [0.0, -2.0, 0.0])


def test_y_up_to_z_up_and_units():
    """A point at BVH (x, y, z) units lands at unit * (x, -z, y) in the world; rest frames are world-aligned."""
    clip = parse_bvh(GOOD)
    m = ClipMotion(clip, unit=CMU_UNIT)
    assert np.allclose(m.rest_positions()[1], [CMU_UNIT, 0.0, 0.0])
    rot, org = m.joint_frames([0.0])
    assert np.allclose(org[0, 0], [0.0, 0.0, CMU_UNIT])      # root at BVH y = 1
    assert np.allclose(rot[0, 1], np.eye(3))


def test_gait_clip_reproduces_the_analytic_walker(tmp_path):
    from sionnafmcw.scenes.walking import straight_person

    walker = straight_person(start_range=5.0, speed=1.4)
    clip = read_bvh(write_bvh(tmp_path / "gait.bvh", gait_clip(walker, 1.2)))
    m = ClipMotion(clip, unit=1.0)
    times = np.array([0.0, 0.2, 0.55, 1.1]) + 1 / 120   # on the clip's frames
    rot, org = m.joint_frames(times)
    pairs = (("pelvis", "Hips"), ("torso", "LowerBack"), ("left_upper_leg", "LeftUpLeg"),
             ("right_lower_leg", "RightLeg"), ("left_foot", "LeftFoot"), ("right_upper_arm", "RightArm"),
             ("left_lower_arm", "LeftForeArm"))
    for k, t in enumerate(times):
        poses = walker.poses(t)
        for seg, joint in pairs:
            j = clip.index(joint)
            assert np.allclose(org[k, j], poses[seg][1], atol=1e-6), (t, joint)
            assert np.allclose(rot[k, j], poses[seg][0], atol=1e-6), (t, joint)


def test_slerp_and_nlerp():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(200, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    assert np.allclose(matrix_from_quat(quat_from_matrix(matrix_from_quat(q))), matrix_from_quat(q), atol=1e-12)
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    for delta in (0.05, 0.2, 0.5):
        r1 = _axis_angle(axis, delta)
        q0, q1 = quat_from_matrix(np.eye(3)), quat_from_matrix(r1)
        worst = 0.0
        for u in np.linspace(0, 1, 41):
            s = matrix_from_quat(slerp(q0, q1, u))
            assert rotation_angle(s) == pytest.approx(u * delta, abs=1e-12)    # constant rate, fixed axis
            n = matrix_from_quat((1 - u) * q0 + u * q1)
            worst = max(worst, float(rotation_angle(n.T @ s)))
        assert worst <= nlerp_slerp_bound(delta) * 1.01
        assert worst >= nlerp_slerp_bound(delta) * 0.9                             # the bound is tight


def test_spinning_arm_turns_at_its_rate():
    rate = 2.0
    clip = parse_bvh(bvh_text(spinning_arm_clip(rate=rate, duration=1.0)))
    m = ClipMotion(clip, unit=1.0)
    t = np.array([0.1234, 0.5, 0.777])      # between frames: slerp of a uniform turn is the turn
    rot, org = m.joint_frames(t)
    j = clip.index("LeftArm")
    for k in range(t.size):
        assert np.allclose(rot[k, j], axis_rotation(2, rate * t[k]), atol=1e-9)
    hand = clip.index("LeftHand")
    arm_length = np.linalg.norm(org[0, hand] - org[0, j])
    assert arm_length == pytest.approx(0.55)
    assert math.atan2(*(org[1, hand] - org[1, j])[[1, 0]]) == pytest.approx(math.pi / 2 + rate * 0.5)


def _axis_angle(axis, angle):
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
