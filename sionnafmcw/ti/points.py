r"""What a TI board's out-of-box (OOB) demo outputs for one frame: its detected points and the
frame-level side data its UART stream can carry.

This is the one hand-over between the on-chip chain (:mod:`sionnafmcw.ti.oob`, which computes it
from a beat cube and the ``.cfg``'s processing commands) and the writers of the formats real
pipelines read (:mod:`sionnafmcw.ti.formats`: the UART TLV stream, ROS 2 bags, RadHAR's text and
``.npz``).

Axes and signs are the SDK's, not sionnafmcw's radar frame: :math:`x` to the right of boresight
(sionnafmcw's :math:`-y`), :math:`y` along boresight (sionnafmcw's :math:`+x`), :math:`z` up;
``velocity`` is the radial velocity, positive receding (the design notes' :math:`v_r`). Every
value is the one the device reports, i.e. already on the device's output grid (SDK 1.x/2.x:
:math:`x, y, z` on the :math:`2^{-q}` m grid of ``xyz_q_format``; SDK 3.x: float32).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GuiMonitor:
    """The ``guiMonitor`` line: which TLVs the demo sends each frame.

    ``detected_objects``: 0 none, 1 the points (SDK 3.x: with side info, TLV 7), 2 the points
    without side info (SDK 3.x only). The others are on/off flags: ``log_mag_range`` (TLV 2, range
    profile), ``noise_profile`` (TLV 3), ``range_azimuth_heatmap`` (TLV 4, azimuth static
    heatmap), ``range_doppler_heatmap`` (TLV 5), ``stats`` (TLV 6).
    """

    detected_objects: int = 1
    log_mag_range: bool = False
    noise_profile: bool = False
    range_azimuth_heatmap: bool = False
    range_doppler_heatmap: bool = False
    stats: bool = False


@dataclass(frozen=True)
class DetectedPoints:
    r"""One frame of the OOB demo's output. Point arrays are ``[N]`` (N <= the demo's point limit).

    Parameters
    ----------
    frame_number : int
        The demo's frame counter (the UART header's ``frameNumber``).
    time : float
        CPI start of the frame (s), the run store's ``frame_time``.
    sdk : int
        Output generation: ``2`` (SDK 1.x/2.x, the xWR14xx layout) or ``3`` (SDK 3.x).
    platform : int
        The UART header's ``platform`` word (e.g. ``0xA1443``, ``0xA1843``, ``0xA6843``).
    x, y, z : float32 ``[N]``
        Position (m), SDK axes, on the device's output grid.
    velocity : float32 ``[N]``
        Radial velocity (m/s, positive receding): Doppler step times ``doppler_index``.
    range_index : uint16 ``[N]``
        Range FFT bin of the detection.
    doppler_index : int16 ``[N]``
        Signed Doppler bin (0 = zero velocity; negative approaching).
    peak_value : uint16 ``[N]``
        SDK 1.x/2.x ``peakVal``: the magnitude of the azimuth FFT at the point's angle bin, as the
        xWR14xx HWA outputs it (``MmwDemo_angleEstimationAzimElev``); SDK 3.x (not sent by the
        device): the detection matrix at the point (sum over virtual antennas of log2 magnitudes,
        Q8).
    snr_db, noise_db : float32 ``[N]``
        SDK 3.x side info (TLV 7), dB on the 0.1 dB grid the device sends; for SDK 1.x/2.x the same
        quantities from the detection matrix (not sent by the device).
    xyz_q_format : int
        SDK 1.x/2.x: the number of fractional bits of x, y, z (TLV 1's ``xyzQFormat``,
        :math:`\lceil\log_2(16/\Delta r)\rceil`); 0 for SDK 3.x (float output).
    range_step, doppler_step : float
        Range bin (m) and Doppler bin (m/s) of the demo's FFT grids.
    range_profile : uint16 ``[n_range]`` or None
        TLV 2: the detection matrix's zero-Doppler row.
    noise_profile : uint16 ``[n_range]`` or None
        TLV 3: the detection matrix's row at the highest Doppler bin (the SDK's noise profile).
    azimuth_static_heatmap : complex64 ``[n_range, n_virtual_azimuth]`` or None
        TLV 4: the zero-Doppler virtual-antenna samples (int16 I/Q on the wire).
    range_doppler_heatmap : uint16 ``[n_range, n_doppler]`` or None
        TLV 5: the detection matrix, Doppler unshifted (bin 0 = zero velocity).
    """

    frame_number: int
    time: float
    sdk: int
    platform: int
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    velocity: np.ndarray
    range_index: np.ndarray
    doppler_index: np.ndarray
    peak_value: np.ndarray
    snr_db: np.ndarray
    noise_db: np.ndarray
    xyz_q_format: int = 9
    range_step: float = 0.0
    doppler_step: float = 0.0
    range_profile: np.ndarray | None = None
    noise_profile: np.ndarray | None = None
    azimuth_static_heatmap: np.ndarray | None = None
    range_doppler_heatmap: np.ndarray | None = None

    @property
    def num_points(self) -> int:
        """Number of detected points."""
        return int(np.asarray(self.x).shape[0])

    @property
    def range(self) -> np.ndarray:
        """Range of each point (m), from its reported coordinates."""
        return np.sqrt(np.asarray(self.x, float) ** 2 + np.asarray(self.y, float) ** 2
                       + np.asarray(self.z, float) ** 2)
