r"""I/Q imbalance of the quadrature receiver: gain and phase mismatch between the I and Q branches.

With the Q branch's gain :math:`g = 10^{\epsilon/20}` (``gain_db`` :math:`\epsilon`) and phase
error :math:`\phi` (``phase_deg``) relative to the I branch, the received
:math:`I' = I`, :math:`Q' = g(Q\cos\phi - I\sin\phi)` is

.. math:: r = \mu x + \nu\bar x,\qquad \mu = \frac{1 + g e^{-j\phi}}{2},\quad \nu = \frac{1 - g e^{j\phi}}{2},

so every tone at :math:`f` gets an image at :math:`-f` (range bin :math:`N - k`) with the image
rejection ratio

.. math:: \mathrm{IRR} = \frac{|\mu|^2}{|\nu|^2} = \frac{1 + 2g\cos\phi + g^2}{1 - 2g\cos\phi + g^2}

(:func:`image_rejection_ratio`; 28.2 dB for 0.5 dB and 3 degrees). It acts on the sampled cube, signal
and noise, after the IF chain (for real, equal I and Q filters the order does not matter). Off by
default: TI's complex-1x mode removes the image band in its digital filter, so the boards' cubes
show no image (model a real I/Q receiver, or TI's complex-2x mode, with it).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

_KEYS = ("gain_db", "phase_deg")


class IQImbalanceError(ValueError):
    """An I/Q imbalance that cannot work; the message names the field."""


def check(spec, where: str = "RadarConfig.iq_imbalance"):
    """Validate ``{"gain_db": ..., "phase_deg": ...}`` (None stays None); return it with float values."""
    if spec is None:
        return None
    if not isinstance(spec, dict) or set(spec) != set(_KEYS):
        raise IQImbalanceError(f"{where} must be a dict {{'gain_db': Q/I gain mismatch (dB), 'phase_deg': Q phase "
                               f"error (degrees)}}, got {spec!r}")
    out = {}
    for key in _KEYS:
        value = spec[key]
        if (not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_))
                or not math.isfinite(value)):
            raise IQImbalanceError(f"{where}.{key} must be a finite number, got {value!r}")
        out[key] = float(value)
    if abs(out["phase_deg"]) >= 90:
        raise IQImbalanceError(f"{where}.phase_deg must lie within (-90, 90) degrees, got {out['phase_deg']!r}")
    return out


def coefficients(spec) -> tuple[complex, complex]:
    r""":math:`(\mu, \nu)` of the module docstring."""
    g = 10.0 ** (spec["gain_db"] / 20.0)
    phi = math.radians(spec["phase_deg"])
    return (1 + g * np.exp(-1j * phi)) / 2, (1 - g * np.exp(1j * phi)) / 2


def image_rejection_ratio(spec) -> float:
    """IRR (linear power ratio) of the module docstring."""
    g = 10.0 ** (spec["gain_db"] / 20.0)
    c = math.cos(math.radians(spec["phase_deg"]))
    return (1 + 2 * g * c + g * g) / (1 - 2 * g * c + g * g)


def apply(cube: np.ndarray, spec) -> np.ndarray:
    r""":math:`\mu x + \nu\bar x` (a new array of the cube's dtype)."""
    mu, nu = coefficients(spec)
    return (mu * cube + nu * np.conj(cube)).astype(cube.dtype)


__all__ = ["IQImbalanceError", "apply", "check", "coefficients", "image_rejection_ratio"]
