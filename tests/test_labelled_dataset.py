r"""Labelled data sets of people (``sionnafmcw.dataset`` with the ``people`` builder), on a real Dask
LocalCluster.

* Spec parameters: ``{cycle: [...]}`` gives item :math:`i` the :math:`(i \bmod n)`-th value; ``{files:
  folder}`` is a choice among the folder's files (absolute, sorted; a folder without files is an
  error naming it); seed parameters the spec leaves free (``seed``, ``furniture_seed``) are drawn per
  item.
* The index's per-item and per-frame labels equal the run stores': ``num_people``, ``person_count``,
  ``activity`` per person, ``joint_position`` (the keypoints), the vital-sign rates the scene drew;
  the activity label of a clip is its shipped activity (or the file's name).
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw import dataset, open_run
from sionnafmcw.dataset import SpecError, load_spec
from sionnafmcw.mocap import library

RADAR = {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64}


def _spec(clips, **parameters) -> dict:
    return {"name": "people", "scenario": "people", "count": 4, "seed": 2, "radar": RADAR,
            "engine_options": {"samples_per_src": 2000, "max_depth": 1},
            "parameters": {"num_people": {"cycle": [2, 1]},
                           "activity": {"cycle": ["walk", "clip", "vital_signs", "wave"]},
                           "clip": {"files": str(clips)}, "random_vitals": False,
                           "breathing_rate": {"uniform": [0.2, 0.4]}, "chairs": [0, 2], "num_frames": 2,
                           "body_mesh_edge": 0.06, **parameters}}


@pytest.fixture()
def clips(tmp_path):
    folder = tmp_path / "clips"
    folder.mkdir()
    for name in ("111_37", "115_06"):
        shutil.copy(library.clip_info(name).path, folder / f"{name}.bvh")
    return folder


def test_spec_cycle_files_and_seeds(clips, tmp_path):
    spec = load_spec(_spec(clips))
    items = spec.items()
    assert [it.parameters["activity"] for it in items] == ["walk", "clip", "vital_signs", "wave"]
    assert [it.parameters["num_people"] for it in items] == [2, 1, 2, 1]
    assert load_spec({**_spec(clips), "count": 6}).item(5).parameters["activity"] == "clip"   # nor on count
    files = sorted(str(p.resolve()) for p in clips.iterdir())
    assert spec.to_dict()["parameters"]["clip"] == {"choice": files}
    assert {it.parameters["clip"] for it in spec.items()} <= set(files)
    for name in ("seed", "furniture_seed"):
        assert len({it.parameters[name] for it in items}) == 4            # drawn per item
    assert load_spec(_spec(clips, furniture_seed=7)).item(0).parameters["furniture_seed"] == 7
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(SpecError, match=r"parameters.clip: \{'files': .*empty'\} matches no file"):
        load_spec(_spec(empty))
    with pytest.raises(SpecError, match=r"parameters.num_frames: \{'files': pattern\} draws file paths"):
        load_spec(_spec(clips, num_frames={"files": str(clips)}))
    with pytest.raises(SpecError, match=r"'cycle' needs a non-empty list"):
        load_spec(_spec(clips, num_people={"cycle": []}))


def test_index_labels_equal_the_stores(clips, tmp_path):
    from distributed import LocalCluster

    spec = _spec(clips)
    items = load_spec(spec).items()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        index = dataset.generate(spec, tmp_path / "ds", scheduler=cluster.scheduler_address, progress=False)
    assert list(index.status.values) == ["complete"] * 4, list(index.error.values)
    assert index.joint_position.dims == ("item", "frame", "person", "joint", "xyz")
    assert list(index.person.values) == ["person0", "person1"] and len(index.joint) == 15
    for i, it in enumerate(items):
        run = open_run(tmp_path / "ds" / "items" / it.id / "run.zarr")
        n = it.parameters["num_people"]
        assert int(index.num_people[i]) == n == len(run.people)
        assert list(index.person_count.values[i]) == [n, n] == list(run.person_count())
        np.testing.assert_allclose(index.joint_position.values[i, :, :n], run.joint_positions(), atol=1e-5)
        assert np.isnan(index.joint_position.values[i, :, n:]).all()          # padding for fewer people
        act = it.parameters["activity"]
        label = library.CLIPS[Path(it.parameters["clip"]).stem].activity if act == "clip" else act
        assert (index.activity.values[i, :, :n] == label).all() and (run.activities() == label).all()
        assert (index.activity.values[i, :, n:] == "").all()
        if act == "vital_signs":       # random_vitals=false: every still person breathes at the drawn rate
            np.testing.assert_allclose(index.breathing_rate.values[i, :n], it.parameters["breathing_rate"])
            np.testing.assert_allclose(index.heart_rate.values[i, :n], 1.2)
        else:
            assert np.isnan(index.breathing_rate.values[i]).all()
        assert index.label_object.values[i] == "person0_torso"
    # the same labels through the examples the TensorFlow stream reads (person axis padded to the index's)
    from sionnafmcw.dataset.examples import Examples

    ex = Examples(tmp_path / "ds", labels=("person_count", "joint_position", "activity"), frames_per_example=2)
    assert ex.label_dtype("joint_position") == (np.float32, (2, 2, 15, 3))
    for e, (x, y) in zip(ex.examples, ex):
        i = list(index.item.values).index(e.item)
        assert list(y["person_count"]) == list(index.person_count.values[i])
        assert y["activity"] == items[i].parameters["activity"]
        np.testing.assert_allclose(y["joint_position"], index.joint_position.values[i], atol=1e-5)   # index: 10 um
        assert x.shape == (2, 16, 64) and x.dtype == np.float32
