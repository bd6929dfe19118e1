r"""``sionnafmcw.torch`` with a real PyTorch, and domain randomisation in a data-set spec, on one small
randomised RadHAR data set generated on a real Dask LocalCluster.

* Randomisation: every item's drawn scenario parameters (range, azimuth, heading, sensor height and
  tilt, room size, materials, furniture) and receiver fields (noise figure, phase noise) lie in the
  ranges of :mod:`sionnafmcw.dataset.randomisation` and differ between items; the run stores keep the
  drawn noise figure; the scene puts the person at the drawn range and azimuth.
* The Dataset: features as :mod:`sionnafmcw.processing` computes them, labels equal to the run
  stores' (activity, keypoints), ``activity_index`` by ``classes``; a DataLoader with two worker
  processes gives every example once, in order; point clouds of a per-frame function are padded per
  batch with a mask; ``point_cloud=True`` without the TI chain is a clear error.

The randomised set: five items (one per class), 2 frames each, 16 chirps x 64 samples, 2000 rays per
source (about 40 s on 2 cores: ``slow``); the Dataset and the DataLoader are also checked on a set of
three moving plates (seconds).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest

import sionnafmcw.torch as storch  # noqa: I001
import torch

from sionnafmcw import dataset, open_run, processing
from sionnafmcw.dataset import load_spec
from sionnafmcw.dataset.randomisation import RADAR_RANGES, RADHAR_RANGES, radhar_spec, range_table
from sionnafmcw.scenes.radhar import CLASSES

FIELDS = ("person_range", "person_azimuth", "heading_offset", "radar_height", "radar_tilt", "room_margin")


def _spec():
    return radhar_spec(name="radhar-tiny", count=5, seed=3, engine_options={"samples_per_src": 2000, "max_depth": 1},
                       num_frames=2, body_mesh_edge=0.06) | {
        "radar": {**radhar_spec()["radar"], "num_chirps": 16, "num_samples": 64}}


PLATES = {"name": "torch-plates", "scenario": "moving_plate", "count": 3, "seed": 5,
          "radar": {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64},
          "engine_options": {"samples_per_src": 2000},
          "parameters": {"speed": {"uniform": [0.5, 2.0]}, "start_range": [3.0, 4.0], "num_frames": 2}}


def _generate(spec, out):
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        index = dataset.generate(spec, out, scheduler=cluster.scheduler_address, progress=False)
    assert list(index.status.values) == ["complete"] * spec["count"], list(index.error.values)
    return out


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return _generate(_spec(), tmp_path_factory.mktemp("torch") / "radhar")


@pytest.fixture(scope="module")
def plates(tmp_path_factory):
    return _generate(PLATES, tmp_path_factory.mktemp("torch") / "plates")


def _in(value, draw) -> bool:
    kind, args = next(iter(draw.items()))
    return args[0] <= value <= args[1] if kind == "uniform" else value in args


def test_spec_draws_every_item_within_the_ranges():
    items = load_spec(_spec() | {"count": 20}).items()
    assert [it.parameters["activity"] for it in items[:5]] == list(CLASSES)
    for name, (draw, why) in RADHAR_RANGES.items():
        assert why and all(_in(it.parameters[name], draw) for it in items), name
        values = {str(it.parameters[name]) for it in items}
        assert len(values) == 20 if "uniform" in draw else len(values) > 1, name      # they differ between items
    for name, (draw, _) in RADAR_RANGES.items():
        assert all(_in(it.radar[name], draw) for it in items), name
        assert len({str(it.radar[name]) for it in items}) > 1, name
    assert load_spec(_spec()).item(3).radar == load_spec(_spec() | {"count": 9}).item(3).radar   # per item
    guide = Path(__file__).resolve().parents[1] / "docs" / "guide" / "datasets.md"
    assert range_table() in guide.read_text()                   # the guide states the ranges the code draws


def test_a_radar_file_with_drawn_receiver_fields(tmp_path):
    from sionnafmcw import RadarConfig
    from sionnafmcw.dataset import SpecError

    cfg = tmp_path / "board.cfg"
    cfg.write_text(RadarConfig.preset("ti-iwr1443boost").to_ti_cfg())
    spec = load_spec(radhar_spec(count=6, radar=str(cfg)) | {"count": 6})
    board = RadarConfig.from_ti_cfg(cfg)
    for it in spec.items():
        assert 14.0 <= it.radar["noise_figure"] <= 18.0
        assert RadarConfig.from_dict(it.radar).replace(noise_figure=board.noise_figure,
                                                       phase_noise=board.phase_noise) == board
    assert len({it.radar["noise_figure"] for it in spec.items()}) == 6
    with pytest.raises(SpecError, match=r"radar: .*nothere.cfg: no such radar file"):
        load_spec(radhar_spec(radar=str(tmp_path / "nothere.cfg")))
    with pytest.raises(SpecError, match=r"unknown RadarConfig field\(s\) noise_figur"):
        load_spec(radhar_spec() | {"radar": {"file": str(cfg), "noise_figur": 3}})


@pytest.mark.slow
def test_randomised_items_reach_the_stores_and_the_scenes(data):
    items = load_spec(_spec()).items()
    index = dataset.open_index(data)
    for k, it in enumerate(items):
        run = open_run(data / "items" / it.id / "run.zarr")
        assert run.radar.noise_figure == pytest.approx(it.radar["noise_figure"])
        for name in FIELDS:
            assert float(index[f"param_{name}"].values[k]) == pytest.approx(it.parameters[name])
        pelvis = run.joint_positions()[0, 0, 0]            # frame 0, person 0, pelvis (world, radar at the origin)
        if it.parameters["activity"] != "walk":            # (a walk is placed by its middle)
            r, phi = it.parameters["person_range"], it.parameters["person_azimuth"]
            assert np.allclose(pelvis[:2], [r * math.cos(phi), r * math.sin(phi)], atol=1e-4)


@pytest.mark.slow
def test_dataset_activity_and_keypoints_equal_the_stores(data):
    ds = storch.RadarDataset(data, features="range_doppler", labels=("person_activity", "joint_position", "range"),
                             frames_per_example=2, classes=CLASSES)
    assert len(ds) == 5
    for k in range(len(ds)):
        e = ds[k]
        item = ds.examples.examples[k].item
        run = open_run(data / "items" / item / "run.zarr")
        assert e["feature"].dtype == torch.float32 and tuple(e["feature"].shape) == (2, 16, 64)
        rd = processing.range_doppler_map(run.cubes(slice(0, 1))[0], run.radar, clutter_removal=True).power
        assert np.allclose(e["feature"][0].numpy(), 10 * np.log10(np.maximum(rd, 1e-30)), atol=1e-3)
        assert e["person_activity"] == CLASSES[k] and int(e["activity_index"]) == k
        assert np.allclose(e["joint_position"].numpy()[:, 0], run.joint_positions()[:2, 0], atol=1e-6)
        assert e["range"].shape == (2,)


def _peaks(cube, radar, frame_time):
    """A real per-frame detector for the test: range-Doppler cells within 20 dB of the map's peak."""
    rd = processing.range_doppler_map(cube, radar, clutter_removal=True)
    d, r = np.nonzero(rd.power >= rd.power.max() / 100)
    rng, vel = rd.ranges[r], rd.velocities[d]
    return np.stack([np.zeros_like(rng), rng, np.zeros_like(rng), vel, 10 * np.log10(rd.power[d, r])], 1)


