r"""Shadow boxing on a captured skeleton: straight punches by inverse kinematics of the arms.

No motion-capture clip of boxing ships with the project, so the activity is animated from joint
keyframes on a captured skeleton (:func:`boxing_clip`): the body holds a captured standing posture,
the fists start in a guard and alternate straight punches (lead hand first), each fist travelling on
a straight line from the guard to full reach and back. The arms follow the fists by analytic
two-link inverse kinematics; nothing else moves (no footwork, no trunk rotation: the radar sees the
arms' micro-Doppler on a still trunk, an under-estimate of a boxer's trunk motion).

Fist path
---------
A punch of the wrist from the guard :math:`\mathbf g` to the target :math:`\mathbf p`
(distance :math:`D`) follows the minimum-jerk profile of aimed arm movements (Flash & Hogan 1985,
J. Neurosci. 5(7):1688-1703), :math:`\mathbf x(t) = \mathbf g + (\mathbf p - \mathbf g)\,f(t/T)`,
:math:`f(s) = 10s^3 - 15s^4 + 6s^5`, whose speed peaks at mid-stroke:

.. math::
    v_{\max} = \frac{D}{T}\,f'(1/2) = \frac{15}{8}\frac{D}{T}
    \quad\Rightarrow\quad T = \frac{15}{8}\frac{D}{v_{\max}}.

The extension time :math:`T` follows from the peak fist speed ``fist_speed``; the retraction takes
``retraction_ratio`` :math:`\times T` on the same profile. Measured peak fist speeds of straight
punches: lead straight (jab) 6.32 +/- 0.42 m/s for junior and 7.16 +/- 0.48 m/s for elite boxers (Liu
et al. 2022, Front. Physiol. 13:1015154, Vicon at the fist); contact speeds of competition-standard
boxers 9.26 +/- 2.09 m/s for single maximal punches, 7.49-8.01 +/- 2.3-2.5 m/s in combinations
(Piorkowski, Lees & Barton 2011, Sports Biomech. 10(1):1-11). :data:`FIST_SPEED_RANGE` spans them:
3 m/s (a combination punch two standard deviations below the mean: relaxed shadow boxing) to 11 m/s
(a single maximal punch one standard deviation above).

Geometry (BVH axes, file units)
-------------------------------
With the shoulder :math:`\mathbf s` (joint ``{Side}Arm``), the upper arm :math:`L_1` and forearm
:math:`L_2` (the offsets of ``{Side}ForeArm`` and ``{Side}Hand``), the body's up :math:`\hat{\mathbf u}`
(+y), left :math:`\hat{\mathbf l}` (right shoulder to left, horizontal) and forward
:math:`\hat{\mathbf f} = \hat{\mathbf l}\times\hat{\mathbf u}`:

* guard: :math:`\mathbf g = \mathbf s + L(0.30\,\hat{\mathbf f} + 0.08\,\hat{\mathbf u}) - 0.3\,w\,\sigma\hat{\mathbf l}`
  (:math:`L = L_1 + L_2`, :math:`w` half the shoulder width, :math:`\sigma` = +1 left, -1 right): fists
  in front of the chin;
* target: the point straight ahead of the mid-shoulders, :math:`\mathbf c + \sqrt{(rL)^2 - w^2}\,
  \hat{\mathbf f}`, at :math:`rL` from the shoulder (reach :math:`r` = 0.92: an almost straight elbow);
* inverse kinematics: the elbow :math:`\mathbf e` lies in the plane of the shoulder, the wrist
  :math:`\mathbf x` and the pole :math:`-\hat{\mathbf u} - 0.6\hat{\mathbf f} + 0.3\sigma\hat{\mathbf l}`
  (elbow down, back under the fist in the guard, and out), :math:`\angle(\mathbf e - \mathbf s, \mathbf x - \mathbf s) = \arccos\frac{L_1^2 + d^2 -
  L_2^2}{2L_1d}`, :math:`d = |\mathbf x - \mathbf s|`; each bone's world rotation is its posture's turned
  by the shortest rotation that takes the bone onto its new direction, and the joints' local rotations
  follow, :math:`\mathbf R_j = (\mathbf R^W_p)^T\mathbf R^W_j`, written as the clip's ``Z Y X``
  channels, 480 keyframes a second: between keyframes the clip is slerped, which bends the fist's line
  into arcs; the peak speed it reads is then high by 1.8 % at 120 keyframes a second, 0.8 % at 240 and
  0.3 % at 480 (measured at 6.3 m/s; the excess falls as the square of the keyframe interval).
"""

from __future__ import annotations

import math

import numpy as np

from .bvh import BvhClip, Joint
from .skeleton import Skeleton
from .synthetic import zyx_angles

