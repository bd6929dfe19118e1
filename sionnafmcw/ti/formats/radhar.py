r"""RadHAR's recordings: the ROS message text dumps of its repository and the project's ``.npz``.

RadHAR (nesl/RadHAR, ``Data/Train|Test/<activity>/*.txt``) stored the TI ROS driver's
``/ti_mmwave/radar_scan`` messages (``ti_mmwave_rospkg/RadarScan``, one per point) as
``rostopic echo`` prints them (ROS 1, Python 2):

.. code-block:: text

    header:
      seq: 3132713
      stamp:
        secs: 1561686184
        nsecs: 612307393
      frame_id: "ti_mmwave"
    point_id: 0
    x: 0.01171875
    ...
    intensity: 30.7298469543
    ---

(``header:`` and ``stamp:`` carry a trailing space; floats printed with 12 significant digits,
Python 2's ``str``). The fields and their meaning are :mod:`~sionnafmcw.ti.formats.ros_driver`'s.

The ``.npz`` of ``realdata/radhar`` (one per recording) holds one entry per point, in recording
order: ``frame`` (int32), ``point_id`` (int32), ``x, y, z, range, velocity`` (float32),
``doppler_bin`` (int32), ``bearing, intensity`` (float32), ``stamp`` (float64, s), and the
scalar strings ``activity`` and ``source``. :func:`write_npz` writes a simulated recording with
exactly these arrays, :func:`read_recording` reads either form into a :class:`Recording`, and
:func:`read_dataset` walks a RadHAR tree (its ``Data`` folder, ``Train``/``Test``, or one split's
``<activity>`` folders, text or ``.npz``).

Frames: the dumps carry no frame number; a frame starts where ``point_id`` stops increasing
(it restarts at 0 with each frame; ids of points the driver dropped are skipped, so a frame may
start at 1). Simulated recordings number frames by their index in the run, so empty frames
leave gaps.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...fs import atomic_write_bytes, atomic_write_text
from ..points import DetectedPoints
from .ros_driver import DriverParams, ros_scan

#: The per-point arrays of a recording, with their dtypes.
POINT_ARRAYS = {"frame": np.int32, "point_id": np.int32, "x": np.float32, "y": np.float32,
                "z": np.float32, "range": np.float32, "velocity": np.float32,
                "doppler_bin": np.int32, "bearing": np.float32, "intensity": np.float32,
                "stamp": np.float64}
#: RadHAR's activities (its folder names).
ACTIVITIES = ("boxing", "jack", "jump", "squats", "walk")
_TEXT_FLOATS = ("x", "y", "z", "range", "velocity", "bearing", "intensity")


class RadharFormatError(ValueError):
    """A file that is not a RadHAR recording; the message names the file and the line."""


@dataclass(frozen=True)
class Recording:
    """One recording: per-point arrays ``[P]`` (:data:`POINT_ARRAYS`) and its labels.

    Axes are the ROS driver's (``x`` forward, ``y`` left, ``z`` up), ``velocity`` positive
    receding, ``bearing`` in degrees (positive left), ``intensity`` in dB, ``stamp`` in s.
    """

    frame: np.ndarray
    point_id: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    range: np.ndarray
    velocity: np.ndarray
    doppler_bin: np.ndarray
    bearing: np.ndarray
    intensity: np.ndarray
    stamp: np.ndarray
    activity: str = ""
    source: str = ""

    @property
    def num_points(self) -> int:
        return int(self.frame.shape[0])

    @property
    def num_frames(self) -> int:
        """Number of frames with at least one point."""
        return int(np.unique(self.frame).size)

    def points_per_frame(self) -> np.ndarray:
        """Points in each frame that has points, in frame order."""
        return np.unique(self.frame, return_counts=True)[1]

    def arrays(self) -> dict:
        """The arrays as the ``.npz`` stores them."""
        out = {name: np.asarray(getattr(self, name), dtype) for name, dtype in POINT_ARRAYS.items()}
        out["activity"] = np.asarray(self.activity)
        out["source"] = np.asarray(self.source)
        return out


# -------------------------------------------------------------------------- from detected points
def recording_from_frames(frames: Iterable[DetectedPoints], params: DriverParams, *,
                          stamp0: float = 0.0, activity: str = "", source: str = "") -> Recording:
    """The recording the ROS driver would have produced from these frames.

    ``frame`` is the frame's index in ``frames`` (0 first), ``stamp`` = ``stamp0`` + the frame's
    CPI start (the driver stamps on receipt; the UART transfer time is not modelled).
    """
    columns: dict[str, list] = {name: [] for name in POINT_ARRAYS}
    for index, points in enumerate(frames):
        scan = ros_scan(points, params)
        k = scan.num_points
        columns["frame"].append(np.full(k, index, np.int32))
        columns["stamp"].append(np.full(k, stamp0 + points.time, np.float64))
        for name in ("point_id", "x", "y", "z", "range", "velocity", "doppler_bin", "bearing",
                     "intensity"):
            columns[name].append(getattr(scan, name))
    arrays = {name: (np.concatenate(parts) if parts else np.zeros(0)).astype(POINT_ARRAYS[name])
              for name, parts in columns.items()}
    return Recording(**arrays, activity=activity, source=source)


# ----------------------------------------------------------------------------------- writing
def _py2_float(value) -> str:
    """A float as Python 2's ``str`` prints it (12 significant digits, always with a point)."""
    text = "%.12g" % float(value)
    if not any(c in text for c in ".eninf"):
        text += ".0"
    return text


