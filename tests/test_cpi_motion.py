"""Motion within the CPI against closed forms: the kinematics of a path, the
quadratic delay in the synthesis, and the Doppler smear of an accelerating target through both engines.

Closed form: a reflector whose range accelerates at :math:`\\ddot R` (constant) over the CPI
:math:`T` has the radial velocity :math:`\\dot R(t) = \\dot R_0 + \\ddot R t`: its Doppler sweeps
:math:`2\\ddot R T/\\lambda` (Hz), i.e. its velocity spectrum covers :math:`[\\dot R_0, \\dot R_0 + \\ddot R T]`.
With a rectangular Doppler window the band is flat between its edges; tolerances are one Doppler
bin (:math:`\\lambda/(2T)` in velocity) on each edge. The frozen model (``cpi_motion="frozen"``, no
Doppler rates) puts the same reflector in one bin.
"""

import numpy as np
import pytest

from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.kinematics import (
    PointKinematics, ego_doppler, element_kinematics, mirror_image, range_acceleration, range_rate,
    rigid_point_kinematics,
)
from sionnafmcw.synthesis import beat_direct, beat_nufft, noise_error_budget, synthesis_accuracy
from sionnafmcw.synthesis.phase import PhasePolynomial, exact_phase
from spectrum_helpers import band_edges, spectrum_band


@pytest.fixture(scope="module")
def radar():
    return RadarConfig.preset("walk-77ghz")


@pytest.fixture(scope="module")
def small_radar():
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=32, num_samples=64, fs=2.5e6)


# ---------------------------------------------------------------------------------------- kinematics
def numeric_derivatives(f, t0=0.0, h=1e-4):
    """First and second central differences of the scalar function ``f`` at ``t0``."""
    f_m, f_0, f_p = f(t0 - h), f(t0), f(t0 + h)
    return (f_p - f_m) / (2 * h), (f_p - 2 * f_0 + f_m) / h**2


def test_segment_range_rate_and_acceleration_match_differences():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x0, v0, a0, x1, v1, a1 = (rng.normal(size=3) * s for s in (2.0, 3.0, 20.0, 2.0, 3.0, 20.0))

        def length(t):
            return np.linalg.norm((x1 + v1 * t + a1 * t * t / 2) - (x0 + v0 * t + a0 * t * t / 2))

        d1, d2 = numeric_derivatives(length)
        assert range_rate(x0, v0, x1, v1) == pytest.approx(d1, rel=1e-6, abs=1e-6)
        assert range_acceleration(x0, v0, a0, x1, v1, a1) == pytest.approx(d2, rel=1e-4, abs=1e-3)


def test_centripetal_term_of_a_target_passing_broadside():
    """A target passing at speed v, range R, broadside: no radial velocity, R'' = v^2 / R."""
    assert range_acceleration(np.zeros(3), np.zeros(3), np.zeros(3), [3.0, 0, 0], [0, 4.5, 0], np.zeros(3)) \
        == pytest.approx(4.5**2 / 3.0)


