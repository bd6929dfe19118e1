"""Data sets on a real Dask LocalCluster: spec validation, the reproducible draw, the index and its
labels, resume (done flags removed; a generation killed with SIGKILL), failing items, spec
mismatch, the lock, and both ways to reach a cluster (a scheduler address, and generate's own).

The spec is small: moving_plate, 2 frames, walk-77ghz cut to 16 chirps x 64 samples, 2000 rays
per source. Items drawn with start_range 0.21 m fail in the builder (the plate, approaching at
0.5-2 m/s, passes 0.2 m within the 1/24 s between the two frames); with seed 4 these are items 1
and 2, the others are at 3 m.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import zarr

from sionnafmcw import dataset, open_run
from sionnafmcw.dataset import DatasetError, DatasetWarning, SpecError, load_spec

RADAR = {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64}


def plate_spec(**changes) -> dict:
    spec = {"name": "plates", "scenario": "moving_plate", "count": 4, "seed": 4, "radar": RADAR,
            "engine_options": {"samples_per_src": 2000},
            "parameters": {"speed": {"uniform": [-2.0, -0.5]}, "start_range": [0.21, 3.0], "num_frames": 2}}
    spec.update(changes)
    return spec


@pytest.fixture(scope="module")
def scheduler():
    """A LocalCluster started here and reached through its TCP address: one worker thread in this
    process, so Sionna is loaded (and its kernels traced) once for all the tests that use it.
    generate's own cluster of worker processes is tested in test_generate_starts_its_own_local_cluster."""
    import logging

    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        assert cluster.scheduler_address.startswith("tcp://")
        yield cluster.scheduler_address


# ===================================================================================== the spec
def test_spec_from_yaml_equals_dict_and_draw_is_reproducible(tmp_path):
    text = textwrap.dedent("""
        name: plates
        scenario: moving_plate
        count: 6
        seed: 11
        radar: walk-77ghz
        engine: path
        engine_options: {samples_per_src: 5000}
        parameters:
          speed: {uniform: [-3.0, 3.0]}
          start_range: [3.0, 4.0, 5.0]
          subdiv: {range: [1, 7, 2]}
          num_frames: 4
        frames: 3
    """)
    (tmp_path / "spec.yaml").write_text(text)
    from_yaml = load_spec(tmp_path / "spec.yaml")
    as_dict = {"name": "plates", "scenario": "moving_plate", "count": 6, "seed": 11, "radar": "walk-77ghz",
               "engine_options": {"samples_per_src": 5000},
               "parameters": {"speed": {"uniform": [-3.0, 3.0]}, "start_range": {"choice": [3.0, 4.0, 5.0]},
                              "subdiv": {"range": [1, 7, 2]}, "num_frames": {"value": 4}}, "frames": [0, 1, 2]}
    assert from_yaml.to_dict() == load_spec(as_dict).to_dict()
    assert from_yaml.frames == [0, 1, 2]

    items = from_yaml.items()
    assert [it.id for it in items] == [f"{i:06d}" for i in range(6)]
    assert items == load_spec(tmp_path / "spec.yaml").items()          # reproducible
    for it in items:
        assert -3.0 <= it.parameters["speed"] < 3.0
        assert it.parameters["start_range"] in (3.0, 4.0, 5.0)
        assert it.parameters["subdiv"] in (1, 3, 5, 7)                 # range includes its end
        assert it.parameters["num_frames"] == 4
    assert len({it.noise_seed for it in items}) == 6
    assert len({it.parameters["speed"] for it in items}) == 6
    # item i depends on (seed, i) only: not on count, nor on the other parameters
    fewer = load_spec({**as_dict, "count": 2, "parameters": {"speed": {"uniform": [-3.0, 3.0]}}}).items()
    assert [f.parameters["speed"] for f in fewer] == [it.parameters["speed"] for it in items[:2]]
    assert [f.noise_seed for f in fewer] == [it.noise_seed for it in items[:2]]
    assert load_spec({**as_dict, "seed": 12}).item(0).parameters["speed"] != items[0].parameters["speed"]


