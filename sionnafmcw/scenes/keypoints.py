r"""Body keypoints: the joint positions pose-estimation data sets label, for every person a builder writes.

:data:`KEYPOINTS` (15 points, the body joints of COCO's and Human3.6M's 3-D skeletons that both of
the project's bodies have; no face points, no fingers or toes):

====================  =====================================================================================
keypoint              where (mocap body :mod:`sionnafmcw.mocap.segments` / walker :mod:`sionnafmcw.scenes.body`)
====================  =====================================================================================
``pelvis``            the root joint (CMU ``Hips``) / the spine origin :math:`O_s`, mid-point of the hip joints
``neck``              base of the neck (CMU ``Neck``) / mid-point of the shoulder joints
``head``              centroid of the head segment's surface (both bodies)
``{side}_shoulder``   CMU ``{Side}Arm`` / the shoulder joint
``{side}_elbow``      CMU ``{Side}ForeArm`` / the elbow joint
``{side}_wrist``      CMU ``{Side}Hand`` / the elbow plus the forearm's length along the forearm
``{side}_hip``        CMU ``{Side}UpLeg`` / the hip joint
``{side}_knee``       CMU ``{Side}Leg`` / the knee joint
``{side}_ankle``      CMU ``{Side}Foot`` / the ankle joint
====================  =====================================================================================

A keypoint is a point fixed in one body segment's frame, its *anchor* ``(segment, offset [3])``:
a joint's position is rigid in its parent joint's frame (BVH: :math:`\mathbf o_j = \mathbf o_p +
\mathbf R_p\mathbf t_j`), so joint :math:`j` is anchored to the segment hanging on :math:`j` (offset 0)
or, when none does (the wrist, the neck), to the segment hanging on its parent, at the rest offset
:math:`\mathbf o_j - \mathbf o_p` (the joint frames are world-aligned at rest,
:mod:`sionnafmcw.mocap.skeleton`). Its world position at time :math:`t` is
:math:`\mathbf R_s(t)\,\mathbf a + \mathbf p_s(t)` with the segment's pose -- the ``to_world`` of its
rigid object -- so keypoints follow whatever moves the segments (clip, sway, breathing). A keypoint
the skeleton has no joint for is NaN.
"""

from __future__ import annotations

import numpy as np

SIDES = ("left", "right")
#: Keypoint names, in the order of the run store's ``joint`` axis.
KEYPOINTS = ("pelvis", "neck", "head") + tuple(
    f"{side}_{part}" for side in SIDES for part in ("shoulder", "elbow", "wrist")) + tuple(
    f"{side}_{part}" for side in SIDES for part in ("hip", "knee", "ankle"))

#: Mocap keypoints at BVH joints (MotionBuilder / CMU names).
_MOCAP_JOINTS = {"pelvis": "Hips", "neck": "Neck", **{
    f"{s}_{k}": f"{S}{j}" for s, S in (("left", "Left"), ("right", "Right")) for k, j in (
        ("shoulder", "Arm"), ("elbow", "ForeArm"), ("wrist", "Hand"), ("hip", "UpLeg"), ("knee", "Leg"),
        ("ankle", "Foot"))}}


def segment_body_anchors(body) -> dict:
    """``{keypoint: (segment, offset [3])}`` of a :class:`~sionnafmcw.mocap.segments.SegmentBody` (module
    docstring); keypoints the skeleton cannot anchor are left out (NaN in :func:`keypoint_positions`)."""
    from ..mocap.segments import _find

    names = body.joint_names
    parents = body.motion.skeleton.parents
    on_joint = {s.joint: k for k, s in body.segments.items()}
    out = {}
    if "head" in body.segments:
        out["head"] = ("head", body.segments["head"].centroid)
    for key, joint_name in _MOCAP_JOINTS.items():
        if key == "pelvis" and "pelvis" in body.segments:
            out[key] = ("pelvis", np.zeros(3))
            continue
        j = _find(names, joint_name)
        if j is None:
            continue
        if j in on_joint:
            out[key] = (on_joint[j], np.zeros(3))
        elif parents[j] >= 0 and int(parents[j]) in on_joint:
            out[key] = (on_joint[int(parents[j])], body.rest[j] - body.rest[int(parents[j])])
    if "neck" not in out and "torso" in body.segments:   # no Neck joint: mid-point of the shoulders
        shoulders = [_find(names, n) for n in ("LeftArm", "RightArm")]
        if None not in shoulders:
            t = body.segments["torso"].joint
            out["neck"] = ("torso", 0.5 * (body.rest[shoulders[0]] + body.rest[shoulders[1]]) - body.rest[t])
    return out


def walker_anchors(person) -> dict:
    """``{keypoint: (segment, offset [3])}`` of a :class:`~sionnafmcw.scenes.body.WalkingPerson` (its
    segment frames, :meth:`~sionnafmcw.scenes.body.WalkingPerson.local_poses`)."""
    b = person.body
    out = {"pelvis": ("pelvis", np.zeros(3)), "neck": ("torso", np.array([0.0, 0.0, b.torso])),
           "head": ("head", np.asarray(person.local_centroids["head"], float))}
    for side in SIDES:
        out[f"{side}_shoulder"] = (f"{side}_upper_arm", np.zeros(3))
        out[f"{side}_elbow"] = (f"{side}_lower_arm", np.zeros(3))
        out[f"{side}_wrist"] = (f"{side}_lower_arm", np.array([0.0, 0.0, -b.forearm]))
        out[f"{side}_hip"] = (f"{side}_upper_leg", np.zeros(3))
        out[f"{side}_knee"] = (f"{side}_lower_leg", np.zeros(3))
        out[f"{side}_ankle"] = (f"{side}_foot", np.zeros(3))
    return out


def keypoint_positions(poses: dict, anchors: dict) -> np.ndarray:
    r"""World keypoints ``[T, K, 3]`` (m, :data:`KEYPOINTS` order) from segment ``poses``
    ``{segment: (rotations [T, 3, 3], translations [T, 3])}``: :math:`\mathbf R_s\mathbf a + \mathbf p_s`;
    NaN where ``anchors`` has no entry."""
    num = len(next(iter(poses.values()))[1])
    out = np.full((num, len(KEYPOINTS), 3), np.nan)
    for k, key in enumerate(KEYPOINTS):
        if key in anchors:
            seg, offset = anchors[key]
            rot, trans = poses[seg]
            out[:, k] = np.einsum("tab,b->ta", rot, np.asarray(offset, float)) + trans
    return out


__all__ = ["KEYPOINTS", "keypoint_positions", "segment_body_anchors", "walker_anchors"]
