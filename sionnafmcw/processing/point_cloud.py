r"""Detections to a radar point cloud.

Chain for one CPI:

1. :func:`range_doppler` (optional static clutter removal) and the non-coherent map
   :math:`P = \sum_{m,n}|Y|^2`;
2. CFAR on :math:`P` (:func:`ca_cfar_2d` or :func:`os_cfar_2d`), optionally thinned to the local
   maxima of :math:`P` (3x3, wrap along Doppler) so that one target gives one point;
3. sub-bin range and velocity by log-parabolic interpolation (:func:`interpolate_peak`), and the
   range-Doppler coupling removed (:func:`range_doppler_coupling`);
4. the detection's virtual snapshot :math:`Y_{i,:,:,k}`, TDM phase compensated at the detection's
   velocity, and its direction from the Bartlett maximum with exact element positions
   (:func:`estimate_direction`): azimuth always, elevation when the layout has an elevation
   aperture (otherwise elevation is taken as 0 for the coordinates and reported as ``None``);
5. Cartesian position in the radar frame :math:`\mathbf c + R\,\hat{\mathbf u}(\phi, \theta_e)`
   (boresight +x, azimuth towards +y, elevation towards +z), at the CPI time of the range peak;
   ranges are measured from the array phase centre :math:`\mathbf c` (:func:`sionnafmcw.array.phase_centre`).

``snr`` is :math:`10\log_{10}(P/\hat\sigma^2)` with the CFAR's local noise estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..echoes import target_direction
from .angle import estimate_direction
from .cfar import ca_cfar_2d, os_cfar_2d
from .fast_time import range_axis, range_doppler_coupling
from ..array import has_elevation_aperture, phase_centre
from .mimo import tdm_phase_compensation, virtual_channels
from .peaks import interpolate_peak, local_maxima, uniform_axis_value
from .rdmap import range_doppler
from .slow_time import velocity_axis


@dataclass
class PointCloud:
    """One CPI's detections, every array ``[point]``.

    ``range`` (m, from the array phase centre), ``velocity`` (m/s, + receding), ``azimuth`` and ``elevation`` (rad;
    ``elevation`` is ``None`` when the array cannot measure it), ``x, y, z`` (m, radar frame),
    ``power`` (range-Doppler map value), ``noise`` (CFAR estimate), ``snr`` (dB),
    ``doppler_index, range_index`` (map cell).
    """

    range: np.ndarray
    velocity: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray | None
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    power: np.ndarray
    noise: np.ndarray
    snr: np.ndarray
    doppler_index: np.ndarray
    range_index: np.ndarray

    def __len__(self) -> int:
        return int(self.range.size)

    @property
    def positions(self) -> np.ndarray:
        """``[point, 3]`` radar-frame coordinates (m)."""
        return np.stack([self.x, self.y, self.z], axis=-1)


def detections_to_point_cloud(cube, radar, cfar: str = "ca", guard=(2, 2), train=(8, 8), pfa: float = 1e-4,
                              rank: int | None = None, clutter_removal: bool = True, peaks_only: bool = True,
                              interpolate: bool = True, correct_coupling: bool = True, range_gate=None,
                              window_range="hann", window_doppler="hann", n_range: int | None = None,
                              n_doppler: int | None = None, max_points: int | None = None) -> PointCloud:
    """Point cloud of one CPI ``[chirp, tx, rx, sample]`` (see the module docstring).

    Parameters
    ----------
    cfar : {"ca", "os"}
        Detector; ``guard``, ``train`` (half-widths, doppler x range), ``pfa`` and ``rank`` (OS) go to it.
    peaks_only : bool
        Keep only detections that are 3x3 local maxima of the map.
    correct_coupling : bool
        Subtract the range-Doppler coupling :math:`v(f_c + 2\\mu t_{mid})/\\mu` from the ranges.
    range_gate : (min, max) in m, optional
        Drop detections outside.
    max_points : int, optional
        Keep the strongest ones.
    """
    rd = range_doppler(cube, radar, window_range, window_doppler, clutter_removal, n_range, n_doppler)
    power = np.sum(np.abs(rd) ** 2, axis=(1, 2)).astype(float)
    if cfar == "ca":
        res = ca_cfar_2d(power, guard, train, pfa)
    elif cfar == "os":
        res = os_cfar_2d(power, guard, train, pfa, rank=rank)
    else:
        raise ValueError(f"detections_to_point_cloud: unknown cfar {cfar!r}; use 'ca' or 'os'")
    det = res.detections & (local_maxima(power) if peaks_only else True)
    ranges_axis = range_axis(radar, rd.shape[-1])
    vel_axis = velocity_axis(radar, rd.shape[0])
    if range_gate is not None:
        lo, hi = (-np.inf if g is None else g for g in range_gate)
        det &= ((ranges_axis >= lo) & (ranges_axis <= hi))[None, :]
    di, ri = np.nonzero(det)
    order = np.argsort(-power[di, ri], kind="stable")
    if max_points is not None:
        order = order[:max_points]
    di, ri = di[order], ri[order]
    if interpolate and di.size:
        fd = interpolate_peak(power, (di, ri), axis=0, circular=True)
        fr = interpolate_peak(power, (di, ri), axis=1)
    else:
        fd, fr = di.astype(float), ri.astype(float)
    vmax = radar.centre_wavelength / (4.0 * radar.block_interval)
    vel = (uniform_axis_value(vel_axis, fd) + vmax) % (2 * vmax) - vmax
    rng = uniform_axis_value(ranges_axis, fr)
    if correct_coupling:
        rng = rng - range_doppler_coupling(vel, radar)
    use_el = has_elevation_aperture(radar)
    az = np.empty(di.size)
    el = np.zeros(di.size)
    for j, (i, k) in enumerate(zip(di, ri)):  # one angle search per detection
        snap = tdm_phase_compensation(rd[i, :, :, k], radar, vel[j], tx_axis=0)
        a, e, _ = estimate_direction(virtual_channels(snap, 0), radar, elevation=use_el)
        az[j] = a
        el[j] = 0.0 if e is None else e
    xyz = phase_centre(radar) + rng[:, None] * target_direction(az, el) if di.size else np.zeros((0, 3))
    p, noise = power[di, ri], res.noise[di, ri]
    with np.errstate(divide="ignore"):
        snr = 10.0 * np.log10(p / noise)
    return PointCloud(rng, vel, az, el if use_el else None, xyz[:, 0], xyz[:, 1], xyz[:, 2], p, noise, snr, di, ri)