#: Physical range of the peak fist speed of a straight punch (m/s; module docstring).
FIST_SPEED_RANGE = (3.0, 11.0)
#: Peak fist speed of a junior boxer's lead straight punch (Liu et al. 2022), m/s: the default.
FIST_SPEED = 6.3
#: Reach of a punch as a fraction of the arm's length (shoulder to wrist).
REACH = 0.92
_ZYX = ("Zrotation", "Yrotation", "Xrotation")


def minimum_jerk(s):
    r"""Minimum-jerk profile :math:`f(s) = 10s^3 - 15s^4 + 6s^5` on :math:`s \in [0, 1]` (clipped outside)."""
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def _rotation_between(a, b):
    """Shortest rotations ``[N, 3, 3]`` taking unit vectors ``a`` [N, 3] onto ``b`` [N, 3] (Rodrigues)."""
    v = np.cross(a, b)
    c = np.einsum("na,na->n", a, b)
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 0] = -v[:, 2], v[:, 1], v[:, 2]
    k[:, 1, 2], k[:, 2, 0], k[:, 2, 1] = -v[:, 0], -v[:, 1], v[:, 0]
    return np.eye(3) + k + np.einsum("nab,nbc->nac", k, k) / (1.0 + c)[:, None, None]


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _needs_zyx(clip: BvhClip, names) -> None:
    for n in names:
        if tuple(clip.joints[clip.index(n)].channels) != _ZYX:
            raise ValueError(f"{clip.path or 'BVH clip'}: joint {n} needs the channels Zrotation Yrotation Xrotation "
                             "(MotionBuilder / CMU layout) to be keyframed")


class Punches:
    """The punch schedule: per punch its ``side`` ('left' or 'right'), ``start`` (s), extension ``T``
    and retraction times (s). Built by :func:`boxing_clip`."""

    def __init__(self, sides, starts, extension, retraction):
        self.sides = list(sides)
        self.starts = np.asarray(starts, float)
        self.extension = np.asarray(extension, float)
        self.retraction = np.asarray(retraction, float)

    def stroke(self, side: str, times) -> np.ndarray:
        """Fraction ``[T]`` of the way from guard to target of the ``side`` fist at clip ``times``."""
        times = np.asarray(times, float)
        out = np.zeros(times.shape)
        for sd, t0, te, tr in zip(self.sides, self.starts, self.extension, self.retraction):
            if sd != side:
                continue
            out += minimum_jerk((times - t0) / te) - minimum_jerk((times - t0 - te) / tr)
        return out

    def to_dict(self) -> list:
        return [{"side": s, "start_s": float(a), "extension_s": float(e), "retraction_s": float(r)}
                for s, a, e, r in zip(self.sides, self.starts, self.extension, self.retraction)]


