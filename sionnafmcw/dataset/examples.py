r"""Examples of a generated data set: windows of consecutive frames, their features and labels (NumPy).

An example is ``frames_per_example`` (:math:`F`) consecutive frames :math:`s, \dots, s+F-1` of
one item, every one of them marked done in the item's run store; windows start at
:math:`s = 0, h, 2h, \dots` (stride :math:`h`, default :math:`F`: no overlap). Features, computed
with :mod:`sionnafmcw.processing` frame by frame:

* ``"iq"``: the beat cubes, complex64 ``[F, chirp, tx, rx, sample]``;
* ``"range_doppler"``: :func:`~sionnafmcw.processing.range_doppler_map` power, float32
  ``[F, doppler, range]`` (options: ``clutter_removal`` (default True), ``db`` (default True:
  :math:`10\log_{10}\max(P, 10^{-30})`), ``window_range``, ``window_doppler``, ``n_range``,
  ``n_doppler``);
* ``"micro_doppler"``: :func:`~sionnafmcw.processing.micro_doppler_spectrogram` over the
  :math:`F` frames, float32 ``[velocity, time]`` (options: ``range_gate``, ``window_chirps``,
  ``hop``, ``n_fft``, ``window``, ``clutter_removal`` (default True), ``db`` (default True)).

Labels (:data:`FRAME_LABELS` per frame, the others one per example): ``radial_velocity`` and
``range`` of the item's label object (float32 ``[F]``, m/s and m, from the run store's truth, see
:mod:`.index`), ``frame_time`` (float64 ``[F]``, s), for data sets of people ``person_count``
(int32 ``[F]``) and ``joint_position`` (float32 ``[F, person, joint, 3]``, m, the person axis padded
with NaN to the index's), ``item`` (id), ``scenario``, ``radar``
(strings), ``start_frame`` (int64), ``person_activity`` (string: the first person's activity at the example's
first frame, from the run store, for data sets of people), and any scenario parameter by its name (``speed``, or
``param_speed``): its value from the index (int64, float32, bool or string; tuples as JSON text).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .index import DatasetError, item_dir, open_index

FEATURES = ("iq", "range_doppler", "micro_doppler")
FRAME_LABELS = ("radial_velocity", "range", "frame_time", "person_count", "joint_position")
PEOPLE_LABELS = ("person_count", "joint_position")
ITEM_LABELS = ("item", "scenario", "radar", "start_frame", "person_activity")
_FEATURE_OPTIONS = {
    "iq": (),
    "range_doppler": ("clutter_removal", "db", "window_range", "window_doppler", "n_range", "n_doppler"),
    "micro_doppler": ("range_gate", "window_chirps", "hop", "n_fft", "window", "clutter_removal", "db"),
}
DB_FLOOR = 1e-30  # W: power floor before 10 log10
#: RadarConfig fields that may differ between the items of one set of examples (a receiver randomised per
#: item): they change the signal, not the waveform, the array or the processing's axes.
RECEIVER_FIELDS = ("name", "tx_power", "noise_figure", "phase_noise", "if_filter", "adc_bits", "adc_full_scale",
                   "rx_gain", "iq_imbalance")


@dataclass(frozen=True)
class Example:
    """``item`` id, its run ``store`` path, ``start`` frame and the item's row in the index."""

    item: str
    store: str
    start: int
    row: int


