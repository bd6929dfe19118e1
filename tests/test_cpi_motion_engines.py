"""Motion within the CPI through the engines: an accelerating plate gets the Doppler
rate of its acceleration (``cpi_motion="quadratic"``) and the closed-form Doppler smear; the frozen
model keeps it in one bin; the PO merge keeps the rates within its bound.

Closed form as in ``tests/test_cpi_motion.py``: the velocity spectrum of a reflector accelerating at
:math:`\\ddot R` over the CPI :math:`T` spans :math:`[\\dot R_0, \\dot R_0 + \\ddot R T]`, one Doppler bin
tolerance at each edge.
"""

import numpy as np
import pytest

from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.synthesis import beat_direct, noise_error_budget
from spectrum_helpers import band_edges, spectrum_band


@pytest.fixture(scope="module")
def radar():
    return RadarConfig.preset("walk-77ghz")


@pytest.fixture(scope="module")
def small_radar():
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=32, num_samples=64, fs=2.5e6)


def accelerating_plate(root, acceleration, v0=1.0, r0=3.0, frames=3, fps=24.0):
    """A metal plate facing the radar (at the origin, 1 m up, looking along +x), receding along +x with
    range r0 + v0 t + a t^2 / 2: per-frame meshes with the manifest velocity v0 + a t."""
    from sionnafmcw.scenes import meshes
    from sionnafmcw.scenes.writer import METAL, AnimationWriter, metal_material

    w = AnimationWriter(root, fps)
    w.add_materials(metal_material())
    for i in range(frames):
        t = i / fps
        r = r0 + v0 * t + acceleration * t * t / 2
        v, f = meshes.plate(np.array([r, 0.0, 1.0]), (0.3, 0.3), normal=[-1.0, 0, 0], subdiv=2)
        w.frame([{"name": "plate", "vertices": v, "faces": f, "material": METAL,
                  "velocity": [v0 + acceleration * t, 0.0, 0.0]}])
    w.finish([0.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    return root


@pytest.mark.parametrize("engine, options", [("path", {}), ("pixel", {"model": "physical-optics"})])
def test_accelerating_plate_through_the_engines(tmp_path, radar, engine, options):
    """The engines give the plate's echo the Doppler rate of its acceleration (the animation's central
    difference of the frame velocities): the closed-form smear with ``cpi_motion="quadratic"``, one
    bin with ``"frozen"``."""
    from sionnafmcw.animation import load_animation
    from sionnafmcw.engines import create

    acceleration, v0 = 40.0, 1.0
    animation = load_animation(accelerating_plate(tmp_path / "plate", acceleration, v0))
    assert np.allclose(animation.object_acceleration(1, "plate"), [acceleration, 0, 0])
    frame, T, bin_v = 1, radar.cpi_duration, radar.velocity_resolution
    v_start = v0 + acceleration * animation.times[frame]
    quadratic = create(engine, cpi_motion="quadratic", **options).echoes(animation, radar, frame)
    assert quadratic.accelerating
    velocities, power = spectrum_band(synthesize(quadratic, radar, rng=2), radar)
    lo, hi = v_start, v_start + acceleration * T
    low, high = band_edges(velocities, power, lo, hi, bin_v)
    assert abs(low - lo) <= bin_v and abs(high - hi) <= bin_v, (low, lo, high, hi)
    frozen = create(engine, cpi_motion="frozen", **options).echoes(animation, radar, frame)
    assert frozen.doppler_rate is None
    velocities, power = spectrum_band(synthesize(frozen, radar, rng=2), radar)
    assert np.all(np.abs(velocities[power >= 0.25 * power.max()] - v_start) <= bin_v)


def test_cpi_motion_option_errors_name_it():
    from sionnafmcw.engines import EngineError, create

    for engine in ("path", "pixel"):
        with pytest.raises(EngineError, match="cpi_motion='cubic'.*frozen, quadratic"):
            create(engine, cpi_motion="cubic")


def test_po_merge_keeps_doppler_rates_within_its_bound(small_radar):
    """Merging contributions with Doppler rates: the rate is a cell key and the bound covers the cube
    error against the unmerged contributions. (Weak scatterers, as a body's PO samples are: the merge
    takes only cell sizes that remove a fifth of the contributions, :data:`~.po_merge.MIN_SAVING`,
    and these 200 need cells of 1/128 of the resolutions, within the noise budget at -60 dBsm.)"""
    from sionnafmcw.engines.po_merge import merge_contributions

    radar = small_radar
    rng = np.random.default_rng(4)
    p = 200
    echoes = Echoes.point_targets(radar, 3.0 + rng.uniform(0, 0.02, p), 1.0 + rng.uniform(0, 0.01, p),
                                  rng.uniform(0, 0.002, p), rcs=1e-6,
                                  radial_accelerations=20.0 + rng.uniform(0, 2.0, p))
    directions = np.tile([1.0, 0.0, 0.0], (p, 1))
    merged = merge_contributions(echoes.a, echoes.tau, echoes.doppler, np.full(p, "x"), directions, radar,
                                 noise_error_budget(radar), doppler_rate=echoes.doppler_rate)
    assert merged.fraction is not None and merged.doppler_rate is not None and merged.a.shape[-1] < p
    whole = beat_direct(echoes, radar)
    cells = beat_direct(Echoes(merged.a, merged.tau, merged.doppler, doppler_rate=merged.doppler_rate), radar)
    assert 0 < np.max(np.abs(whole - cells)) <= merged.bound


@pytest.mark.parametrize("engine, options", [("path", {}), ("pixel", {"model": "physical-optics"})])
def test_accelerating_radar_smears_static_clutter(tmp_path, radar, engine, options):
    """A static plate 4 m ahead, the radar approaching it at 1 m/s and accelerating towards it at 30 m/s^2
    (its pose through the API): the plate's radial velocity sweeps [-1 - a T, -1] (the radar's
    acceleration enters as any other, relative), one bin when frozen."""
    from sionnafmcw import scenes
    from sionnafmcw.animation import RadarPose, load_animation
    from sionnafmcw.engines import create

    animation = load_animation(scenes.build("moving_plate", tmp_path / "plate", start_range=4.0, speed=0.0,
                                            size=0.3, num_frames=1))
    a, T, bin_v = 30.0, radar.cpi_duration, radar.velocity_resolution
    pose = RadarPose([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], velocity=[1.0, 0.0, 0.0], acceleration=[a, 0.0, 0.0])
    echoes = create(engine, cpi_motion="quadratic", **options).echoes(animation, radar, 0, radar_pose=pose)
    velocities, power = spectrum_band(synthesize(echoes, radar, rng=3), radar)
    lo, hi = -1.0 - a * T, -1.0
    low, high = band_edges(velocities, power, lo, hi, bin_v)
    assert abs(low - lo) <= bin_v and abs(high - hi) <= bin_v, (low, lo, high, hi)
    frozen = create(engine, **options).echoes(animation, radar, 0, radar_pose=pose)
    velocities, power = spectrum_band(synthesize(frozen, radar, rng=3), radar)
    assert np.all(np.abs(velocities[power >= 0.25 * power.max()] + 1.0) <= bin_v)
