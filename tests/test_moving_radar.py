"""A moving radar against closed forms: ego-Doppler of static clutter, a corridor of
corner reflectors passed at the right ranges, the per-frame pose in the manifest, the API, the run
store and the plots.

Closed forms. A radar moving at speed :math:`v` at an angle :math:`\\theta` to its line of sight
towards a static reflector sees the range rate :math:`\\dot R = -v\\cos\\theta` (approaching for
:math:`|\\theta| < 90°`), i.e. the Doppler :math:`f_D = -2\\dot R/\\lambda = 2v\\cos\\theta/\\lambda`
(positive approaching, the project's sign) and the velocity axis shows :math:`-v\\cos\\theta`.
A trihedral's triple bounce is the point reflection through its corner: its range is the corner's
distance from the phase centre. Tolerances: one Doppler bin :math:`\\lambda/(2T)` and one range bin
:math:`c/(2B)` (the radar moves 0.13 m, 1.4 range bins, during a 27 ms CPI at 5 m/s: the range
FFT sees the mean range, half of it, within the bin).
"""

import json
import shutil

import numpy as np
import pytest

from sionnafmcw import RadarConfig, processing, scenes, simulate, synthesize
from sionnafmcw.animation import AnimationError, RadarPose, load_animation
from sionnafmcw.engines import EngineError, create
from sionnafmcw.geometry import world_phase_centre
from sionnafmcw.store import open_run


@pytest.fixture(scope="module")
def radar():
    return RadarConfig.preset("walk-77ghz")


def peak_velocity(echoes, radar):
    m = processing.range_doppler_map(synthesize(echoes, radar, noise=False), radar)
    i, k = m.peak()
    return m.velocities[i], m.ranges[k]


@pytest.mark.parametrize("engine, options", [("path", {}), ("pixel", {"model": "physical-optics"})])
@pytest.mark.parametrize("theta_deg, speed", [(0.0, 2.0), (0.0, -2.0), (60.0, 3.0)])
def test_static_plate_seen_from_a_moving_radar(tmp_path, radar, engine, options, theta_deg, speed):
    """A static plate 4 m ahead; the radar moves at ``speed`` at ``theta`` to the line of sight: the plate's
    radial velocity is -v cos(theta) (Doppler 2 v cos(theta)/lambda) within one Doppler bin, sign included."""
    theta = np.deg2rad(theta_deg)
    out = scenes.build("moving_plate", tmp_path / "plate", start_range=4.0, speed=0.0, size=0.3, num_frames=2,
                       radar_velocity=(speed * np.cos(theta), speed * np.sin(theta), 0.0))
    animation = load_animation(out)
    assert animation.radar_moves and animation.radar_track is not None
    echoes = create(engine, **options).echoes(animation, radar, 0)
    velocity, _ = peak_velocity(echoes, radar)
    expected = -speed * np.cos(theta)
    assert abs(velocity - expected) <= radar.velocity_resolution, (velocity, expected)
    assert np.sign(velocity) == np.sign(expected)


def test_frame_poses_follow_the_track(tmp_path, radar):
    """The engine takes the pose of the frame it is asked for: a static plate's range shrinks by v t."""
    out = scenes.build("moving_plate", tmp_path / "plate", start_range=5.0, speed=0.0, size=0.3, num_frames=24,
                       radar_velocity=(4.0, 0.0, 0.0))
    animation = load_animation(out)
    engine = create("pixel", model="physical-optics")
    for frame in (0, 12, 23):
        _, r = peak_velocity(engine.echoes(animation, radar, frame), radar)
        centre = world_phase_centre(radar, animation.radar_pose_at(frame).position, [0.0, 0.0, 0.0])
        expected = 5.0 - (centre[0] - 0.0) - 4.0 * radar.cpi_duration / 2
        assert abs(r - expected) <= radar.range_resolution, (frame, r, expected)


