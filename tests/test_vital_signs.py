r"""Vital signs: the chest wall's breathing and heartbeat survive every stage, and come back out.

A heartbeat moves the chest by 0.1-0.5 mm, a two-way phase of :math:`4\pi d/\lambda` = 0.32 rad at
0.1 mm (77 GHz). Stage by stage (fast):

* **scene**: ``vital_signs`` writes the thorax's ``to_world`` translated by exactly :math:`d(t)\hat{\mathbf n}`
  (float64 in the XML and the manifest) and a non-zero manifest velocity in every frame (the path
  engine's static-scene cache treats the thorax as moving because its transform changes and its
  velocity is not zero); the drawn rates and amplitudes lie within the physiological ranges and
  differ between items;
* **path engine** (static-scene cache, PO render, PO merge): a rigid metal plate before a static
  wall, moved 0.05 mm per frame along the line of sight: its echoes turn by :math:`4\pi\Delta d/\lambda`
  per frame at the carrier within :math:`1/\cos\theta_{max} - 1` of it (the samples' path lengths grow
  by :math:`\Delta d\cos\theta` to :math:`\Delta d/\cos\theta`, :math:`\theta_{max}` the plate corners'
  angle seen from the radar) plus float32 vertex rounding (two roundings of a coordinate at 2 m,
  1.2e-7 m each); its range bin turns by the same at :math:`\lambda_{mid}`, plus the PO merge's beat
  phase (at most :math:`\pi/256` per frame; measured 2e-3 rad);
* **PO merge**: merging contributions into cells of 1/256 of the resolutions keeps the carrier
  channel :math:`\sum_p a_p e^{-j2\pi f_c\tau_p}` exactly, so a 0.1 mm shift of every contribution turns
  it by exactly :math:`4\pi\cdot 0.1\,\mathrm{mm}/\lambda` whatever the cells (it sums, it does not move);
* **synthesis** (NUFFT at the noise budget, complex64): against the exact direct sum, the phase of
  the chest's range bin errs by at most :math:`E_{max}/A` (:math:`E_{max}` the budget per sample,
  20 dB below the thermal noise; :math:`A` the bin's amplitude), measured and printed: far below
  0.32 rad;
* **estimator** (:func:`sionnafmcw.processing.vital_signs`): on point-target cubes with a static
  echo in the same bin and thermal noise, 30 s at 25 fps, both rates within 0.05 Hz.

Slow: the whole chain on the ``vital_signs`` scenario (a sitting person 1 m from the radar, rates
and amplitudes drawn: seed 3 puts the heart rate 0.002 Hz from the breathing's sixth harmonic),
path engine, ``ti-awr1843boost`` with one Tx and two chirps (4.4 cm range bins), thermal noise,
30 s at 25 fps (25 fps keeps the breathing's phase step below pi per frame at the ranges' worst
corner, 0.5 Hz and 12 mm: :math:`4\pi\cdot\pi f A/(\lambda\,\mathrm{fps})` = 0.77 pi): both rates
within 0.05 Hz of the manifest's truth.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sionnafmcw import RadarConfig, load_animation, scenes
from sionnafmcw.constants import SPEED_OF_LIGHT
from sionnafmcw.echoes import Echoes
from sionnafmcw.processing.fast_time import range_axis, range_fft
from sionnafmcw.processing.vitals import vital_signs
from sionnafmcw.scenes.activities import still_person
from sionnafmcw.scenes.vitals import (BREATHING_AMPLITUDE, BREATHING_RATE, HEART_AMPLITUDE, HEART_RATE, VitalSigns)
from sionnafmcw.synthesis import synthesize
from sionnafmcw.synthesis.accuracy import noise_error_budget

RATE_TOLERANCE = 0.05  # Hz, the requirement (1.5 bins of a 30 s record)


def small_radar(num_rx=1):
    base = RadarConfig.preset("walk-77ghz")
    return base.replace(num_chirps=4, num_samples=64, tx_positions=base.tx_positions[:1],
                        rx_positions=base.rx_positions[:num_rx], tx_order=[0], name="vitals-small")


# =========================================================================== scene
def test_vitals_are_drawn_within_the_ranges():
    draws = [VitalSigns.draw(s) for s in range(200)]
    for name, (lo, hi) in (("breathing_rate", BREATHING_RATE), ("breathing_amplitude", BREATHING_AMPLITUDE),
                           ("heart_rate", HEART_RATE), ("heart_amplitude", HEART_AMPLITUDE)):
        values = np.array([getattr(v, name) for v in draws])
        assert values.min() >= lo and values.max() <= hi
        assert values.max() - values.min() > 0.8 * (hi - lo)      # spread over the range
    with pytest.raises(ValueError, match="heart_rate=3.0 is outside 0.8..2.0"):
        VitalSigns(heart_rate=3.0)


def test_vital_signs_scene_moves_the_chest_by_d(tmp_path):
    """No sway: the thorax's translation is the posture's plus d(t) n, exactly; its velocity d'(t) n."""
    fps, n = 25.0, 12
    items = []
    for seed in (0, 1):
        out = scenes.build("vital_signs", tmp_path / f"v{seed}", seed=seed, sway_rms=0.0, num_frames=n, fps=fps,
                           body_mesh_edge=0.05)
        anim = load_animation(out)
        activity = json.loads((out / "animation.json").read_text())["activity"]
        vitals = VitalSigns(**activity["vital_signs"])
        items.append(activity["vital_signs"])
        params = {k: v.default for k, v in scenes.parameters("vital_signs").items()}
        params.update(seed=seed, sway_rms=0.0, num_frames=n, fps=fps, body_mesh_edge=0.05)
        person, _ = still_person(params, "sitting")
        p0 = anim.motion(0, "torso").translation
        rot = anim.motion(0, "torso").rotation
        normal = rot @ person.body.forward            # the body's rest forward turned with the thorax
        for i in range(n):
            m = anim.motion(i, "torso")
            t = i / fps
            assert np.allclose(m.rotation, rot, atol=1e-12)
            assert np.allclose(m.translation - p0, (vitals.displacement(t) - vitals.displacement(0.0)) * normal,
                               atol=1e-12)
            # differences over h = 0.01 frame: central inside (error h^2 d'/6), one-sided at the ends (h d''/2)
            h = person.velocity_step / fps
            wb, wh = 2 * np.pi * vitals.breathing_rate, 2 * np.pi * vitals.heart_rate
            amp = (vitals.breathing_amplitude / 2, vitals.heart_amplitude / 2)
            tol = (h / 2 * (wb ** 2 * amp[0] + wh ** 2 * amp[1]) if i in (0, n - 1)
                   else h ** 2 / 6 * (wb ** 3 * amp[0] + wh ** 3 * amp[1])) + 1e-12
            assert np.allclose(m.velocity, vitals.velocity(t) * normal, atol=tol)
            assert np.any(anim.object_velocity(i, "torso") != 0)
            assert np.all(anim.object_velocity(i, "pelvis") == 0)
    assert items[0] != items[1]