def test_spec_radar_forms_and_list_choice():
    spec = load_spec(plate_spec(radar=["walk-77ghz", RADAR], count=16))
    names = {it.radar_name for it in spec.items()}
    assert names == {"walk-77ghz", "walk-77ghz(num_chirps=16,num_samples=64)"}
    small = next(it for it in spec.items() if it.radar_name != "walk-77ghz")
    assert small.radar["num_chirps"] == 16 and small.radar["num_samples"] == 64


def test_spec_tuple_parameter():
    spec = load_spec({"name": "cr", "scenario": "corner_reflectors", "count": 2, "seed": 0, "radar": "walk-77ghz",
                      "parameters": {"ranges": [3.0, 4.0], "azimuths": [0.0, 0.1], "speeds": [[0.0, 1.0], [1.0, 0.0]]}})
    it = spec.item(0)
    assert it.parameters["ranges"] == [3.0, 4.0]                    # a flat list is the tuple's value
    assert it.parameters["speeds"] in ([0.0, 1.0], [1.0, 0.0])      # a list of lists: choices


def test_a_scenario_seed_is_drawn_per_item_unless_set():
    """A builder with a ``seed`` parameter (none of the shipped ones has one yet) gets one per item."""
    from sionnafmcw.scenes.registry import Parameter, register

    @register("_test_seeded", "test only", {"seed": Parameter(0, int, "", "random details", low=0),
                                            "size": Parameter(1.0, float, "m", "size", low=0.1)})
    def _seeded(out, seed, size):  # pragma: no cover - never built
        raise AssertionError

    base = {"name": "s", "scenario": "_test_seeded", "count": 3, "seed": 1, "radar": "walk-77ghz"}
    seeds = [it.parameters["seed"] for it in load_spec(base).items()]
    assert len(set(seeds)) == 3 and all(0 <= s < 2**31 for s in seeds)
    assert [it.parameters["seed"] for it in load_spec({**base, "parameters": {"seed": 5}}).items()] == [5, 5, 5]


@pytest.mark.parametrize("changes, match", [
    ({"paramters": {}}, r"unknown field\(s\) paramters"),
    ({"count": 0}, r"count must be an integer >= 1"),
    ({"count": 2.5}, r"count must be an integer >= 1"),
    ({"seed": -1}, r"seed must be an integer >= 0"),
    ({"scenario": "moving_plates"}, r"scenario 'moving_plates' is unknown; choose one of .*moving_plate"),
    ({"parameters": {"velocity": 1.0}}, r"no parameter 'velocity'; its parameters: start_range, speed"),
    ({"parameters": {"speed": {"uniform": [2.0, 1.0]}}}, r"parameters.speed: 'uniform' needs lo < hi"),
    ({"parameters": {"speed": {"uniform": [1.0]}}}, r"parameters.speed: 'uniform' needs \[lo, hi\]"),
    ({"parameters": {"subdiv": {"uniform": [1, 3]}}}, r"parameters.subdiv: .*'subdiv' has type int.*range"),
    ({"parameters": {"subdiv": {"range": [1, 5, 0]}}}, r"parameters.subdiv: 'range' step must be > 0"),
    ({"parameters": {"subdiv": {"range": [5, 1, 1]}}}, r"parameters.subdiv: 'range' needs lo <= hi"),
    ({"parameters": {"subdiv": {"range": [1, 5, 0.5]}}}, r"integer lo, hi and step"),
    ({"parameters": {"speed": {"uniform": [-200.0, 0.0]}}}, r"parameters.speed: .*out of range"),
    ({"parameters": {"speed": []}}, r"parameters.speed: 'choice' needs a non-empty list"),
    ({"parameters": {"speed": {"normal": [0, 1]}}}, r"exactly one key among value, choice, cycle,"),
    ({"parameters": {"room": "yes"}}, r"parameters.room: .*not a bool"),
    ({"radar": "awr9999"}, r"radar: unknown radar preset 'awr9999'"),
    ({"radar": {"preset": "walk-77ghz", "chirps": 8}}, r"radar: unknown RadarConfig field\(s\) chirps; known: .*num_chirps"),
    ({"radar": {"preset": "walk-77ghz", "num_samples": 100000}}, r"radar: .*ADC window"),
    ({"radar": []}, r"radar is an empty list"),
    ({"engine": "raster"}, r"engine 'raster' is not available; choose one of path"),
    ({"engine_options": {"samples": 10}}, r"engine_options samples are not options of the 'path' engine"),
    ({"frames": 3}, r"frames reach index 2 but an item can have only 2 frames"),
    ({"parameters": {"fps": [24.0, 1000.0]}}, r"radar 'walk-77ghz\(num_chirps=16,num_samples=64\)' with fps up to "
                                               r"1000: .*longer than the frame period"),
    ({"frames": [0, 0]}, r"frames lists a frame twice"),
    ({"radar_pose": {"position": [0, 0]}}, r"radar_pose must be"),
    ({"name": "my data"}, r"name must be a non-empty string"),
])
def test_spec_validation_names_field_and_fix(changes, match):
    with pytest.raises(SpecError, match=match):
        load_spec(plate_spec(**changes))


