"""simulate + run store, end to end on hand-written animation directories (real Sionna RT).

Tolerances come from the radar's resolution: half a range bin (c/2B) and half a Doppler bin
(lambda_mid / 2 L T_b) for range and velocity; 2 degrees for azimuth, a fifth of the 12-element
array's Rayleigh width (2/12 rad = 9.5 degrees), which a Bartlett peak reaches easily at these SNRs.
"""

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from animation_helpers import plate_mesh, write_plate_animation
from sionnafmcw import PathEngine, RadarConfig, open_run, processing, simulate
from sionnafmcw.animation import frame_xml_text, write_animation, write_ply
from sionnafmcw.geometry import rotation_matrix
from sionnafmcw.store import RunStoreError

METAL = {"mat-itu_metal": ("itu-radio-material", {"type": "metal"})}


@pytest.fixture(scope="module")
def radar():
    # walk-77ghz with 64 chirps: 9.8 cm range bins, 0.29 m/s Doppler bins, +-9.2 m/s
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=64)


def fast_engine(**kw):
    return PathEngine(samples_per_src=20_000, **kw)


def write_scene(root, objects, num_frames=2, fps=24.0):
    """``objects``: list of (name, mesh_fn(t) -> (vertices, faces), velocity [3])."""
    root = Path(root)
    frames = []
    for i in range(num_frames):
        t = i / fps
        shapes = []
        for name, mesh_fn, _ in objects:
            v, f = mesh_fn(t)
            write_ply(root / "meshes" / f"{name}_{i:04d}.ply", v, f)
            shapes.append({"name": name, "ply": f"../meshes/{name}_{i:04d}.ply", "material": "mat-itu_metal"})
        (root / "frames").mkdir(parents=True, exist_ok=True)
        (root / "frames" / f"{i:04d}.xml").write_text(frame_xml_text(shapes, METAL))
        frames.append({"xml": f"frames/{i:04d}.xml", "objects": {name: vel for name, _, vel in objects}})
    write_animation(root, frames, fps, ((0, 0, 0), (0, 0, 0)))
    return root


def facing_plate(distance, azimuth, speed, size=0.4):
    """A square metal plate facing the radar at ``azimuth``, moving radially at ``speed`` (m/s, + receding)."""
    u = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    rot = rotation_matrix([azimuth, 0, 0])
    v0, faces = plate_mesh([0, 0, 0], size=(size, size), normal_axis=0)

    def mesh(t):
        return v0 @ rot.T + (distance + speed * t) * u, faces

    return mesh, speed * u


@pytest.mark.parametrize("speed", [1.5, -2.0])
def test_moving_plate_range_and_velocity(tmp_path, radar, speed):
    """A plate at 4 m moving at +1.5 (receding) / -2.0 m/s: range and v_r within half a bin, sign right."""
    root = write_plate_animation(tmp_path / "plate", distance=4.0, velocity=(speed, 0, 0), num_frames=2,
                                 fps=24.0, size=(0.5, 0.5))
    ds = simulate(root, radar, engine=fast_engine(), out=tmp_path / "run.zarr", progress=False)
    track = processing.doppler_time(ds.iq.values, radar)
    truth_v = ds.truth_radial_velocity.values[:, 0]
    truth_r = ds["truth_position"].values[:, 0, 0]  # plate face, on boresight
    assert np.all(np.sign(track.velocities) == np.sign(speed))
    assert np.all(np.abs(track.velocities - truth_v) < radar.velocity_resolution / 2)
    assert np.all(np.abs(track.ranges - truth_r) < radar.range_resolution / 2)


def test_two_plates_separated_in_azimuth(tmp_path, radar):
    """Two plates at 4 m, -20 and +25 degrees, moving apart in Doppler: two azimuth peaks within 2 degrees."""
    az = np.deg2rad([-20.0, 25.0])
    objects = []
    for name, a, speed in (("left", az[0], 1.0), ("right", az[1], -1.0)):
        mesh, vel = facing_plate(4.0, a, speed)
        objects.append((name, mesh, vel))
    root = write_scene(tmp_path / "two", objects, num_frames=1)
    ds = simulate(root, radar, engine=fast_engine(), out=tmp_path / "two.zarr", progress=False)
    cube = ds.iq.values[0]
    rd = processing.range_doppler(cube, radar, clutter_removal=True)
    rd = processing.tdm_phase_compensation(rd, radar, processing.velocity_axis(radar, rd.shape[0]))
    rdm = processing.range_doppler_map(cube, radar, clutter_removal=True)
    found = []
    for speed in (1.0, -1.0):
        i_v = np.argmin(np.abs(rdm.velocities - speed))
        i_r = np.argmax(rdm.power[i_v])
        snapshot = rd[i_v, :, :, i_r].reshape(-1)
        azimuth, _, _ = processing.estimate_direction(snapshot, radar, elevation=False)
        found.append(azimuth)
    assert abs(np.rad2deg(found[0] - az[0])) < 2.0
    assert abs(np.rad2deg(found[1] - az[1])) < 2.0
    # and the range-azimuth map shows them as two separate peaks
    ra = processing.range_azimuth_map(cube, radar)
    profile = ra.power.max(axis=1) if ra.power.shape[1] == len(ra.ranges) else ra.power.max(axis=0)
    azis = ra.azimuths
    near = [np.argmin(np.abs(azis - a)) for a in az]
    valley = np.argmin(np.abs(azis - az.mean()))
    assert profile[valley] < 0.25 * min(profile[near[0]], profile[near[1]])


