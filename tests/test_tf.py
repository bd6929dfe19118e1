"""sionnafmcw.tf with a real TensorFlow: shapes and dtypes of every feature, labels equal to the
run stores' truth, features equal to the processing functions, shuffling, item selection,
partially generated items, clear errors, and a Keras fit on the stream.

The data set (moving_plate, 3 items of 4 frames, 16 chirps x 64 samples) is generated once, on
a Dask cluster of one worker thread in this process (the ``distributed.Client`` path of
generate).
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import zarr

import sionnafmcw.tf as stf  # before tensorflow: see the module docstring  # noqa: I001
import tensorflow as tf

from sionnafmcw import RadarConfig, open_run, processing
from sionnafmcw.dataset import DatasetError, generate, open_index
from sionnafmcw.geometry import world_phase_centre

SPEC = {"name": "tf-plates", "scenario": "moving_plate", "count": 3, "seed": 5,
        "radar": {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64},
        "engine_options": {"samples_per_src": 2000},
        "parameters": {"speed": {"uniform": [0.5, 2.0]}, "start_range": [3.0, 4.0], "num_frames": 4}}
RADAR = RadarConfig.preset("walk-77ghz").replace(num_chirps=16, num_samples=64)
LABELS = ("radial_velocity", "range", "frame_time", "item", "speed", "start_frame")


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    import logging

    from distributed import Client, LocalCluster

    out = tmp_path_factory.mktemp("tf") / "plates"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        index = generate(SPEC, out, scheduler=client, progress=False)
    assert (index.status.values == "complete").all()
    return out


def _store(data, item):
    return open_run(Path(data) / "items" / item / "run.zarr")


@pytest.mark.parametrize("features, shape, dtype", [
    ("iq", (2, 16, 3, 4, 64), tf.complex64),
    ("range_doppler", (2, 16, 64), tf.float32),        # [frame, doppler = chirps, range = samples]
    ("micro_doppler", (16, 2), tf.float32),            # [velocity, one column per CPI]
])
def test_shapes_and_dtypes(data, features, shape, dtype):
    ds = stf.dataset(data, features=features, labels=LABELS, frames_per_example=2, batch_size=4)
    x_spec, y_spec = ds.element_spec
    assert x_spec.shape.as_list() == [None, *shape] and x_spec.dtype == dtype
    assert y_spec["radial_velocity"].shape.as_list() == [None, 2] and y_spec["radial_velocity"].dtype == tf.float32
    assert y_spec["frame_time"].dtype == tf.float64 and y_spec["item"].dtype == tf.string
    assert y_spec["speed"].dtype == tf.float32 and y_spec["start_frame"].dtype == tf.int64
    sizes = []
    for x, y in ds:
        assert tuple(x.shape[1:]) == shape and x.dtype == dtype
        assert np.all(np.isfinite(np.abs(x.numpy())))
        assert y["range"].shape == (x.shape[0], 2)
        sizes.append(int(x.shape[0]))
    assert sizes == [4, 2]  # 3 items x 2 windows of 2 frames


def test_labels_equal_store_truth(data):
    index = open_index(data)
    ds = stf.dataset(data, features="iq", labels=LABELS, frames_per_example=2)
    seen = set()
    for x, y in ds:
        item, start = y["item"].numpy().decode(), int(y["start_frame"])
        seen.add((item, start))
        run = _store(data, item)
        frames = slice(start, start + 2)
        np.testing.assert_array_equal(y["radial_velocity"].numpy(),
                                      run.truth_radial_velocity.values[frames, 0].astype(np.float32))
        np.testing.assert_array_equal(y["frame_time"].numpy(), run.frame_time.values[frames])
        centre = world_phase_centre(RADAR, run.pose.position, run.pose.orientation)
        np.testing.assert_allclose(y["range"].numpy(),
                                   np.linalg.norm(run.truth_position.values[frames, 0] - centre, axis=-1), rtol=1e-6)
        assert float(y["speed"]) == np.float32(index.param_speed.sel(item=item).item())
        np.testing.assert_array_equal(x.numpy(), run.iq.values[frames])
    assert seen == {(i, s) for i in ("000000", "000001", "000002") for s in (0, 2)}


def test_features_are_the_processing_functions(data):
    run = _store(data, "000001")
    cube = run.iq.values
    rd = next(iter(stf.dataset(data, features="range_doppler", labels="item", items=["000001"])))[0].numpy()
    expected = 10 * np.log10(processing.range_doppler_map(cube[0], RADAR, clutter_removal=True).power)
    np.testing.assert_allclose(rd[0], expected.astype(np.float32), rtol=1e-5, atol=1e-3)
    md = next(iter(stf.dataset(data, features="micro_doppler", labels="item", items=["000001"], frames_per_example=4,
                               feature_options={"db": False, "window_chirps": 8, "hop": 4})))[0].numpy()
    spec = processing.micro_doppler_spectrogram(cube, RADAR, run.frame_time.values, window_chirps=8, hop=4)
    assert md.shape == spec.power.shape and md.shape[1] > 4
    np.testing.assert_allclose(md, spec.power.astype(np.float32), rtol=1e-5)


def test_single_label_shuffle_and_item_selection(data):
    plain = [float(y) for _, y in stf.dataset(data, features="iq", labels="speed")]
    assert len(plain) == 12  # 3 items x 4 single-frame examples
    shuffled = [float(y) for _, y in stf.dataset(data, features="iq", labels="speed", shuffle=True, seed=3)]
    assert sorted(shuffled) == sorted(plain) and shuffled != plain
    only = [y.numpy().decode() for _, y in stf.dataset(data, features="iq", labels="item", items=["000002"])]
    assert only == ["000002"] * 4
    strided = [int(y) for _, y in stf.dataset(data, features="iq", labels="start_frame", items=["000000"],
                                              frames_per_example=2, frame_stride=1)]
    assert strided == [0, 1, 2]


def test_partially_generated_items_give_only_whole_windows(data, tmp_path):
    copy = tmp_path / "partial"
    shutil.copytree(data, copy)
    zarr.open_group(str(copy / "items" / "000002" / "run.zarr"), mode="r+")["frame_done"][3] = False
    starts = [(y["item"].numpy().decode(), int(y["start_frame"]))
              for _, y in stf.dataset(copy, labels=("item", "start_frame"), frames_per_example=2)]
    assert ("000002", 0) in starts and ("000002", 2) not in starts and ("000001", 2) in starts


def test_clear_errors(data, tmp_path):
    with pytest.raises(ValueError, match="features='doppler' is unknown; choose one of iq, range_doppler"):
        stf.dataset(data, features="doppler")
    with pytest.raises(ValueError, match=r"label 'velocity' is unknown; .*or a scenario parameter \(.*speed"):
        stf.dataset(data, labels=("velocity",))
    with pytest.raises(ValueError, match="feature_options n_fft do not apply to features='range_doppler'"):
        stf.dataset(data, feature_options={"n_fft": 64})
    with pytest.raises(DatasetError, match="no item has 5 consecutive frames done"):
        stf.dataset(data, frames_per_example=5)
    with pytest.raises(DatasetError, match="has no index.zarr"):
        stf.dataset(tmp_path)


def test_keras_fits_on_the_stream(data):
    ds = stf.dataset(data, features="range_doppler", labels="speed", batch_size=4)
    model = tf.keras.Sequential([tf.keras.Input((1, 16, 64)), tf.keras.layers.Flatten(), tf.keras.layers.Dense(1)])
    model.compile(optimizer="adam", loss="mse")
    history = model.fit(ds, epochs=2, verbose=0, shuffle=False)
    assert len(history.history["loss"]) == 2 and np.all(np.isfinite(history.history["loss"]))


def test_missing_tensorflow_gives_the_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "tensorflow", None)  # `import tensorflow` now raises ImportError
    spec = importlib.util.spec_from_file_location("sionnafmcw._tf_probe", stf.__file__)
    module = importlib.util.module_from_spec(spec)
    with pytest.raises(ImportError, match=r"pip install 'sionnafmcw\[tf\]'"):
        spec.loader.exec_module(module)
