"""Beat synthesis against closed forms: phase model, fast vs direct sum, TDM timing, noise, SNR."""

import numpy as np
import pytest

from sionnafmcw import BOLTZMANN, SPEED_OF_LIGHT, T0, Echoes, RadarConfig, synthesize
from sionnafmcw.synthesis import beat_direct, beat_nufft
from sionnafmcw.synthesis.phase import PhasePolynomial, exact_phase


@pytest.fixture(scope="module")
def small_radar():
    # walk-77ghz timing and array, fewer chirps/samples so the direct sum stays cheap
    return RadarConfig.preset("walk-77ghz").replace(num_chirps=32, num_samples=64, fs=2.5e6)


def random_echoes(radar, count, seed, max_speed=9.0):
    rng = np.random.default_rng(seed)
    return Echoes.point_targets(
        radar,
        rng.uniform(0.5, 0.95 * radar.max_range, count),
        rng.uniform(-max_speed, max_speed, count),
        np.deg2rad(rng.uniform(-70, 70, count)),
        np.deg2rad(rng.uniform(-30, 30, count)),
        rng.uniform(0.01, 2.0, count),
    )


def test_phase_polynomial_is_exact(small_radar):
    """The (l, k') polynomial equals the exact phase to float64 round-off (cycles)."""
    radar = small_radar
    rng = np.random.default_rng(1)
    tau0 = rng.uniform(1e-9, 2e-7, 50)[:, None, None]
    nu = rng.uniform(-1e-7, 1e-7, 50)[:, None, None]  # |v| up to 15 m/s
    l = np.arange(radar.num_chirps)[None, :, None]
    k = np.arange(radar.num_samples)[None, None, :]
    for slot in range(radar.num_tx):
        poly = PhasePolynomial.from_delay_doppler(tau0, nu, slot, radar)
        exact = exact_phase(tau0, nu, (l * radar.num_tx + slot) * radar.chirp_interval,
                            radar.adc_start_time + k / radar.fs, radar)
        approx = poly.evaluate(l, k - (radar.num_samples - 1) / 2)
        # phases reach 1e4 cycles: float64 round-off is ~1e-12 cycles
        assert np.max(np.abs(exact - approx)) < 1e-9
        shifted = poly.shift_chirp_origin(7.5)
        assert np.max(np.abs(shifted.evaluate(l - 7.5, k - (radar.num_samples - 1) / 2) - exact)) < 1e-9


@pytest.mark.parametrize("tx_order", [[0, 1, 2], [2, 0, 1]])
def test_fast_sum_matches_direct_sum(small_radar, tx_order):
    """The two implementations agree to <= 1e-5 relative (norm of the difference)."""
    radar = small_radar.replace(tx_order=tx_order)
    echoes = random_echoes(radar, 300, seed=len(tx_order) + tx_order[0])
    direct = beat_direct(echoes, radar)
    fast = beat_nufft(echoes, radar)
    error = np.linalg.norm(fast - direct) / np.linalg.norm(direct)
    assert error <= 1e-5
    # and per channel, so that no channel hides in the total
    for m in range(radar.num_tx):
        for n in range(radar.num_rx):
            e = np.linalg.norm(fast[:, m, n] - direct[:, m, n]) / np.linalg.norm(direct[:, m, n])
            assert e <= 1e-5


def test_fast_sum_handles_paths_beyond_max_range_and_padding(small_radar):
    """Multipath beyond the unambiguous range aliases exactly as in the direct sum; zero gains are padding."""
    radar = small_radar
    echoes = random_echoes(radar, 40, seed=5)
    far = Echoes.point_targets(radar, [2.3 * radar.max_range], [3.0], [0.2])
    padded = Echoes.concatenate([echoes, far, Echoes(np.zeros((3, 4, 5), complex), np.zeros((3, 4, 5)),
                                                     np.zeros((3, 4, 5)))])
    direct = beat_direct(padded, radar)
    fast = beat_nufft(padded, radar)
    assert np.linalg.norm(fast - direct) / np.linalg.norm(direct) <= 1e-5