class Examples:
    """The examples of a data set folder (see the module docstring); NumPy only, no TensorFlow."""

    def __init__(self, path, features: str = "range_doppler", labels=("radial_velocity",),
                 frames_per_example: int = 1, frame_stride: int | None = None, items=None,
                 feature_options: dict | None = None):
        from ..store import open_run

        self.path = Path(path)
        self.index = open_index(self.path)
        if features not in FEATURES:
            raise ValueError(f"features={features!r} is unknown; choose one of {', '.join(FEATURES)}")
        self.features = features
        options = dict(feature_options or {})
        bad = sorted(set(options) - set(_FEATURE_OPTIONS[features]))
        if bad:
            raise ValueError(f"feature_options {', '.join(bad)} do not apply to features={features!r}; its options: "
                             f"{', '.join(_FEATURE_OPTIONS[features]) or 'none'}")
        self.feature_options = options
        self.single_label = isinstance(labels, str)
        self.labels = (labels,) if self.single_label else tuple(labels)
        params = [v[len("param_"):] for v in self.index.data_vars if v.startswith("param_")]
        for name in self.labels:
            if name not in FRAME_LABELS + ITEM_LABELS and name not in params and \
                    not (name.startswith("param_") and name[len("param_"):] in params):
                raise ValueError(f"label {name!r} is unknown; choose from {', '.join(FRAME_LABELS + ITEM_LABELS)} "
                                 f"or a scenario parameter ({', '.join(params)})")
            if (name in PEOPLE_LABELS or name == "person_activity") and "person" not in self.index.dims:
                raise ValueError(f"label {name!r} needs a data set of people (its index has no person axis)")
        F = int(frames_per_example)
        if F < 1:
            raise ValueError(f"frames_per_example must be >= 1, got {frames_per_example}")
        stride = F if frame_stride is None else int(frame_stride)
        if stride < 1:
            raise ValueError(f"frame_stride must be >= 1, got {frame_stride}")
        self.frames_per_example, self.frame_stride = F, stride

        ids = [str(x) for x in self.index.item.values]
        if items is not None:
            wanted = [str(x) for x in items]
            missing = sorted(set(wanted) - set(ids))
            if missing:
                raise ValueError(f"items {', '.join(missing)} are not in {self.path}'s index")
            ids = [i for i in ids if i in set(wanted)]
        row_of = {str(x): k for k, x in enumerate(self.index.item.values)}
        self.examples: list[Example] = []
        radar = None
        for item in ids:
            store = item_dir(self.path, item) / "run.zarr"
            if not store.exists():
                continue
            run = open_run(store)
            done = run.done_mask
            starts = [s for s in range(0, done.size - F + 1, stride) if done[s:s + F].all()]
            if not starts:
                continue
            if radar is None:
                radar = run.radar
            elif run.radar.replace(**{f: getattr(radar, f) for f in RECEIVER_FIELDS}) != radar:
                raise DatasetError(f"{self.path}: item {item} has another radar than the items before it, so the "
                                   "features differ in shape; select items of one radar with items= (the index's "
                                   "'radar' variable)")
            self.examples += [Example(item, str(store), s, row_of[item]) for s in starts]
        if not self.examples:
            raise DatasetError(f"{self.path}: no item has {F} consecutive frames done (frames_per_example={F}); "
                               "generate the data set first, or lower frames_per_example")
        self.radar = radar
        self._row_of_store = {e.store: e.row for e in self.examples}
        self._local = threading.local()

    def __len__(self) -> int:
        return len(self.examples)

    # ------------------------------------------------------------------ reading
    def _run(self, store: str):
        """The :class:`~sionnafmcw.store.Run` of ``store``, one per thread."""
        from ..store import open_run

        cache = getattr(self._local, "runs", None)
        if cache is None:
            cache = self._local.runs = {}
        if store not in cache:
            cache[store] = open_run(store)
        return cache[store]

    def cubes(self, example: Example) -> np.ndarray:
        """``[F, chirp, tx, rx, sample]`` complex64 beat cubes of the example."""
        return self._run(example.store).cubes(slice(example.start, example.start + self.frames_per_example))

    def frame_labels(self, example: Example) -> dict:
        """``radial_velocity``, ``range`` (float32 ``[F]``) and ``frame_time`` (float64 ``[F]``) from the store."""
        run = self._run(example.store)
        sl = slice(example.start, example.start + self.frames_per_example)
        out = {"frame_time": run.frame_times[sl]}
        if any(n in PEOPLE_LABELS for n in self.labels):
            out["person_count"] = run.person_count()[sl].astype(np.int32)
            joints = np.full((self.frames_per_example, self.index.sizes["person"], self.index.sizes["joint"], 3),
                             np.nan, np.float32)
            if run.people:
                jp = run.joint_positions()[sl]
                joints[:, :jp.shape[1], :jp.shape[2]] = jp
            out["joint_position"] = joints
        obj = str(self.index.label_object.values[self._row_of_store[example.store]])
        if not obj:
            nan = np.full(self.frames_per_example, np.nan, np.float32)
            out.update(radial_velocity=nan, range=nan.copy())
        else:
            out["radial_velocity"] = run.truth(obj)[sl].astype(np.float32)
            out["range"] = run.object_range(obj)[sl].astype(np.float32)
        return out

    def item_label(self, name: str, example: Example):
        """A per-example label (``item``, ``scenario``, ``radar``, ``start_frame``, ``person_activity`` or a
        scenario parameter)."""
        if name == "item":
            return example.item
        if name == "start_frame":
            return np.int64(example.start)
        if name == "person_activity":
            return str(self.index["activity"].values[example.row, example.start, 0])
        var = name if name in ("scenario", "radar") or name.startswith("param_") else f"param_{name}"
        value = self.index[var].values[example.row]
        return value.item() if hasattr(value, "item") else str(value)

    # ------------------------------------------------------------------ features
    def feature(self, example: Example, cubes: np.ndarray | None = None, frame_time=None) -> np.ndarray:
        """The example's feature array (see the module docstring)."""
        from .. import processing

        x = self.cubes(example) if cubes is None else cubes
        o = self.feature_options
        if self.features == "iq":
            return x.astype(np.complex64, copy=False)
        db = o.get("db", True)
        if self.features == "range_doppler":
            kw = {k: o[k] for k in ("window_range", "window_doppler", "n_range", "n_doppler") if k in o}
            clutter = o.get("clutter_removal", True)
            maps = [processing.range_doppler_map(c, self.radar, clutter_removal=clutter, **kw).power for c in x]
            power = np.stack(maps)
        else:
            if frame_time is None:
                frame_time = self.frame_labels(example)["frame_time"]
            kw = {k: o[k] for k in ("range_gate", "window_chirps", "hop", "n_fft", "window") if k in o}
            power = processing.micro_doppler_spectrogram(x, self.radar, frame_time,
                                                         clutter_removal=o.get("clutter_removal", True), **kw).power
        if db:
            power = 10.0 * np.log10(np.maximum(power, DB_FLOOR))
        return power.astype(np.float32)

    def feature_shape_dtype(self) -> tuple[tuple, np.dtype]:
        """Shape and dtype of every feature array (from an all-zero example of this radar)."""
        r = self.radar
        zeros = np.zeros((self.frames_per_example, r.num_chirps, r.num_tx, r.num_rx, r.num_samples), np.complex64)
        times = np.arange(self.frames_per_example, dtype=float)  # any increasing times: shapes only
        f = self.feature(self.examples[0], zeros, times)
        return f.shape, f.dtype

    def label_dtype(self, name: str):
        """NumPy dtype (or ``str``) and shape of label ``name``."""
        if name in ("radial_velocity", "range"):
            return np.float32, (self.frames_per_example,)
        if name == "frame_time":
            return np.float64, (self.frames_per_example,)
        if name == "person_count":
            return np.int32, (self.frames_per_example,)
        if name == "joint_position":
            return np.float32, (self.frames_per_example, self.index.sizes["person"], self.index.sizes["joint"], 3)
        if name == "start_frame":
            return np.int64, ()
        value = self.item_label(name, self.examples[0])
        if isinstance(value, bool):
            return np.bool_, ()
        if isinstance(value, int):
            return np.int64, ()
        if isinstance(value, float):
            return np.float32, ()
        return str, ()

    def __iter__(self):
        """``(feature, labels)`` per example, in order (``labels`` a dict, or the array for one label name)."""
        for ex in self.examples:
            frame = self.frame_labels(ex)
            x = self.feature(ex, frame_time=frame["frame_time"])
            labels = {n: frame[n] if n in FRAME_LABELS else self.item_label(n, ex) for n in self.labels}
            yield x, (labels[self.labels[0]] if self.single_label else labels)


__all__ = ["Example", "Examples", "FEATURES", "FRAME_LABELS", "ITEM_LABELS", "PEOPLE_LABELS"]