def _message_text(rec: Recording, i: int, seq: int, frame_id: str) -> str:
    stamp = float(rec.stamp[i])
    secs = int(np.floor(stamp))
    nsecs = int(round((stamp - secs) * 1e9))
    if nsecs >= 1_000_000_000:
        secs, nsecs = secs + 1, nsecs - 1_000_000_000
    return ("header: \n"
            f"  seq: {seq}\n"
            "  stamp: \n"
            f"    secs: {secs}\n"
            f"    nsecs: {nsecs}\n"
            f"  frame_id: \"{frame_id}\"\n"
            f"point_id: {int(rec.point_id[i])}\n"
            f"x: {_py2_float(rec.x[i])}\n"
            f"y: {_py2_float(rec.y[i])}\n"
            f"z: {_py2_float(rec.z[i])}\n"
            f"range: {_py2_float(rec.range[i])}\n"
            f"velocity: {_py2_float(rec.velocity[i])}\n"
            f"doppler_bin: {int(rec.doppler_bin[i])}\n"
            f"bearing: {_py2_float(rec.bearing[i])}\n"
            f"intensity: {_py2_float(rec.intensity[i])}\n"
            "---\n")


def write_text(path, recording: Recording, *, frame_id: str = "ti_mmwave", seq0: int = 0) -> None:
    """Write ``recording`` as RadHAR's message text dump, whole or not at all
    (:func:`sionnafmcw.fs.atomic_write_text`)."""
    atomic_write_text(path, "".join(_message_text(recording, i, seq0 + i, frame_id)
                                    for i in range(recording.num_points)))


def write_npz(path, recording: Recording) -> None:
    """Write ``recording`` as a compressed ``.npz`` with exactly the arrays of
    ``realdata/radhar``, whole or not at all (:func:`sionnafmcw.fs.atomic_write_bytes`)."""
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **recording.arrays())
    atomic_write_bytes(path, buffer.getvalue())


# ----------------------------------------------------------------------------------- reading
def frames_from_point_ids(point_id: np.ndarray) -> np.ndarray:
    """Frame index of each point of a dump: a new frame where ``point_id`` stops increasing."""
    pid = np.asarray(point_id, np.int64)
    if pid.size == 0:
        return np.zeros(0, np.int32)
    starts = np.concatenate([[0], (np.diff(pid) <= 0).astype(np.int64)])
    return np.cumsum(starts).astype(np.int32)


