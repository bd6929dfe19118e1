r"""Shadow boxing on a captured skeleton: straight punches by inverse kinematics of the arms.

No motion-capture clip of boxing ships with the project, so the activity is animated from joint
keyframes on a captured skeleton (:func:`boxing_clip`): the body holds a captured standing posture,
the fists start in a guard and alternate straight punches (lead hand first), each fist travelling on
a straight line from the guard to full reach and back. The arms follow the fists by analytic
two-link inverse kinematics. A straight punch is a whole-body movement, so the trunk moves with it
(section *Trunk* below): the pelvis and the thorax turn about the vertical toward the punch, timed
before the fist (the kinetic chain), the trunk shifts forward, and between punches the boxer bounces
in the stance; the legs follow by inverse kinematics with the feet planted.

Fist path
---------
A punch of the wrist from the guard :math:`\mathbf g` to the target :math:`\mathbf p`
(distance :math:`D`) follows the minimum-jerk profile of aimed arm movements (Flash & Hogan 1985,
J. Neurosci. 5(7):1688-1703), :math:`\mathbf x(t) = \mathbf g + (\mathbf p - \mathbf g)\,f(t/T)`,
:math:`f(s) = 10s^3 - 15s^4 + 6s^5`, whose speed peaks at mid-stroke:

.. math::
    v_{\max} = \frac{D}{T}\,f'(1/2) = \frac{15}{8}\frac{D}{T}
    \quad\Rightarrow\quad T = \frac{15}{8}\frac{D}{v_{\max}}.

The fist's world speed is the stroke's plus the trunk's (the guard is carried by the turning, shifting
thorax), so :math:`T` is set per punch such that the peak *world* speed of the fist's tip is
``fist_speed``: every time of a punch (stroke, trunk turn, shift) scales with :math:`T`, so the
peak speed goes as :math:`1/T` and :math:`T \leftarrow T\,v_{\rm peak}(T)/v_{\rm fist}` converges
in a few steps (the bounce, independent of :math:`T`, is why it takes more than one); the retraction takes
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
* target: a point of the world on the line straight ahead of the posture's mid-shoulders
  :math:`\mathbf c + s\,\hat{\mathbf f}`, at :math:`rL` from the punching shoulder where that
  shoulder is when the fist arrives (turned and shifted forward with the thorax; reach :math:`r` = 0.92:
  an almost straight elbow); the guard moves with the thorax, the target does not; both are places
  of the fist's tip, whose path is :math:`\mathbf x(t) = \mathbf G(t) + (\mathbf p - \mathbf G(t))\,u(t)`;
* the arms by two-link inverse kinematics (:func:`~.keyframes.place_limb`), the elbow towards the pole
  :math:`-\hat{\mathbf u} - 0.6\hat{\mathbf f} + 0.3\sigma\hat{\mathbf l}` (down, back under the fist in
  the guard, and out), on :data:`~.keyframes.KEYFRAME_RATE` keyframes a second.

Trunk
-----
The rear-hand straight (cross) is driven by the legs and the trunk: the pelvis turns about the
vertical toward the punch, the thorax turns further and later, and the fist follows (a proximal-to-
distal sequence). Traced sources: Dinu & Louis 2020 (Front. Sports Act. Living 2:598861; 17-IMU suits on
15 elite and 8 junior boxers): the punch comes from a proximal-to-distal synchronisation of the body's
segments, and in the cross the front foot carries more of the ground reaction force than the rear
(60.6 / 39.4 % elite, 54.1 / 45.9 % junior): a forward weight shift; Dinu, Millot, Slawinski & Louis
2020 (Proceedings 49(1):61): the cross is a forward translation of the body, and elite bouts show about
56 vertical hip movements a minute; Lenetsky, Harris & Brughelli 2013 (Strength Cond. J. 35(2):1-7):
punching moves the arm, the trunk and the legs, the lower body a primary contributor. The angles and
rates of the pelvis's and the thorax's axial rotation (tens of degrees, peak trunk rates of several
hundred deg/s, as Whiting, Gregor & Finerman 1988, Med. Sci. Sports Exerc. 20(5), and Cheraghi et al.
2014 are cited for them) were not read for this module: the figures below are **assumptions** of
those orders of magnitude, and so are the shift's size and the bounce.

* Thorax axial rotation of a cross :math:`\psi_t` = ``trunk_rotation`` (default 0.6 rad, 34 deg;
  range 0.3-0.9 rad, 17-52 deg); the pelvis turns :data:`PELVIS_SHARE` of it (the thorax turns further
  than the pelvis: the "X-factor" stretch); the lead-hand straight (jab) turns :data:`JAB_SHARE` of the
  cross's (a jab is thrown with little trunk rotation). Toward the punch: a right-hand punch turns the
  trunk to the left (the right shoulder comes forward). The spine's joints share the thorax's extra
  turn over the pelvis evenly (``LowerBack``, ``Spine``, ``Spine1``).
* Timing: the pelvis turns over :math:`[t_0 - 0.4T, t_0 + T]`, the thorax over :math:`[t_0 - 0.2T,
  t_0 + T]` (:math:`t_0` the fist's start, :math:`T` its extension): both on minimum-jerk profiles that
  end when the fist arrives, the pelvis first; both turn back over the fist's retraction. Peak
  angular rate of the thorax :math:`\frac{15}{8}\psi_t/(1.2T)`: 0.6 rad over 1.2 x 0.146 s (a 7.2 m/s
  cross) gives 369 deg/s, of the several hundred deg/s the literature is cited for.
* Weight shift: the pelvis (and the trunk on it) moves forward by ``weight_shift`` (default 0.05 m,
  an assumption; the jab :data:`JAB_SHARE` of it) on the thorax's profile.
* Stance: the pelvis sits :data:`STANCE_CROUCH` (0.03 m, assumed) below the captured standing
  posture (a boxer's knees are flexed) and bounces on the balls of the feet: a vertical oscillation
  :math:`-\tfrac{b}{2}(1 - \cos 2\pi f_b t)` of peak-to-peak ``bounce`` (default 0.03 m) at
  ``bounce_rate`` (default 2.5 Hz), both assumed (no measurement of the shadow-boxing bounce was
  found); it runs through the punches. Its peak vertical speed is :math:`\pi f_b b` (0.24 m/s).
* Legs: the ankles stay where the posture has them, the feet flat (their world rotation kept), the
  knees by two-link inverse kinematics toward the front; the heel lift of a real bounce and the rear
  foot's pivot are not modelled (the radar sees the trunk, which moves as stated).

Every point of the thorax moves rigidly with it: a point at horizontal distance :math:`r` from the
spine's vertical axis moves at :math:`r\dot\psi_t` from the turn, plus the shift and the bounce.
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
#: Default thorax axial rotation of a rear-hand straight (rad; module docstring, an assumption within the
#: measured tens of degrees) and its physical range.
TRUNK_ROTATION = 0.6
TRUNK_ROTATION_RANGE = (0.0, 1.0)
#: The pelvis's share of the thorax's axial rotation (assumed).
PELVIS_SHARE = 0.6
#: A jab's trunk rotation and weight shift as a share of the cross's (assumed).
JAB_SHARE = 0.35
#: Default forward weight shift of the pelvis in a cross (m, assumed).
WEIGHT_SHIFT = 0.05
#: Knee flexion of the stance: the pelvis this far below the captured standing posture (m, assumed).
STANCE_CROUCH = 0.03
#: Default stance bounce: peak-to-peak vertical pelvis travel (m) and rate (Hz), assumed.
BOUNCE = 0.03
BOUNCE_RATE = 2.5
#: Lead of the pelvis's and the thorax's turn before the fist's start, in units of the extension time.
PELVIS_LEAD, THORAX_LEAD = 0.4, 0.2
#: The spine joints, pelvis to thorax, and the share of the thorax's extra turn over the pelvis each takes.
SPINE = (("LowerBack", 1.0 / 3.0), ("Spine", 2.0 / 3.0), ("Spine1", 1.0))


class Punches:
    """The punch schedule: per punch its ``side`` ('left' or 'right'), ``start`` (s), extension and
    retraction times (s), and the trunk's motion per punch: ``thorax`` axial rotation (rad, signed: + turns
    the body's forward toward its left) and forward ``shift`` (m). Built by :func:`boxing_clip`."""

    def __init__(self, sides, starts, extension, retraction, thorax=None, shift=None):
        self.sides = list(sides)
        self.starts = np.asarray(starts, float)
        self.extension = np.asarray(extension, float)
        self.retraction = np.asarray(retraction, float)
        self.thorax = np.zeros(len(self.sides)) if thorax is None else np.asarray(thorax, float)
        self.shift = np.zeros(len(self.sides)) if shift is None else np.asarray(shift, float)

    def stroke_of(self, k: int, times) -> np.ndarray:
        """Fraction ``[T]`` of the way from guard to target of punch ``k``'s fist at clip ``times``."""
        times = np.asarray(times, float)
        t0, te, tr = self.starts[k], self.extension[k], self.retraction[k]
        return minimum_jerk((times - t0) / te) - minimum_jerk((times - t0 - te) / tr)

    def stroke(self, side: str, times) -> np.ndarray:
        """Fraction ``[T]`` of the way from guard to target of the ``side`` fist at clip ``times``."""
        out = np.zeros(np.shape(times))
        for k, sd in enumerate(self.sides):
            if sd == side:
                out += self.stroke_of(k, times)
        return out

    def trunk(self, times, lead: float) -> np.ndarray:
        """Fraction ``[N, T]`` of each punch's trunk motion at clip ``times``, for a turn that starts ``lead``
        extension times before the fist and ends when it arrives (module docstring)."""
        times = np.asarray(times, float)[None]
        t0, te, tr = self.starts[:, None], self.extension[:, None], self.retraction[:, None]
        return minimum_jerk((times - t0 + lead * te) / ((1.0 + lead) * te)) - minimum_jerk((times - t0 - te) / tr)

    def pelvis_rotation(self, times) -> np.ndarray:
        """The pelvis's axial rotation (rad) at ``times``: :data:`PELVIS_SHARE` of the thorax's, turned earlier."""
        return PELVIS_SHARE * self.thorax @ self.trunk(times, PELVIS_LEAD)

    def thorax_rotation(self, times) -> np.ndarray:
        """The thorax's axial rotation (rad) at ``times``."""
        return self.thorax @ self.trunk(times, THORAX_LEAD)

    def forward_shift(self, times) -> np.ndarray:
        """The pelvis's forward weight shift (m) at ``times``."""
        return self.shift @ self.trunk(times, THORAX_LEAD)

    def to_dict(self) -> list:
        return [{"side": s, "start_s": float(a), "extension_s": float(e), "retraction_s": float(r),
                 "thorax_rotation_rad": float(th), "weight_shift_m": float(sh)}
                for s, a, e, r, th, sh in zip(self.sides, self.starts, self.extension, self.retraction,
                                               self.thorax, self.shift)]


