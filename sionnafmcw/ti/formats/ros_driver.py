r"""What TI's ROS drivers make of one frame of the out-of-box demo's UART stream.

RadHAR (and most TI-based human-sensing data sets) were recorded through the TI ROS driver
(``ti_mmwave_rospkg``, ROS 1; its ROS 2 port ``ti_mmwave_rospkg`` of TI's ``mmwave_ti_ros``
``ros2_driver``), not from the UART directly. The driver turns each detected point into ROS
quantities in ``DataHandlerClass.cpp`` (``sortIncomingData``, read in both versions):

* axes: ROS :math:`x` = sensor :math:`y` (forward), ROS :math:`y = -` sensor :math:`x` (left),
  :math:`z` up;
* SDK 1.x/2.x (points with indices): ``range = rangeIdx * range_resolution``,
  ``velocity = dopplerIdx * doppler_vel_resolution``, ``doppler_bin = dopplerIdx + numLoops / 2``
  (uint16, integer division), ``bearing = atan2(-x_s, y_s)`` in degrees (positive to the left),
  ``intensity = 10 log10(peakVal + 1)`` dB;
* SDK 3.x (float points): ``x, y, z, velocity`` from TLV 1 and ``intensity = snr / 10`` dB from
  the side info (TLV 7, snr in 0.1 dB steps);
* a point is published only when ROS :math:`x \ne 0`, and, when the launch file sets them below
  90 degrees, :math:`z^2 / (x^2 + y^2) < \tan^2(\text{elevation limit})` and
  :math:`|y / x| < \tan(\text{azimuth limit})`; ``point_id`` keeps the point's index in the
  device's list (RadHAR's dumps skip the ids of the dropped points).

The driver's grid steps are not the device's FFT bins but what its ``ParameterParser`` derives
from the ``.cfg`` (float32 arithmetic, :math:`c_0 = 299792458` m/s):

.. math::
    B = \mu\,N_s / F_s,\qquad \Delta R = \frac{c_0}{2 B},\qquad
    f_c = f_0 + \mu\,(t_\text{adc} + N_s / (2 F_s)),\qquad
    \Delta v = \frac{c_0}{2 f_c\,T_c\,N_\text{tx}\,N_\text{loops}}

(:math:`T_c` = idle + ramp end time). With 240 samples on a 256-point range FFT, RadHAR's
``range`` (0.0436 m steps) is therefore not the range of the reported :math:`x, y, z`
(0.0409 m bins): this is the driver's behaviour, kept as is.

For SDK 3.x points the ROS 1 driver's ``RadarScan`` leaves ``range``, ``doppler_bin``,
``bearing`` and ``intensity`` unset (stale values of the previous message); here they are filled
with the same quantities computed from the point (its Doppler index, :math:`\sqrt{x^2+y^2+z^2}`,
the bearing above and snr/10), so that every record is meaningful.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..points import DetectedPoints

#: Speed of light as the driver's ParameterParser uses it (float32).
C0 = np.float32(299792458.0)


@dataclass(frozen=True)
class DriverParams:
    """The TI ROS driver's parameters that enter its point conversion.

    Parameters
    ----------
    range_resolution : float
        ``/ti_mmwave/range_resolution`` (m): :math:`c_0 / (2 B)`, :math:`B` the sampled sweep.
    doppler_vel_resolution : float
        ``/ti_mmwave/doppler_vel_resolution`` (m/s).
    num_loops : int
        ``/ti_mmwave/numLoops`` (``frameCfg``'s loops): the offset of ``doppler_bin``.
    frame_id : str
        The launch file's ``frame_id`` (``"ti_mmwave"`` in TI's launch files and RadHAR).
    max_elevation_deg, max_azimuth_deg : float
        The launch file's angle limits; 90 (the driver's default) disables the test.
    """

    range_resolution: float
    doppler_vel_resolution: float
    num_loops: int
    frame_id: str = "ti_mmwave"
    max_elevation_deg: float = 90.0
    max_azimuth_deg: float = 90.0

    @classmethod
    def from_radar(cls, radar, **kwargs) -> "DriverParams":
        """The parameters the driver's ParameterParser derives from the ``.cfg`` of ``radar``.

        ``radar`` is a :class:`~sionnafmcw.radar.RadarConfig` (SI units); the arithmetic is the
        driver's, in float32 (see the module docstring).
        """
        f32 = np.float32
        fs = f32(radar.fs)
        kf = f32(radar.slope)
        nr = f32(radar.num_samples)
        adc_duration = f32(nr / fs)
        bw = f32(adc_duration * kf)
        pri = f32(radar.chirp_interval)
        fc = f32(f32(radar.fc) + kf * f32(f32(radar.adc_start_time) + adc_duration / f32(2)))
        ntx = len(radar.tx_order)
        vrange = f32(C0 / (f32(2) * bw))
        max_vel = f32(C0 / (f32(2) * fc * pri) / f32(ntx))
        vvel = f32(max_vel / f32(radar.num_chirps))
        return cls(range_resolution=float(vrange), doppler_vel_resolution=float(vvel),
                   num_loops=int(radar.num_chirps), **kwargs)


@dataclass(frozen=True)
class RosScan:
    """One frame as the driver publishes it (ROS axes); arrays ``[K]`` over the published points.

    ``point_id`` is the point's index in the device's list; ``x, y, z, range, velocity, bearing,
    intensity`` float32 (m, m/s, degrees, dB); ``doppler_bin`` uint16.
    """

    point_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    range: np.ndarray
    velocity: np.ndarray
    doppler_bin: np.ndarray
    bearing: np.ndarray
    intensity: np.ndarray

    @property
    def num_points(self) -> int:
        return int(self.point_id.shape[0])


def intensity_db(points: DetectedPoints) -> np.ndarray:
    """The driver's ``intensity`` (dB, float32): SDK 1.x/2.x ``10 log10(peakVal + 1)``, SDK 3.x
    ``snr / 10`` with snr the side info's int16 in 0.1 dB."""
    if points.sdk == 3:
        snr = np.round(np.asarray(points.snr_db, np.float64) * 10.0).astype(np.int16)
        return (snr / 10.0).astype(np.float32)
    peak = np.asarray(points.peak_value, np.uint16).astype(np.float64)
    return (10.0 * np.log10(peak + 1.0)).astype(np.float32)


