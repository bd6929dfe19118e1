r"""Stream a generated data set (:mod:`sionnafmcw.dataset`) into TensorFlow as a ``tf.data.Dataset``.

::

    import sionnafmcw.tf as stf
    ds = stf.dataset("data/plates", features="range_doppler", labels=("radial_velocity",),
                     frames_per_example=4, batch_size=8, shuffle=True, seed=0)
    model.fit(ds, epochs=3)

Needs TensorFlow (``pip install 'sionnafmcw[tf]'``, i.e. ``tensorflow-cpu``). Examples, features
and labels are those of :class:`sionnafmcw.dataset.examples.Examples` (windows of consecutive
done frames; ``iq`` / ``range_doppler`` / ``micro_doppler`` computed with
:mod:`sionnafmcw.processing`; labels from the run stores' truth and the index).

Pipeline: a table of example numbers (``from_tensor_slices``, with the per-example string and
parameter labels as tensors) -> optional ``shuffle`` of that small table (no data is read yet) ->
``map`` of a ``tf.numpy_function`` that reads the example's frames from its Zarr store and
computes the feature, in parallel (``num_parallel_calls``, order kept with
``deterministic=True``) -> ``ensure_shape`` to the static shapes -> optional ``batch`` ->
``prefetch``. Only the examples in flight are in memory.

Import order: in this environment, loading Dr.Jit (Mitsuba, Sionna) *after* TensorFlow crashes
the process (segmentation fault; TensorFlow 2.21 and Dr.Jit 1.x ship conflicting native
libraries), while the other order works. This module therefore imports Dr.Jit before TensorFlow,
and warns when TensorFlow was imported first.
"""

from __future__ import annotations

import sys
import warnings

if "tensorflow" in sys.modules and "drjit" not in sys.modules:
    warnings.warn("sionnafmcw.tf: TensorFlow was imported before Dr.Jit; importing Dr.Jit, Mitsuba or Sionna RT "
                  "in this process may now crash it. Import sionnafmcw.tf (or drjit) before tensorflow.",
                  RuntimeWarning, stacklevel=2)
else:
    from . import sionna_rt  # noqa: F401  (Dr.Jit must be loaded before TensorFlow, see the module docstring)

try:
    import tensorflow as tf
except ImportError as exc:  # pragma: no cover - exercised only without TensorFlow
    raise ImportError(
        "sionnafmcw.tf needs TensorFlow, which is not installed. Install it with\n"
        "    pip install 'sionnafmcw[tf]'      (from a checkout: pip install -e '.[tf]')\n"
        "which installs tensorflow-cpu (>= 2.18, the first releases built for NumPy 2)."
    ) from exc

import numpy as np

from .dataset.examples import FEATURES, FRAME_LABELS, Examples

__all__ = ["FEATURES", "dataset"]


def _tf_dtype(dtype):
    if dtype is str:
        return tf.string
    return tf.as_dtype(np.dtype(dtype))


def dataset(path, features: str = "range_doppler", labels=("radial_velocity",), frames_per_example: int = 1,
            frame_stride: int | None = None, batch_size: int | None = None, shuffle: bool = False,
            seed: int | None = None, items=None, feature_options: dict | None = None, drop_remainder: bool = False,
            num_parallel_calls=None, deterministic: bool = True) -> "tf.data.Dataset":
    """A ``tf.data.Dataset`` of ``(feature, labels)`` over the data set folder ``path``.

    Parameters
    ----------
    path : folder written by :func:`sionnafmcw.dataset.generate`
    features : ``"iq"`` (complex64 ``[F, chirp, tx, rx, sample]``), ``"range_doppler"`` (float32
        ``[F, doppler, range]``) or ``"micro_doppler"`` (float32 ``[velocity, time]``)
    labels : a label name (then ``labels`` in each element is that tensor) or a tuple of names
        (then a dict): ``radial_velocity``, ``range`` (float32 ``[F]``), ``frame_time`` (float64
        ``[F]``), for people ``person_count`` (int32 ``[F]``) and ``joint_position`` (float32
        ``[F, person, joint, 3]``), ``item``, ``scenario``, ``radar`` (string), ``start_frame`` (int64), or a
        scenario parameter (``speed`` ...: int64 / float32 / bool / string)
    frames_per_example : F, consecutive frames per example
    frame_stride : frames between example starts (default F)
    batch_size : batch the examples (default: unbatched)
    shuffle, seed : shuffle the examples (the whole table, reshuffled every epoch)
    items : item ids to use (default all)
    feature_options : see :mod:`sionnafmcw.dataset.examples` (e.g. ``{"db": False}``)
    num_parallel_calls : parallel feature computations (default ``tf.data.AUTOTUNE``)
    deterministic : keep the order of the examples in the parallel map
    """
    ex = Examples(path, features=features, labels=labels, frames_per_example=frames_per_example,
                  frame_stride=frame_stride, items=items, feature_options=feature_options)
    shape, dtype = ex.feature_shape_dtype()
    frame_names = [n for n in ex.labels if n in FRAME_LABELS]
    label_specs = {n: ex.label_dtype(n) for n in ex.labels}

    table = {"_example": tf.range(len(ex), dtype=tf.int64)}
    for name in ex.labels:
        if name in FRAME_LABELS:
            continue
        dt, _ = label_specs[name]
        values = [ex.item_label(name, e) for e in ex.examples]
        table[name] = tf.constant(values, dtype=_tf_dtype(dt))
    ds = tf.data.Dataset.from_tensor_slices(table)
    if shuffle:
        ds = ds.shuffle(len(ex), seed=seed, reshuffle_each_iteration=True)

    out_types = [_tf_dtype(dtype)] + [_tf_dtype(label_specs[n][0]) for n in frame_names]

    def load_numpy(k):
        e = ex.examples[int(k)]
        frame = ex.frame_labels(e)
        x = ex.feature(e, frame_time=frame["frame_time"])
        return (x, *[frame[n].astype(label_specs[n][0], copy=False) for n in frame_names])

    def load(element):
        outs = tf.numpy_function(load_numpy, [element["_example"]], out_types, stateful=False)
        x = tf.ensure_shape(outs[0], shape)
        y = {}
        for name, value in zip(frame_names, outs[1:]):
            y[name] = tf.ensure_shape(value, label_specs[name][1])
        for name in ex.labels:
            if name not in FRAME_LABELS:
                y[name] = element[name]
        y = {n: y[n] for n in ex.labels}
        return x, (y[ex.labels[0]] if ex.single_label else y)

    ds = ds.map(load, num_parallel_calls=num_parallel_calls or tf.data.AUTOTUNE, deterministic=deterministic)
    if batch_size:
        ds = ds.batch(int(batch_size), drop_remainder=drop_remainder)
    return ds.prefetch(tf.data.AUTOTUNE)

