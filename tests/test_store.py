"""The run store's reader (:class:`sionnafmcw.store.Run`) on stores written by its writer
(:class:`~sionnafmcw.store.RunStore`): decoded attributes, frames, truth, errors.

No engine runs here: the frames are written directly, so every expected value is known in closed form.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from sionnafmcw import RadarConfig
from sionnafmcw.geometry import rotation_matrix, world_phase_centre
from sionnafmcw.store import FORMAT, RunStore, RunStoreError, open_run

RADAR = RadarConfig.preset("ti-awr1843boost").replace(num_chirps=4, num_samples=16)
POSE = {"position": [1.0, -2.0, 1.5], "orientation": [0.4, 0.1, -0.05]}
NUM_FRAMES = 5


def _write(path, done=(0, 1, 3), objects=("torso", "plate")):
    """A store with ``done`` frames written: frame n's cube is n + 1j everywhere, objects move in a line."""
    store = RunStore.open(path, RADAR, NUM_FRAMES, list(objects),
                          attrs={"radar": RADAR.to_dict(), "radar_pose": POSE, "engine": {"engine": "path", "max_depth": 1},
                                 "scene": "/scenes/x", "seed": 3, "noise": False})
    shape = (RADAR.num_chirps, RADAR.num_tx, RADAR.num_rx, RADAR.num_samples)
    for n in done:
        t = n / 24
        pos = np.array([[4.0 + k + 0.5 * t, 1.0 * k, 1.0] for k in range(len(objects))])
        vel = np.array([[0.5, 0.0, 0.0]] * len(objects))
        store.write_frame(n, np.full(shape, n + 1j, np.complex64), t, pos, vel, np.full(len(objects), 0.25 * n))
    return path


def test_run_decodes_the_attributes(tmp_path):
    run = open_run(_write(tmp_path / "run.zarr"))
    assert run.radar == RADAR
    np.testing.assert_array_equal(run.pose.position, POSE["position"])
    np.testing.assert_array_equal(run.pose.orientation, POSE["orientation"])
    # phase centre: the radar-frame centre of the virtual array, rotated and moved into the world
    expected = np.array(POSE["position"]) + rotation_matrix(POSE["orientation"]) @ RADAR.phase_centre
    np.testing.assert_allclose(run.phase_centre, expected, atol=1e-12)
    np.testing.assert_allclose(run.phase_centre, world_phase_centre(RADAR, POSE["position"], POSE["orientation"]))
    assert run.objects == ["torso", "plate"]
    assert run.engine == {"engine": "path", "max_depth": 1}
    assert str(run.scene) == "/scenes/x"
    assert run.attrs["seed"] == 3 and run.attrs["format"] == FORMAT
    assert run.num_frames == NUM_FRAMES


def test_frames_and_truth_mask_the_frames_not_done(tmp_path):
    run = open_run(_write(tmp_path / "run.zarr"))
    np.testing.assert_array_equal(run.done_frames, [0, 1, 3])
    np.testing.assert_array_equal(run.done_mask, [True, True, False, True, False])
    t = run.frame_times
    np.testing.assert_allclose(t[[0, 1, 3]], np.array([0, 1, 3]) / 24)
    assert np.isnan(t[[2, 4]]).all()
    cube = run.cube(3)
    assert cube.dtype == np.complex64 and cube.shape == (4, 3, 4, 16) and np.all(cube == 3 + 1j)
    np.testing.assert_array_equal(run.cubes([0, 1])[:, 0, 0, 0, 0], [1j, 1 + 1j])
    np.testing.assert_array_equal(run.cubes([3, 0])[:, 0, 0, 0, 0], [3 + 1j, 1j])
    with pytest.raises(RunStoreError, match=r"run\.zarr: frame 2 is not written yet \(3 of 5 frames done\)"):
        run.cube(2)
    with pytest.raises(RunStoreError, match=r"frame 7 is outside the run's 0\.\.4"):
        run.cube(7)
    v = run.truth("plate")
    np.testing.assert_allclose(v[[0, 1, 3]], [0.0, 0.25, 0.75])
    assert np.isnan(v[[2, 4]]).all()
    pos = run.object_position("plate")
    np.testing.assert_allclose(pos[3], [5.0 + 0.5 * 3 / 24, 1.0, 1.0])
    np.testing.assert_allclose(run.object_range("plate")[3], np.linalg.norm(pos[3] - run.phase_centre))
    with pytest.raises(RunStoreError, match=r"object 'arm' is not in the run's truth; it has torso, plate"):
        run.truth("arm")


