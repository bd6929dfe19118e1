r"""The out-of-box demo's UART byte stream: one packet per frame, TLVs as ``guiMonitor`` selects.

Every field is little-endian, as the device's R4F writes its structs. A packet is

=============================  ==============================================================
part                           fields
=============================  ==============================================================
header, SDK 1.x/2.x: 36 B      ``magicWord`` u16[4] = 0x0102 0x0304 0x0506 0x0708 (the bytes
                               ``02 01 04 03 06 05 08 07``), then u32 ``version``,
                               ``totalPacketLen``, ``platform``, ``frameNumber``,
                               ``timeCpuCycles``, ``numDetectedObj``, ``numTLVs``
header, SDK 3.x: 40 B          the same plus u32 ``subFrameNumber``
each TLV                       u32 ``type``, u32 ``length`` (of the payload, header
                               excluded), payload
padding                        zero bytes up to a multiple of 32 bytes
                               (``MMWDEMO_OUTPUT_MSG_SEGMENT_LEN``); ``totalPacketLen``
                               counts header, TLVs and padding
=============================  ==============================================================

TLVs and their payloads, in the order the demo sends them:

====  =====================  ================================================================
type  ``guiMonitor`` flag    payload
====  =====================  ================================================================
1     detectedObjects        SDK 1.x/2.x (``MmwDemo_output_message_dataObjDescr`` +
                             ``MmwDemo_detectedObj``): u16 numObj, u16 xyzQFormat, then per
                             point u16 rangeIdx, i16 dopplerIdx, u16 peakVal, i16 x, y, z
                             (m in Q ``xyzQFormat``); sent when detectedObjects = 1 and there
                             are points. SDK 3.x (``DPIF_PointCloudCartesian``): per point
                             float32 x, y, z, velocity; sent when detectedObjects = 1 (also
                             with no point: the SDK's ``1 || (2 && n > 0)`` test) or when it is
                             2 and there are points
7     detectedObjects = 1    SDK 3.x only, after TLV 1 (``DPIF_PointCloudSideInfo``): per
                             point i16 snr, i16 noise in 0.1 dB; sent when there are points
2     logMagRange            u16 per range bin: the detection matrix at zero Doppler
3     noiseProfile           u16 per range bin: the detection matrix at the noise Doppler bin
4     rangeAzimuthHeatMap    ``cmplx16ImRe_t`` (i16 imag, i16 real) per range bin and virtual
                             azimuth antenna, antenna fastest
5     rangeDopplerHeatMap    u16 per range bin and Doppler bin, Doppler fastest
6     statsInfo              6 x u32 (``MmwDemo_output_message_stats``: inter-frame processing
                             time, transmit output time, inter-frame processing margin,
                             inter-chirp processing margin, active-frame and inter-frame CPU
                             load)
9     statsInfo              SDK 3.x only, after TLV 6 (``MmwDemo_temperatureStats``): i32
                             tempReportValid, u32 time, i16 x 10 sensor temperatures
====  =====================  ================================================================

Layouts: SDK 1.x/2.x as the xWR14xx demo (``mmw_output.h``, ``detected_obj.h``, the demo's
``MmwDemo_transmitProcessedOutput``) and TI's ROS driver (``DataHandlerClass.cpp``) read it;
SDK 3.x as the xWR18xx/68xx demo of SDK 3.4 (``mmw_output.h``, ``dpif_pointcloud.h``). The header's
``version`` is ``major << 24 | minor << 16 | bugfix << 8 | build`` (:data:`SDK_VERSION`; the ROS
driver picks the layout on ``version >> 24 < 3``).

What a simulation cannot know is written as the device's "nothing": the processing-time
statistics (TLV 6) are zeros, the temperature report (TLV 9) has ``tempReportValid = -1`` (not
valid) and zero readings. ``timeCpuCycles`` is the R4F's 200 MHz cycle counter at the frame's
CPI start, modulo :math:`2^{32}`.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
import numpy as np

from ...fs import atomic_write_bytes
from ..points import DetectedPoints, GuiMonitor

MAGIC_WORD = bytes([2, 1, 4, 3, 6, 5, 8, 7])
#: Packets are padded to a multiple of this many bytes.
SEGMENT_LEN = 32
#: The header's ``version`` word per output generation (SDK 2.1.0.4 for xWR14xx, SDK 3.4.0.3).
SDK_VERSION = {2: (2, 1, 0, 4), 3: (3, 4, 0, 3)}
#: The R4F clock that ``timeCpuCycles`` counts (Hz).
CPU_CLOCK = 200e6

DETECTED_POINTS = 1
RANGE_PROFILE = 2
NOISE_PROFILE = 3
AZIMUTH_STATIC_HEAT_MAP = 4
RANGE_DOPPLER_HEAT_MAP = 5
STATS = 6
DETECTED_POINTS_SIDE_INFO = 7
TEMPERATURE_STATS = 9


class TlvError(ValueError):
    """A frame that cannot be written in the layout asked for; the message names what is missing."""


def _version_word(sdk: int) -> int:
    major, minor, bugfix, build = SDK_VERSION[sdk]
    return (major << 24) | (minor << 16) | (bugfix << 8) | build


def _int16(values, what: str, frame: int) -> np.ndarray:
    a = np.round(np.asarray(values, np.float64))
    if a.size and (a.min() < -32768 or a.max() > 32767):
        raise TlvError(f"frame {frame}: {what} does not fit the int16 of the UART layout")
    return a.astype("<i2")


def _required(array, what: str, flag: str, frame: int) -> np.ndarray:
    if array is None:
        raise TlvError(f"frame {frame}: guiMonitor's {flag} asks for the {what}, which the frame "
                       f"does not carry; set {flag} to 0 or compute the frame with it")
    return np.asarray(array)


def _points_sdk2(p: DetectedPoints) -> bytes:
    scale = 2.0 ** p.xyz_q_format
    n = p.num_points
    rec = np.zeros(n, dtype=[("range", "<u2"), ("doppler", "<i2"), ("peak", "<u2"),
                             ("x", "<i2"), ("y", "<i2"), ("z", "<i2")])
    rec["range"] = np.asarray(p.range_index, np.uint16)
    rec["doppler"] = np.asarray(p.doppler_index, np.int16)
    rec["peak"] = np.asarray(p.peak_value, np.uint16)
    for axis in ("x", "y", "z"):
        rec[axis] = _int16(np.asarray(getattr(p, axis), np.float64) * scale,
                           f"{axis} in Q{p.xyz_q_format}", p.frame_number)
    return struct.pack("<HH", n, p.xyz_q_format) + rec.tobytes()


def _points_sdk3(p: DetectedPoints) -> bytes:
    rec = np.stack([np.asarray(p.x, "<f4"), np.asarray(p.y, "<f4"), np.asarray(p.z, "<f4"),
                    np.asarray(p.velocity, "<f4")], axis=-1)
    return np.ascontiguousarray(rec, "<f4").tobytes()


def _side_info(p: DetectedPoints) -> bytes:
    rec = np.stack([_int16(np.asarray(p.snr_db, np.float64) * 10, "snr", p.frame_number),
                    _int16(np.asarray(p.noise_db, np.float64) * 10, "noise", p.frame_number)],
                   axis=-1)
    return np.ascontiguousarray(rec, "<i2").tobytes()


def _u16(array) -> bytes:
    return np.ascontiguousarray(np.asarray(array), "<u2").tobytes()


def _cmplx16_im_re(array, frame: int) -> bytes:
    a = np.asarray(array)
    out = np.stack([_int16(a.imag, "azimuth heatmap (imag)", frame),
                    _int16(a.real, "azimuth heatmap (real)", frame)], axis=-1)
    return np.ascontiguousarray(out, "<i2").tobytes()


def frame_tlvs(points: DetectedPoints, gui: GuiMonitor) -> list[tuple[int, bytes]]:
    """The TLVs (type, payload) of one frame, in the order the demo sends them."""
    p, frame, sdk = points, points.frame_number, points.sdk
    n = p.num_points
    tlvs: list[tuple[int, bytes]] = []
    if sdk == 3:
        if gui.detected_objects == 1 or (gui.detected_objects == 2 and n > 0):
            tlvs.append((DETECTED_POINTS, _points_sdk3(p)))
        if gui.detected_objects == 1 and n > 0:
            tlvs.append((DETECTED_POINTS_SIDE_INFO, _side_info(p)))
    elif gui.detected_objects == 1 and n > 0:
        tlvs.append((DETECTED_POINTS, _points_sdk2(p)))
    if gui.log_mag_range:
        tlvs.append((RANGE_PROFILE, _u16(_required(p.range_profile, "range profile",
                                                    "logMagRange", frame))))
    if gui.noise_profile:
        tlvs.append((NOISE_PROFILE, _u16(_required(p.noise_profile, "noise profile",
                                                    "noiseProfile", frame))))
    if gui.range_azimuth_heatmap:
        heat = _required(p.azimuth_static_heatmap, "azimuth static heatmap",
                         "rangeAzimuthHeatMap", frame)
        tlvs.append((AZIMUTH_STATIC_HEAT_MAP, _cmplx16_im_re(heat, frame)))
    if gui.range_doppler_heatmap:
        tlvs.append((RANGE_DOPPLER_HEAT_MAP, _u16(_required(
            p.range_doppler_heatmap, "range-Doppler heatmap", "rangeDopplerHeatMap", frame))))
    if gui.stats:
        tlvs.append((STATS, bytes(6 * 4)))
        if sdk == 3:
            tlvs.append((TEMPERATURE_STATS, struct.pack("<iI10h", -1, 0, *([0] * 10))))
    return tlvs


def frame_packet(points: DetectedPoints, gui: GuiMonitor, subframe: int = 0) -> bytes:
    """One frame's UART packet: header, the TLVs ``gui`` selects, padding to 32 bytes."""
    if points.sdk not in SDK_VERSION:
        raise TlvError(f"frame {points.frame_number}: sdk must be 2 (SDK 1.x/2.x) or 3 (SDK 3.x), "
                       f"got {points.sdk}")
    if points.sdk == 2 and (points.platform & 0xFFFF) != 0x1443:
        raise TlvError(f"frame {points.frame_number}: the SDK 1.x/2.x layout (36-byte header) is the xWR14xx "
                       f"demo's, but platform is {points.platform:#x}; readers (TI's ROS driver) take the "
                       "header length from the platform, so use platform 0xA1443 or the SDK 3.x layout")
    tlvs = frame_tlvs(points, gui)
    header_len = 36 if points.sdk == 2 else 40
    body = b"".join(struct.pack("<II", kind, len(payload)) + payload for kind, payload in tlvs)
    total = SEGMENT_LEN * ((header_len + len(body) + SEGMENT_LEN - 1) // SEGMENT_LEN)
    cycles = int(round(points.time * CPU_CLOCK)) % (1 << 32)
    fields = [_version_word(points.sdk), total, points.platform, points.frame_number, cycles,
              points.num_points, len(tlvs)]
    if points.sdk == 3:
        fields.append(subframe)
    header = MAGIC_WORD + struct.pack(f"<{len(fields)}I", *fields)
    packet = header + body
    return packet + bytes(total - len(packet))


def write_tlv(path, frames: Iterable[DetectedPoints], gui: GuiMonitor) -> int:
    """Write the frames' packets, one after the other, as the UART stream file ``path``.

    Written whole or not at all (:func:`sionnafmcw.fs.atomic_write_bytes`). Returns the number of
    frames written.
    """
    packets = [frame_packet(points, gui) for points in frames]
    atomic_write_bytes(path, b"".join(packets))
    return len(packets)