@pytest.mark.parametrize("velocity", [0.0, 1e-37, 1e-13, 1e-9])
@pytest.mark.parametrize("noise_budget", [False, True])
def test_fast_sum_near_zero_doppler(small_radar, velocity, noise_budget):
    """A target all but static (1e-37 m/s, a value a property-based test met: finufft's type 3
    rescales by the sources' spread, and in single precision a spread of ~1e-37 made every sample
    NaN) gives the direct sum within 1e-5 (tight default), or within the error bound the noise
    budget chose (single precision)."""
    from sionnafmcw.synthesis import noise_error_budget, synthesis_accuracy

    radar = small_radar
    echoes = Echoes.point_targets(radar, [0.4 * radar.max_range, 0.6 * radar.max_range], [velocity, 2 * velocity],
                                  [0.1, -0.2])
    direct = beat_direct(echoes, radar)
    if noise_budget:
        budget = noise_error_budget(radar)
        accuracy = synthesis_accuracy(echoes, radar, max_error=budget)
        fast = beat_nufft(echoes, radar, max_error=budget)
        assert np.all(np.isfinite(fast))
        assert max_channel_error(fast, direct) <= accuracy.error_bound + 1e-6 * np.abs(direct).max()
    else:
        fast = beat_nufft(echoes, radar)
        assert np.all(np.isfinite(fast))
        assert np.linalg.norm(fast - direct) / np.linalg.norm(direct) <= 1e-5


def test_single_sample_matches_closed_form(small_radar):
    """One contribution, one sample, written out by hand from the beat model of :mod:`sionnafmcw.synthesis`."""
    radar = small_radar.replace(tx_order=[1, 2, 0])
    a, tau0, fd = 0.3 - 0.2j, 41e-9, -812.0
    echoes = Echoes(np.full((3, 4, 1), a), np.full((3, 4, 1), tau0), np.full((3, 4, 1), fd))
    cube = synthesize(echoes, radar, noise=False)
    l, m, n, k = 5, 0, 2, 17
    q = radar.tx_order.index(m)  # slot of physical Tx 0
    t = (l * radar.num_tx + q) * radar.chirp_interval + radar.adc_start_time + k / radar.fs
    t_fast = radar.adc_start_time + k / radar.fs
    tau = tau0 - fd / radar.fc * t
    expected = np.sqrt(radar.tx_power) * np.conj(a) * np.exp(
        2j * np.pi * (radar.fc * tau + radar.slope * tau * t_fast - radar.slope * tau**2 / 2))
    # complex64 output: relative precision ~1e-7
    assert abs(cube[l, m, n, k] - expected) <= 1e-6 * abs(expected)


def test_tdm_transmit_offset_is_modelled(small_radar):
    """A mover seen by two Tx at the same position differs by the Doppler phase of the slot offset."""
    radar = small_radar.replace(tx_positions=np.zeros((3, 3)), rx_positions=np.zeros((4, 3)), tx_order=[0, 1, 2])
    v = 4.0
    echoes = Echoes.point_targets(radar, [3.0], [v], [0.0])
    cube = synthesize(echoes, radar, noise=False)
    # phase of Tx1 relative to Tx0 for chirp 0, sample at the ADC centre
    k = radar.num_samples // 2
    measured = np.angle(cube[0, 1, 0, k] / cube[0, 0, 0, k])
    # d(phi)/dt = -f_D' with the instantaneous frequency at that sample; one slot = T_c later
    f_inst = radar.fc + radar.slope * (radar.adc_start_time + k / radar.fs)
    fd = -2 * v / SPEED_OF_LIGHT * f_inst
    expected = np.angle(np.exp(-2j * np.pi * fd * radar.chirp_interval))
    # the delay also grows by 2 v T_c / c within the slot: its beat-frequency term is 1e-4 rad here
    assert abs(np.angle(np.exp(1j * (measured - expected)))) < 2e-3
    assert abs(expected) > 0.1  # the offset is not negligible: 1.5 rad at 4 m/s


def test_thermal_noise_power(small_radar):
    """Noise-only cube: per-sample power k T0 F Fs (to 4 standard errors of the estimate)."""
    radar = small_radar
    cube = synthesize(Echoes.empty(3, 4), radar, noise=True, rng=7)
    expected = BOLTZMANN * T0 * 10 ** (radar.noise_figure / 10) * radar.fs
    measured = np.mean(np.abs(cube) ** 2)
    # |w|^2 is exponential: the mean of K samples has relative standard error 1/sqrt(K)
    assert abs(measured / expected - 1) < 4 / np.sqrt(cube.size)
    assert abs(np.mean(cube.real**2) / np.mean(cube.imag**2) - 1) < 8 / np.sqrt(cube.size)
    assert cube.dtype == np.complex64


