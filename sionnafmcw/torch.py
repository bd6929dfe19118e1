r"""Read a generated data set (:mod:`sionnafmcw.dataset`) in PyTorch: a ``torch.utils.data.Dataset``
and a ``DataLoader`` that pads variable-length point clouds.

::

    import sionnafmcw.torch as storch
    ds = storch.RadarDataset("data/radhar", features="range_doppler", labels=("person_activity", "joint_position"),
                             frames_per_example=60, frame_stride=10, classes=("boxing", "jumping_jacks", "jump",
                             "squat", "walk"))
    loader = storch.loader(ds, batch_size=16, shuffle=True, num_workers=2)
    for batch in loader:
        x, y = batch["feature"], batch["activity_index"]

Needs PyTorch (``pip install 'sionnafmcw[torch]'``; ``scripts/setup.sh`` installs the CPU build).
Examples, features and labels are those of :class:`sionnafmcw.dataset.examples.Examples`, the same
as :mod:`sionnafmcw.tf` gives: windows of :math:`F` consecutive done frames; ``iq`` (complex64
``[F, chirp, tx, rx, sample]``), ``range_doppler`` (float32 ``[F, doppler, range]``) or
``micro_doppler`` (float32 ``[velocity, time]``); per-frame labels ``radial_velocity``, ``range``,
``frame_time``, ``person_count``, ``joint_position`` (the keypoints, ``[F, person, joint, 3]``), and
per example ``person_activity`` (the first person's, from the run store), ``item``, ``scenario``, ``radar``, ``start_frame`` or a scenario parameter.
An element is a dict: ``feature`` and every label as tensors (strings stay Python strings), plus
``activity_index`` (int64, the position of ``person_activity`` in ``classes``) when ``classes`` is given.

Point clouds
------------
With ``point_cloud`` an element also holds ``point_cloud``, float32 ``[F, N_max, 5]`` (``x, y, z``
in the sensor's axes, m; ``velocity``, m/s positive receding; ``intensity``, dB) and
``num_points`` (int64 ``[F]``): a function of one frame's beat cube, ``f(cube [chirp, tx, rx, sample],
radar, frame_time) -> DetectedPoints | array [N, 5]``, is called per frame (:func:`points_array`
turns the device's :class:`~sionnafmcw.ti.points.DetectedPoints` into the five columns; intensity is
RadHAR's: :math:`10\log_{10}(\mathrm{peakVal} + 1)` for SDK 1.x/2.x, the SNR in dB for SDK 3.x, as
TI's ROS driver reports it). ``point_cloud=True`` runs the sensor's own on-chip chain on the
example's frames of its run store (:func:`ti_point_clouds`: :func:`sionnafmcw.ti.oob.run_point_clouds`,
the ``.cfg``'s processing, the frame counter and the DC calibration as the demo has them). Clouds differ in length,
so the batches of :func:`loader` pad them (:func:`pad_collate`): ``point_cloud`` ``[B, F, N, 5]``
zero-padded to the batch's most points, ``point_mask`` (bool, True on real points) and
``num_points`` ``[B, F]``.

Workers: every worker opens its own Zarr stores (the stores are read-only); with ``num_workers > 0``
the :class:`~sionnafmcw.dataset.examples.Examples` object is pickled into each worker.
"""

from __future__ import annotations

try:
    import torch
    from torch.utils.data import DataLoader, Dataset
except ImportError as exc:  # pragma: no cover - exercised only without PyTorch
    raise ImportError(
        "sionnafmcw.torch needs PyTorch, which is not installed. Install its CPU build with\n"
        "    pip install torch --index-url https://download.pytorch.org/whl/cpu\n"
        "(or pip install 'sionnafmcw[torch]', which on Linux takes PyPI's CUDA build, ~3 GB with its libraries)."
    ) from exc

import numpy as np

from .dataset.examples import FEATURES, FRAME_LABELS, Examples

#: The columns of a point cloud.
POINT_FIELDS = ("x", "y", "z", "velocity", "intensity")


def points_array(points) -> np.ndarray:
    """``[N, 5]`` float32 (:data:`POINT_FIELDS`) of a :class:`~sionnafmcw.ti.points.DetectedPoints` (module
    docstring), or of an array ``[N, 5]`` (checked)."""
    if hasattr(points, "peak_value"):
        if points.sdk >= 3:
            intensity = np.asarray(points.snr_db, np.float32)
        else:
            intensity = 10.0 * np.log10(np.asarray(points.peak_value, np.float64) + 1.0)
        cols = [points.x, points.y, points.z, points.velocity, intensity]
        return np.stack([np.asarray(c, np.float32).reshape(-1) for c in cols], axis=1)
    arr = np.asarray(points, np.float32)
    if arr.ndim != 2 or arr.shape[1] != len(POINT_FIELDS):
        raise ValueError(f"a point cloud must be [N, {len(POINT_FIELDS)}] ({', '.join(POINT_FIELDS)}), got shape "
                         f"{arr.shape}")
    return arr


def ti_point_clouds(store, frames, processing=None) -> list:
    """The sensor's own point clouds (:class:`~sionnafmcw.ti.points.DetectedPoints`) of frames ``frames`` of
    the run store ``store``: the out-of-box demo's on-chip chain (:func:`sionnafmcw.ti.oob.run_point_clouds`)
    with ``processing`` (a ``.cfg`` path or text, or its :class:`~sionnafmcw.ti.processing.TiProcessing`;
    None: the processing lines of the ``.cfg`` the run's radar was read from); a clear error where that
    chain is not installed."""
    try:
        from .ti import oob
    except ImportError as exc:
        raise RuntimeError("sionnafmcw.torch: point clouds need the TI on-chip chain sionnafmcw.ti.oob, which this "
                           "installation of sionnafmcw lacks; pass point_cloud=f, a function of (cube, radar, "
                           "frame_time), or leave point_cloud off") from exc
    return list(oob.run_point_clouds(store, processing=processing, frames=list(frames)))