def test_spec_missing_fields_and_bad_files(tmp_path):
    spec = plate_spec()
    del spec["seed"], spec["radar"]
    with pytest.raises(SpecError, match=r"missing field\(s\) seed, radar"):
        load_spec(spec)
    with pytest.raises(SpecError, match="no such file"):
        load_spec(tmp_path / "nope.yaml")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(SpecError, match=r"bad.json cannot be parsed"):
        load_spec(tmp_path / "bad.json")
    (tmp_path / "list.yaml").write_text("- a\n- b\n")
    with pytest.raises(SpecError, match=r"list.yaml: the top level must be a mapping"):
        load_spec(tmp_path / "list.yaml")


# ===================================================================================== folder checks
def test_folder_refusals_without_a_cluster(tmp_path):
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(DatasetError, match="not a data set folder"):
        dataset.generate(plate_spec(), other, progress=False)
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / ".lock").write_text(json.dumps({"host": socket.gethostname(), "pid": os.getppid()}))
    with pytest.raises(DatasetError, match=f"being generated by process {os.getppid()}"):
        dataset.generate(plate_spec(), locked, progress=False)
    assert not (locked / "spec.json").exists()


# ===================================================================================== generation
def test_run_item_reports_a_wrong_label_object_before_simulating(tmp_path):
    spec = load_spec(plate_spec(count=1, label_object="torso"))
    task = {"spec": spec.to_dict(), "item": spec.item(0).to_dict(), "dir": str(tmp_path / "item"), "threads": None}
    result = dataset.run_item(task)  # the task function, here in this process: it never raises
    assert result["status"] == "failed"
    assert "label_object 'torso' is not an object of this scene; its objects: plate" in result["error"]
    assert (tmp_path / "item" / "scene" / "animation.json").exists() and not (tmp_path / "item" / "run.zarr").exists()


def _mtimes(store: Path, frame: int) -> int:
    return (store / "iq" / "c" / str(frame) / "0" / "0" / "0" / "0").stat().st_mtime_ns


