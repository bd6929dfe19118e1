"""Where moving points come from (sionnafmcw.validation.moving_points): the per-frame factoring and the
truth classes on hand-made recordings whose figures are known by construction, the chain variants of
RadHAR's own .cfg, and the command line's one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.geometry import world_to_radar
from sionnafmcw.ti.formats.radhar import Recording
from sionnafmcw.validation.moving_points import (PersonTruth, chain_variants, driver_range_step, main,
                                                 moving_point_structure, moving_points_against_truth)

RADHAR = next((p / "shared" / "realdata" / "radhar" for p in Path(__file__).resolve().parents
               if (p / "shared" / "realdata" / "radhar").is_dir()), Path("shared/realdata/radhar"))
RADHAR_CFG = RADHAR / "1443es1_short_range_3d.cfg"

#: The hand-made Doppler grid (0.6 m/s per bin, bin 8 static) and the driver's range step (m).
STEP, OFFSET, RSTEP = 0.6, 8, 0.05


def recording(frame, k, x, y=None, z=None, driver_range=None):
    """Points of the driver's fields: ``k`` the signed Doppler bin, ``x, y, z`` the radar-frame position,
    ``driver_range`` the driver's ``range`` (default: the position's range on the driver's grid)."""
    frame, k, x = (np.asarray(a) for a in (frame, k, x))
    n = frame.size
    y = np.zeros(n) if y is None else np.asarray(y, float)
    z = np.zeros(n) if z is None else np.asarray(z, float)
    rng = np.sqrt(x ** 2 + y ** 2 + z ** 2) if driver_range is None else np.asarray(driver_range, float)
    rng = np.rint(rng / RSTEP) * RSTEP
    point_id = np.concatenate([np.arange(c) for c in np.unique(frame, return_counts=True)[1]])
    return Recording(frame=frame.astype(np.int32), point_id=point_id.astype(np.int32), x=x.astype(np.float32),
                     y=y.astype(np.float32), z=z.astype(np.float32), range=rng.astype(np.float32),
                     velocity=(k * STEP).astype(np.float32), doppler_bin=(k + OFFSET).astype(np.int32),
                     bearing=np.zeros(n, np.float32), intensity=np.full(n, 25.0, np.float32),
                     stamp=np.zeros(n), activity="walk", source="hand-made")


def test_the_moving_points_factor_into_frames_groups_range_bins_and_second_points():
    # range bins (driver's 0.05 m steps) and signed Doppler bins, frame by frame:
    #   frame 0: k=1 at bins 40, 41, 42 (one group of 3) and a second point at 41; static bin 60; a near
    #            point (0.1 m) at k=1, which does not count
    #   frame 1: k=1 at bins 40 and 42 (two groups: bin 41 empty), k=2 at bin 45
    #   frame 2: static only
    frame = [0, 0, 0, 0, 0, 0, 1, 1, 1, 2]
    k = [1, 1, 1, 1, 0, 1, 1, 1, 2, 0]
    bins = [40, 41, 42, 41, 60, 2, 40, 42, 45, 50]
    rec = recording(frame, np.array(k), np.array(bins) * RSTEP)
    assert driver_range_step(rec) == pytest.approx(RSTEP, rel=1e-6)
    s = moving_point_structure(rec, grid=(STEP, OFFSET))
    assert s["frames"] == 3
    assert s["moving_points_per_frame"] == pytest.approx(7 / 3)
    assert s["frames_with_moving"] == pytest.approx(2 / 3)
    assert s["groups_per_moving_frame"] == pytest.approx(4 / 2)
    assert s["range_bins_per_group"] == pytest.approx(6 / 4)
    assert s["points_per_range_bin"] == pytest.approx(7 / 6)
    assert s["second_point_share"] == pytest.approx(1 / 7)
    assert s["groups_of_3_or_more"] == pytest.approx(1 / 4)
    assert s["frames_with_two_bins"] == pytest.approx(1 / 2)
    assert s["gaps_per_moving_frame"] == pytest.approx(1 / 2)
    # the product of the factors is the count
    product = (s["frames_with_moving"] * s["groups_per_moving_frame"] * s["range_bins_per_group"]
               * s["points_per_range_bin"])
    assert product == pytest.approx(s["moving_points_per_frame"])


def test_a_range_off_the_drivers_grid_is_named():
    rec = recording([0, 0, 0], np.array([1, 1, 1]), np.array([2.0, 2.05, 2.1]))
    bad = Recording(**{**rec.__dict__, "range": np.array([2.0, 2.05, 2.12], np.float32)})
    with pytest.raises(ValueError, match="hand-made: point 2 has range 2.12"):
        driver_range_step(bad)


