r"""A ROS 2 bag as TI's ROS 2 driver records it, written with ``rosbags`` (no ROS installation).

TI's ROS 2 driver (``mmwave_ti_ros``'s ``ros2_driver``, package ``ti_mmwave_rospkg``,
``DataHandlerClass.cpp``) publishes, per frame:

* ``/ti_mmwave/radar_scan_pcl``: ``sensor_msgs/msg/PointCloud2`` of its PCL point type
  ``mmWaveCloudType`` (``PCL_ADD_POINT4D`` + a union of float intensity, velocity): fields
  ``x`` (offset 0), ``y`` (4), ``z`` (8), ``intensity`` (16), ``velocity`` (20), all FLOAT32,
  ``point_step`` 32, one row (``height`` 1, ``width`` = points), little-endian, dense; only
  frames with at least one published point;
* ``/ti_mmwave/radar_scan``: one ``ti_mmwave_rospkg_msgs/msg/RadarScan`` per published point
  (:data:`RADAR_SCAN_MSG`: ``seq``, ``stamp`` as whole seconds, ``frame_id``, then the point's
  ``point_id, x, y, z, range, velocity, doppler_bin, bearing, intensity``).

The per-point quantities, the axes (ROS :math:`x` = sensor :math:`y`, ROS :math:`y = -` sensor
:math:`x`) and which points are published are :mod:`~sionnafmcw.ti.formats.ros_driver`'s.
Where the ROS 2 driver leaves a value unset it is filled with what its ROS 1 sibling (which
RadHAR recorded through) computes: for SDK 1.x/2.x points the ROS 2 driver's point cloud keeps
``intensity`` and ``velocity`` at 0 (the assignment is commented out), here they are
``10 log10(peakVal + 1)`` and the Doppler velocity; for SDK 3.x points its ``RadarScan`` leaves
``range, doppler_bin, bearing, intensity`` unset, here they are computed from the point, and it
publishes each SDK 3.x ``RadarScan`` a second time before its angle test (here once, when the
point passes, as for SDK 1.x/2.x). The
driver's ``RadarScan`` ``seq`` stays 0 and its point-cloud header stamp is broken (whole seconds
written as PCL microseconds); here every message is stamped with the frame's time, ``stamp0`` +
the CPI start, which is also the bag's receive time of its messages.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..points import DetectedPoints
from .ros_driver import DriverParams, ros_scan

POINT_CLOUD_TOPIC = "/ti_mmwave/radar_scan_pcl"
RADAR_SCAN_TOPIC = "/ti_mmwave/radar_scan"
POINT_CLOUD_TYPE = "sensor_msgs/msg/PointCloud2"
RADAR_SCAN_TYPE = "ti_mmwave_rospkg_msgs/msg/RadarScan"
#: ``ti_mmwave_rospkg_msgs/msg/RadarScan.msg`` of TI's ROS 2 driver.
RADAR_SCAN_MSG = """uint32 seq
uint32 stamp
string frame_id
uint16 point_id
float32 x
float32 y
float32 z
float32 range
float32 velocity
uint16 doppler_bin
float32 bearing
float32 intensity
"""
#: ``mmWaveCloudType``'s fields: name, byte offset (FLOAT32 each); and its size.
POINT_FIELDS = (("x", 0), ("y", 4), ("z", 8), ("intensity", 16), ("velocity", 20))
POINT_STEP = 32


def typestore():
    """A ``rosbags`` type store (ROS 2 Humble) that knows the driver's RadarScan."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(RADAR_SCAN_MSG, RADAR_SCAN_TYPE))
    return store


def point_cloud_data(x, y, z, intensity, velocity) -> bytes:
    """The ``data`` of the driver's PointCloud2: ``mmWaveCloudType`` records, 32 bytes each."""
    n = len(x)
    rec = np.zeros((n, POINT_STEP // 4), "<f4")
    for (name, offset), values in zip(POINT_FIELDS, (x, y, z, intensity, velocity)):
        rec[:, offset // 4] = values
    return rec.tobytes()


def _stamp(store, seconds: float):
    sec = int(np.floor(seconds))
    nanosec = min(int(round((seconds - sec) * 1e9)), 999_999_999)
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def write_rosbag2(path, frames: Iterable[DetectedPoints], params: DriverParams, *,
                  stamp0: float = 0.0) -> int:
    """Write the frames as the driver publishes them into a new ROS 2 bag (folder ``path``,
    SQLite3 storage, bag version 8).

    Whole or not at all: the bag is written under its own name inside a hidden sibling
    ``.<name>.partial-*`` (what :func:`sionnafmcw.fs.sweep_leftovers` removes after a kill) and
    renamed into place when complete. Returns the number of frames read.
    """
    from rosbags.rosbag2 import Writer

    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path} exists; not replacing it")
    holder = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-", dir=path.parent))
    tmp = holder / path.name          # the bag names its database after its folder
    store = typestore()
    types = store.types
    PointCloud2, PointField, Header = (types["sensor_msgs/msg/PointCloud2"],
                                       types["sensor_msgs/msg/PointField"],
                                       types["std_msgs/msg/Header"])
    RadarScan = types[RADAR_SCAN_TYPE]
    fields = [PointField(name=name, offset=offset, datatype=PointField.FLOAT32, count=1)
              for name, offset in POINT_FIELDS]
    count = 0
    try:
        with Writer(tmp, version=8) as writer:
            pcl_conn = writer.add_connection(POINT_CLOUD_TOPIC, POINT_CLOUD_TYPE, typestore=store)
            scan_conn = writer.add_connection(RADAR_SCAN_TOPIC, RADAR_SCAN_TYPE, typestore=store)
            for points in frames:
                count += 1
                scan = ros_scan(points, params)
                seconds = stamp0 + points.time
                t_ns = int(round(seconds * 1e9))
                for i in range(scan.num_points):
                    msg = RadarScan(seq=0, stamp=int(np.floor(seconds)), frame_id=params.frame_id,
                                    point_id=int(scan.point_id[i]), x=float(scan.x[i]),
                                    y=float(scan.y[i]), z=float(scan.z[i]),
                                    range=float(scan.range[i]), velocity=float(scan.velocity[i]),
                                    doppler_bin=int(scan.doppler_bin[i]),
                                    bearing=float(scan.bearing[i]),
                                    intensity=float(scan.intensity[i]))
                    writer.write(scan_conn, t_ns, store.serialize_cdr(msg, RADAR_SCAN_TYPE))
                if scan.num_points == 0:
                    continue
                data = point_cloud_data(scan.x, scan.y, scan.z, scan.intensity, scan.velocity)
                cloud = PointCloud2(
                    header=Header(stamp=_stamp(store, seconds), frame_id=params.frame_id),
                    height=1, width=scan.num_points, fields=fields, is_bigendian=False,
                    point_step=POINT_STEP, row_step=POINT_STEP * scan.num_points,
                    data=np.frombuffer(data, np.uint8), is_dense=True)
                writer.write(pcl_conn, t_ns, store.serialize_cdr(cloud, POINT_CLOUD_TYPE))
        os.rename(tmp, path)
    finally:
        shutil.rmtree(holder, ignore_errors=True)
    return count
