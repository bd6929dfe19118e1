r"""Receiver thermal noise.

Complex white Gaussian noise referred to the receiver input, power per complex sample

.. math:: \sigma^2 = k_B T_0 F F_s,

with :math:`F = 10^{NF/10}` and :math:`F_s` the complex sampling rate (the noise bandwidth of a
complex baseband receiver sampled at :math:`F_s`). Real and imaginary parts each carry
:math:`\sigma^2/2`. After an :math:`N_sL`-point coherent FFT a target of received power
:math:`P_r` reaches :math:`\mathrm{SNR} = N_s L P_r / \sigma^2` (rectangular windows).
"""

from __future__ import annotations

import numpy as np


def thermal_noise(shape, radar, rng: np.random.Generator) -> np.ndarray:
    """Complex64 noise of the given shape with power ``radar.noise_power`` per sample."""
    sigma = np.sqrt(radar.noise_power / 2.0)
    noise = rng.standard_normal(shape, dtype=np.float32) + 1j * rng.standard_normal(shape, dtype=np.float32)
    return (sigma * noise).astype(np.complex64)