def test_car_park_corridor_ranges_and_ego_doppler(tmp_path, radar):
    """A radar driving at 5 m/s between two rows of corner reflectors: in every simulated frame each
    reflector's corner range (from the frame's phase centre, at the CPI centre) has a range peak within
    one range bin, whose Doppler is the ego-Doppler -v cos(theta) (at the CPI start: the frozen CPI) within
    one Doppler bin; the store
    holds the pose per frame and the truth relative to the moving radar."""
    out = scenes.build("car_park", tmp_path / "park", num_pillars=2, spacing=2.5, first=4.0, lane_width=3.0,
                       speed=5.0, leg=0.15, num_frames=24)
    animation = load_animation(out)
    frames = [0, 6, 12]   # every pillar ahead, within its trihedral's view (the radar drives 2.5 m)
    run = simulate(animation, radar, engine="path", engine_options={"max_depth": 3}, out=tmp_path / "run.zarr",
                   frames=frames, progress=False, seed=1)
    assert run.radar_moves and run.attrs["radar_track"]["frames"] == 24
    for f in frames:
        pose = run.pose_at(f)
        track_pose = animation.radar_pose_at(f)
        assert np.allclose(pose.position, track_pose.position) and np.allclose(pose.velocity, [5.0, 0.0, 0.0])
        rd = processing.range_doppler(run.cube(f), radar)
        power = np.sum(np.abs(rd) ** 2, axis=(1, 2))                   # [doppler, range]
        profile = power.sum(axis=0)
        ranges = processing.range_axis(radar, profile.size)
        velocities = processing.velocity_axis(radar, power.shape[0])
        centre = run.phase_centre_at(f) + np.array([5.0, 0, 0]) * radar.cpi_duration / 2
        floor = np.median(profile)
        for name in run.objects:
            apex = _corner(name)
            r_true = np.linalg.norm(apex - centre)
            near = np.abs(ranges - r_true) <= radar.range_resolution
            assert profile[near].max() > 100 * floor, (f, name, r_true)
            cell = np.flatnonzero(near)[np.argmax(profile[near])]
            assert abs(ranges[cell] - r_true) <= radar.range_resolution
            # the frozen CPI (the default) carries the Doppler of the CPI start (the pillars alongside the
            # lane turn the line of sight by up to 0.16 m/s of range rate during the CPI)
            start = run.phase_centre_at(f)
            v_true = -5.0 * (apex - start)[0] / np.linalg.norm(apex - start)
            v_peak = velocities[np.argmax(power[:, cell])]
            assert abs(v_peak - v_true) <= radar.velocity_resolution, (f, name, v_peak, v_true)
            # truth: the range rate from the moving phase centre at the CPI start
            c0 = run.phase_centre_at(f)
            p = run.object_position(name)[f]
            assert run.truth(name)[f] == pytest.approx(-5.0 * (p - c0)[0] / np.linalg.norm(p - c0), rel=1e-9)


def _corner(name, first=4.0, spacing=2.5, lane_width=3.0, height=1.0):
    """The corner of reflector ``pillar_<k>_<side>`` of the ``car_park`` builder (its docstring)."""
    _, k, side = name.split("_")
    return np.array([first + int(k) * spacing, (1.0 if side == "left" else -1.0) * lane_width / 2, height])


# ---------------------------------------------------------------------------------------- contract
def _manifest(path):
    return json.loads((path / "animation.json").read_text())


@pytest.fixture
def tracked_scene(tmp_path):
    return scenes.build("moving_plate", tmp_path / "tracked", start_range=4.0, speed=0.0, size=0.3, num_frames=3,
                        radar_velocity=(1.0, 0.0, 0.0))


def test_manifest_radar_track_round_trip(tracked_scene):
    manifest = _manifest(tracked_scene)
    assert all("radar" in f for f in manifest["frames"])
    assert manifest["frames"][1]["radar"]["velocity"] == [1.0, 0.0, 0.0]
    animation = load_animation(tracked_scene)
    assert np.allclose(animation.radar_pose_at(2).position, [2 / 24.0, 0.0, 1.0])
    assert np.allclose(animation.radar_pose.position, [0.0, 0.0, 1.0])
    assert np.allclose(animation.radar_pose_at(1).acceleration, 0.0)   # central differences of a constant velocity


@pytest.mark.parametrize("edit, message", [
    (lambda m: m["frames"][1]["radar"].pop("velocity"), r"frames\[1\]\.radar\.velocity' is missing"),
    (lambda m: m["frames"][2].pop("radar"), r"frames\[2\] has no field 'radar'"),
    (lambda m: m["frames"][0]["radar"].update(velocity=[1, "fast", 0]), r"frames\[0\]\.radar\.velocity' must be 3"),
    (lambda m: m["frames"][1]["radar"].update(speed=3), r"frames\[1\]\.radar' has unknown field\(s\) speed"),
    (lambda m: m["frames"][0].update(radar=[0, 0, 1]), r"frames\[0\]\.radar' must be an object"),
])
def test_manifest_radar_track_errors_name_the_field(tracked_scene, edit, message):
    manifest = _manifest(tracked_scene)
    edit(manifest)
    (tracked_scene / "animation.json").write_text(json.dumps(manifest))
    with pytest.raises(AnimationError, match=message):
        load_animation(tracked_scene)