def test_same_seed_same_cube(small_radar):
    echoes = random_echoes(small_radar, 5, seed=3)
    a = synthesize(echoes, small_radar, rng=11)
    b = synthesize(echoes, small_radar, rng=11)
    c = synthesize(echoes, small_radar, rng=12)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_received_power_follows_radar_equation(small_radar):
    """Monostatic-limit power of a point target: P_t G^2 lambda^2 sigma / ((4 pi)^3 R^4)."""
    radar = small_radar.replace(antenna_pattern="tr38901")
    r, rcs = 4.0, 0.5
    echoes = Echoes.point_targets(radar, [r], [0.0], [0.0], rcs=rcs)
    g = 10 ** 0.8  # tr38901 boresight gain, 8 dBi
    expected = radar.tx_power * g**2 * radar.wavelength**2 * rcs / ((4 * np.pi) ** 3 * r**4)
    cube = synthesize(echoes, radar, noise=False)
    # elements sit mm off the axis: their distances and off-boresight gains differ by < 1e-4
    assert np.allclose(np.abs(cube) ** 2, expected, rtol=1e-3)


def test_input_errors_name_the_problem(small_radar):
    echoes = random_echoes(small_radar, 3, seed=1)
    with pytest.raises(ValueError, match="method"):
        synthesize(echoes, small_radar, method="fft")
    wrong = RadarConfig.preset("ti-iwr1443boost")
    with pytest.raises(ValueError, match="2 x 4"):
        synthesize(echoes, wrong)
    with pytest.raises(ValueError, match="Echoes.tau"):
        Echoes(np.ones((1, 1, 2)), np.ones((1, 1, 3)), np.zeros((1, 1, 2)))


def test_tx_rx_leakage_option(small_radar):
    """Leakage: a static tone at the Tx-Rx distance with power P_t 10^(C/10) per channel, none by default."""
    radar = small_radar
    echoes = random_echoes(radar, 3, seed=2)
    plain = synthesize(echoes, radar, noise=False)
    leaky = synthesize(echoes, radar, noise=False, leakage_db=-30.0)
    tone = leaky - plain
    assert np.allclose(np.abs(tone) ** 2, radar.tx_power * 1e-3, rtol=1e-4)
    # static: identical in every chirp of a channel
    assert np.allclose(tone, tone[:1], atol=1e-6 * np.abs(tone).max())
    # beat frequency mu * d / c for the Tx0-Rx0 distance d: phase step per sample
    d = np.linalg.norm(radar.tx_positions[0] - radar.rx_positions[0])
    step = np.angle(tone[0, 0, 0, 1:] / tone[0, 0, 0, :-1])
    assert np.allclose(step, 2 * np.pi * radar.slope * d / SPEED_OF_LIGHT / radar.fs, atol=1e-4)


def budget_echoes(radar, seed, max_speed=9.0):
    """A walk-like mix: a moving body (many weak contributions, radial speeds up to ``max_speed``),
    static clutter, multipath beyond R_max."""
    rng = np.random.default_rng(seed)
    body = Echoes.point_targets(radar, rng.uniform(2.0, 3.0, 200), rng.uniform(-max_speed, max_speed, 200),
                                np.deg2rad(rng.uniform(-10, 10, 200)), 0.0, np.full(200, 1.0 / 200))
    clutter = random_echoes(radar, 100, seed=seed + 1, max_speed=0.0)
    far = Echoes.point_targets(radar, rng.uniform(1.1, 2.5, 5) * radar.max_range, rng.uniform(-3, 3, 5),
                               np.deg2rad(rng.uniform(-40, 40, 5)), 0.0, 0.5)
    return Echoes.concatenate([body, clutter, far])


def max_channel_error(fast, direct):
    return max(np.abs(fast[:, m, n] - direct[:, m, n]).max() for m in range(fast.shape[1]) for n in range(fast.shape[2]))


@pytest.mark.parametrize("tx_order, scale, max_speed, precision", [([0, 1, 2], 1.0, 9.0, "complex128"),
                                                                   ([2, 0, 1], 1.0, 9.0, "complex128"),
                                                                   ([2, 0, 1], 0.05, 9.0, "complex64"),
                                                                   ([0, 1, 2], 0.05, 17.0, "complex64"),
                                                                   ([0, 1, 2], 0.05, 20.0, "complex128")])
