"""The formats real TI pipelines read, written from the on-chip chain's frames
(:class:`~sionnafmcw.ti.points.DetectedPoints`), one module per format:

* :mod:`~sionnafmcw.ti.formats.tlv` -- the out-of-box demo's UART byte stream (magic word,
  header, TLVs as ``guiMonitor`` selects, padding), SDK 1.x/2.x (xWR14xx) and SDK 3.x layouts
  (:func:`write_tlv`, :func:`frame_packet`).
* :mod:`~sionnafmcw.ti.formats.ros_driver` -- what TI's ROS drivers make of a frame (ROS axes,
  range/Doppler/bearing/intensity, which points they publish): :class:`DriverParams`,
  :func:`ros_scan`.
* :mod:`~sionnafmcw.ti.formats.rosbag2` -- a ROS 2 bag as TI's ROS 2 driver records it
  (``PointCloud2`` on ``/ti_mmwave/radar_scan_pcl``, ``RadarScan`` per point), written with
  ``rosbags`` (:func:`write_rosbag2`).
* :mod:`~sionnafmcw.ti.formats.radhar` -- RadHAR's message text dumps and the project's ``.npz``
  of RadHAR recordings, written (:func:`write_text`, :func:`write_npz`) and read
  (:func:`read_recording`, :func:`read_dataset`) with one reader for simulated and real data.
"""

from __future__ import annotations

from .radhar import (Recording, RadharFormatError, read_dataset, read_recording,
                     recording_from_frames, write_npz, write_text)
from .ros_driver import DriverParams, RosScan, ros_scan
from .rosbag2 import write_rosbag2
from .tlv import TlvError, frame_packet, write_tlv

#: The formats of ``sionnafmcw pointcloud --format``.
FORMATS = ("npz", "radhar", "tlv", "rosbag2")

__all__ = ["DriverParams", "FORMATS", "RadharFormatError", "Recording", "RosScan", "TlvError",
           "frame_packet", "read_dataset", "read_recording", "recording_from_frames", "ros_scan",
           "write_npz", "write_rosbag2", "write_text", "write_tlv"]