def test_generate_index_failures_resume_and_spec_mismatch(tmp_path, scheduler):
    spec = load_spec(plate_spec())
    items = spec.items()
    failing = [it.id for it in items if it.parameters["start_range"] < 1.0]
    good = [it.id for it in items if it.id not in failing]
    assert failing and len(good) >= 2, "seed 4 should draw both kinds of items"
    out = tmp_path / "ds"

    with pytest.warns(DatasetWarning, match=rf"(?s)2/4 items complete .*item {failing[0]} failed: ValueError"):
        index = dataset.generate(plate_spec(), out, scheduler=scheduler, progress=False)

    # ---- the index: items, parameters, status, labels
    assert list(index.item.values) == [it.id for it in items]
    assert list(index.status.values) == ["failed" if it.id in failing else "complete" for it in items]
    for it in items:
        row = index.sel(item=it.id)
        assert float(row.param_speed) == it.parameters["speed"]
        assert float(row.param_start_range) == it.parameters["start_range"]
        assert float(row.param_size) == 0.5                              # builder default filled in
        assert int(row.noise_seed) == it.noise_seed
        assert row.scenario.item() == "moving_plate"
        assert int(row.attempts) == 1 and bool(row.ran)
        if it.id in failing:
            assert "into the radar" in row.error.item() and int(row.frames_done) == 0
            assert np.isnan(row.radial_velocity.values).all()
            record = json.loads((out / "items" / it.id / "item.json").read_text())
            assert record["status"] == "failed" and "Traceback" in record["traceback"]
            continue
        assert row.error.item() == "" and int(row.frames_done) == 2 and row.label_object.item() == "plate"
        run = open_run(out / "items" / it.id / "run.zarr")
        assert run.attrs["seed"] == it.noise_seed
        assert run.attrs["radar"]["num_chirps"] == 16
        np.testing.assert_array_equal(row.radial_velocity.values, run.truth_radial_velocity.values[:, 0])
        np.testing.assert_array_equal(row.frame_time.values, run.frame_time.values)
        # physics: a plate on boresight, R(t) = R0 + v t, seen from a phase centre a few mm off axis
        v, r0 = it.parameters["speed"], it.parameters["start_range"]
        np.testing.assert_allclose(row.radial_velocity.values, v, atol=1e-3)
        np.testing.assert_allclose(row.range.values, r0 + v * run.frame_time.values, atol=2e-3)
    on_disk = dataset.open_index(out)
    assert list(on_disk.status.values) == list(index.status.values)
    assert "2/4 items complete" in on_disk.attrs["summary"]
    assert json.loads((out / "spec.json").read_text())["spec"] == spec.to_dict()

    # ---- resume: item good[0] lost its frame-1 done flag (as if killed mid-frame); good[1] is whole
    cut, whole = out / "items" / good[0] / "run.zarr", out / "items" / good[1] / "run.zarr"
    zarr.open_group(str(cut), mode="r+")["frame_done"][1] = False
    before = {"cut0": _mtimes(cut, 0), "cut1": _mtimes(cut, 1), "whole0": _mtimes(whole, 0), "whole1": _mtimes(whole, 1)}
    time.sleep(0.01)
    with pytest.warns(DatasetWarning):
        again = dataset.generate(plate_spec(), out, scheduler=scheduler, progress=False)
    ran = dict(zip(again.item.values, again.ran.values))
    assert ran == {it.id: it.id in failing or it.id == good[0] for it in items}
    assert list(again.status.values) == list(index.status.values)
    assert int(again.sel(item=good[0]).attempts) == 2 and int(again.sel(item=good[1]).attempts) == 1
    assert all(int(again.sel(item=i).attempts) == 2 for i in failing)     # failed items are retried
    assert _mtimes(cut, 0) == before["cut0"] and _mtimes(cut, 1) != before["cut1"]   # only frame 1 redone
    assert _mtimes(whole, 0) == before["whole0"] and _mtimes(whole, 1) == before["whole1"]
    assert open_run(cut).done_mask.all()

    # ---- a different spec into the same folder is refused, naming what differs
    with pytest.raises(DatasetError, match=r"different spec \(differs in: count\).*new folder"):
        dataset.generate(plate_spec(count=5), out, scheduler=scheduler, progress=False)
    changed = plate_spec()
    changed["parameters"] = {**changed["parameters"], "speed": {"uniform": [-1.0, -0.5]}}
    with pytest.raises(DatasetError, match=r"differs in: parameters.speed"):
        dataset.generate(changed, out, scheduler=scheduler, progress=False)
    with pytest.raises(ValueError, match="workers= and cluster_options= configure the local cluster only"):
        dataset.generate(plate_spec(), out, scheduler=scheduler, workers=2, progress=False)


