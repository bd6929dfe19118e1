"""Doppler spectrum helpers of the motion-within-the-CPI tests: the band a linear frequency sweep occupies."""

import numpy as np

from sionnafmcw import processing


def spectrum_band(cube, radar):
    """The velocity axis (m/s) and the Doppler power spectrum of the strongest range bin (rectangular
    Doppler window, so that a linear frequency sweep gives a flat band)."""
    m = processing.range_doppler_map(cube, radar, window_doppler=None)
    k = int(np.argmax(m.power.max(axis=0)))
    p = m.power[:, k]
    return m.velocities, p


def band_edges(velocities, power, lo, hi, bin_v):
    """The velocities (m/s) where the spectrum crosses -6 dB of its mean power inside ``[lo + bin, hi - bin]``,
    lowest and highest, linearly interpolated between bins: the band edges of a linear sweep."""
    inside = (velocities >= lo + bin_v) & (velocities <= hi - bin_v)
    threshold = 0.25 * (power[inside].mean() if np.any(inside) else power.max())
    above = np.flatnonzero(power >= threshold)
    first, last = above.min(), above.max()

    def crossing(i, j):   # where the power crosses the threshold between bins i (below) and j (above)
        return velocities[i] + (threshold - power[i]) / (power[j] - power[i]) * (velocities[j] - velocities[i])

    low = crossing(first - 1, first) if first > 0 else velocities[first]
    high = crossing(last + 1, last) if last + 1 < velocities.size else velocities[last]
    return low, high
