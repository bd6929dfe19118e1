r"""A BVH clip mirrored left for right: the same motion done with the other side of the body.

The mirror is the reflection :math:`\mathbf M = \mathrm{diag}(-1, 1, 1)` of the file's axes (its
:math:`x = 0` plane; the lateral axis of MotionBuilder / CMU files, whose T-pose holds the arms along
:math:`\pm x`), with every left joint swapped for its right counterpart. With world joint frames
:math:`(\mathbf R^W_j, \mathbf o^W_j)` of the clip, the mirrored clip has

.. math::
    \mathbf o'^W_{j} = \mathbf M\,\mathbf o^W_{\bar j}, \qquad
    \mathbf R'^W_{j} = \mathbf M\,\mathbf R^W_{\bar j}\,\mathbf M

(:math:`\bar j` the counterpart of :math:`j`, :math:`j` itself on the midline). It is a BVH clip of the
same hierarchy, because the reflection passes through the chain: :math:`\mathbf M` is its own inverse,
so :math:`\mathbf M\mathbf R_p\mathbf R_j\mathbf M = (\mathbf M\mathbf R_p\mathbf M)(\mathbf M\mathbf R_j
\mathbf M)` and :math:`\mathbf M(\mathbf o_p + \mathbf R_p\mathbf t_j) = \mathbf M\mathbf o_p +
(\mathbf M\mathbf R_p\mathbf M)\,\mathbf M\mathbf t_j`: offsets become :math:`\mathbf M\mathbf t_{\bar j}`,
local rotations :math:`\mathbf M\mathbf R_{\bar j}\mathbf M`. For one elementary rotation
:math:`\mathbf M\mathbf R_x(\theta)\mathbf M = \mathbf R_x(\theta)` and
:math:`\mathbf M\mathbf R_{y,z}(\theta)\mathbf M = \mathbf R_{y,z}(-\theta)`, so whatever the channel
order, a mirrored channel is ``Xposition`` negated, ``Xrotation`` kept, ``Yrotation`` and
``Zrotation`` negated, the other positions kept. The reflection keeps the handedness of rotations
(:math:`\det(\mathbf M\mathbf R\mathbf M) = 1`), so meshes built on the mirrored skeleton face outwards
as before: a mirrored person is a person, not a reflected mesh.

Counterparts are found by name: ``Left``/``Right`` anywhere in the name (``LeftArm``, ``RightUpLeg``), or
a leading ``L``/``R`` before a capital (``LHipJoint``, ``RThumb``); a joint whose counterpart is absent or
whose channels differ from it is its own. numpy only.
"""

from __future__ import annotations

import re

import numpy as np

from .bvh import BvhClip, Joint

#: The reflection of the file's axes (x -> -x).
MIRROR = np.diag([-1.0, 1.0, 1.0])
#: Sign of each channel under the reflection (module docstring).
CHANNEL_SIGN = {"Xposition": -1.0, "Yposition": 1.0, "Zposition": 1.0, "Xrotation": 1.0, "Yrotation": -1.0,
                "Zrotation": -1.0}


def counterpart(name: str) -> str:
    """The name of the joint on the other side (``LeftArm`` -> ``RightArm``, ``LThumb`` -> ``RThumb``);
    the name itself for a midline joint."""
    if "Left" in name:
        return name.replace("Left", "Right")
    if "Right" in name:
        return name.replace("Right", "Left")
    m = re.fullmatch(r"([LR])([A-Z].*)", name)
    if m:
        return ("R" if m.group(1) == "L" else "L") + m.group(2)
    return name


def mirrored(clip: BvhClip) -> BvhClip:
    """``clip`` mirrored left for right (module docstring): same joints in the same order, each one's
    offset, end site and channels taken from its counterpart and reflected."""
    index = {n: i for i, n in enumerate(clip.names)}
    slices = clip.channel_slices()
    joints, columns = [], []
    for j, joint in enumerate(clip.joints):
        k = index.get(counterpart(joint.name), j)
        other = clip.joints[k]
        if other.channels != joint.channels or (other.end_site is None) != (joint.end_site is None):
            k, other = j, joint
        joints.append(Joint(joint.name, joint.parent, MIRROR @ other.offset, joint.channels,
                            None if other.end_site is None else MIRROR @ other.end_site, joint.line,
                            list(joint.children)))
        sign = np.array([CHANNEL_SIGN[c] for c in other.channels])
        columns.append(clip.motion[:, slices[k]] * sign)
    motion = np.concatenate(columns, axis=1) if columns else clip.motion.copy()
    return BvhClip(joints, clip.frame_time, motion, None if clip.path is None else f"{clip.path} (mirrored)")


__all__ = ["CHANNEL_SIGN", "MIRROR", "counterpart", "mirrored"]