def bounce_height(times, bounce: float, bounce_rate: float) -> np.ndarray:
    r"""Stance bounce: the pelvis's height (m) relative to the stance, :math:`-\tfrac{b}{2}(1 - \cos 2\pi f_b t)`."""
    return -0.5 * bounce * (1.0 - np.cos(2.0 * np.pi * bounce_rate * np.asarray(times, float)))


def yaw(angle) -> np.ndarray:
    """Rotations ``[T, 3, 3]`` about the BVH vertical (+y) by ``angle`` [T] rad (+: forward toward the left)."""
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros(np.shape(angle) + (3, 3))
    r[..., 0, 0], r[..., 0, 2], r[..., 2, 0], r[..., 2, 2], r[..., 1, 1] = c, s, -s, c, 1.0
    return r


class Trunk:
    """The trunk's rigid motion (module docstring) at ``times``: the root's displacement ``root_shift`` [T, 3]
    (file units) and the world rotation of each spine joint about the vertical, as a chain from the root;
    :meth:`carry` moves posture points fixed to the thorax (the shoulders, the guard)."""

    def __init__(self, pose: HeldPosture, punches: Punches, times, unit: float, bounce: float, bounce_rate: float):
        up, _, fwd = pose.body_axes()
        self.pelvis = yaw(punches.pelvis_rotation(times))
        thorax = punches.thorax_rotation(times)
        pelvis = punches.pelvis_rotation(times)
        self.spine = [(name, yaw(pelvis + share * (thorax - pelvis))) for name, share in SPINE]
        height = bounce_height(times, bounce, bounce_rate) - STANCE_CROUCH
        self.root_shift = (punches.forward_shift(times)[:, None] * fwd + height[:, None] * up) / unit
        ow = pose.world_origins
        self.origins = [ow[0]] + [ow[pose.joint(name)] for name, _ in SPINE]

    def carry(self, point) -> np.ndarray:
        """Positions ``[T, 3]`` of a posture point fixed to the thorax (at and above ``Spine1``)."""
        rots = [self.pelvis] + [r for _, r in self.spine]
        x = self.origins[0] + self.root_shift
        for k in range(len(self.origins) - 1):
            x = x + np.einsum("tab,b->ta", rots[k], self.origins[k + 1] - self.origins[k])
        return x + np.einsum("tab,b->ta", rots[-1], np.asarray(point, float) - self.origins[-1])

    def pelvis_point(self, point) -> np.ndarray:
        """Positions ``[T, 3]`` of a posture point fixed to the pelvis (the hip joints)."""
        return self.origins[0] + self.root_shift + np.einsum("tab,b->ta", self.pelvis, np.asarray(point) - self.origins[0])

    @property
    def thorax(self) -> np.ndarray:
        return self.spine[-1][1]