def test_api_radar_track_errors_name_radar_pose(tracked_scene, radar):
    animation = load_animation(tracked_scene)
    engine = create("pixel")
    with pytest.raises(EngineError, match=r"radar_pose: a radar track has one RadarPose per frame .*\(3\), got 2"):
        engine.echoes(animation, radar, 0, radar_pose=[animation.radar_pose] * 2)
    with pytest.raises(EngineError, match=r"radar_pose\[1\]: a radar track holds RadarPose objects"):
        engine.echoes(animation, radar, 0, radar_pose=[animation.radar_pose, (1, 2), animation.radar_pose])
    with pytest.raises(AnimationError, match="RadarPose.velocity must be 3 finite numbers"):
        RadarPose([0, 0, 1], [0, 0, 0], velocity=[1.0, np.nan, 0.0])


def test_api_radar_track_overrides_the_scene(tmp_path, radar):
    """``simulate(radar_pose=[...])``: one RadarPose per frame, with its velocity, moves a radar the scene
    keeps at rest; the store records it."""
    out = scenes.build("moving_plate", tmp_path / "plate", start_range=4.0, speed=0.0, size=0.3, num_frames=2)
    animation = load_animation(out)
    assert not animation.radar_moves
    track = [RadarPose([t * 2.0, 0.0, 1.0], [0.0, 0.0, 0.0], velocity=[2.0, 0.0, 0.0]) for t in animation.times]
    run = simulate(animation, radar, engine="pixel", engine_options={"model": "physical-optics"},
                   out=tmp_path / "run.zarr", radar_pose=track, progress=False, noise=False)
    assert run.radar_moves
    assert np.allclose(run.pose_at(1).position, track[1].position)
    velocity, _ = peak_velocity_of_cube(run.cube(0), radar)
    assert abs(velocity + 2.0) <= radar.velocity_resolution
    assert run.truth("plate")[0] == pytest.approx(-2.0, rel=1e-3)


def peak_velocity_of_cube(cube, radar):
    m = processing.range_doppler_map(cube, radar)
    i, k = m.peak()
    return m.velocities[i], m.ranges[k]