# =========================================================================== stages
def _plate_scene(root, steps, step):
    """A 0.2 m metal plate 2 m in front of the radar, facing it, moved ``step`` m per frame (rigid), and a
    static concrete wall at 3.5 m."""
    from sionnafmcw.animation.rigid import transform_matrix
    from sionnafmcw.scenes import meshes
    from sionnafmcw.scenes.writer import METAL, AnimationWriter, itu_material, metal_material

    w = AnimationWriter(root, 10.0)
    w.add_materials(metal_material())
    wall_id, wall = itu_material("concrete", 0.2)
    w.add_materials(wall)
    v, f = meshes.box((3.5, -1.0, 0.0), (3.6, 1.0, 2.0))
    w.static("wall", v, f, wall_id)
    v, f = meshes.plate((0.0, 0.0, 0.0), (0.2, 0.2), normal=(-1.0, 0.0, 0.0), subdiv=8)
    w.rigid("plate", v, f, METAL)
    for i in range(steps):
        w.frame(rigid={"plate": {"to_world": transform_matrix(np.eye(3), (2.0 + i * step, 0.0, 1.0)),
                                 "velocity": np.array([step * 10.0, 0.0, 0.0]),
                                 "angular_velocity": np.zeros(3)}})
    w.finish((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    return load_animation(root)


def test_sub_millimetre_steps_survive_the_path_engine(tmp_path):
    r"""The plate's echoes (static wall cached, PO render, PO merge) turn by :math:`2k\Delta d` per step at the
    carrier, within the spread of the samples' path-length changes, :math:`\Delta d\cos\theta` to
    :math:`\Delta d/\cos\theta` (:math:`\theta` up to the plate corners' 4.0 degrees, relative 2.5e-3), plus
    float32 vertex rounding; synthesised (the plate's own echoes) and range-transformed, its bin turns by
    the same at the sweep centre's wavelength, give or take the PO merge's beat phase: a merged
    contribution keeps its carrier phase exactly but takes its cell's mean delay into the beat; the
    merge's cells keep that within its share of the noise budget
    (:func:`~sionnafmcw.engines.po_merge.merge_contributions`), far below the pi/256 rad per frame
    allowed here (and the plate's samples change cells as it moves)."""
    from sionnafmcw import PathEngine

    radar = small_radar()
    step = 5e-5
    anim = _plate_scene(tmp_path / "plate", 4, step)
    engine = PathEngine(samples_per_src=20_000, max_depth=1)
    k = int(np.argmin(np.abs(range_axis(radar) - 2.0)))
    carrier, binned = [], []
    for i in range(anim.num_frames):
        echoes = engine.echoes(anim, radar, i)
        labels = np.asarray(echoes.labels)[0, 0]
        plate = labels == "plate"
        assert echoes.static_count > 0 and not plate[:echoes.static_count].any()   # the wall cached, the plate not
        a, tau = echoes.a[0, 0, plate], echoes.tau[0, 0, plate]
        carrier.append(np.sum(np.conj(a) * np.exp(2j * np.pi * radar.fc * tau)))
        own = Echoes(echoes.a[..., plate], echoes.tau[..., plate], echoes.doppler[..., plate])
        y = range_fft(synthesize(own, radar, noise=False), window="hann", axis=-1).mean(axis=0)[0, 0, k]
        binned.append(y)
    theta_max = math.atan(0.1 * math.sqrt(2) / 2.0)
    rounding = 2 * 2 * math.pi / radar.centre_wavelength * 2 * 1.2e-7
    for values, wavelength, merge in ((carrier, SPEED_OF_LIGHT / radar.fc, 0.0),
                                      (binned, radar.centre_wavelength, 2 * math.pi / 256)):
        dphi = np.angle(np.array(values[1:]) / np.array(values[:-1]))
        expected = 4 * math.pi * step / wavelength
        tol = expected * (1 / math.cos(theta_max) - 1) + rounding + merge
        print(f"\nplate steps of {step * 1e3:.3f} mm: phase steps {np.round(dphi, 6)} rad, expected {expected:.6f} "
              f"+- {tol:.1e} rad")
        assert np.allclose(dphi, expected, atol=tol)


def test_po_merge_keeps_the_carrier_phase():
    """A patch of chest merged into the coarsest cells (an unlimited budget: the merge's own error bound
    is tested in tests/test_po_merge.py) keeps the channel at the carrier exactly, so a 0.1 mm step of
    the chest turns the merged channel by exactly 4 pi d / lambda."""
    from sionnafmcw.engines.po_merge import FRACTIONS, merge_contributions

    radar = RadarConfig.preset("walk-77ghz")
    rng = np.random.default_rng(5)
    p = 4000
    tau = 2 * (1.0 + rng.uniform(0.0, 0.3, p)) / SPEED_OF_LIGHT       # a patch of chest 1.0-1.3 m away
    m, n = radar.num_tx, radar.num_rx
    a = np.broadcast_to((rng.normal(size=p) + 1j * rng.normal(size=p)) * 1e-4, (m, n, p)).copy()
    dop = np.broadcast_to(rng.normal(0, 5.0, p), (m, n, p)).copy()
    labels = np.array(["torso"] * p)
    directions = np.tile([1.0, 0.0, 0.0], (p, 1))                      # the chest seen along the boresight
    shift = 2 * 1e-4 / SPEED_OF_LIGHT                                   # 0.1 mm further
    carrier = []
    for dt in (0.0, shift):
        t = np.broadcast_to(tau + dt, (m, n, p)).copy()
        merged = merge_contributions(a, t, dop, labels, directions, radar, budget=np.inf)
        assert merged.fraction == FRACTIONS[0] and merged.a.shape[-1] < p          # it did merge
        # Sionna's a holds no carrier phase: the channel at the carrier is sum a exp(-j 2 pi f_c tau)
        carrier.append(np.sum(merged.a[0, 0] * np.exp(-2j * np.pi * radar.fc * merged.tau[0, 0])))
        assert carrier[-1] == pytest.approx(np.sum(a[0, 0] * np.exp(-2j * np.pi * radar.fc * t[0, 0])), rel=1e-9)
    turn = np.angle(carrier[0] / carrier[1])
    assert turn == pytest.approx(2 * np.pi * radar.fc * shift, abs=1e-9)
    assert 2 * np.pi * radar.fc * shift == pytest.approx(4 * np.pi * 1e-4 * radar.fc / SPEED_OF_LIGHT)


def _chest_echoes(radar, d, rcs=0.1, static_rcs=0.05):
    """A chest at 1 m + d (point, radial velocity 0) and a static echo 3 cm behind it (same range bin)."""
    return Echoes.point_targets(radar, [1.0 + d, 1.03], [0.0, 0.0], [0.0, 0.05], rcs=[rcs, static_rcs])


def test_synthesis_phase_floor_is_far_below_a_heartbeat():
    radar = small_radar()
    budget = noise_error_budget(radar)
    worst, bound = 0.0, 0.0
    k = int(np.argmin(np.abs(range_axis(radar) - 1.0)))
    for d in np.linspace(0.0, 0.012, 7):
        echoes = _chest_echoes(radar, d)
        fast = synthesize(echoes, radar, noise=False, max_error=budget)
        exact = synthesize(echoes, radar, noise=False, method="direct")
        yf = range_fft(fast, window="hann", axis=-1)[..., k]
        ye = range_fft(exact, window="hann", axis=-1)[..., k]
        worst = max(worst, float(np.max(np.abs(np.angle(yf / ye)))))
        bound = max(bound, float(budget / np.min(np.abs(ye))))
    heartbeat = 4 * math.pi * 1e-4 / radar.centre_wavelength
    print(f"\nsynthesis phase error at the chest bin: {worst:.2e} rad (bound E_max/A = {bound:.2e} rad); a 0.1 mm "
          f"heartbeat turns it by {heartbeat:.3f} rad")
    assert worst <= bound
    assert bound < 0.01 * heartbeat     # 40 dB below


def test_estimator_recovers_both_rates_from_point_target_cubes():
    radar = small_radar(num_rx=2)
    fps, seconds = 25.0, 30.0
    vitals = VitalSigns(0.31, 0.008, 1.37, 0.0002, 0.4, 1.1)
    t = np.arange(int(fps * seconds)) / fps
    rng = np.random.default_rng(11)
    budget = noise_error_budget(radar)
    cubes = np.array([synthesize(_chest_echoes(radar, float(d)), radar, noise=True, rng=rng, max_error=budget)
                      for d in vitals.displacement(t)])
    est = vital_signs(cubes, radar, fps)
    print(f"\nestimator on point targets: breathing {est.breathing_rate:.4f} Hz (truth {vitals.breathing_rate}), "
          f"heart {est.heart_rate:.4f} Hz (truth {vitals.heart_rate}), range {est.range:.3f} m")
    assert abs(est.breathing_rate - vitals.breathing_rate) <= RATE_TOLERANCE
    assert abs(est.heart_rate - vitals.heart_rate) <= RATE_TOLERANCE
    expected = 4 * math.pi * vitals.breathing_amplitude / radar.centre_wavelength
    assert np.ptp(est.phase) == pytest.approx(expected, rel=0.1)


# =========================================================================== end to end
@pytest.mark.slow
def test_vital_signs_rates_through_the_path_engine(tmp_path):
    from sionnafmcw import PathEngine, simulate

    base = RadarConfig.preset("ti-awr1843boost")    # 3.44 GHz: 4.4 cm range bins separate the chest
    radar = base.replace(num_chirps=2, tx_positions=base.tx_positions[:1], tx_order=[0], name="vitals")
    fps, seconds = 25.0, 30.0
    out = scenes.build("vital_signs", tmp_path / "vs", seed=3, num_frames=int(fps * seconds), fps=fps,
                       body_mesh_edge=0.02)
    truth = json.loads((out / "animation.json").read_text())["activity"]["vital_signs"]
    run = simulate(load_animation(out), radar, engine=PathEngine(samples_per_src=20_000, max_depth=1),
                   out=tmp_path / "vs.zarr", progress=False, noise=True)
    est = vital_signs(run.dataset.iq.values, radar, fps)
    err_b = est.breathing_rate - truth["breathing_rate"]
    err_h = est.heart_rate - truth["heart_rate"]
    print(f"\nvital_signs through the path engine: breathing {est.breathing_rate:.4f} Hz (truth "
          f"{truth['breathing_rate']:.4f}, error {err_b:+.4f}), heart {est.heart_rate:.4f} Hz (truth "
          f"{truth['heart_rate']:.4f}, error {err_h:+.4f}); amplitudes {truth['breathing_amplitude'] * 1e3:.2f} mm, "
          f"{truth['heart_amplitude'] * 1e3:.3f} mm; chest bin at {est.range:.3f} m")
    assert abs(err_b) <= RATE_TOLERANCE and abs(err_h) <= RATE_TOLERANCE
