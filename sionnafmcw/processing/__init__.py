r"""Radar signal processing of TDM-MIMO FMCW beat cubes.

Input: one CPI ``[chirp, tx, rx, sample]`` (complex, Tx in physical order), or frames of them
``[frame, chirp, tx, rx, sample]``. Conventions (:mod:`sionnafmcw.store`): range bins of the unshifted
range FFT span :math:`[0, R_{max})`; Doppler spectra are ``fftshift``-ed and every velocity is the
radial velocity :math:`v_r` (m/s, positive receding) on the sweep-centre wavelength
:math:`\lambda_{mid}`; angles are radians, azimuth positive towards +y, elevation towards +z.

Modules: :mod:`.windows` (unit-sum windows), :mod:`.fast_time` (range), :mod:`.clutter`,
:mod:`.slow_time` (Doppler), :mod:`.rdmap` (range-Doppler), :mod:`.mimo` (virtual channels, TDM
phase; the array geometry itself is :mod:`sionnafmcw.array`), :mod:`.angle` (angle FFT, Bartlett, range-azimuth), :mod:`.cfar`, :mod:`.peaks`
(sub-bin interpolation), :mod:`.micro_doppler` (Doppler track, spectrogram),
:mod:`.point_cloud`, :mod:`sionnafmcw.processing.vitals` (breathing and heart rate from the chest bin's phase).
"""

from .angle import (AngleSpectrum, RangeAzimuthMap, angle_fft, bartlett_spectrum, estimate_direction,
                    range_azimuth_map, steering_vectors)
from .cfar import CFARResult, ca_cfar_2d, ca_cfar_factor, cfar_footprint, os_cfar_2d, os_cfar_factor
from .clutter import remove_static_clutter
from .fast_time import range_axis, range_doppler_coupling, range_fft
from .micro_doppler import DopplerTrack, MicroDopplerSpectrogram, doppler_time, micro_doppler_spectrogram
from .mimo import tdm_phase_compensation, virtual_channels
from .peaks import interpolate_peak, local_maxima, parabolic_offset, uniform_axis_value
from .point_cloud import PointCloud, detections_to_point_cloud
from .rdmap import RangeDopplerMap, range_doppler, range_doppler_map
from .slow_time import doppler_fft, velocity_axis
from .vitals import VitalSignsEstimate, vital_signs
from .windows import window_weights

__all__ = [
    "AngleSpectrum", "CFARResult", "DopplerTrack", "MicroDopplerSpectrogram", "PointCloud", "RangeAzimuthMap",
    "RangeDopplerMap", "VitalSignsEstimate", "angle_fft", "bartlett_spectrum", "ca_cfar_2d", "ca_cfar_factor", "cfar_footprint",
    "detections_to_point_cloud", "doppler_fft", "doppler_time", "estimate_direction",
    "interpolate_peak", "local_maxima", "micro_doppler_spectrogram", "os_cfar_2d", "os_cfar_factor",
    "parabolic_offset", "range_axis", "range_azimuth_map", "range_doppler", "range_doppler_coupling",
    "range_doppler_map", "range_fft", "remove_static_clutter", "steering_vectors", "tdm_phase_compensation",
    "uniform_axis_value", "velocity_axis", "virtual_channels", "vital_signs",
    "window_weights",
]