def test_noise_budget_keeps_error_20_db_below_noise(small_radar, tx_order, scale, max_speed, precision):
    """With noise on, every sample's synthesis error is >= 20 dB below the thermal noise.

    Echoes 26 dB weaker (``scale`` 0.05) leave room for single precision under the NUFFT bound's
    safety factor of 16 on finufft's tolerance, up to twice the unambiguous velocity (9.3 m/s:
    17 m/s is |B_p| = 0.92 cycle per TDM block, 20 m/s is 1.08, past the single-precision limit)."""
    from sionnafmcw.synthesis import noise_error_budget, synthesis_accuracy

    radar = small_radar.replace(tx_order=tx_order)
    echoes = budget_echoes(radar, seed=len(tx_order) + tx_order[0], max_speed=max_speed)
    echoes = Echoes(echoes.a * scale, echoes.tau, echoes.doppler)
    budget = noise_error_budget(radar)
    assert budget == pytest.approx(0.1 * np.sqrt(radar.noise_power))  # 20 dB below sigma
    accuracy = synthesis_accuracy(echoes, radar, max_error=budget)
    # looser than the tight default (else the test shows nothing), and the bound meets the budget
    assert accuracy.nufft_tol >= 10 * 1e-7 and accuracy.error_bound <= budget * (1 + 1e-9)
    assert accuracy.dtype == precision
    direct = beat_direct(echoes, radar)
    fast = beat_nufft(echoes, radar, max_error=budget)
    assert max_channel_error(fast, direct) <= accuracy.error_bound
    # synthesize applies it: its noise-on cube minus the same noise is the fast sum (complex64)
    shape = direct.shape
    from sionnafmcw.synthesis import thermal_noise

    signal = synthesize(echoes, radar, noise=True, rng=3) - thermal_noise(shape, radar, np.random.default_rng(3))
    rounding = 1e-6 * np.abs(direct).max()  # complex64 storage of the cube and of the noise
    assert max_channel_error(signal, direct) <= budget + rounding


def test_noise_budget_strong_echoes_fall_back_to_double_precision(small_radar):
    """Echoes 90 dB over the noise (Tx-Rx leakage) need a tolerance single precision cannot give."""
    from sionnafmcw.synthesis import noise_error_budget, synthesis_accuracy

    radar = small_radar
    echoes = Echoes.concatenate([budget_echoes(radar, seed=9), Echoes.leakage(radar, -20.0)])
    budget = noise_error_budget(radar)
    accuracy = synthesis_accuracy(echoes, radar, max_error=budget)
    assert accuracy.dtype == "complex128" and accuracy.nufft_tol < 5e-5
    fast = beat_nufft(echoes, radar, max_error=budget)
    assert fast.dtype == np.complex128
    assert max_channel_error(fast, beat_direct(echoes, radar)) <= accuracy.error_bound <= budget * (1 + 1e-9)


def test_noise_off_keeps_tight_tolerance(small_radar):
    """Without noise the fast sum keeps finufft tol 1e-7 in double precision, and meets its bound."""
    from sionnafmcw.synthesis import synthesis_accuracy

    radar = small_radar
    echoes = budget_echoes(radar, seed=4)
    accuracy = synthesis_accuracy(echoes, radar)
    assert accuracy.nufft_tol == 1e-7 and accuracy.dtype == "complex128" and accuracy.max_error is None
    direct = beat_direct(echoes, radar)
    fast = beat_nufft(echoes, radar)
    assert max_channel_error(fast, direct) <= accuracy.error_bound
    # relative to the strongest sample: 1e-7 of the strength sum is ~1e-6 of the signal here
    assert np.linalg.norm(fast - direct) / np.linalg.norm(direct) <= 1e-5
    cube = synthesize(echoes, radar, noise=False)
    assert np.abs(cube - direct).max() <= accuracy.error_bound + 1e-6 * np.abs(direct).max()


