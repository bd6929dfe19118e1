r"""Small motions of a still person: breathing and heartbeat at the chest wall, postural sway.

Chest-wall displacement
-----------------------
Along the chest's outward normal :math:`\hat{\mathbf n}` (the thorax's forward axis),

.. math::
    d(t) = \frac{A_b}{2}\bigl(1 - \cos(2\pi f_b t + \varphi_b)\bigr)
         + \frac{A_h}{2}\bigl(1 - \cos(2\pi f_h t + \varphi_h)\bigr),

with peak-to-peak amplitudes and rates within the ranges radar vital-sign studies use
(:data:`BREATHING_RATE` 0.1-0.5 Hz, 6-30 breaths/min; :data:`BREATHING_AMPLITUDE` 4-12 mm;
:data:`HEART_RATE` 0.8-2 Hz, 48-120 beats/min; :data:`HEART_AMPLITUDE` 0.1-0.5 mm).
:meth:`VitalSigns.draw` draws rates and amplitudes uniformly within them and phases uniformly
in :math:`[0, 2\pi)`. At 77 GHz a displacement :math:`d` turns the echo's phase by
:math:`4\pi d/\lambda`: 16 rad for 5 mm of breathing, 0.32 rad for 0.1 mm of heartbeat.

The model moves the thorax segment rigidly along :math:`\hat{\mathbf n}` (:func:`chest_wall`): its
front, the surface a radar in front of (or above) the chest sees, moves by :math:`d(t)`; its back
moves too, which a real chest's does far less, but the back faces away from the radar (a chair
back or the floor is not modelled behind it). A deforming chest (front moving, back still) would
need a PLY per frame (the data contract allows it) and gives the same front-surface phase.

Postural sway
-------------
A person standing (or sitting) still is not still: the body sways as an inverted pendulum about the
ankles (the seat), its centre of mass wandering a few millimetres, mostly below 1 Hz (quiet-stance
centre-of-pressure excursions are of the order of 5 mm RMS in healthy adults: e.g. T. E. Prieto et
al., "Measures of postural steadiness", *IEEE Trans. Biomed. Eng.* 43(9), 1996). :class:`PosturalSway`
turns the segments about a pivot by small angles :math:`\theta_{AP}(t)` (about the body's left axis)
and :math:`\theta_{ML}(t)` (about its forward axis), each a sum of :data:`SWAY_COMPONENTS` sinusoids at
frequencies drawn uniformly in :data:`SWAY_BAND` with random phases, scaled so that the point
``lever`` metres above the pivot moves ``rms`` metres RMS (the two directions sharing it,
anteroposterior twice the mediolateral variance, as quiet stance shows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

BREATHING_RATE = (0.1, 0.5)          # Hz
BREATHING_AMPLITUDE = (0.004, 0.012)  # m, peak to peak
HEART_RATE = (0.8, 2.0)              # Hz
HEART_AMPLITUDE = (0.0001, 0.0005)   # m, peak to peak
SWAY_BAND = (0.05, 0.8)              # Hz
SWAY_COMPONENTS = 12


def _check(name, value, bounds):
    if not (bounds[0] <= value <= bounds[1]):
        raise ValueError(f"VitalSigns: {name}={value!r} is outside {bounds[0]}..{bounds[1]}")


@dataclass(frozen=True)
class VitalSigns:
    """Chest-wall displacement (module docstring): rates (Hz), peak-to-peak amplitudes (m), phases (rad)."""

    breathing_rate: float = 0.25
    breathing_amplitude: float = 0.005
    heart_rate: float = 1.2
    heart_amplitude: float = 0.0003
    breathing_phase: float = 0.0
    heart_phase: float = 0.0

    def __post_init__(self):
        _check("breathing_rate", self.breathing_rate, BREATHING_RATE)
        _check("breathing_amplitude", self.breathing_amplitude, BREATHING_AMPLITUDE)
        _check("heart_rate", self.heart_rate, HEART_RATE)
        _check("heart_amplitude", self.heart_amplitude, HEART_AMPLITUDE)

    @classmethod
    def draw(cls, rng) -> "VitalSigns":
        """Rates and amplitudes uniform within the physiological ranges, phases uniform (``rng``: a Generator or seed)."""
        rng = np.random.default_rng(rng)
        return cls(float(rng.uniform(*BREATHING_RATE)), float(rng.uniform(*BREATHING_AMPLITUDE)),
                   float(rng.uniform(*HEART_RATE)), float(rng.uniform(*HEART_AMPLITUDE)),
                   float(rng.uniform(0, 2 * math.pi)), float(rng.uniform(0, 2 * math.pi)))

    def displacement(self, t) -> np.ndarray:
        """:math:`d(t)` (m) outward along the chest normal."""
        t = np.asarray(t, float)
        return (0.5 * self.breathing_amplitude * (1 - np.cos(2 * np.pi * self.breathing_rate * t + self.breathing_phase))
                + 0.5 * self.heart_amplitude * (1 - np.cos(2 * np.pi * self.heart_rate * t + self.heart_phase)))

    def velocity(self, t) -> np.ndarray:
        """:math:`\\dot d(t)` (m/s)."""
        t = np.asarray(t, float)
        wb, wh = 2 * np.pi * self.breathing_rate, 2 * np.pi * self.heart_rate
        return (0.5 * self.breathing_amplitude * wb * np.sin(wb * t + self.breathing_phase)
                + 0.5 * self.heart_amplitude * wh * np.sin(wh * t + self.heart_phase))

    def to_dict(self) -> dict:
        return {k: float(getattr(self, k)) for k in ("breathing_rate", "breathing_amplitude", "heart_rate",
                                                     "heart_amplitude", "breathing_phase", "heart_phase")}


def chest_wall(vitals: VitalSigns, forward_local, segment: str = "torso"):
    """A movement for :class:`~sionnafmcw.mocap.person.PosedPerson`: ``segment`` translated by
    :math:`d(t)\\hat{\\mathbf n}`, :math:`\\hat{\\mathbf n} = \\mathbf R\\,` ``forward_local`` (the segment
    frame's forward axis in the world, turned with any sway applied before)."""
    f = np.asarray(forward_local, float)
    f = f / np.linalg.norm(f)

    def move(times, poses):
        r, p = poses[segment]
        n = np.einsum("tab,b->ta", r, f)
        out = dict(poses)
        out[segment] = (r, p + vitals.displacement(times)[:, None] * n)
        return out

    return move


def _rotation_about(axis, angle):
    """Rodrigues rotations ``[T, 3, 3]`` about the unit ``axis`` by ``angle [T]`` (rad)."""
    k = np.asarray(axis, float)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a = np.asarray(angle, float)[:, None, None]
    return np.eye(3) + np.sin(a) * kx + (1 - np.cos(a)) * (kx @ kx)


class PosturalSway:
    """Inverted-pendulum sway about ``pivot`` [3] (m, world) of the ``segments`` (None: all) of a posture
    whose body axes are ``forward`` and ``left`` (world, horizontal); ``rms`` (m) at ``lever`` m above
    the pivot; ``seed`` draws the frequencies and phases (module docstring)."""

    def __init__(self, pivot, forward, left, rms: float, lever: float, seed=0, segments=None):
        if rms < 0 or not math.isfinite(rms):
            raise ValueError(f"PosturalSway: rms must be >= 0 m, got {rms!r}")
        if not lever > 0:
            raise ValueError(f"PosturalSway: lever must be > 0 m, got {lever!r}")
        self.pivot = np.asarray(pivot, float)
        self.forward = np.asarray(forward, float) / np.linalg.norm(forward)
        self.left = np.asarray(left, float) / np.linalg.norm(left)
        self.segments = None if segments is None else set(segments)
        rng = np.random.default_rng(seed)
        theta_rms = rms / lever
        self.components = []
        for axis, share in ((self.left, 2.0 / 3.0), (self.forward, 1.0 / 3.0)):   # AP: 2x the ML variance
            f = rng.uniform(*SWAY_BAND, SWAY_COMPONENTS)
            phase = rng.uniform(0, 2 * math.pi, SWAY_COMPONENTS)
            amp = np.full(SWAY_COMPONENTS, theta_rms * math.sqrt(share) * math.sqrt(2.0 / SWAY_COMPONENTS))
            self.components.append((axis, f, phase, amp))

    def angles(self, times) -> list[np.ndarray]:
        """``[theta_AP [T], theta_ML [T]]`` (rad)."""
        t = np.asarray(times, float)[:, None]
        return [np.sum(a * np.sin(2 * np.pi * f * t + ph), axis=1) for _, f, ph, a in self.components]

    def __call__(self, times, poses):
        times = np.atleast_1d(np.asarray(times, float))
        (ax_ap, *_), (ax_ml, *_) = self.components
        th_ap, th_ml = self.angles(times)
        s = np.einsum("tab,tbc->tac", _rotation_about(ax_ap, th_ap), _rotation_about(ax_ml, th_ml))
        out = {}
        for k, (r, p) in poses.items():
            if self.segments is not None and k not in self.segments:
                out[k] = (r, p)
                continue
            out[k] = (np.einsum("tab,tbc->tac", s, r), np.einsum("tab,tb->ta", s, p - self.pivot) + self.pivot)
        return out


__all__ = ["BREATHING_AMPLITUDE", "BREATHING_RATE", "HEART_AMPLITUDE", "HEART_RATE", "PosturalSway", "SWAY_BAND",
           "SWAY_COMPONENTS", "VitalSigns", "chest_wall"]
