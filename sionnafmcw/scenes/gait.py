r"""The Boulic-Thalmann global human walking model: gait timing and joint trajectories.

R. Boulic, N. Magnenat-Thalmann, D. Thalmann, "A global human walking model with real-time
kinematic personification", *The Visual Computer* 6(6), 344-358, 1990 (the appendices give the
trajectories below as functions of the normalised cycle time and the relative velocity). The
constants and control points follow V. C. Chen's implementation of the model in *The
Micro-Doppler Effect in Radar*, Artech House 2011, ch. 5 (pedestrian model), as ported to Python
by M. Czerkawski (public "Human Motion Simulator" scripts, "from scripts authored by V.C. Chen
and Yang Hai"); the deviations from that code are listed at the end.

Normalisation and timing
------------------------
:math:`H_t` is the height of the thigh (hip joint above the ankle: thigh + shank length,
``0.491 H`` with Winter's ratios, see :mod:`.body`). The relative velocity is

.. math::  RV = V / H_t \quad [1/s],

the relative length of a cycle (a stride: two steps) :math:`RL_c = 1.346\sqrt{RV}`, so a cycle
is :math:`L_c = RL_c H_t` metres long and lasts :math:`D_c = RL_c / RV = L_c / V` seconds; the
duration of support (stance) is :math:`D_s = 0.752 D_c - 0.143` s, i.e. the support fraction
:math:`d_s = D_s / D_c`. The model is defined for :math:`0 < RV \le 3` (Boulic: "the walking
speed is limited to RV = 3"; MATLAB's ``backscatterPedestrian`` limits V to 1.4 H, RV = 2.85).

Beyond RV = 3 (the paper's 4.52 m/s is a run: RV = 5.1 for a 1.8 m person) the *shape* of every
trajectory is frozen at :math:`RV_c = \min(RV, RV_{max})` (``rv_max = 3``) while the body moves
at the requested :math:`V`. The stride length stays :math:`L_c = RL_c(RV_c) H_t` and the cycle
is traversed faster, :math:`D_c = L_c / V` (cadence rises with V). Within the model's range this
is exactly Boulic's :math:`D_c = RL_c/RV`; above it the feet still stop during stance (the leg
geometry covers the stride it was built for) instead of sliding, and the limb velocities scale
with V. A real run has a flight phase and longer strides, which this walking model does not have.

Trajectories (normalised time :math:`t \in [0, 1)`, right heel strike at :math:`t = 0`; the
left side is the same curve shifted by half a cycle; angles in degrees here, radians in the API)
---------------------------------------------------------------------------------------------------
Translations of the spine origin :math:`O_s` (metres, as in Chen's code):

* vertical :math:`-a_v + a_v\sin 2\pi(2t - 0.35)`, :math:`a_v = 0.015\,RV`;
* lateral :math:`a_l \sin 2\pi(t - 0.1)`, :math:`a_l = -0.032` (:math:`RV \ge 0.5`) else
  :math:`-0.128\,RV(1 - RV)`;
* forward/backward :math:`a_a \sin 2\pi(2t + 2\varphi_a)`, :math:`\varphi_a = 0.625 - d_s`,
  :math:`a_a = -0.021` (:math:`RV \ge 0.5`) else :math:`-0.084\,RV(1 - RV)`.

Rotations of the pelvis and the back:

* back flexion (forward/backward) :math:`-a_1 + a_1\sin 2\pi(2t - 0.1)`, :math:`a_1 = 2` (else
  :math:`8RV(1-RV)`), negative = leaning forward;
* pelvic list (left/right), four cosine arcs on [0, .15), [.15, .5), [.5, .65), [.65, 1) with
  amplitude :math:`a_2 = 0.01\,RV` (Chen's value; it makes the list negligible);
* pelvic torsion :math:`-a_3\cos 2\pi t`, :math:`a_3 = 4RV`.

Joint flexions (periodic PCHIP through control points :math:`(t_k, \theta_k)`, as Chen does;
Boulic drew them as splines through the same points):

* hip: :math:`(-0.1, 25), (0.5, -15), (0.9, 25)` for :math:`0.5 \le RV < 1.3` (gait "b"); for
  :math:`RV \ge 1.3` (gait "c") :math:`t_1 = 0.2r - 0.1`, :math:`\theta_1 = 25 + 5r`,
  :math:`\theta_3 = 25 + 6r` with :math:`r = (RV - 1.3)/1.7`; below 0.5 (gait "a") the angles scale
  with :math:`RV`: :math:`(50, -30, 50)\,RV`;
* knee: :math:`(0.17, 3 + 22r), (0.4, 3), (0.75 - 0.05r, 70 - 5r), (1 - 0.03r, 3 + 3r)` (gait c;
  b: r = 0; a: the swing peak :math:`140\,RV`);
* ankle: :math:`(0, -3 + 5r), (0.08, -18 + 4r), (0.5 - 0.1r, 8 - 3r), (d_s, -20 - 8r), (0.85, -3 + 5r)`
  (positive = dorsiflexion, toe up; a: :math:`(-3, -30RV - 3, 22RV - 3, -34RV - 3, -3)`);
* thorax torsion: :math:`(0.1, \tfrac43 RV), (0.4, -1.5RV), (0.6, -\tfrac43 RV), (0.9, 1.5RV)`;
* shoulder flexion :math:`3 - a_{sh}/2 - a_{sh}\cos 2\pi t`, :math:`a_{sh} = 9.88\,RV`;
* elbow flexion: gait c :math:`(0.05, 14 - 6r), (0.51 + 0.04r, 44 + 26r), (0.9 - 0.1r, 17 - 6r)`
  (b and a: Chen's values, continuous at RV = 0.5 and 1.3).

Positive hip, shoulder and elbow flexion swing the distal segment forward, positive knee flexion
folds the shank backward.

Deviations from Chen's code (and why)
-------------------------------------
* Cycle duration :math:`D_c = RL_c/RV` (Boulic's definition; the port's ``rdc = rlc/(rv*Ht)``
  divides by :math:`H_t` once more) and the forward progression :math:`RL_c H_t` per cycle (the
  port advances :math:`RL_c`, a relative length, as metres).
* Gait "a" lateral and forward amplitudes carry the sign of gait "b" (Chen's expressions flip
  sign at RV = 0.5); elbow gait "c" third point uses :math:`(RV - 1.3)` where the port has
  :math:`(RV - 0.13)` (a typo that breaks continuity at RV = 1.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PchipInterpolator

#: Highest relative velocity the Boulic model is defined for (1/s).
RV_MAX = 3.0


def relative_cycle_length(rv: float) -> float:
    """:math:`RL_c = 1.346\\sqrt{RV}` (cycle length over the thigh height)."""
    return 1.346 * math.sqrt(rv)


def _periodic_pchip(xs, ys):
    """Periodic (period 1) PCHIP through control points (merging points that coincide mod 1)."""
    pts = sorted(((x % 1.0, y) for x, y in zip(xs, ys)), key=lambda p: p[0])
    merged = []
    for x, y in pts:
        if merged and abs(x - merged[-1][0]) < 1e-9:
            merged[-1] = (merged[-1][0], 0.5 * (merged[-1][1] + y))
        else:
            merged.append((x, y))
    if len(merged) > 1 and abs(merged[0][0] + 1.0 - merged[-1][0]) < 1e-9:
        merged.pop()
    x = np.array([p[0] for p in merged])
    y = np.array([p[1] for p in merged])
    return PchipInterpolator(np.concatenate([x - 1, x, x + 1]), np.concatenate([y, y, y]))


@dataclass(frozen=True)
class BoulicGait:
    """Joint and pelvis trajectories of Boulic's model for gait-shaping relative velocity ``rv`` (1/s).

    Every method takes the gait phase ``t`` in cycles (any real; the fractional part is used;
    right heel strike at integer phases) and returns metres or radians. ``rv`` is the
    shape-determining :math:`RV_c` (at most :data:`RV_MAX`).
    """

    rv: float
    _curves: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        rv = float(self.rv)
        if not (0.0 < rv <= RV_MAX + 1e-12):
            raise ValueError(f"BoulicGait: relative velocity {rv} 1/s outside the model's (0, {RV_MAX}]")
        object.__setattr__(self, "_curves", self._build(rv))

    # ---------------------------------------------------------------- timing
    @property
    def gait(self) -> str:
        """Boulic's regime: ``"a"`` (RV < 0.5), ``"b"`` (0.5 <= RV < 1.3), ``"c"`` (1.3 <= RV <= 3)."""
        return "a" if self.rv < 0.5 else ("b" if self.rv < 1.3 else "c")

    @property
    def relative_cycle_length(self) -> float:
        return relative_cycle_length(self.rv)

    @property
    def model_cycle_duration(self) -> float:
        """:math:`D_c = RL_c/RV` (s) at the shaping velocity."""
        return self.relative_cycle_length / self.rv

    @property
    def support_fraction(self) -> float:
        """:math:`d_s = (0.752 D_c - 0.143)/D_c`: fraction of the cycle a foot is on the ground."""
        dc = self.model_cycle_duration
        return (0.752 * dc - 0.143) / dc

    # ---------------------------------------------------------------- curves
    def _build(self, rv):
        ds = (0.752 * relative_cycle_length(rv) / rv - 0.143) / (relative_cycle_length(rv) / rv)
        g = "a" if rv < 0.5 else ("b" if rv < 1.3 else "c")
        r = (rv - 1.3) / 1.7 if g == "c" else 0.0
        if g == "a":
            hip = ([-0.1, 0.5, 0.9], [50 * rv, -30 * rv, 50 * rv])
            knee = ([0.17, 0.4, 0.75, 1.0], [3, 3, 140 * rv, 3])
            ankle = ([0, 0.08, 0.5, ds, 0.85], [-3, -30 * rv - 3, 22 * rv - 3, -34 * rv - 3, -3])
            elbow = ([0.05, 0.5, 0.9], [6 * rv + 3, 34 * rv + 3, 10 * rv + 3])
        elif g == "b":
            hip = ([-0.1, 0.5, 0.9], [25, -15, 25])
            knee = ([0.17, 0.4, 0.75, 1.0], [3, 3, 70, 3])
            ankle = ([0, 0.08, 0.5, ds, 0.85], [-3, -18, 8, -20, -3])
            q = (rv - 0.5) / 0.8
            elbow = ([0.05, 0.01 * q + 0.5, 0.9], [8 * q + 6, 24 * q + 20, 9 * q + 8])
        else:
            hip = ([0.2 * r - 0.1, 0.5, 0.9], [5 * r + 25, -15, 6 * r + 25])
            knee = ([-0.05 * r + 0.17, 0.4, -0.05 * r + 0.75, -0.03 * r + 1.0],
                    [22 * r + 3, 3, -5 * r + 70, 3 * r + 3])
            ankle = ([0, 0.08, -0.1 * r + 0.5, ds, 0.85],
                     [5 * r - 3, 4 * r - 18, -3 * r + 8, -8 * r - 20, 5 * r - 3])
            elbow = ([0.05, 0.04 * r + 0.51, -0.1 * r + 0.9], [-6 * r + 14, 26 * r + 44, -6 * r + 17])
        thorax = ([0.1, 0.4, 0.6, 0.9], [4 / 3 * rv, -4.5 / 3 * rv, -4 / 3 * rv, 4.5 / 3 * rv])
        return {"hip": _periodic_pchip(*hip), "knee": _periodic_pchip(*knee), "ankle": _periodic_pchip(*ankle),
                "elbow": _periodic_pchip(*elbow), "thorax": _periodic_pchip(*thorax), "ds": ds}

    @staticmethod
    def _frac(t):
        return np.mod(np.asarray(t, dtype=float), 1.0)

    # translations of the spine origin (m)
    def vertical(self, t):
        av = 0.015 * self.rv
        return -av + av * np.sin(2 * np.pi * (2 * self._frac(t) - 0.35))

    def lateral(self, t):
        """Lateral translation (m, + towards the body's left)."""
        al = -0.032 if self.rv >= 0.5 else -0.128 * self.rv * (1 - self.rv)
        return al * np.sin(2 * np.pi * (self._frac(t) - 0.1))

    def forward(self, t):
        """Forward/backward translation (m) about the uniform progression."""
        aa = -0.021 if self.rv >= 0.5 else -0.084 * self.rv * (1 - self.rv)
        phia = 0.625 - self._curves["ds"]
        return aa * np.sin(2 * np.pi * (2 * self._frac(t) + 2 * phia))

    # rotations (rad)
    def back_flexion(self, t):
        """Flexion of the back (upper body) about the lateral axis, negative = leaning forward."""
        a1 = 2.0 if self.rv >= 0.5 else 8 * self.rv * (1 - self.rv)
        return np.deg2rad(-a1 + a1 * np.sin(2 * np.pi * (2 * self._frac(t) - 0.1)))

    def pelvic_list(self, t):
        """Pelvis rotation about the forward axis (the pelvis falls on the side of the swinging leg)."""
        a2 = 0.01 * self.rv
        t = self._frac(t)
        out = np.where(t < 0.15, -a2 + a2 * np.cos(2 * np.pi * 10 * t / 3),
              np.where(t < 0.5, -a2 - a2 * np.cos(2 * np.pi * 10 * (t - 0.15) / 7),
              np.where(t < 0.65, a2 - a2 * np.cos(2 * np.pi * 10 * (t - 0.5) / 3),
                       a2 + a2 * np.cos(2 * np.pi * 10 * (t - 0.65) / 7))))
        return np.deg2rad(out)

    def pelvic_torsion(self, t):
        """Pelvis rotation about the vertical axis (Chen's sign: the body turns by minus this angle)."""
        return np.deg2rad(-4.0 * self.rv * np.cos(2 * np.pi * self._frac(t)))

    def hip(self, t):
        return np.deg2rad(self._curves["hip"](self._frac(t)))

    def knee(self, t):
        return np.deg2rad(self._curves["knee"](self._frac(t)))

    def ankle(self, t):
        return np.deg2rad(self._curves["ankle"](self._frac(t)))

    def thorax_torsion(self, t):
        """Thorax rotation about the vertical axis (Chen's sign: the thorax turns by minus this angle)."""
        return np.deg2rad(self._curves["thorax"](self._frac(t)))

    def shoulder(self, t):
        ash = 9.88 * self.rv
        return np.deg2rad(3 - ash / 2 - ash * np.cos(2 * np.pi * self._frac(t)))

    def elbow(self, t):
        return np.deg2rad(self._curves["elbow"](self._frac(t)))