def test_mirror_image_moves_with_a_turning_mirror():
    """The image of a moving point in a translating, turning plane mirror: velocity and acceleration
    against differences of the image computed from the mirror's pose at t +- h."""
    rng = np.random.default_rng(5)
    omega, alpha = np.array([0.3, -1.2, 2.0]), np.array([4.0, 1.0, -3.0])
    q0, vq, aq = np.array([1.0, 2.0, 0.5]), np.array([0.5, -1.0, 0.2]), np.array([3.0, 0.0, -2.0])
    n0 = np.array([0.2, 0.9, 0.3]) / np.linalg.norm([0.2, 0.9, 0.3])
    x0, vx, ax = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)

    def rotation(t):
        """R(t) with dR/dt = [omega + alpha t]_x R, R(0) = I (numerically, to 1e-12)."""
        from scipy.integrate import solve_ivp

        def rhs(time, y):
            w = omega + alpha * time
            return (np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]) @ y.reshape(3, 3)).ravel()

        if t == 0:
            return np.eye(3)
        return solve_ivp(rhs, (0, t), np.eye(3).ravel(), rtol=1e-12, atol=1e-13).y[:, -1].reshape(3, 3)

    def image(t):
        n = rotation(t) @ n0
        q = q0 + vq * t + aq * t * t / 2
        x = x0 + vx * t + ax * t * t / 2
        return x - 2 * n * (n @ (x - q))

    h = 1e-3
    m_m, m_0, m_p = image(-h), image(0.0), image(h)
    got = mirror_image(PointKinematics(x0, vx, ax), PointKinematics(q0, vq, aq), n0, omega, alpha)
    assert np.allclose(got.position, m_0, atol=1e-12)
    assert np.allclose(got.velocity, (m_p - m_m) / (2 * h), rtol=0, atol=1e-3)   # O(h^2) differences
    assert np.allclose(got.acceleration, (m_p - 2 * m_0 + m_m) / h**2, rtol=0, atol=1e-2)


def test_rigid_point_and_element_kinematics():
    from sionnafmcw.animation import RadarPose
    from sionnafmcw.geometry import rotation_matrix

    kin = rigid_point_kinematics([[1.0, 0, 0]], np.zeros(3), np.zeros(3), [0, 0, 2.0])
    assert np.allclose(kin.velocity, [[0, 2.0, 0]]) and np.allclose(kin.acceleration, [[-4.0, 0, 0]])
    pose = RadarPose([1.0, 2.0, 1.0], [0.3, 0.0, 0.0], velocity=[2.0, 0, 0], angular_velocity=[0, 0, 0.5])
    local = np.array([[0.0, 0.01, 0.0]])
    kin = element_kinematics(pose, local)
    arm = rotation_matrix(pose.orientation) @ local[0]
    assert np.allclose(kin.position[0], pose.position + arm)
    assert np.allclose(kin.velocity[0], pose.velocity + np.cross(pose.angular_velocity, arm))


def test_ego_doppler_of_a_moving_radar():
    """A radar moving at v towards a static reflector at angle theta off its velocity: f = 2 v cos(theta) / lambda."""
    wavelength = 3e8 / 77e9
    for theta in np.deg2rad([0.0, 30.0, 60.0, 120.0]):
        v = 3.0 * np.array([np.cos(theta), np.sin(theta), 0.0])
        elements = PointKinematics(np.zeros((1, 3)), v[None], np.zeros((1, 3)))
        f = ego_doppler(elements, elements, [[5.0, 0, 0]], [[5.0, 0, 0]], wavelength)
        assert f.shape == (1, 1, 1)
        assert f[0, 0, 0] == pytest.approx(2 * 3.0 * np.cos(theta) / wavelength)


# ---------------------------------------------------------------------------------------- synthesis
def test_phase_polynomial_with_doppler_rate_within_its_dropped_bound(small_radar):
    rng = np.random.default_rng(2)
    tau0 = rng.uniform(1e-8, 6e-8, 30)
    nu = rng.uniform(-5, 5, 30) * 2 / 3e8
    beta = rng.uniform(-150, 150, 30) * 2 / 3e8
    radar = small_radar
    l = np.arange(radar.num_chirps)[:, None, None]
    k = np.arange(radar.num_samples)[None, :, None]
    for slot in range(radar.num_tx):
        poly = PhasePolynomial.from_delay_doppler(tau0, nu, slot, radar, beta)
        exact = exact_phase(tau0, nu, (l * radar.num_tx + slot) * radar.chirp_interval,
                            radar.adc_start_time + k / radar.fs, radar, beta)
        error = np.max(np.abs(exact - poly.evaluate(l, k - (radar.num_samples - 1) / 2)), axis=(0, 1))
        assert np.all(error <= poly.dropped + 1e-9)
        shifted = poly.shift_chirp_origin(7.5)
        moved = shifted.evaluate(l - 7.5, k - (radar.num_samples - 1) / 2)
        assert np.max(np.abs(moved - poly.evaluate(l, k - (radar.num_samples - 1) / 2))) < 1e-9