def _read_text(path: Path) -> dict:
    columns: dict[str, list] = {"point_id": [], "doppler_bin": [], "stamp": [],
                                **{name: [] for name in _TEXT_FLOATS}}
    record: dict = {}
    secs = nsecs = None
    with open(path, encoding="utf-8", errors="strict") as f:
        for lineno, line in enumerate(f, 1):
            text = line.strip()
            if not text or text in ("header:", "stamp:") or text.startswith(("seq:", "frame_id:")):
                continue
            if text == "---":
                if len(record) != len(_TEXT_FLOATS) + 2 or secs is None or nsecs is None:
                    raise RadharFormatError(f"{path}:{lineno}: incomplete message before '---'")
                for name, value in record.items():
                    columns[name].append(value)
                columns["stamp"].append(secs + nsecs * 1e-9)
                record, secs, nsecs = {}, None, None
                continue
            key, sep, value = text.partition(":")
            if not sep:
                raise RadharFormatError(f"{path}:{lineno}: expected 'field: value', got {text!r}")
            try:
                if key == "secs":
                    secs = int(value)
                elif key == "nsecs":
                    nsecs = int(value)
                elif key in ("point_id", "doppler_bin"):
                    record[key] = int(value)
                elif key in _TEXT_FLOATS:
                    record[key] = float(value)
                else:
                    raise RadharFormatError(f"{path}:{lineno}: unknown field {key!r} (not a "
                                            "ti_mmwave_rospkg/RadarScan dump)")
            except ValueError as exc:
                if isinstance(exc, RadharFormatError):
                    raise
                raise RadharFormatError(f"{path}:{lineno}: bad value for {key}: {value.strip()!r}")
    if record:
        raise RadharFormatError(f"{path}: the last message is not closed by '---'")
    arrays = {name: np.asarray(values, POINT_ARRAYS[name]) for name, values in columns.items()}
    arrays["frame"] = frames_from_point_ids(arrays["point_id"])
    return arrays


def _source_of(path: Path) -> str:
    parts = path.parts
    if "Data" in parts:
        return "/".join(parts[len(parts) - 1 - parts[::-1].index("Data"):])
    return path.name


def read_recording(path, activity: str | None = None) -> Recording:
    """Read one recording: a RadHAR text dump (``.txt``) or a ``.npz`` of
    ``realdata/radhar`` or :func:`write_npz`.

    ``activity`` defaults to the one stored in the ``.npz``, or for a text dump the name of its
    folder.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such recording")
    if path.suffix == ".npz":
        with np.load(path, allow_pickle=False) as data:
            missing = [name for name in POINT_ARRAYS if name not in data.files]
            if missing:
                raise RadharFormatError(f"{path}: not a RadHAR recording, missing arrays "
                                        f"{', '.join(missing)}")
            arrays = {name: np.asarray(data[name], dtype) for name, dtype in POINT_ARRAYS.items()}
            stored_activity = str(data["activity"]) if "activity" in data.files else ""
            source = str(data["source"]) if "source" in data.files else path.name
    else:
        arrays = _read_text(path)
        stored_activity = path.parent.name
        source = _source_of(path)
    return Recording(**arrays, activity=stored_activity if activity is None else activity,
                     source=source)


def recording_files(root) -> list[Path]:
    """The recordings under ``root`` (``<activity>/*.txt|*.npz`` at any depth), sorted."""
    root = Path(root)
    if root.is_file():
        return [root]
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: no such folder")
    files = [p for p in root.rglob("*") if p.suffix in (".txt", ".npz") and p.is_file()
             and p.name.lower() not in ("readme.txt", "license.txt")]
    return sorted(files)


def read_dataset(root) -> Iterator[Recording]:
    """Every recording under ``root`` (a clone's ``Data``, ``Data/Train``, or ``realdata/radhar``
    ``train``), one :class:`Recording` each, activity from its folder or ``.npz``."""
    for path in recording_files(root):
        yield read_recording(path)