def test_corner_reflector_brighter_than_plate(tmp_path, radar):
    """A trihedral and a plate of the same edge, both turned 15 degrees off the radar: the
    trihedral's triple bounce still comes back; the plate's mirror echo misses the radar."""
    a = 0.3

    def trihedral(t, center):
        # three mutually orthogonal square faces meeting at the corner, opening towards -x (the radar)
        faces_v, faces_f = [], []
        for normal_axis in range(3):
            v, f = plate_mesh([0, 0, 0], size=(a, a), normal_axis=normal_axis)
            shift = np.full(3, a / 2)
            shift[normal_axis] = 0.0
            faces_f.append(f + sum(len(x) for x in faces_v))
            faces_v.append(v + shift)
        v = np.concatenate(faces_v)
        # corner at the origin, faces on the +x+y+z octant: rotate so the axis (1,1,1) points to the radar
        axis = np.ones(3) / np.sqrt(3)
        target = -np.array([1.0, 0.0, 0.0])
        k = np.cross(axis, target)
        s, c = np.linalg.norm(k), axis @ target
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]]) / s
        rot = np.eye(3) + s * kx + (1 - c) * kx @ kx
        turn = rotation_matrix([np.deg2rad(15), 0, 0])
        return (v @ rot.T) @ turn.T + center + np.array([0.5, 0, 0]) * t, np.concatenate(faces_f)

    def tilted_plate(t, center):
        v, f = plate_mesh([0, 0, 0], size=(a, a), normal_axis=0)
        return v @ rotation_matrix([np.deg2rad(15), 0, 0]).T + center + np.array([0.5, 0, 0]) * t, f

    powers = {}
    for name, fn in (("corner", trihedral), ("plate", tilted_plate)):
        root = write_scene(tmp_path / name, [(name, lambda t, fn=fn: fn(t, np.array([4.0, 0, 0])), [0.5, 0, 0])],
                           num_frames=1)
        engine = fast_engine(max_depth=3)
        ds = simulate(root, radar, engine=engine, out=tmp_path / f"{name}.zarr", progress=False, noise=False)
        rdm = processing.range_doppler_map(ds.iq.values[0], radar, clutter_removal=True)
        powers[name] = rdm.power.max()
    # metal, geometric optics: the trihedral returns ~|R|^6 of the incident power density; the
    # plate returns nothing specular. Require 20 dB.
    assert powers["corner"] > 100 * powers["plate"]


def test_store_layout_resume_and_determinism(tmp_path, radar):
    root = write_plate_animation(tmp_path / "plate", distance=3.0, velocity=(1.0, 0, 0), num_frames=4, fps=24.0,
                                 size=(0.4, 0.4))
    engine = fast_engine()  # deterministic by default: identical paths run to run
    out = tmp_path / "run.zarr"
    simulate(root, radar, engine=engine, out=out, frames=[0, 1], progress=False, seed=3)
    traced = len(engine.stats)
    # interrupted in frame 2: its cube written, its done flag not
    import zarr

    g = zarr.open_group(str(out), mode="r+")
    g["iq"][2] = np.ones(g["iq"].shape[1:], dtype=np.complex64)
    ds = simulate(root, radar, engine=engine, out=out, progress=False, seed=3)
    assert len(engine.stats) - traced == 2  # frames 2 and 3 only: 0 and 1 were done
    assert ds.frame_done.values.all()
    assert ds.iq.dims == ("frame", "chirp", "tx", "rx", "sample")
    assert ds["truth_position"].dims == ("frame", "object", "xyz")
    assert list(ds.object.values) == ["plate"]
    assert ds.attrs["radar"] == radar.to_dict() and ds.attrs["seed"] == 3
    assert RadarConfig.from_dict(ds.attrs["radar"]) == radar

    # same seed, same cube, in a fresh store and a fresh engine
    again = simulate(root, radar, engine=fast_engine(), out=tmp_path / "again.zarr",
                     progress=False, seed=3)
    assert np.array_equal(again.iq.values, ds.iq.values)
    assert xr.open_zarr(out).iq.dtype == np.complex64

    # resuming with other settings names the difference
    with pytest.raises(RunStoreError, match="seed"):
        simulate(root, radar, engine=fast_engine(), out=out, progress=False, seed=4)
    with pytest.raises(RunStoreError, match="engine"):
        simulate(root, radar, engine=fast_engine(deterministic=False), out=out, progress=False, seed=3)
    with pytest.raises(RunStoreError, match="no such"):
        open_run(tmp_path / "missing.zarr")


