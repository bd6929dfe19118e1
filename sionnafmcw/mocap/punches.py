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

The point that follows the path is the fist's tip: the far end of the hand, which the segment body
holds straight along the forearm (:mod:`.segments`, an ellipsoid of the hand's length
:math:`L_h` beyond the wrist), so no surface of the arm moves faster than the measured fist speed
(the wrist, nearer the elbow, is slower while the forearm turns).

Geometry (BVH axes, file units)
-------------------------------
With the shoulder :math:`\mathbf s` (joint ``{Side}Arm``), the upper arm :math:`L_1` and forearm with
the hand :math:`L_2` (the offsets of ``{Side}ForeArm`` and ``{Side}Hand``, plus :math:`L_h`), the body's up :math:`\hat{\mathbf u}`
(+y), left :math:`\hat{\mathbf l}` (right shoulder to left, horizontal) and forward
:math:`\hat{\mathbf f} = \hat{\mathbf l}\times\hat{\mathbf u}`:

* guard: :math:`\mathbf g = \mathbf s + L(0.30\,\hat{\mathbf f} + 0.08\,\hat{\mathbf u}) - 0.3\,w\,\sigma\hat{\mathbf l}`
  (:math:`L = L_1 + L_2`, :math:`w` half the shoulder width, :math:`\sigma` = +1 left, -1 right): fists
  in front of the chin;
* target: the point straight ahead of the mid-shoulders, :math:`\mathbf c + \sqrt{(rL)^2 - w^2}\,
  \hat{\mathbf f}`, at :math:`rL` from the shoulder (reach :math:`r` = 0.92: an almost straight elbow);
  the guard and the target are places of the fist's tip;
* the arms by two-link inverse kinematics (:func:`~.keyframes.place_limb`), the elbow towards the pole
  :math:`-\hat{\mathbf u} - 0.6\hat{\mathbf f} + 0.3\sigma\hat{\mathbf l}` (down, back under the fist in
  the guard, and out), on :data:`~.keyframes.KEYFRAME_RATE` keyframes a second.
"""

from __future__ import annotations

import math

import numpy as np

from .bvh import BvhClip
from .keyframes import KEYFRAME_RATE, HeldPosture, minimum_jerk, place_limb

#: Physical range of the peak fist speed of a straight punch (m/s; module docstring).
FIST_SPEED_RANGE = (3.0, 11.0)
#: Peak fist speed of a junior boxer's lead straight punch (Liu et al. 2022), m/s: the default.
FIST_SPEED = 6.3
#: Reach of a punch as a fraction of the arm's length (shoulder to wrist).
REACH = 0.92


class Punches:
    """The punch schedule: per punch its ``side`` ('left' or 'right'), ``start`` (s), extension and
    retraction times (s). Built by :func:`boxing_clip`."""

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
            if sd == side:
                out += minimum_jerk((times - t0) / te) - minimum_jerk((times - t0 - te) / tr)
        return out

    def to_dict(self) -> list:
        return [{"side": s, "start_s": float(a), "extension_s": float(e), "retraction_s": float(r)}
                for s, a, e, r in zip(self.sides, self.starts, self.extension, self.retraction)]


def boxing_clip(base: BvhClip, base_time: float, unit: float, duration: float, fist_speed: float = FIST_SPEED,
                punch_rate: float = 2.0, retraction_ratio: float = 1.5, lead: str = "left", seed: int = 0,
                hand_length: float = 0.0, frame_rate: float = KEYFRAME_RATE) -> tuple[BvhClip, Punches]:
    r"""Shadow boxing (module docstring) on the posture of ``base`` at clip time ``base_time``.

    ``unit`` (m per file unit) turns ``fist_speed`` (m/s, peak) and ``hand_length`` (m: the fist's tip lies
    that far beyond the wrist, along the forearm) into the clip's units; punches come
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
    n = int(math.floor(duration * frame_rate + 1e-9)) + 1
    pose = HeldPosture(base, base_time, n, frame_rate)
    up, left, fwd = pose.body_axes()
    ow = pose.world_origins
    shoulders = {side: ow[pose.joint(f"{S}Arm")] for side, S in (("left", "Left"), ("right", "Right"))}
    half_width = 0.5 * np.linalg.norm(shoulders["left"] - shoulders["right"])
    centre = 0.5 * (shoulders["left"] + shoulders["right"])
    hand = hand_length / unit
    geometry = {}
    for side, S in (("left", "Left"), ("right", "Right")):
        arm = pose.bone(f"{S}ForeArm") + pose.bone(f"{S}Hand") + hand
        sigma = 1.0 if side == "left" else -1.0
        guard = shoulders[side] + arm * (0.30 * fwd + 0.08 * up) - 0.3 * half_width * sigma * left
        target = centre + math.sqrt(max((REACH * arm) ** 2 - half_width**2, 0.0)) * fwd
        geometry[side] = (S, sigma, guard, target)

    rng = np.random.default_rng(seed)
    period = 1.0 / punch_rate
    order = [lead, "right" if lead == "left" else "left"]
    starts, sides, ext, ret = [], [], [], []
    t, i = 0.25 * period, 0
    while True:
        side = order[i % 2]
        _, _, guard, target = geometry[side]
        te = 1.875 * np.linalg.norm(target - guard) * unit / fist_speed
        tr = retraction_ratio * te
        t0 = max(t + rng.uniform(-0.2, 0.2) * period, 0.0)
        if t0 + te + tr > pose.times[-1]:
            break
        if len(sides) >= 2 and t0 < starts[-2] + ext[-2] + ret[-2]:
            raise ValueError(f"punch_rate={punch_rate}/s is too fast for fist_speed={fist_speed} m/s: a fist's "
                             f"punch takes {te + tr:.3f} s; lower punch_rate or raise fist_speed")
        starts.append(t0)
        sides.append(side)
        ext.append(te)
        ret.append(tr)
        t += period
        i += 1
    punches = Punches(sides, starts, ext, ret)
    for side, (S, sigma, guard, target) in geometry.items():
        u = punches.stroke(side, pose.times)[:, None]
        place_limb(pose, f"{S}Arm", f"{S}ForeArm", f"{S}Hand", shoulders[side], guard + (target - guard) * u,
                   -up - 0.6 * fwd + 0.3 * sigma * left, extension=hand, what=f"{side} fist")
    return pose.clip("boxing"), punches


__all__ = ["FIST_SPEED", "FIST_SPEED_RANGE", "Punches", "REACH", "boxing_clip"]