def test_truth_at_cpi_centre_of_constant_velocity(tmp_path):
    """No acceleration: the object is at p + v T/2 at the CPI centre, and the range rate follows."""
    run = open_run(_write(tmp_path / "run.zarr"))
    got = run.truth_at_cpi_centre("torso")
    t = np.array([0, 1, 3]) / 24 + RADAR.cpi_duration / 2
    p = np.stack([4.0 + 0.5 * t, np.zeros_like(t), np.ones_like(t)], -1)
    los = p - run.phase_centre
    want = los @ np.array([0.5, 0.0, 0.0]) / np.linalg.norm(los, axis=-1)
    np.testing.assert_allclose(got[[0, 1, 3]], want, atol=1e-12)
    assert np.isnan(got[[2, 4]]).all()


def test_truth_in_radar_frame(tmp_path):
    run = open_run(_write(tmp_path / "run.zarr"))
    ranges, azimuths = run.truth_in_radar_frame(1)
    pos = run.object_position("plate")[1]
    q = rotation_matrix(POSE["orientation"]).T @ (pos - np.array(POSE["position"])) - RADAR.phase_centre
    np.testing.assert_allclose(ranges[1], np.linalg.norm(q), atol=1e-12)
    np.testing.assert_allclose(azimuths[1], np.arctan2(q[1], q[0]), atol=1e-12)
    # the range from the radar frame is the world range from the phase centre
    np.testing.assert_allclose(ranges, [run.object_range(o)[1] for o in run.objects], atol=1e-12)
    empty = open_run(_write(tmp_path / "empty.zarr", objects=()))
    assert empty.objects == [] and empty.truth_in_radar_frame(0)[0].size == 0


def test_run_delegates_to_the_dataset_and_pickles(tmp_path):
    run = open_run(_write(tmp_path / "run.zarr"))
    assert run.sizes["frame"] == NUM_FRAMES and run.sizes["tx"] == RADAR.num_tx
    assert "iq" in run and "nothing" not in run
    np.testing.assert_array_equal(run["iq"][3].values, run.cube(3))
    np.testing.assert_array_equal(run.frame_done.values, run.done_mask)  # a dataset variable, by attribute
    assert run.isel(frame=slice(0, 2)).sizes["frame"] == 2
    again = pickle.loads(pickle.dumps(run))
    assert again.path == run.path and again.radar == RADAR
    assert "frames done 3/5" in repr(run)


def test_errors_name_the_store_in_library_language(tmp_path):
    with pytest.raises(RunStoreError, match=r"missing\.zarr: no such run store"):
        open_run(tmp_path / "missing.zarr")
    (tmp_path / "plain").mkdir()
    (tmp_path / "plain" / "file.txt").write_text("x")
    with pytest.raises(RunStoreError, match=r"plain is not a readable run store") as err:
        open_run(tmp_path / "plain")
    assert "--" not in str(err.value)
    with pytest.raises(RunStoreError, match=r"plain exists and is not a run store .*write the run to another path") as err:
        RunStore.open(tmp_path / "plain", RADAR, NUM_FRAMES, [], attrs={})
    assert "--out" not in str(err.value)
    path = _write(tmp_path / "run.zarr")
    with pytest.raises(RunStoreError, match=r"was written with a different 'seed'"):
        RunStore.open(path, RADAR, NUM_FRAMES, ["torso", "plate"],
                      attrs={"radar": RADAR.to_dict(), "radar_pose": POSE, "engine": {"engine": "path", "max_depth": 1},
                             "scene": "/scenes/x", "seed": 4, "noise": False})


# ===================================================================================== crash safety
ATTRS = {"radar": RADAR.to_dict(), "radar_pose": POSE, "engine": {"engine": "path", "max_depth": 1},
         "scene": "/scenes/x", "seed": 3, "noise": False}