def _fist_paths(pose, punches, guards, shoulders, centre, fwd, reach, times, unit, bounce, bounce_rate):
    r"""The fists' tips ``{side: [T, 3]}`` at ``times`` (file units) and the :class:`Trunk`.

    Punch :math:`k`'s target is the point :math:`\mathbf c + s\hat{\mathbf f}` of the line ahead of the
    posture's mid-shoulders at the reach :math:`\rho` from its shoulder :math:`\mathbf s` where the thorax
    carries it when the fist arrives: with :math:`\mathbf d = \mathbf s - \mathbf c`,
    :math:`s = \mathbf d\cdot\hat{\mathbf f} + \sqrt{\rho^2 - |\mathbf d|^2 + (\mathbf d\cdot\hat{\mathbf f})^2}`.
    The tip runs from the guard the thorax carries, :math:`\mathbf G(t)`, by the stroke :math:`u_k(t)`:
    :math:`\mathbf x = \mathbf G + \sum_k(\mathbf p_k - \mathbf G)u_k` (one fist's strokes do not overlap).
    """
    trunk = Trunk(pose, punches, times, unit, bounce, bounce_rate)
    paths = {side: trunk.carry(guards[side]) for side in ("left", "right")}
    tips = {side: g.copy() for side, g in paths.items()}
    for k, (side, t0, te) in enumerate(zip(punches.sides, punches.starts, punches.extension)):
        d = Trunk(pose, punches, np.array([t0 + te]), unit, bounce, bounce_rate).carry(shoulders[side])[0] - centre
        along = d @ fwd
        target = centre + (along + math.sqrt(max(reach[side] ** 2 - d @ d + along**2, 0.0))) * fwd
        tips[side] += (target - paths[side]) * punches.stroke_of(k, times)[:, None]
    return tips, trunk


