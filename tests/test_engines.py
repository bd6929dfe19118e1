"""The engine family: the registry, the template method, a third engine in one file, the Sionna boundary.

The example engine below is the whole cost of a new engine: one class (hooks only) and one
``engines.register`` line; it runs through ``simulate`` on a real Mitsuba/Sionna scene.
Tolerances: half a range bin (c/2B) and half a Doppler bin, as in ``tests/test_simulate.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from animation_helpers import write_plate_animation
from sionnafmcw import Echoes, RadarConfig, engines, processing, simulate, sionna_rt
from sionnafmcw.animation import load_animation
from sionnafmcw.engines import Engine, EngineError, FrameStats, PathEngine, PixelEngine
from sionnafmcw.geometry import rotation_matrix, world_to_radar


# ------------------------------------------------------------------------------- a third engine
class CentroidEngine(Engine):
    """Every moving object is an ideal point target of RCS ``rcs`` (m^2) at its mesh centroid."""

    name = "centroid"

    def __init__(self, rcs: float = 1.0, track_kernels: bool = False):
        super().__init__(track_kernels=track_kernels)
        self.rcs = float(rcs)

    def _settings(self) -> dict:
        return {"rcs": self.rcs}

    def _load(self, scene, animation, radar):
        return None  # nothing beyond the loaded scene

    def _frame_echoes(self, animation, radar, frame, pose):
        names = animation.object_names
        centroids = animation.object_positions(frame, names)
        p = world_to_radar(np.array([centroids[n] for n in names]), pose.position, pose.orientation)
        v = np.array([animation.object_velocity(frame, n) for n in names]) @ rotation_matrix(pose.orientation)
        ranges = np.linalg.norm(p, axis=-1)
        radial = np.einsum("ij,ij->i", v, p) / ranges  # positive receding
        echoes = Echoes.point_targets(radar, ranges, radial, np.arctan2(p[:, 1], p[:, 0]),
                                      np.arcsin(p[:, 2] / ranges), rcs=self.rcs, labels=names)
        return echoes, {"num_targets": len(names)}


@pytest.fixture
def centroid_registered():
    engines.register("centroid", CentroidEngine)
    yield
    engines._REGISTRY.pop("centroid", None)


@pytest.fixture(scope="module")
def radar():
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=64)


def test_third_engine_is_one_class_and_one_register_line(tmp_path, radar, centroid_registered):
    assert engines.names() == ["path", "pixel", "centroid"]
    assert engines.options("centroid") == {"rcs": 1.0, "track_kernels": False}
    root = write_plate_animation(tmp_path / "plate", distance=4.0, velocity=(1.5, 0, 0), num_frames=2, fps=24.0,
                                 size=(0.5, 0.5))
    run = simulate(root, radar, engine="centroid", engine_options={"rcs": 2.0}, out=tmp_path / "run.zarr",
                   progress=False)
    assert run.engine == {"engine": "centroid", "rcs": 2.0}
    track = processing.doppler_time(run.dataset.iq.values, radar)
    truth_v = run.dataset.truth_radial_velocity.values[:, 0]
    truth_r = run.dataset.truth_position.values[:, 0, 0]  # plate centroid, on boresight
    assert np.all(np.abs(track.velocities - truth_v) < radar.velocity_resolution / 2)
    assert np.all(np.abs(track.ranges - truth_r) < radar.range_resolution / 2)


def test_template_owns_pose_stats_reload_and_scene(tmp_path, radar):
    root = write_plate_animation(tmp_path / "plate", distance=3.0, num_frames=2, radar_pose=None)
    anim = load_animation(root)
    engine = CentroidEngine()
    assert engine.scene is None and engine.last_stats is None
    with pytest.raises(EngineError, match="no 'radar' pose"):
        engine.echoes(anim, radar, 0)
    pose = ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    e0 = engine(anim, radar, 0, radar_pose=pose)
    e1 = engine.echoes(anim, radar, 1, radar_pose=pose)
    assert e0.labels.tolist() == [[["plate"]] * radar.num_rx] * radar.num_tx
    assert not np.array_equal(e0.tau, e1.tau)  # the plate moved
    assert [s.reloaded for s in engine.stats] == [True, False]
    assert isinstance(engine.last_stats, FrameStats) and engine.last_stats.num_targets == 1
    assert engine.scene is not None  # the Sionna scene the template loaded
    engine.echoes(anim, radar.replace(num_chirps=32), 1, radar_pose=pose)
    assert engine.last_stats.reloaded  # a new radar reloads
    engine.close()
    assert engine.scene is None
    assert repr(engine) == "CentroidEngine(rcs=1.0)" and engine.settings() == {"engine": "centroid", "rcs": 1.0}


# ------------------------------------------------------------------------------- registry
def test_registry_lists_and_creates_the_built_in_engines():
    assert engines.names()[:2] == ["path", "pixel"]
    assert engines.engine_class("path") is PathEngine and engines.engine_class("pixel") is PixelEngine
    assert engines.options("path")["max_depth"] == 2 and engines.options("pixel")["n_az"] == 128
    engine = engines.create("path", max_depth=1)
    assert isinstance(engine, PathEngine) and engine.settings()["engine"] == "path"
    assert engine.settings()["max_depth"] == 1


def test_registry_errors_name_the_engine_or_option_and_the_valid_ones():
    with pytest.raises(EngineError, match=r"engine 'raster' is unknown; choose one of path, pixel"):
        engines.create("raster")
    with pytest.raises(EngineError, match=r"'raster' is unknown"):
        engines.options("raster")
    with pytest.raises(EngineError, match=r"engine 'path' has no option 'depth'; valid options: max_depth, "):
        engines.create("path", depth=3)
    with pytest.raises(EngineError, match="'module:Class'"):
        engines.register("bad", "no_colon_here")


def test_registered_class_must_carry_its_name():
    class Unnamed(CentroidEngine):
        name = "other"

    engines.register("unnamed", Unnamed)
    try:
        with pytest.raises(EngineError, match=r"Unnamed.name = 'unnamed'"):
            engines.create("unnamed")
    finally:
        engines._REGISTRY.pop("unnamed", None)


def test_simulate_rejects_an_object_that_is_no_engine(tmp_path, radar):
    root = write_plate_animation(tmp_path / "plate", num_frames=1)
    with pytest.raises(TypeError, match="path, pixel"):
        simulate(root, radar, engine=object(), out=tmp_path / "x.zarr", progress=False)
    with pytest.raises(EngineError, match="choose one of path, pixel"):
        simulate(root, radar, engine="raster", out=tmp_path / "y.zarr", progress=False)


# ------------------------------------------------------------------------------- Sionna boundary
def test_boundary_versions_are_the_verified_ones():
    assert sionna_rt.check_versions() == []
    installed = sionna_rt.installed_versions()
    for package, version in sionna_rt.VERIFIED_VERSIONS.items():
        assert installed[package].split(".")[:2] == version.split(".")[:2]


def test_unverified_version_is_a_clear_error():
    other = dict(sionna_rt.VERIFIED_VERSIONS, **{"sionna-rt": "2.3.0"})
    with pytest.raises(sionna_rt.UnverifiedVersionError, match=r"sionna-rt 2\.3\.0 is installed.*verified against "
                                                               r"2\.2\.0.*pip install 'sionna-rt==2\.2\.\*'"):
        sionna_rt.check_versions(other, allow_unverified=False)
    with pytest.warns(UserWarning, match="sionna-rt 2.3.0"):
        assert len(sionna_rt.check_versions(other, allow_unverified=True)) == 1


def test_min_segment_length_is_the_radar_one_and_fails_loudly_when_gone(monkeypatch):
    from sionnafmcw.engines.traced_paths import RADAR_MIN_SEGMENT_LENGTH

    assert set(sionna_rt.min_segment_length().values()) == {RADAR_MIN_SEGMENT_LENGTH}
    # a Sionna release without the constant in one solver module (simulated by removing it here)
    module = sionna_rt.MIN_SEGMENT_LENGTH_MODULES[0]
    monkeypatch.delattr(module, "MIN_SEGMENT_LENGTH")
    with pytest.raises(sionna_rt.SionnaBoundaryError, match=rf"{module.__name__} has no MIN_SEGMENT_LENGTH"):
        sionna_rt.set_min_segment_length(RADAR_MIN_SEGMENT_LENGTH)


def test_engines_import_sionna_only_through_the_boundary():
    from pathlib import Path

    import sionnafmcw

    package = Path(sionnafmcw.__file__).parent
    offenders = []
    for path in [*package.joinpath("engines").glob("*.py"), package / "materials.py", package / "simulation.py",
                 package / "electromagnetics.py"]:
        for line in path.read_text().splitlines():
            words = line.split()
            if words[:1] in (["import"], ["from"]) and words[1].split(".")[0] in ("drjit", "mitsuba", "sionna"):
                offenders.append(f"{path.name}: {line.strip()}")
    assert offenders == []