def test_cpi_longer_than_frame_period_is_rejected(tmp_path, radar):
    from sionnafmcw import RadarConfigError

    # 64 chirps x 3 Tx x 35 us = 6.7 ms of chirps; at 200 fps a frame lasts 5 ms
    root = write_plate_animation(tmp_path / "plate", num_frames=2, fps=200.0)
    with pytest.raises(RadarConfigError, match="frame period"):
        simulate(root, radar, engine=fast_engine(), out=tmp_path / "x.zarr", progress=False)
    assert not (tmp_path / "x.zarr").exists()


class _ThreadsSeen(PathEngine):
    """The path engine, recording Dr.Jit's pool size and BLAS's threads while it computes each frame."""

    def _frame_echoes(self, animation, radar, frame, pose):
        import drjit as dr
        from threadpoolctl import threadpool_info

        from sionnafmcw.threads import synthesis_pool

        blas = [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]
        self.seen = getattr(self, "seen", []) + [(dr.thread_count(), blas, synthesis_pool())]
        return super()._frame_echoes(animation, radar, frame, pose)


def test_run_threads_set_during_the_run_and_restored(tmp_path, radar):
    """simulate(threads=N): Dr.Jit's pool at N - 1 (at least 1), BLAS at 1 and the synthesis pool at N // 2
    (at least 1) while frames run, all as before afterwards; the cube does not depend on the thread
    counts (bit for bit)."""
    import drjit as dr
    from threadpoolctl import threadpool_info

    from sionnafmcw.simulation import SimulationError

    root = write_plate_animation(tmp_path / "plate", distance=3.0, velocity=(1.0, 0, 0), num_frames=2, fps=24.0,
                                 size=(0.4, 0.4))

    def blas_threads():
        return [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]

    from sionnafmcw.threads import available_cores, synthesis_pool

    before_dr, before_blas = dr.thread_count(), blas_threads()
    assert synthesis_pool() == available_cores()
    cubes = []
    for threads, wanted, synthesis in ((4, 3, 2), (1, 1, 1)):
        engine = _ThreadsSeen(samples_per_src=20_000)
        run = simulate(root, radar, engine=engine, out=tmp_path / f"t{threads}.zarr", progress=False, threads=threads)
        assert engine.seen and all(seen == (wanted, [1] * len(before_blas), synthesis) for seen in engine.seen), \
            engine.seen
        assert dr.thread_count() == before_dr and blas_threads() == before_blas
        assert synthesis_pool() == available_cores()
        cubes.append(run.iq.values)
    assert np.array_equal(cubes[0], cubes[1])
    with pytest.raises(SimulationError, match="threads must be an integer >= 1"):
        simulate(root, radar, engine=fast_engine(), out=tmp_path / "bad.zarr", progress=False, threads=0)
    assert not (tmp_path / "bad.zarr").exists()


def test_synthesis_takes_every_thread_while_it_is_behind(tmp_path, radar, monkeypatch):
    """A synthesis slower than the engine (each frame's held 0.3 s): the first frame is synthesised on
    the run's share (threads // 2), the frames started while a later frame's echoes were already ready
    on all the run's threads (sionnafmcw.threads.synthesis_catching_up), the last one (nothing behind
    it) on the share again; at most PENDING_FRAMES frames' echoes wait; the cubes are the unhurried
    run's, bit for bit."""
    import time

    import sionnafmcw.simulation as simulation
    from sionnafmcw.threads import synthesis_pool

    root = write_plate_animation(tmp_path / "plate", distance=3.0, velocity=(1.0, 0, 0), num_frames=5, fps=24.0,
                                 size=(0.4, 0.4))
    reference = simulate(root, radar, engine=fast_engine(), out=tmp_path / "ref.zarr", progress=False, threads=4)
    real, seen, waiting = simulation.synthesize, [], []

    def slow(echoes, *args, **kwargs):
        seen.append(synthesis_pool())
        time.sleep(0.3)
        return real(echoes, *args, **kwargs)

    class Counting(PathEngine):
        def _frame_echoes(self, animation, radar_, frame, pose):
            waiting.append(len(seen))          # frames whose synthesis has started when this one is computed
            return super()._frame_echoes(animation, radar_, frame, pose)

    monkeypatch.setattr(simulation, "synthesize", slow)
    run = simulate(root, radar, engine=Counting(samples_per_src=20_000), out=tmp_path / "slow.zarr", progress=False,
                   threads=4)
    assert len(seen) == 5 and seen[0] == 2 and seen[1:4] == [4, 4, 4] and seen[4] == 2, seen
    # the engine ran at most PENDING_FRAMES frames ahead of the synthesis
    assert all(frame - started <= simulation.PENDING_FRAMES for frame, started in enumerate(waiting)), waiting
    np.testing.assert_array_equal(run.iq.values, reference.iq.values)