def test_zero_doppler_rates_give_the_frozen_cube_bit_for_bit(small_radar):
    echoes = Echoes.point_targets(small_radar, [3.0, 5.0], [1.0, -2.0], [0.1, -0.3])
    with_zeros = Echoes(echoes.a, echoes.tau, echoes.doppler, doppler_rate=np.zeros(echoes.shape))
    assert not with_zeros.accelerating
    assert np.array_equal(synthesize(echoes, small_radar, rng=1), synthesize(with_zeros, small_radar, rng=1))


def accelerating_targets(radar, seed=0, count=40, max_acceleration=120.0):
    rng = np.random.default_rng(seed)
    return Echoes.point_targets(radar, rng.uniform(1.0, 0.9 * radar.max_range, count), rng.uniform(-6, 6, count),
                                np.deg2rad(rng.uniform(-60, 60, count)), 0.0, rng.uniform(0.01, 1.0, count),
                                radial_accelerations=rng.uniform(-max_acceleration, max_acceleration, count))


def test_fast_sum_with_doppler_rates_matches_the_direct_sum(small_radar):
    """Tight tolerances (noise off): 1e-5 relative; with the noise budget, every sample within the bound."""
    radar = small_radar
    echoes = accelerating_targets(radar)
    direct = beat_direct(echoes, radar)
    fast = beat_nufft(echoes, radar)
    assert np.linalg.norm(fast - direct) / np.linalg.norm(direct) <= 1e-5
    assert synthesis_accuracy(echoes, radar).chirp_blocks > 1   # the 120 m/s^2 sweep is cut into blocks
    budget = noise_error_budget(radar)
    accuracy = synthesis_accuracy(echoes, radar, max_error=budget)
    error = np.max(np.abs(beat_nufft(echoes, radar, max_error=budget) - direct))
    assert error <= accuracy.error_bound <= budget * (1 + 1e-9)


def test_frozen_fast_sum_is_unchanged_by_the_rates_code(small_radar):
    """Echoes without rates take the fast sum of before (same accuracy settings, one block)."""
    echoes = accelerating_targets(small_radar).frozen()
    accuracy = synthesis_accuracy(echoes, small_radar, max_error=noise_error_budget(small_radar))
    assert accuracy.chirp_blocks == 1 and all(len(t) == 3 for t in accuracy.terms)


@pytest.mark.parametrize("acceleration", [20.0, -30.0, 50.0])
def test_constant_acceleration_smears_doppler_by_the_closed_form(radar, acceleration):
    """Point target at 4 m, 1 m/s, constant radial acceleration a: the velocity spectrum spans
    [v0, v0 + a T] within one Doppler bin at each edge; the frozen model puts it in one bin."""
    v0, T, bin_v = 1.0, radar.cpi_duration, radar.velocity_resolution
    echoes = Echoes.point_targets(radar, [4.0], [v0], [0.0], radial_accelerations=[acceleration])
    velocities, power = spectrum_band(synthesize(echoes, radar, rng=1), radar)
    lo, hi = sorted([v0, v0 + acceleration * T])
    assert (hi - lo) / bin_v > 5   # a smear of many bins
    low, high = band_edges(velocities, power, lo, hi, bin_v)
    assert abs(low - lo) <= bin_v and abs(high - hi) <= bin_v, (low, lo, high, hi)
    # the frozen CPI: one bin at v0 (-6 dB width of one bin)
    velocities, power = spectrum_band(synthesize(echoes.frozen(), radar, rng=1), radar)
    above = velocities[power >= 0.25 * power.max()]
    assert np.all(np.abs(above - v0) <= bin_v)