def ros_scan(points: DetectedPoints, params: DriverParams) -> RosScan:
    """Convert one frame as ``DataHandlerClass.cpp`` does, keeping the points it publishes."""
    f32 = np.float32
    xs = np.asarray(points.x, f32)
    ys = np.asarray(points.y, f32)
    zs = np.asarray(points.z, f32)
    doppler = np.asarray(points.doppler_index, np.int16).astype(np.int32)
    if points.sdk == 3:
        velocity = np.asarray(points.velocity, f32)
        rng = np.sqrt(xs * xs + ys * ys + zs * zs).astype(f32)
    else:
        velocity = (doppler.astype(f32) * f32(params.doppler_vel_resolution)).astype(f32)
        rng = (np.asarray(points.range_index, np.uint16).astype(f32)
               * f32(params.range_resolution)).astype(f32)
    x_ros, y_ros = ys, (-xs).astype(f32)
    bearing = (np.arctan2(-xs, ys).astype(np.float64) / np.pi * 180.0).astype(f32)
    doppler_bin = (doppler + params.num_loops // 2).astype(np.uint16)
    keep = x_ros != 0
    with np.errstate(divide="ignore", invalid="ignore"):
        if 0 <= params.max_elevation_deg < 90:
            ratio2 = f32(np.tan(np.radians(params.max_elevation_deg))) ** 2
            keep &= (zs * zs) / (x_ros * x_ros + y_ros * y_ros) < ratio2
        if 0 <= params.max_azimuth_deg < 90:
            keep &= np.abs(y_ros / x_ros) < f32(np.tan(np.radians(params.max_azimuth_deg)))
    ids = np.flatnonzero(keep)
    return RosScan(point_id=ids.astype(np.uint16), x=x_ros[ids], y=y_ros[ids], z=zs[ids],
                   range=rng[ids], velocity=velocity[ids], doppler_bin=doppler_bin[ids],
                   bearing=bearing[ids], intensity=intensity_db(points)[ids])