def test_moving_points_against_a_known_body_and_a_tilted_radar():
    position, orientation = np.array([0.0, 0.0, 1.0]), np.array([0.0, -0.1, 0.0])
    body = np.array([[2.0, 0.0, 0.1], [2.1, 0.0, 1.0], [2.2, 0.0, 1.7]])
    truth = PersonTruth(body_points=np.stack([body, body]), trunk_radial_velocity=np.array([0.62, 0.05]),
                        radar_position=position, radar_orientation=orientation, source="hand-made truth")
    # world points: on the body (trunk's bin), a wall echo 1.2 m beyond it, a floor image, one in front of
    # the body at a limb's bin, a point 0.1 m above the floor (below it if the tilt were ignored: 2.1 m x
    # sin 0.1 = 0.21 m), a static point; frame 1: on the body while the trunk is in bin 0
    world = np.array([[2.05, 0.0, 1.0], [3.5, 0.0, 1.0], [2.1, 0.0, -0.6], [1.2, 0.0, 1.0], [2.1, 0.0, 0.1],
                      [2.1, 0.0, 1.2], [2.1, 0.0, 1.1]])
    frame = np.array([0, 0, 0, 0, 0, 0, 1])
    k = np.array([1, 1, 1, 2, 1, 0, 1])
    local = world_to_radar(world, position, orientation)
    rec = recording(frame, k, local[:, 0], local[:, 1], local[:, 2])
    result = moving_points_against_truth((rec, truth), grid=(STEP, OFFSET))
    points, summary = result["points"], result["summary"]
    assert list(points["location"]) == ["on_body", "beyond_body", "below_floor", "before_body", "on_body",
                                        "on_body"]
    np.testing.assert_allclose(points["z"], world[k != 0, 2], atol=1e-5)
    assert summary["location"] == pytest.approx({"on_body": 3 / 6, "before_body": 1 / 6, "beyond_body": 1 / 6,
                                                 "below_floor": 1 / 6})
    # the trunk is at bin round(0.62 / 0.6) = 1 in frame 0 and at 0 in frame 1
    assert list(points["trunk_bin"]) == [1, 1, 1, 1, 1, 0]
    assert summary["at_trunk_bin"] == pytest.approx(4 / 6)
    assert summary["abs_bin"] == pytest.approx({"1": 5 / 6, "2": 1 / 6, "3_or_more": 0.0})
    # the wall echo is 3.5 - 1 m away in world x; its offset beyond the body's farthest point
    far = np.linalg.norm(world_to_radar(body, position, orientation), axis=1).max()
    assert points["offset"][1] == pytest.approx(np.linalg.norm(local[1]) - far, abs=1e-5)
    speed = {c["low"]: c for c in summary["by_bulk_speed"]}
    assert speed[1.0]["frames"] == 1 and speed[1.0]["moving_points_per_frame"] == 5
    assert speed[0.0]["frames"] == 1 and speed[0.0]["moving_points_per_frame"] == 1
    walking = [c for c in summary["by_trunk_range_walking"] if c["frames"]]
    assert len(walking) == 1 and walking[0]["low"] == 2.0 and walking[0]["moving_points_per_frame"] == 5
    assert summary["frames_trunk_moving"] == pytest.approx(1 / 2)


def test_a_recording_longer_than_its_truth_is_named():
    truth = PersonTruth(body_points=np.ones((2, 3, 3)), trunk_radial_velocity=np.zeros(2),
                        radar_position=np.zeros(3), radar_orientation=np.zeros(3), source="run.zarr")
    rec = recording([0, 5], np.array([1, 1]), np.array([2.0, 2.05]))
    with pytest.raises(ValueError, match="frame 5 is beyond the 2 frames of run.zarr"):
        moving_points_against_truth((rec, truth), grid=(STEP, OFFSET))


@pytest.mark.skipif(not RADHAR_CFG.exists(), reason="RadHAR's .cfg is not on this machine")
def test_chain_variants_change_one_part_each():
    from sionnafmcw.ti.processing import processing_from_cfg

    base = processing_from_cfg(RADHAR_CFG.read_text())
    variants = chain_variants(base)
    assert variants["as run"] == base
    assert not base.peak_grouping.in_range and variants["peak grouping along range too"].peak_grouping.in_range
    assert variants["CFAR threshold +6 dB"].cfar_range.threshold == base.cfar_range.threshold + 512
    assert base.multi_object.enabled and not variants["no second points"].multi_object.enabled
    for name, changed in variants.items():
        differing = [f for f in ("peak_grouping", "cfar_range", "multi_object")
                     if getattr(changed, f) != getattr(base, f)]
        assert len(differing) == (0 if name == "as run" else 1), name