def boxing_clip(base: BvhClip, base_time: float, unit: float, duration: float, fist_speed: float = FIST_SPEED,
                punch_rate: float = 2.0, retraction_ratio: float = 1.5, lead: str = "left", seed: int = 0,
                frame_rate: float = 480.0) -> tuple[BvhClip, Punches]:
    r"""Shadow boxing (module docstring) on the posture of ``base`` at clip time ``base_time``.

    ``unit`` (m per file unit) turns ``fist_speed`` (m/s, peak) into the clip's units; punches come
    ``1/punch_rate`` s apart on average (each start jittered uniformly by +-20 % of that), alternating
    sides from ``lead``; ``seed`` draws the jitter. Returns the clip (``duration`` s at ``frame_rate``
    frames per second; frame 0 is a frame of the motion, not a T-pose) and its :class:`Punches`.
    """
    lo, hi = FIST_SPEED_RANGE
    if not lo <= fist_speed <= hi:
        raise ValueError(f"fist_speed={fist_speed} m/s is outside the measured range {lo}-{hi} m/s of straight "
                         "punches (sionnafmcw.mocap.punches)")
    if lead not in ("left", "right"):
        raise ValueError(f"lead={lead!r}: choose 'left' (orthodox) or 'right' (southpaw)")
    if not (punch_rate > 0 and duration > 0 and retraction_ratio > 0):
        raise ValueError("boxing_clip: punch_rate, duration and retraction_ratio must be > 0")
    sides = {"left": "Left", "right": "Right"}
    names = [f"{S}{j}" for S in sides.values() for j in ("Arm", "ForeArm", "Hand")]
    _needs_zyx(base, [n for n in names if not n.endswith("Hand")])
    k = int(round(base_time / base.frame_time))
    if not 0 <= k < base.num_frames:
        raise ValueError(f"base_time={base_time} s is outside the clip {base.path or ''} (0..{base.duration:.3f} s)")
    n = int(math.floor(duration * frame_rate + 1e-9)) + 1
    times = np.arange(n) / frame_rate
    motion = np.repeat(base.motion[k:k + 1], n, axis=0)
    still = BvhClip(base.joints, 1.0 / frame_rate, motion, base.path)
    sk = Skeleton(still)
    rw, ow = sk.forward(sk.local_rotations[:1], sk.local_translations[:1])
    rw, ow = rw[0], ow[0]
    idx = {nm: still.index(nm) for nm in names}
    up = np.array([0.0, 1.0, 0.0])
    left = ow[idx["LeftArm"]] - ow[idx["RightArm"]]
    left[1] = 0.0
    half_width = 0.5 * np.linalg.norm(left)
    left = left / np.linalg.norm(left)
    fwd = np.cross(left, up)
    centre = 0.5 * (ow[idx["LeftArm"]] + ow[idx["RightArm"]])
    slices = still.channel_slices()

    rng = np.random.default_rng(seed)
    period = 1.0 / punch_rate
    geometry = {}
    for side, S in sides.items():
        s = ow[idx[f"{S}Arm"]]
        l1 = np.linalg.norm(still.joints[idx[f"{S}ForeArm"]].offset)
        l2 = np.linalg.norm(still.joints[idx[f"{S}Hand"]].offset)
        sigma = 1.0 if side == "left" else -1.0
        reach = REACH * (l1 + l2)
        guard = s + (l1 + l2) * (0.30 * fwd + 0.08 * up) - 0.3 * half_width * sigma * left
        target = centre + math.sqrt(max(reach**2 - half_width**2, 0.0)) * fwd
        geometry[side] = (s, l1, l2, sigma, guard, target)
    order = [lead, "right" if lead == "left" else "left"]
    starts, sds, ext, ret = [], [], [], []
    t = 0.25 * period
    i = 0
    while True:
        side = order[i % 2]
        _, _, _, _, guard, target = geometry[side]
        te = 1.875 * np.linalg.norm(target - guard) * unit / fist_speed
        tr = retraction_ratio * te
        t0 = t + rng.uniform(-0.2, 0.2) * period
        if t0 + te + tr > times[-1]:
            break
        if sds and side in sds[-2:-1] and t0 < starts[-2] + ext[-2] + ret[-2]:
            raise ValueError(f"punch_rate={punch_rate}/s is too fast for fist_speed={fist_speed} m/s: a fist's "
                             f"punch takes {te + tr:.3f} s; lower punch_rate or raise fist_speed")
        starts.append(max(t0, 0.0))
        sds.append(side)
        ext.append(te)
        ret.append(tr)
        t += period
        i += 1
    punches = Punches(sds, starts, ext, ret)

    for side, S in sides.items():
        s, l1, l2, sigma, guard, target = geometry[side]
        u = punches.stroke(side, times)[:, None]
        wrist = guard + (target - guard) * u
        d_vec = wrist - s
        d = np.linalg.norm(d_vec, axis=1)
        if np.any(d > l1 + l2) or np.any(d < abs(l1 - l2)):
            raise ValueError(f"boxing_clip: the {side} fist's path leaves the arm's reach")
        a = _unit(d_vec)
        pole = -up - 0.6 * fwd + 0.3 * sigma * left
        pole = _unit(pole - np.einsum("na,a->n", a, pole)[:, None] * a)
        cos_e = np.clip((l1**2 + d**2 - l2**2) / (2 * l1 * d), -1.0, 1.0)
        elbow = s + l1 * (cos_e[:, None] * a + np.sqrt(1 - cos_e**2)[:, None] * pole)
        j_arm, j_fore, j_hand = idx[f"{S}Arm"], idx[f"{S}ForeArm"], idx[f"{S}Hand"]
        parent = still.joints[j_arm].parent
        r_parent = rw[parent]
        # upper arm: the rest world rotation turned so that the forearm joint's offset points at the elbow
        r_arm0 = rw[j_arm]
        bone0 = np.repeat(_unit(r_arm0 @ still.joints[j_fore].offset)[None], n, 0)
        r_arm = np.einsum("nab,bc->nac", _rotation_between(bone0, _unit(elbow - s)), r_arm0)
        r_fore0 = np.einsum("nab,bc->nac", r_arm, sk.local_rotations[0, j_fore])
        bone1 = _unit(np.einsum("nab,b->na", r_fore0, still.joints[j_hand].offset))
        r_fore = np.einsum("nab,nbc->nac", _rotation_between(bone1, _unit(wrist - elbow)), r_fore0)
        local_arm = np.einsum("ba,nbc->nac", r_parent, r_arm)
        local_fore = np.einsum("nba,nbc->nac", r_arm, r_fore)
        motion[:, slices[j_arm]] = zyx_angles(local_arm)
        motion[:, slices[j_fore]] = zyx_angles(local_fore)
    clip = BvhClip([Joint(j.name, j.parent, j.offset, j.channels, j.end_site, j.line, list(j.children))
                    for j in base.joints], 1.0 / frame_rate, motion, f"boxing on {base.path or 'BVH clip'}")
    return clip, punches


__all__ = ["FIST_SPEED", "FIST_SPEED_RANGE", "Punches", "REACH", "boxing_clip", "minimum_jerk"]