def test_loader_with_two_workers_pads_point_clouds(plates):
    ds = storch.RadarDataset(plates, features="iq", labels=("item", "speed"), frames_per_example=1, frame_stride=1,
                             point_cloud=_peaks)
    loader = storch.loader(ds, batch_size=4, num_workers=2)
    seen, items = 0, []
    for batch in loader:
        b = len(batch["item"])
        assert batch["feature"].dtype == torch.complex64 and tuple(batch["feature"].shape[1:]) == (1, 16, 3, 4, 64)
        n = batch["num_points"]
        assert tuple(batch["point_cloud"].shape[:3]) == (b, 1, int(n.max())) and batch["point_cloud"].shape[3] == 5
        assert torch.equal(batch["point_mask"].sum(-1), n)
        assert float(batch["point_cloud"][~batch["point_mask"]].abs().sum()) == 0.0     # zero padding
        assert batch["speed"].dtype == torch.float32 and batch["speed"].shape == (b,)
        items += batch["item"]
        seen += b
    assert seen == len(ds) == 6 and items == [ds[k]["item"] for k in range(len(ds))]


def test_features_equal_processing_and_errors_are_clear(plates):
    ds = storch.RadarDataset(plates, features="range_doppler", labels="radial_velocity", frames_per_example=2)
    e = ds[1]
    run = open_run(plates / "items" / ds.examples.examples[1].item / "run.zarr")
    rd = processing.range_doppler_map(run.cubes(slice(1, 2))[0], run.radar, clutter_removal=True).power
    assert np.allclose(e["feature"][1].numpy(), 10 * np.log10(np.maximum(rd, 1e-30)), atol=1e-3)
    assert np.allclose(e["radial_velocity"].numpy(), run.truth(run.objects[0])[:2])
    with pytest.raises(ValueError, match="label 'person_activity' needs a data set of people"):
        storch.RadarDataset(plates, labels="person_activity")
    with pytest.raises(ValueError, match="point_cloud must be"):
        storch.RadarDataset(plates, point_cloud="ti")
    with pytest.raises(ValueError, match=r"must be \[N, 5\]"):
        storch.points_array(np.zeros((3, 4)))
    try:
        import sionnafmcw.ti.oob  # noqa: F401
    except ImportError:
        ds = storch.RadarDataset(plates, features="range_doppler", point_cloud=True)
        with pytest.raises(RuntimeError, match="sionnafmcw.ti.oob"):
            ds[0]
    else:  # once the TI chain is merged: the demo's chain with a .cfg's processing lines
        with pytest.raises(ValueError, match="did not come from a TI .cfg"):     # walk-77ghz has none
            storch.RadarDataset(plates, features="range_doppler", point_cloud=True)[0]
        from test_ti_cfg import PROFILE_3D_18XX     # a demo .cfg with its processing lines

        ds = storch.RadarDataset(plates, features="range_doppler", frames_per_example=2, point_cloud=True,
                                 ti_processing=PROFILE_3D_18XX)
        e = ds[0]
        assert len(e["point_cloud"]) == 2 and all(c.shape[1] == 5 for c in e["point_cloud"])
        assert e["num_points"].tolist() == [len(c) for c in e["point_cloud"]]