def test_frames_subset_and_radar_pose_override(tmp_path, scheduler):
    """frames: [1] simulates frame 1 only (the item is complete without frame 0); radar_pose moves
    the radar 0.5 m sideways, so the plate at range x on the x axis has dR/dt = v x / sqrt(x^2 + 0.5^2)."""
    pose = {"position": [0.0, 0.5, 1.0], "orientation": [0.0, 0.0, 0.0]}
    spec = plate_spec(count=1, frames=[1], radar_pose=pose,
                      parameters={"speed": 1.5, "start_range": 3.0, "num_frames": 2})
    index = dataset.generate(spec, tmp_path / "sub", scheduler=scheduler, progress=False)
    row = index.sel(item="000000")
    assert row.status.item() == "complete" and int(row.frames_done) == 1
    run = open_run(tmp_path / "sub" / "items" / "000000" / "run.zarr")
    assert list(run.done_mask) == [False, True] and list(run.done_frames) == [1]
    assert run.attrs["radar_pose"] == pose
    assert np.isnan(row.radial_velocity.values[0])
    x = 3.0 + 1.5 / 24.0
    np.testing.assert_allclose(row.radial_velocity.values[1], 1.5 * x / np.hypot(x, 0.5), atol=2e-3)
    np.testing.assert_allclose(row.range.values[1], np.hypot(x, 0.5), atol=5e-3)


def test_generate_starts_its_own_local_cluster(tmp_path, capsys):
    """scheduler=None: generate starts (and closes) a LocalCluster of 2 worker processes itself; the
    two items (seed 4: item 0 at 3 m, item 1 at 0.21 m, which fails) run one in each process."""
    spec = plate_spec(count=2)
    with pytest.warns(DatasetWarning, match="item 000001 failed"):
        index = dataset.generate(spec, tmp_path / "own", workers=2, progress=True)
    assert list(index.status.values) == ["complete", "failed"]
    err = capsys.readouterr().err
    assert "1/2 items complete (1 generated now, 0 already done), 1 failed" in err and "generate plates" in err
    workers = set(index.worker.values)
    assert len(workers) == 2 and str(os.getpid()) not in {w.split(":")[1] for w in workers}
    run = open_run(tmp_path / "own" / "items" / "000000" / "run.zarr")
    np.testing.assert_array_equal(index.sel(item="000000").radial_velocity.values, run.truth_radial_velocity.values[:, 0])
    assert index.sel(item="000001").error.item().startswith("ValueError: moving_plate:")


KILL_SCRIPT = """
import json, sys
from sionnafmcw import dataset
if __name__ == "__main__":
    dataset.generate(json.loads(sys.argv[1]), sys.argv[2], workers=1, progress=False)
"""


@pytest.mark.slow
def test_killed_generation_resumes(tmp_path, scheduler):
    """SIGKILL the generating process group after the first item; a new run redoes only the rest."""
    spec = plate_spec(count=4, parameters={"speed": {"uniform": [0.5, 2.0]}, "num_frames": 6})
    out = tmp_path / "killed"
    script = tmp_path / "gen.py"
    script.write_text(KILL_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), json.dumps(spec), str(out)], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 240
        done = []
        while time.monotonic() < deadline and not done:
            done = [p.parent.name for p in out.glob("items/*/item.json")
                    if json.loads(p.read_text())["status"] == "complete"]
            assert proc.poll() is None, "the generation ended before it could be killed"
            time.sleep(0.2)
        assert done, "no item finished within 240 s"
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    time.sleep(1.0)
    assert (out / ".lock").exists()                                    # left behind by the killed run
    states = {it.id: dataset.store_state(out / "items" / it.id / "run.zarr")["complete"]
              for it in load_spec(spec).items()}
    assert sum(states.values()) < 4
    index = dataset.generate(spec, out, scheduler=scheduler, progress=False)
    assert (index.status.values == "complete").all()
    assert dict(zip(index.item.values, index.ran.values)) == {i: not c for i, c in states.items()}
    assert not (out / ".lock").exists()