def test_creation_is_atomic_and_sweeps_what_killed_writers_left(tmp_path):
    """The store appears whole (every attribute in its zarr.json); temporary stores beside it and
    ``*.partial`` chunk files inside it are removed by the next open; done frames are kept."""
    import json

    path = tmp_path / "run.zarr"
    stale = tmp_path / ".run.zarr.partial-0123456789ab"  # a creation killed before its rename
    (stale / "iq").mkdir(parents=True)
    _write(path, done=(0, 1))
    assert not stale.exists()
    attrs = json.loads((path / "zarr.json").read_text())["attributes"]
    assert attrs["format"] == FORMAT and {"radar", "radar_pose", "engine", "seed", "noise"} <= set(attrs)
    partial = path / "iq" / "c" / "3" / "0" / "0" / "0" / "0.feedbeef.partial"  # a chunk write cut off
    partial.parent.mkdir(parents=True)
    partial.write_bytes(b"half")
    store = RunStore.open(path, RADAR, NUM_FRAMES, ["torso", "plate"], attrs=ATTRS)
    assert not partial.exists() and store.done().tolist() == [True, True, False, False, False]
    assert list(tmp_path.iterdir()) == [path]  # no lock left: RunStore.open releases it unless told to hold it


def test_a_store_cut_off_by_a_non_atomic_creation_is_replaced_but_never_one_with_done_frames(tmp_path):
    import zarr

    path = tmp_path / "run.zarr"
    group = zarr.open_group(str(path), mode="w-", zarr_format=3)  # what an old, killed creation left
    group.create_array("frame_done", shape=(NUM_FRAMES,), dtype="bool", fill_value=False)
    group.attrs["format"] = FORMAT  # half of the attributes
    _write(path, done=(2,))
    assert open_run(path).done_frames.tolist() == [2]
    group = zarr.open_group(str(path), mode="r+", zarr_format=3)
    group.attrs.update({"radar": None})  # damaged attributes, but a frame is done: not ours to discard
    with pytest.raises(RunStoreError, match="different 'radar'"):
        RunStore.open(path, RADAR, NUM_FRAMES, ["torso", "plate"], attrs=ATTRS)
    assert open_run(path).done_frames.tolist() == [2]


def test_the_lock_refuses_a_live_writer_and_takes_over_a_dead_one(tmp_path):
    import json
    import os
    import socket
    import subprocess
    import sys

    from sionnafmcw.store import RunStoreBusy

    path = _write(tmp_path / "run.zarr", done=(0,))
    lock = tmp_path / ".run.zarr.lock"
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": os.getppid()}))  # alive
    with pytest.raises(RunStoreBusy, match=rf"held by process {os.getppid()} on this machine"):
        RunStore.open(path, RADAR, NUM_FRAMES, ["torso", "plate"], attrs=ATTRS)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": int(dead.stdout)}))  # gone
    store = RunStore.open(path, RADAR, NUM_FRAMES, ["torso", "plate"], attrs=ATTRS, hold_lock=True)
    assert json.loads(lock.read_text())["pid"] == os.getpid()
    store.close()
    assert not lock.exists() and store.done()[0]


def test_unreadable_frame_named_and_check_run_marks_it(tmp_path):
    from sionnafmcw.store import CorruptFrameError, check_run

    path = _write(tmp_path / "run.zarr")
    (path / "iq" / "c" / "1" / "0" / "0" / "0" / "0").write_bytes(b"not a zstd frame")
    run = open_run(path)
    with pytest.raises(CorruptFrameError, match=r"frame 1 is marked done but cannot be read .*check_run") as err:
        run.cube(1)
    assert err.value.frame == 1 and "--" not in str(err.value)
    np.testing.assert_array_equal(run.cube(3), np.full(run.cube(3).shape, 3 + 1j, np.complex64))
    report = check_run(path, repair=False)
    assert list(report["corrupt"]) == [1] and not report["repaired"]
    assert open_run(path).done_frames.tolist() == [0, 1, 3]
    report = check_run(path)
    assert report["repaired"] and open_run(path).done_frames.tolist() == [0, 3]
    assert check_run(path)["corrupt"] == {}