@pytest.mark.parametrize("channels_per_plan", [1, 3])
def test_keystone_fitted_per_plan_leaves_the_cross_residual_of_the_range_spread(small_radar, channels_per_plan):
    """The cross residual delta_p = C_p - eps B_p is about (mu/F^2) A_p B_p, so a slope fitted
    to a moving body 6.0-6.3 m away leaves (mu/F^2)(A_p - A_mean) B_p: its weight in the error bound
    falls to at most the range span over the range (0.3 / 6.0, far below the radar slope's). With a
    budget that lets the Taylor series drop the fitted residual but not the radar slope's, the fitted
    plans carry the constant term only, and the sum still meets its bound against the direct sum."""
    from sionnafmcw.synthesis import nufft, synthesis_accuracy
    from sionnafmcw.synthesis.accuracy import TAYLOR_SHARE

    radar = small_radar
    rng = np.random.default_rng(12)
    body = Echoes.point_targets(radar, rng.uniform(6.0, 6.3, 300), rng.uniform(-4.0, 4.0, 300),
                                np.deg2rad(rng.uniform(-10, 10, 300)), 0.0, np.full(300, 1.0 / 300))
    grid = nufft._Grid(radar)

    def cross_weight(channels):   # the cross term's weight in the Taylor bound (accuracy.choose_accuracy)
        return max(float((c.amplitude * c.phases[0]).sum()) for c in channels) * np.sqrt(radar.tx_power)

    radar_slope = cross_weight(nufft._channels(body, radar, grid))
    channels, groups, shifts = nufft._plans(body, radar, grid, channels_per_plan)
    fitted = cross_weight(channels)
    assert len(groups) == 12 // channels_per_plan and all(s != 0 for s in shifts)
    assert 0 < fitted <= 0.3 / 6.0 * radar_slope
    # a budget whose Taylor share lies between the two weights
    budget = np.sqrt(fitted * radar_slope) / TAYLOR_SHARE
    unfitted = nufft._accuracy(nufft._channels(body, radar, grid), radar, budget, 1e-7, 1e-8)
    accuracy = synthesis_accuracy(body, radar, max_error=budget, channels_per_plan=channels_per_plan)
    assert (1, 0, 0) in unfitted.terms and accuracy.terms == ((0, 0, 0),)
    fast = beat_nufft(body, radar, max_error=budget, channels_per_plan=channels_per_plan)
    assert max_channel_error(fast, beat_direct(body, radar)) <= accuracy.error_bound <= budget * (1 + 1e-9)


def test_single_precision_strengths_round_only_the_phase(small_radar):
    """In complex64 the strengths' phases are rounded to float32 (within [-pi, 2pi]: at most 2^-22 rad)
    before the cosines; with the complex64 product's rounding (2 x 2^-24) every strength stays within
    4e-7 of its |a_p| of the complex128 one, whose magnitude is |a_p| to float64 rounding."""
    from sionnafmcw.synthesis import nufft

    radar = small_radar   # 64 samples: Ns - 1 is odd and the A-wrap sign is folded into the phase
    echoes = budget_echoes(radar, seed=21)
    channels = nufft._channels(echoes, radar, nufft._Grid(radar))
    assert max(c.phase.max() for c in channels) > np.pi   # some wrap signs are folded in
    for c in channels:
        assert c.phase.min() >= -np.pi and c.phase.max() <= 2 * np.pi
        single, double = c.strength(np.complex64), c.strength(np.complex128)
        assert single.dtype == np.complex64 and double.dtype == np.complex128
        assert np.all(np.abs(single - double) <= 4e-7 * c.amplitude)
        np.testing.assert_allclose(np.abs(double), c.amplitude, rtol=1e-15)


@pytest.mark.parametrize("noise_budget", [False, True])
def test_still_contributions_are_summed_once_for_every_chirp(small_radar, noise_budget):
    """Still targets (zero Doppler, a radar at rest) have the same beat in every chirp: the fast sum takes
    them through a 1-D transform over the samples (nufft._still_cubes), so every chirp of a still-only cube
    is the same row bit for bit (the 2-D transform's rows differ by its own error), within the error bound
    of the whole sum of the direct sum; mixed with moving targets and with phase-noise weights, both sums
    within the bound the accuracy module gives the whole (still and moving together)."""
    from sionnafmcw.synthesis import noise_error_budget, synthesis_accuracy

    radar = small_radar
    budget = noise_error_budget(radar) if noise_budget else None
    still = random_echoes(radar, 300, seed=11, max_speed=0.0)
    still = Echoes(still.a * (0.05 if noise_budget else 1.0), still.tau, still.doppler)
    assert np.all(still.doppler == 0.0)
    fast = beat_nufft(still, radar, max_error=budget)
    assert np.array_equal(fast, np.broadcast_to(fast[:1], fast.shape))
    direct = beat_direct(still, radar)
    assert max_channel_error(fast, direct) <= synthesis_accuracy(still, radar, max_error=budget).error_bound
    mixed = Echoes.concatenate([still, random_echoes(radar, 100, seed=12, max_speed=6.0)])
    weights = np.random.default_rng(13).uniform(0.0, 2e-8, mixed.a.shape)
    bound = synthesis_accuracy(mixed, radar, max_error=budget).error_bound
    fast, fast_w = beat_nufft(mixed, radar, max_error=budget, weights=weights)
    direct, direct_w = beat_direct(mixed, radar, weights=weights)
    assert max_channel_error(fast, direct) <= bound
    assert max_channel_error(fast_w, direct_w) <= bound * weights.max()
