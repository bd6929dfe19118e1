"""Matplotlib figures as a radar engineer reads them: dB colour scales, axes in m, m/s and degrees.

Every function draws into ``ax`` (a new figure when None) and returns the axes. Velocity axes
are the radial velocity (range rate, positive receding).
"""

from __future__ import annotations

import numpy as np


def _axes(ax, figsize=(6.4, 4.8)):
    if ax is None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=figsize, constrained_layout=True)
    return ax


def _db(power, dynamic_range):
    p = 10 * np.log10(np.maximum(np.asarray(power, float), 1e-300))
    top = p.max()
    return p, top - dynamic_range, top


def plot_range_doppler(rdmap, ax=None, dynamic_range=60.0, truth=None, title="Range-Doppler map"):
    """``rdmap``: :class:`~sionnafmcw.processing.RangeDopplerMap`; ``truth``: optional [(range, v_r), ...] markers."""
    ax = _axes(ax)
    p, lo, hi = _db(rdmap.power, dynamic_range)
    mesh = ax.pcolormesh(rdmap.velocities, rdmap.ranges, p.T, shading="nearest", vmin=lo, vmax=hi, cmap="viridis")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB W)")
    if truth is not None:
        truth = np.atleast_2d(truth)
        ax.plot(truth[:, 1], truth[:, 0], "r*", ms=9, mfc="none", label="truth")
        ax.legend(loc="upper right")
    ax.set_xlabel("radial velocity (m/s, + receding)")
    ax.set_ylabel("range (m)")
    ax.set_title(title)
    return ax


def plot_range_azimuth(ramap, ax=None, dynamic_range=50.0, truth=None, title="Range-azimuth map"):
    """``ramap``: :class:`~sionnafmcw.processing.RangeAzimuthMap` (``power`` [range, azimuth] or [azimuth, range])."""
    ax = _axes(ax)
    power = np.asarray(ramap.power)
    if power.shape == (len(ramap.azimuths), len(ramap.ranges)):
        power = power.T
    p, lo, hi = _db(power, dynamic_range)
    mesh = ax.pcolormesh(np.rad2deg(ramap.azimuths), ramap.ranges, p, shading="nearest", vmin=lo, vmax=hi,
                         cmap="viridis")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB W)")
    if truth is not None:
        truth = np.atleast_2d(truth)
        ax.plot(np.rad2deg(truth[:, 1]), truth[:, 0], "r*", ms=9, mfc="none", label="truth")
        ax.legend(loc="upper right")
    ax.set_xlabel("azimuth (deg, + towards radar +y)")
    ax.set_ylabel("range (m)")
    ax.set_title(title)
    return ax


def plot_doppler_time(times, velocities, truth_times=None, truth_velocities=None, ax=None,
                      spectrogram=None, title="Doppler-time"):
    """Estimated velocity per CPI (line), ground truth as red stars (the paper's Fig. 3).

    ``spectrogram``: optional :class:`~sionnafmcw.processing.MicroDopplerSpectrogram` drawn underneath.
    """
    ax = _axes(ax)
    if spectrogram is not None:
        p, lo, hi = _db(spectrogram.power, 40.0)
        ax.pcolormesh(spectrogram.times, spectrogram.velocities, p if p.shape[0] == len(spectrogram.velocities) else p.T,
                      shading="nearest", vmin=lo, vmax=hi, cmap="Greys")
    ax.plot(times, velocities, "b.-", label="estimate (strongest cell)")
    if truth_velocities is not None:
        ax.plot(truth_times if truth_times is not None else times, truth_velocities, "r*", label="ground truth")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("radial velocity (m/s, + receding)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return ax


def plot_micro_doppler(spectrogram, ax=None, dynamic_range=40.0, title="Micro-Doppler spectrogram"):
    """``spectrogram``: :class:`~sionnafmcw.processing.MicroDopplerSpectrogram`."""
    ax = _axes(ax)
    power = np.asarray(spectrogram.power)
    if power.shape != (len(spectrogram.velocities), len(spectrogram.times)):
        power = power.T
    p, lo, hi = _db(power, dynamic_range)
    mesh = ax.pcolormesh(spectrogram.times, spectrogram.velocities, p, shading="nearest", vmin=lo, vmax=hi,
                         cmap="magma")
    ax.figure.colorbar(mesh, ax=ax, label="power (dB)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("radial velocity (m/s, + receding)")
    ax.set_title(title)
    return ax


def save(ax, path) -> str:
    """Save the figure of ``ax`` as PNG and close it."""
    import matplotlib.pyplot as plt

    fig = ax.figure
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return str(path)