class RadarDataset(Dataset):
    """A map-style dataset of the examples of a data set folder (module docstring).

    Parameters
    ----------
    path, features, labels, frames_per_example, frame_stride, items, feature_options :
        as :class:`~sionnafmcw.dataset.examples.Examples` (and :func:`sionnafmcw.tf.dataset`); ``labels``
        a name or a tuple of names.
    classes : the activity names, in order: adds ``activity_index`` (and the ``person_activity`` label).
    point_cloud : False, True (:func:`ti_point_clouds`, the sensor's chain) or a function
        ``f(cube, radar, frame_time)`` called per frame.
    ti_processing : with ``point_cloud=True``, the demo's ``.cfg`` (path or text) whose processing lines
        run; None: those of the ``.cfg`` each run's radar was read from.
    """

    def __init__(self, path, features: str = "range_doppler", labels=("radial_velocity",),
                 frames_per_example: int = 1, frame_stride: int | None = None, items=None,
                 feature_options: dict | None = None, classes=None, point_cloud=False, ti_processing=None):
        labels = (labels,) if isinstance(labels, str) else tuple(labels)
        if classes is not None and "person_activity" not in labels:
            labels = labels + ("person_activity",)
        self.examples = Examples(path, features=features, labels=labels, frames_per_example=frames_per_example,
                                 frame_stride=frame_stride, items=items, feature_options=feature_options)
        self.labels = self.examples.labels
        self._dtypes = {n: self.examples.label_dtype(n)[0] for n in self.labels}   # as sionnafmcw.tf casts them
        self.classes = None if classes is None else tuple(str(c) for c in classes)
        if not (point_cloud is True or point_cloud is False or point_cloud is None or callable(point_cloud)):
            raise ValueError("point_cloud must be False, True (the TI chain) or a function f(cube, radar, frame_time)")
        self.point_cloud = point_cloud or None
        self.ti_processing = ti_processing

    def __len__(self) -> int:
        return len(self.examples)

    def __getitem__(self, k: int) -> dict:
        ex = self.examples
        e = ex.examples[int(k)]
        frame = ex.frame_labels(e)
        cubes = ex.cubes(e)
        out = {"feature": torch.from_numpy(np.ascontiguousarray(ex.feature(e, cubes, frame["frame_time"])))}
        for name in self.labels:
            value = frame[name] if name in FRAME_LABELS else ex.item_label(name, e)
            dtype = self._dtypes[name]
            out[name] = str(value) if dtype is str else torch.as_tensor(np.asarray(value, dtype=dtype))
        if self.classes is not None:
            act = out["person_activity"]
            if act not in self.classes:
                raise ValueError(f"example {k} (item {e.item}) has activity {act!r}, not one of classes="
                                 f"{list(self.classes)}")
            out["activity_index"] = torch.tensor(self.classes.index(act), dtype=torch.int64)
        if self.point_cloud is True:
            frames = range(e.start, e.start + ex.frames_per_example)
            clouds = [points_array(c) for c in ti_point_clouds(e.store, frames, self.ti_processing)]
        elif self.point_cloud is not None:
            clouds = [points_array(self.point_cloud(c, ex.radar, float(t))) for c, t in zip(cubes, frame["frame_time"])]
        if self.point_cloud is not None:
            out["num_points"] = torch.tensor([len(c) for c in clouds], dtype=torch.int64)
            out["point_cloud"] = [torch.from_numpy(c) for c in clouds]
        return out


def pad_collate(batch: list) -> dict:
    """Collate dataset elements (dicts) into a batch: tensors stacked, strings listed, point clouds padded
    with zeros to the batch's most points, ``point_mask`` [B, F, N] True on real points."""
    out = {}
    for key in batch[0]:
        values = [b[key] for b in batch]
        if key == "point_cloud":
            frames = len(values[0])
            most = max([len(c) for v in values for c in v] + [0])
            cloud = torch.zeros((len(values), frames, most, len(POINT_FIELDS)), dtype=torch.float32)
            mask = torch.zeros((len(values), frames, most), dtype=torch.bool)
            for i, v in enumerate(values):
                for f, c in enumerate(v):
                    cloud[i, f, :len(c)] = c
                    mask[i, f, :len(c)] = True
            out["point_cloud"], out["point_mask"] = cloud, mask
        elif isinstance(values[0], torch.Tensor):
            out[key] = torch.stack(values)
        else:
            out[key] = list(values)
    return out


def loader(dataset: RadarDataset, batch_size: int = 8, shuffle: bool = False, num_workers: int = 0,
           seed: int | None = None, **kwargs) -> DataLoader:
    """A ``torch.utils.data.DataLoader`` over ``dataset`` with :func:`pad_collate`; ``seed`` fixes the
    shuffle (a ``torch.Generator``); other keyword arguments go to ``DataLoader``."""
    if seed is not None:
        gen = torch.Generator()
        gen.manual_seed(int(seed))
        kwargs.setdefault("generator", gen)
    kwargs.setdefault("collate_fn", pad_collate)
    return DataLoader(dataset, batch_size=batch_size, shuffle=shuffle, num_workers=num_workers, **kwargs)


__all__ = ["FEATURES", "POINT_FIELDS", "RadarDataset", "loader", "pad_collate", "points_array", "ti_point_clouds"]