@dataclass(frozen=True)
class GaitTiming:
    """Timing of a gait at speed ``speed`` (m/s) for thigh height ``thigh_height`` (m).

    ``rv`` = V/H_t; ``rv_shape`` = min(rv, rv_max) shapes the trajectories; ``cycle_length`` =
    RL_c(rv_shape) H_t (m); ``cycle_duration`` = cycle_length / V (s).
    """

    speed: float
    thigh_height: float
    rv_max: float = RV_MAX

    def __post_init__(self):
        if not (self.speed > 0):
            raise ValueError(f"walking speed must be positive, got {self.speed} m/s")
        if not (0 < self.rv_max <= RV_MAX):
            raise ValueError(f"rv_max must be in (0, {RV_MAX}], got {self.rv_max}")

    @property
    def rv(self) -> float:
        return self.speed / self.thigh_height

    @property
    def rv_shape(self) -> float:
        return min(self.rv, self.rv_max)

    @property
    def clamped(self) -> bool:
        return self.rv > self.rv_max

    @property
    def cycle_length(self) -> float:
        return relative_cycle_length(self.rv_shape) * self.thigh_height

    @property
    def cycle_duration(self) -> float:
        return self.cycle_length / self.speed


__all__ = ["BoulicGait", "GaitTiming", "RV_MAX", "relative_cycle_length"]
