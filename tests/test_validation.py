"""Reduced versions of the validation experiments, with the same metrics and targets.

* ``pixel_vs_path`` on the rough moving plate, 4 frames: range-profile correlation >= 0.95,
  Doppler-time within one Doppler bin on every CPI, power within 3 dB. Reduced resolution: a
  128 x 64 pixel grid (0.94 x 0.94 degree pixels: the 0.5 m plate at 3 m spans about 10 x 10 of
  them, so the quadrature error of the pixel sum is a few per cent, << 3 dB) and 3e5 rays per Tx
  element (about 700 diffuse paths on the plate: Monte-Carlo power error ~ 1/sqrt(700) ~ 4 %).
* ``circle_walk`` with the pixel engine on the first 8 CPIs at the engine's 128 x 64 pixels:
  e_velo <= 0.3 m/s, the issue's target for the pixel engine. The pixel grid is not reduced: at
  0.94 degree pixels the torso (0.35 x 0.55 m at 6-8 m) covers 12-24 pixels; at 64 x 32 only
  3-6, and the strongest cell is then a limb or a wall edge as often as the torso (measured
  e_velo 0.54 m/s), so that grid cannot resolve what the metric measures.
* The truth at the CPI centre against the closed form of uniform circular motion.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sionnafmcw.geometry import world_phase_centre
from sionnafmcw.radar import RadarConfig
from sionnafmcw.store import RunStore, open_run
from sionnafmcw.validation import circle_walk, names, pixel_vs_path, run


def test_experiments_are_registered():
    assert names() == ["point_targets", "circle_walk", "pixel_vs_path"]
    with pytest.raises(ValueError, match="unknown; choose one of point_targets"):
        run("nope", [])


def test_pixel_vs_path_on_the_rough_moving_plate(tmp_path, capsys):
    status = pixel_vs_path.main(["--scenes", "moving_plate", "--frames", "4", "--samples-per-src", "300000",
                                 "--n-az", "128", "--n-el", "64", "--out", str(tmp_path), "--quiet"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    metrics = json.loads(last)
    assert metrics == json.loads((tmp_path / "metrics.json").read_text())
    assert "physical optics" in metrics["models"]["pixel"]  # like with like by default
    m = metrics["scenes"]["moving_plate"]
    assert m["range_profile_correlation"] >= 0.95
    assert m["doppler_time_within_one_bin"] == 1.0
    assert abs(m["power_difference_db"]) <= 3.0
    assert status == 0 and metrics["passed"]
    for kind in ("range_profile", "range_doppler", "doppler_time", "angle"):
        assert (tmp_path / f"moving_plate_{kind}.png").stat().st_size > 10_000


def test_circle_walk_pixel_engine_reduced(tmp_path, capsys):
    status = circle_walk.main(["--engine", "pixel", "--frames", "8", "--out", str(tmp_path), "--quiet"])
    metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    m = metrics["engines"]["pixel"]
    assert m["num_cpis"] == 8
    assert m["e_velo"] <= circle_walk.TARGETS["pixel"]
    assert status == 0
    for name in ("doppler_time_pixel.png", "range_doppler_pixel.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_truth_at_cpi_centre_for_circular_motion(tmp_path):
    """Uniform circular motion sampled at frame times, written to a run store: the CPI-centre radial
    velocity the reader gives against the closed form."""
    radar = RadarConfig.preset("walk-77ghz").replace(num_samples=8)  # the preset's CPI (26.9 ms), small cubes
    fps, r, v = 24.0, 3.0, 4.52
    w = v / r
    t = np.arange(24) / fps
    pos = np.stack([r * np.cos(w * t), r * np.sin(w * t), np.ones_like(t)], -1)[:, None, :]
    vel = np.stack([-v * np.sin(w * t), v * np.cos(w * t), np.zeros_like(t)], -1)[:, None, :]
    radar_position = np.array([-5.0, 0.0, 1.0])
    store = RunStore.open(tmp_path / "run.zarr", radar, t.size, ["torso"],
                          attrs={"radar": radar.to_dict(),
                                 "radar_pose": {"position": radar_position.tolist(), "orientation": [0.0, 0.0, 0.0]}})
    cube = np.zeros((radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples), np.complex64)
    for n in range(t.size):
        store.write_frame(n, cube, t[n], pos[n], vel[n], np.zeros(1))
    run = open_run(tmp_path / "run.zarr")
    radar = run.radar  # the CPI duration the reader uses
    got = run.truth_at_cpi_centre("torso")

    c = world_phase_centre(radar, radar_position, np.zeros(3))
    assert np.allclose(run.phase_centre, c)
    tc = t + radar.cpi_duration / 2
    pc = np.stack([r * np.cos(w * tc), r * np.sin(w * tc), np.ones_like(tc)], -1)
    vc = np.stack([-v * np.sin(w * tc), v * np.cos(w * tc), np.zeros_like(tc)], -1)
    want = np.sum(vc * (pc - c), -1) / np.linalg.norm(pc - c, axis=-1)
    # residual: jerk term v^3/r^2 * dt^2 / 2 plus the central-difference error of the acceleration
    dt = radar.cpi_duration / 2
    bound = (v**3 / r**2) * dt**2 / 2 + (v**3 / r**2) * (1 / fps) ** 2 / 6 * dt
    inner = slice(1, -1)  # one-sided differences at the ends
    np.testing.assert_allclose(got[inner], want[inner], atol=2 * bound)
    frame_start = np.sum(vel[:, 0] * (pos[:, 0] - c), -1) / np.linalg.norm(pos[:, 0] - c, axis=-1)
    assert np.max(np.abs(frame_start - want)) > 20 * bound  # the correction matters