def test_store_without_pose_arrays_reads_and_resumes(tmp_path, radar):
    """A store written before the moving radar (no radar_* arrays) reads its one pose for every frame and resumes."""
    import warnings

    import zarr

    out = scenes.build("moving_plate", tmp_path / "plate", start_range=4.0, speed=1.0, size=0.3, num_frames=2)
    store = tmp_path / "old.zarr"
    simulate(out, radar, engine="pixel", out=store, frames=[0], progress=False, noise=False)
    for name in ("radar_position", "radar_orientation", "radar_velocity", "radar_angular_velocity"):
        shutil.rmtree(store / name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        zarr.consolidate_metadata(str(store))
    run = open_run(store)
    assert "radar_position" not in run._group and not run.radar_moves
    assert np.allclose(run.pose_at(0).position, [0.0, 0.0, 1.0])
    assert len(run.poses()) == 2
    resumed = simulate(out, radar, engine="pixel", out=store, frames=[1], progress=False, noise=False)
    assert list(resumed.done_frames) == [0, 1]
    assert np.allclose(resumed.pose_at(1).position, [0.0, 0.0, 1.0])


def test_scene_builder_refuses_a_radar_that_hits_a_target(tmp_path):
    with pytest.raises(ValueError, match="radar_velocity=.*comes .* from a target in frame"):
        scenes.build("moving_plate", tmp_path / "crash", start_range=1.0, speed=0.0, num_frames=24,
                     radar_velocity=(5.0, 0.0, 0.0))


def test_plots_follow_the_moving_radar(tmp_path, radar):
    """``sionnafmcw plot`` on a moving-radar run: the scene top view draws the radar track, the
    range-azimuth truth is in the frame's radar frame."""
    from sionnafmcw.cli import main

    out = scenes.build("car_park", tmp_path / "park", num_pillars=1, num_frames=3, speed=5.0)
    store = tmp_path / "run.zarr"
    simulate(out, radar, engine="pixel", out=store, progress=False, noise=False)
    run = open_run(store)
    ranges, azimuths = run.truth_in_radar_frame(2)
    centre = run.phase_centre_at(2)
    for name, r in zip(run.objects, ranges):
        assert r == pytest.approx(np.linalg.norm(run.object_position(name)[2] - centre))
    assert main(["plot", str(store), "--out", str(tmp_path / "figs"), "--kind", "scene", "--kind", "ra",
                 "--quiet"]) == 0
    assert (tmp_path / "figs" / "scene_top_view.png").exists()


# ---------------------------------------------------------------------------------------- Blender
MOVING_RADAR_BLEND = r'''
import sys
import bpy
out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = 24, 1.0
scene.frame_start, scene.frame_end = 1, 9
me = bpy.data.meshes.new("plate")
me.from_pydata([(4, -0.2, 0.8), (4, 0.2, 0.8), (4, 0.2, 1.2), (4, -0.2, 1.2)], [], [(0, 1, 2, 3)])
m = bpy.data.materials.new("Steel")
m["radio_material"] = "itu:metal"
me.materials.append(m)
scene.collection.objects.link(bpy.data.objects.new("plate", me))
radar = bpy.data.objects.new("radar", None)
scene.collection.objects.link(radar)
for frame, x, yaw in ((1, 0.0, 0.0), (9, 1.0, 0.2)):   # 3 m/s along +x, yawing at 0.6 rad/s
    radar.location, radar.rotation_euler = (x, 0.0, 1.0), (0.0, 0.0, yaw)
    radar.keyframe_insert("location", frame=frame)
    radar.keyframe_insert("rotation_euler", frame=frame)
act = radar.animation_data.action
curves = list(act.fcurves) if hasattr(act, "fcurves") else [
    fc for layer in act.layers for strip in layer.strips for bag in strip.channelbags for fc in bag.fcurves]
for fc in curves:
    for kp in fc.keyframe_points:
        kp.interpolation = "LINEAR"
bpy.ops.wm.save_as_mainfile(filepath=out)
'''


def test_blender_exports_a_moving_radar_as_a_track(tmp_path):
    """An empty named ``radar`` keyframed (LINEAR) to move at 3 m/s along +x and yaw at 0.6 rad/s: every
    exported frame has its pose, velocity and angular velocity (central differences: exact for a
    linear motion, to float32 positions)."""
    import subprocess

    from sionnafmcw.blender import BLENDER_VENV, export_blend

    python = BLENDER_VENV / "bin" / "python"
    assert python.exists(), f"{python} is missing: run 'make .venv-blender/.installed'"
    (tmp_path / "build.py").write_text(MOVING_RADAR_BLEND)
    proc = subprocess.run([str(python), str(tmp_path / "build.py"), "--", str(tmp_path / "moving.blend")],
                          capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    animation = load_animation(export_blend(tmp_path / "moving.blend", tmp_path / "anim", timeout=180))
    assert animation.radar_moves and animation.num_frames == 9
    for i in range(animation.num_frames):
        pose = animation.radar_pose_at(i)
        assert np.allclose(pose.position, [3.0 * i / 24, 0.0, 1.0], atol=1e-5)
        assert pose.orientation[0] == pytest.approx(0.6 * i / 24, abs=1e-5)
        assert np.allclose(pose.velocity, [3.0, 0.0, 0.0], atol=1e-3)
        assert np.allclose(pose.angular_velocity, [0.0, 0.0, 0.6], atol=1e-3)


def test_radar_track_accelerations_from_central_differences(tracked_scene):
    """A track that states velocities but no accelerations gets their central differences."""
    manifest = _manifest(tracked_scene)
    for i, frame in enumerate(manifest["frames"]):
        frame["radar"]["velocity"] = [float(i), 0.0, 0.0]
    manifest["frames"][2]["radar"]["acceleration"] = [0.0, 5.0, 0.0]   # stated: kept
    (tracked_scene / "animation.json").write_text(json.dumps(manifest))
    animation = load_animation(tracked_scene)
    assert np.allclose(animation.radar_pose_at(1).acceleration, [24.0, 0.0, 0.0])   # (2 - 0) / (2/24 s)
    assert np.allclose(animation.radar_pose_at(0).acceleration, [24.0, 0.0, 0.0])   # one-sided
    assert np.allclose(animation.radar_pose_at(2).acceleration, [0.0, 5.0, 0.0])


def test_truth_at_cpi_centre_from_a_moving_radar():
    """A static target, a radar passing it at constant velocity: the range rate at the CPI centre is the
    closed form from the relative position there."""
    from sionnafmcw.store import radial_velocity_at_cpi_centre

    times = np.arange(5) / 24.0
    v = np.array([5.0, 0.0, 0.0])
    centres = np.array([[0.0, 0.0, 1.0]]) + times[:, None] * v
    target = np.array([4.0, 1.5, 1.0])
    duration = 0.0269
    got = radial_velocity_at_cpi_centre(times, np.tile(target, (5, 1)), np.zeros((5, 3)), centres, duration,
                                        np.tile(v, (5, 1)))
    mid = centres + v * duration / 2
    expected = -np.einsum("fi,i->f", target - mid, v) / np.linalg.norm(target - mid, axis=1)
    assert np.allclose(got, expected, atol=1e-9)