def test_the_command_line_names_a_missing_export(tmp_path, capsys):
    assert main(["--synthetic", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and str(tmp_path / "walk") in err and "\n" not in err


# ------------------------------------------------------------------ which echoes make the moving cells
def test_body_regions_of_segment_names():
    from sionnafmcw.validation.moving_cells import ROOM, body_region

    assert [body_region(n) for n in ("left_upper_arm", "right_lower_arm", "left_foot", "right_upper_leg", "torso",
                                     "pelvis", "head", ROOM)] == ["arms", "arms", "legs", "legs", "trunk and head",
                                                                  "trunk and head", "trunk and head", ROOM]


@pytest.mark.skipif(not RADHAR_CFG.exists(), reason="RadHAR's .cfg is not on this machine")
def test_cell_spectrum_is_the_chains_before_rounding():
    """Two point targets through the chain's rounded range FFT and Doppler FFT, and through cell_spectrum:
    the same spectrum to the range FFT's rounding (half an int16 step per sample, far below the peaks)."""
    from sionnafmcw.echoes import Echoes
    from sionnafmcw.synthesis import synthesize
    from sionnafmcw.ti.cfg import read_ti_cfg
    from sionnafmcw.ti.oob import doppler_fft, range_spectra
    from sionnafmcw.validation.moving_cells import cell_spectrum

    radar = read_ti_cfg(RADHAR_CFG.read_text())
    echoes = Echoes.point_targets(radar, ranges=[1.5, 2.2], radial_velocities=[0.0, 0.6], azimuths=[0.1, -0.3],
                                  rcs=[0.3, 0.1])
    cube = synthesize(echoes, radar, rng=3)
    exact = cell_spectrum(cube, radar)
    chain = doppler_fft(range_spectra(cube, radar).reshape(radar.num_chirps, radar.num_tx * radar.num_rx, -1), 2,
                        rounded=False)
    assert exact.shape == chain.shape == (16, 12, 256)
    assert np.abs(exact - chain).max() < 1.0          # int16 steps: the range FFT's rounding, through the window
    assert np.abs(chain).max() > 1e3


@pytest.mark.skipif(not RADHAR_CFG.exists(), reason="RadHAR's .cfg is not on this machine")
def test_moving_cell_sources_of_a_simulated_walker(tmp_path):
    """A walker without a room, approaching at 1 m/s (1.6 Doppler bins), simulated for three frames: the engine
    re-run reproduces every stored cube, every moving point's source is one of the walker's segments (no
    room), the region shares and the body's power shares are shares, the echoes re-scaled by 0 dB give the
    run's points and the body 60 dB down none; a different scene is refused."""
    from sionnafmcw import scenes, simulate
    from sionnafmcw.validation.moving_cells import MovingCellsError, REGIONS, moving_cell_sources

    common = dict(activity="walk", num_frames=3, body_mesh_edge=0.06, room=False, walk_direction="toward",
                  walk_speed=1.0, walk_path="straight", heading_offset=0.0, person_azimuth=0.0)
    scene = scenes.build("radhar", tmp_path / "scene", person_range=1.6, **common)
    store = tmp_path / "run.zarr"
    simulate(scene, RADHAR_CFG, out=store, progress=False, seed=7, threads=1,
             engine_options={"samples_per_src": 20000})
    result = moving_cell_sources(store, [0, 1, 2], gains={"unchanged": {"arms": 0.0},
                                                          "no body": {"arms": -60, "legs": -60, "trunk and head": -60}})
    assert np.all(result["frames"]["reproduction_error"] <= 1e-3)
    summary = result["summary"]
    # a 0 dB gain is the run again (one point of the three frames may flip at the 1e-4 reproduction), and a
    # body 60 dB down leaves no moving point (nothing else moves)
    variants = summary["variants"]
    assert variants["unchanged"]["moving_points_per_frame"] == pytest.approx(
        variants["as run"]["moving_points_per_frame"], abs=1 / 3)
    assert variants["as run"]["moving_points_per_frame"] >= 1
    assert variants["no body"]["moving_points_per_frame"] == 0
    assert summary["moving_points"] >= 1
    segments = {"torso", "pelvis", "head", "left_upper_arm", "left_lower_arm", "right_upper_arm", "right_lower_arm",
                "left_upper_leg", "left_lower_leg", "left_foot", "right_upper_leg", "right_lower_leg", "right_foot"}
    assert set(result["points"]["source"].tolist()) <= segments
    assert summary["region"]["room"] == 0.0
    assert sum(summary["region"][r] for r in REGIONS) == pytest.approx(1.0)
    assert sum(summary["body_power"].values()) == pytest.approx(1.0)
    assert np.all((result["points"]["share"] > 0) & (result["points"]["share"] <= 1))
    other = scenes.build("radhar", tmp_path / "other", person_range=2.0, **common)
    with pytest.raises(MovingCellsError, match="frame 0 re-run differs from the stored cube"):
        moving_cell_sources(store, [0], scene=other)


@pytest.mark.parametrize("extra, named", [(["--chain"], "--items"), (["--sources", "10"], "--items"),
                                          (["--limb-gains=-6"], "--sources"), (["--source-items", "000001"], "--sources")])
def test_the_command_line_names_an_option_without_the_one_it_needs(tmp_path, capsys, extra, named):
    with pytest.raises(SystemExit) as exit_:
        main(["--synthetic", str(tmp_path), *extra])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert named in err