def boxing_clip(base: BvhClip, base_time: float, unit: float, duration: float, fist_speed: float = FIST_SPEED,
                punch_rate: float = 2.0, retraction_ratio: float = 1.5, lead: str = "left", seed: int = 0,
                hand_length: float = 0.0, trunk_rotation: float = TRUNK_ROTATION, weight_shift: float = WEIGHT_SHIFT,
                bounce: float = BOUNCE, bounce_rate: float = BOUNCE_RATE,
                frame_rate: float = KEYFRAME_RATE) -> tuple[BvhClip, Punches]:
    r"""Shadow boxing (module docstring) on the posture of ``base`` at clip time ``base_time``.

    ``unit`` (m per file unit) turns ``fist_speed`` (m/s, the peak world speed of the fist's tip, trunk
    included) and ``hand_length`` (m: the fist's tip lies that far beyond the wrist, along the forearm) into
    the clip's units; punches come ``1/punch_rate`` s apart on average (each start jittered uniformly by
    +-20 % of that), alternating sides from ``lead``; ``seed`` draws the jitter. ``trunk_rotation`` (rad,
    thorax turn of a cross), ``weight_shift`` (m), ``bounce`` (m peak to peak) and ``bounce_rate`` (Hz) move
    the trunk (module docstring). Returns the clip (``duration`` s at ``frame_rate`` frames per second;
    frame 0 is a frame of the motion, not a T-pose) and its :class:`Punches`.
    """
    lo, hi = FIST_SPEED_RANGE
    if not lo <= fist_speed <= hi:
        raise ValueError(f"fist_speed={fist_speed} m/s is outside the measured range {lo}-{hi} m/s of straight "
                         "punches (sionnafmcw.mocap.punches)")
    if lead not in ("left", "right"):
        raise ValueError(f"lead={lead!r}: choose 'left' (orthodox) or 'right' (southpaw)")
    if not (punch_rate > 0 and duration > 0 and retraction_ratio > 0):
        raise ValueError("boxing_clip: punch_rate, duration and retraction_ratio must be > 0")
    for name, value, (a, b) in (("trunk_rotation", trunk_rotation, TRUNK_ROTATION_RANGE),
                                ("weight_shift", weight_shift, (0.0, 0.15)), ("bounce", bounce, (0.0, 0.08)),
                                ("bounce_rate", bounce_rate, (0.0, 5.0))):
        if not a <= value <= b:
            raise ValueError(f"{name}={value} is outside {a}..{b} (sionnafmcw.mocap.punches)")
    n = int(math.floor(duration * frame_rate + 1e-9)) + 1
    pose = HeldPosture(base, base_time, n, frame_rate)
    up, left, fwd = pose.body_axes()
    ow = pose.world_origins
    shoulders = {side: ow[pose.joint(f"{S}Arm")] for side, S in (("left", "Left"), ("right", "Right"))}
    half_width = 0.5 * np.linalg.norm(shoulders["left"] - shoulders["right"])
    centre = 0.5 * (shoulders["left"] + shoulders["right"])
    hand = hand_length / unit
    geometry, arm_reach = {}, {}
    for side, S in (("left", "Left"), ("right", "Right")):
        arm = pose.bone(f"{S}ForeArm") + pose.bone(f"{S}Hand") + hand
        sigma = 1.0 if side == "left" else -1.0
        guard = shoulders[side] + arm * (0.30 * fwd + 0.08 * up) - 0.3 * half_width * sigma * left
        target = centre + math.sqrt(max((REACH * arm) ** 2 - half_width**2, 0.0)) * fwd
        geometry[side] = (S, sigma, guard, target)
        arm_reach[side] = REACH * arm
    guards = {side: g[2] for side, g in geometry.items()}

    rng = np.random.default_rng(seed)
    period = 1.0 / punch_rate
    order = [lead, "right" if lead == "left" else "left"]
    starts, sides, ext = [], [], []
    t, i = 0.25 * period, 0
    while True:
        side = order[i % 2]
        _, _, guard, target = geometry[side]
        te = 1.875 * np.linalg.norm(target - guard) * unit / fist_speed
        t0 = max(t + rng.uniform(-0.2, 0.2) * period, 0.0)
        if t0 > pose.times[-1]:
            break
        starts.append(t0)
        sides.append(side)
        ext.append(te)
        t += period
        i += 1
    # the trunk per punch: a right-hand punch turns the body's forward to the left (+)
    thorax = np.array([(1.0 if s == "right" else -1.0) * trunk_rotation * (1.0 if s != lead else JAB_SHARE)
                       for s in sides])
    shift = np.array([weight_shift * (1.0 if s != lead else JAB_SHARE) for s in sides])
    ext = np.array(ext)
    for _ in range(6):        # peak world speed of each fist's tip -> fist_speed (module docstring)
        punches = Punches(sides, starts, ext, retraction_ratio * ext, thorax, shift)
        h = 0.25 / frame_rate
        scale = np.empty(len(sides))
        for k, (side, t0, te) in enumerate(zip(sides, starts, ext)):
            tt = np.arange(t0 - PELVIS_LEAD * te, t0 + te * (1 + retraction_ratio) + h, h)
            x = _fist_paths(pose, punches, guards, shoulders, centre, fwd, arm_reach, tt, unit, bounce,
                            bounce_rate)[0][side]
            scale[k] = np.linalg.norm(np.diff(x, axis=0), axis=1).max() / h * unit / fist_speed
        ext = ext * scale
        if np.abs(scale - 1.0).max() < 1e-4:
            break
    keep = np.array(starts) + ext * (1 + retraction_ratio) <= pose.times[-1]
    sides = [s for s, k in zip(sides, keep) if k]
    starts, ext, thorax, shift = np.array(starts)[keep], ext[keep], thorax[keep], shift[keep]
    punches = Punches(sides, starts, ext, retraction_ratio * ext, thorax, shift)
    for k in range(2, len(sides)):
        if starts[k] < starts[k - 2] + ext[k - 2] * (1 + retraction_ratio):
            raise ValueError(f"punch_rate={punch_rate}/s is too fast for fist_speed={fist_speed} m/s: a fist's "
                             f"punch takes {ext[k - 2] * (1 + retraction_ratio):.3f} s; lower punch_rate or raise "
                             "fist_speed")
    paths, trunk = _fist_paths(pose, punches, guards, shoulders, centre, fwd, arm_reach, pose.times, unit, bounce,
                               bounce_rate)
    # the trunk: root translation and rotation, the spine's extra turn (module docstring)
    root = 0
    sl = pose.slices[root]
    channels = list(base.joints[root].channels)
    for axis, name in enumerate(("Xposition", "Yposition", "Zposition")):
        if name not in channels:
            raise ValueError(f"{base.path or 'BVH clip'}: the root needs position channels to move the trunk")
        pose.motion[:, sl.start + channels.index(name)] += trunk.root_shift[:, axis]
    rw = pose.world_rotations
    pose.set_rotation(root, np.einsum("tab,bc->tac", trunk.pelvis, rw[root]))
    parent_turn = trunk.pelvis
    for name, turn in trunk.spine:
        j = pose.joint(name)
        rp = rw[base.joints[j].parent]
        rel = np.einsum("tba,tbc->tac", parent_turn, turn)           # the turn over the parent's
        pose.set_rotation(j, np.einsum("ba,tbc,cd,de->tae", rp, rel, rp, pose.local[j]))
        parent_turn = turn
    for side, (S, sigma, guard, target) in geometry.items():
        parent = np.einsum("tab,bc->tac", trunk.thorax, rw[base.joints[pose.joint(f"{S}Arm")].parent])
        place_limb(pose, f"{S}Arm", f"{S}ForeArm", f"{S}Hand", trunk.carry(shoulders[side]), paths[side],
                   np.einsum("tab,b->ta", trunk.thorax, -up - 0.6 * fwd + 0.3 * sigma * left), parent_world=parent,
                   extension=hand, what=f"{side} fist")
    for S in ("Left", "Right"):        # the legs: ankles planted, feet flat, knees forward
        hip = trunk.pelvis_point(ow[pose.joint(f"{S}UpLeg")])
        ankle = np.broadcast_to(ow[pose.joint(f"{S}Foot")], hip.shape)
        parent = np.einsum("tab,bc->tac", trunk.pelvis, rw[base.joints[pose.joint(f"{S}UpLeg")].parent])
        place_limb(pose, f"{S}UpLeg", f"{S}Leg", f"{S}Foot", hip, ankle, fwd, parent_world=parent,
                   end_world=rw[pose.joint(f"{S}Foot")], what=f"{S.lower()} foot")
    return pose.clip("boxing"), punches


__all__ = ["BOUNCE", "BOUNCE_RATE", "FIST_SPEED", "FIST_SPEED_RANGE", "JAB_SHARE", "PELVIS_SHARE", "Punches", "REACH",
           "STANCE_CROUCH", "TRUNK_ROTATION", "TRUNK_ROTATION_RANGE", "Trunk", "WEIGHT_SHIFT", "bounce_height",
           "boxing_clip", "yaw"]
