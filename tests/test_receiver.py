"""The receiver: phase noise, IF chain, ADC and I/Q imbalance against closed forms.

Tolerances: the noise-free cubes are exact to the direct sum (1e-12) or the NUFFT's tight default
(1e-7), so a complex gain is checked to 1e-6; averaged periodograms of Gaussian terms have a relative
standard deviation 1/sqrt(looks) per bin (and 1/sqrt(looks * bins) over independent bins of a
rectangular window), checked within 5 of those; model approximations add their own stated bound.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import signal

from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.ti.dca1000 import read_dca1000, write_dca1000
from sionnafmcw.radar import RadarConfigError
from sionnafmcw.receiver import adc, if_filter, iq_imbalance, noise_power, phase_noise, summary, ti
from sionnafmcw.synthesis import AdcClippingWarning

WALK = RadarConfig.preset("walk-77ghz")
AWR = RadarConfig.preset("ti-awr1843boost")


def single_element(base, **changes):
    """One Tx and one Rx at the origin (point echoes exactly on a range bin), iso pattern, receiver off."""
    fields = dict(tx_positions=[[0.0, 0.0, 0.0]], rx_positions=[[0.0, 0.0, 0.0]], tx_order=[0], antenna_pattern="iso",
                  phase_noise=None, if_filter=None, adc_bits=None, iq_imbalance=None)
    fields.update(changes)
    return base.replace(**fields)


def tone(radar, tau, amplitude=1e-3, doppler=0.0) -> Echoes:
    """Echoes of one contribution per channel with the given delays (s)."""
    tau = np.atleast_1d(np.asarray(tau, float))
    shape = (radar.num_tx, radar.num_rx, tau.size)
    return Echoes(np.full(shape, amplitude, complex), np.broadcast_to(tau, shape).copy(), np.full(shape, doppler))


def on_bin(radar, k) -> np.ndarray:
    """Delays whose beat frequencies are k F_s / N exactly (k may exceed N: beyond the unambiguous range)."""
    return np.asarray(k, float) * radar.fs / (radar.num_samples * radar.slope)


# ============================================================================ phase noise
def test_phase_noise_table_interpolation_and_errors():
    table = phase_noise.check_table([[1e6, -93.0]])
    # one point: -20 dB/decade through it
    assert phase_noise.ssb_dbc(table, [1e5, 1e6, 1e7]).tolist() == pytest.approx([-73.0, -93.0, -113.0])
    plateau = phase_noise.check_table([[1e6, -110.0], [1e4, -85.0], [1e5, -85.0]])      # sorted on the way in
    assert plateau[0] == [1e4, -85.0]
    assert phase_noise.ssb_dbc(plateau, [3e4, np.sqrt(1e5 * 1e6), 1e7]).tolist() == pytest.approx(
        [-85.0, -97.5, -135.0])                                                        # log-log, end slope kept
    assert 2 * 10 ** (-9.3) == pytest.approx(phase_noise.phase_psd(table, 1e6))       # L = S_phi / 2
    for bad, field in (([[1e6, 3.0]], "negative number of dBc/Hz"), ([[0.0, -90.0]], "positive frequency"),
                       ([[1e6]], r"\[1\]|\[0\] must be a pair"), ([], "non-empty"),
                       ([[1e6, -90.0], [1e6, -91.0]], "appears twice")):
        with pytest.raises(RadarConfigError, match=field):
            WALK.replace(phase_noise=bad)


def test_phase_noise_one_realisation_shared_by_channels_and_scaled_by_delay():
    """The phase-noise term is j phi'(t) tau_p x_p(t): divided by j tau x it gives the same frequency noise
    for every receiver and for a target at another range (one realisation per CPI), and the samples of
    sionnafmcw.receiver.phase_noise.frequency_noise drawn from the same seed."""
    radar = WALK.replace(num_chirps=16, phase_noise=[[1e6, -85.0]], antenna_pattern="iso")
    seen = []
    for k in (17, 61):
        echoes = tone(radar, on_bin(radar, k))
        clean = synthesize(echoes, radar, noise=False, method="direct").astype(np.complex128)
        noisy = synthesize(echoes, radar, noise=False, phase_noise=True, method="direct", rng=11)
        tau_c = phase_noise.delay_weights(echoes.tau, echoes.doppler, radar)[0, 0, 0]
        seen.append(((noisy - clean) / (1j * tau_c * clean)).real)                     # [chirp, tx, rx, sample]
    expected = phase_noise.frequency_noise(radar, np.random.default_rng(11))          # [chirp, tx, sample]
    scale = np.abs(expected).max()
    for found in seen:
        # complex64 cube: the difference of two cubes 40 dB apart keeps ~1e-3 of the term
        np.testing.assert_allclose(found, np.broadcast_to(expected[:, :, None, :], found.shape), atol=3e-3 * scale)
    assert np.std(expected) > 0
    # different Tx slots fire at different times: different samples of the one realisation
    assert np.corrcoef(expected[:, 0].ravel(), expected[:, 1].ravel())[0, 1] < 0.1


@pytest.mark.parametrize("k0", [20, 80])
def test_phase_noise_skirt_at_the_closed_form_level(k0):
    """A strong target's range-profile skirt, relative to its peak, is 4 sin^2(pi nu tau) L(nu) F_s / N per bin.

    One element, target on bin k0 (rectangular window: no leakage of its own), 256 chirps (independent
    looks of white FM noise), bins 3..0.45 F_s away: 1/sqrt(256 * bins) spread. The first-order model
    (2 pi nu tau)^2 S_phi must match within 5 of those; the exact 4 sin^2 within that plus the model's
    stated error (x/sin x)^2 - 1, x = pi nu tau (1.5 % on average at 52 ns). Two ranges 4x apart: a
    12 dB higher skirt (range correlation)."""
    radar = single_element(WALK, num_chirps=256, phase_noise=[[1e6, -80.0]])
    n = radar.num_samples
    tau = on_bin(radar, k0)
    cube = synthesize(tone(radar, tau), radar, noise=False, phase_noise=True, rng=2)[:, 0, 0, :]
    power = (np.abs(np.fft.fft(cube.astype(np.complex128), axis=-1)) ** 2).mean(axis=0)
    m = np.arange(n)
    offset = ((m - k0 + n // 2) % n - n // 2) * radar.fs / n
    sel = (np.abs(m - k0) >= 3) & (np.abs(offset) < 0.45 * radar.fs)
    measured = power[sel] / power[k0]
    bin_hz = radar.fs / n
    exact = 10 ** (phase_noise.skirt_dbc(radar.phase_noise, offset[sel], tau) / 10) * bin_hz
    level = 10 ** (phase_noise.ssb_dbc(radar.phase_noise, np.abs(offset[sel])) / 10)
    first = (2 * np.pi * offset[sel] * tau) ** 2 * level * bin_hz
    spread = 5 / math.sqrt(radar.num_chirps * sel.sum())
    assert abs(measured.mean() / first.mean() - 1) < spread
    bound = phase_noise.first_order_error(offset[sel], tau).mean()
    assert abs(measured.mean() / exact.mean() - 1) < spread + bound
    # per bin, each within 5 sigma of 256 looks of its closed form
    assert np.all(np.abs(np.log(measured / first)) < 5 / math.sqrt(radar.num_chirps))
    # the level: flat at (2 pi tau)^2 L(1 MHz) (1 MHz)^2 per Hz for L ~ f^-2
    flat = (2 * np.pi * tau) ** 2 * 1e-8 * 1e12 * bin_hz
    assert measured.mean() == pytest.approx(flat, rel=spread)


def test_phase_noise_leaves_the_thermal_noise_of_a_seed_and_noise_free_cubes_alone():
    radar = single_element(WALK, num_chirps=8)
    silent = tone(radar, on_bin(radar, 10), amplitude=0.0)
    with_pn = radar.replace(phase_noise=[[1e6, -80.0]])
    np.testing.assert_array_equal(synthesize(silent, radar, rng=4), synthesize(silent, with_pn, rng=4))
    echoes = tone(radar, on_bin(radar, 10))
    assert np.array_equal(synthesize(echoes, with_pn, noise=False), synthesize(echoes, radar, noise=False))
    a = synthesize(echoes, with_pn, rng=5)
    np.testing.assert_array_equal(a, synthesize(echoes, with_pn, rng=5))          # reproducible
    assert not np.array_equal(a, synthesize(echoes, with_pn, rng=6))


def test_phase_noise_nufft_matches_the_direct_sum():
    """The delay-weighted sum rides in the same NUFFT plans: the phase-noise cube equals the direct one."""
    radar = WALK.replace(num_chirps=16, phase_noise=[[1e6, -85.0]])
    echoes = Echoes.point_targets(radar, [2.0, 4.5, 7.0], [1.0, -2.0, 0.5], np.deg2rad([-20.0, 5.0, 30.0]))
    fast = synthesize(echoes, radar, noise=False, phase_noise=True, rng=3)
    slow = synthesize(echoes, radar, noise=False, phase_noise=True, rng=3, method="direct")
    assert np.abs(fast - slow).max() < 1e-5 * np.abs(slow).max()


# ============================================================================ IF chain
def independent_ti_chain(radar):
    """TI's chain built here from scipy directly, in physical units (rad/s) and ba form: HPF1 and HPF2
    first-order sections, the elliptic anti-alias filter shifted to 0.4 F_s."""
    f1, f2 = ti.HPF1_CORNERS[0], ti.HPF2_CORNERS[0]
    hp = [signal.butter(1, 2 * np.pi * f, btype="highpass", analog=True) for f in (f1, f2)]
    aa = signal.ellip(6, 0.5, 60.0, 2 * np.pi * 0.4 * radar.fs, analog=True)

    def h(f):
        f = np.asarray(f, float)
        out = np.ones(f.shape, complex)
        for b, a in hp:
            out *= signal.freqs(b, a, 2 * np.pi * f)[1]
        return out * signal.freqs(*aa, 2 * np.pi * (f - 0.4 * radar.fs))[1]

    return h


def test_if_chain_gain_is_the_filters_own_response_and_attenuates_beyond_max_range():
    """Range profile of on-bin targets (one element, rectangular window): the peak with the TI chain over the
    peak without is H(f_beat) of scipy's own filter, complex, from 1 bin to 1.6 F_s (past the unambiguous
    range the target folds back, attenuated by the anti-alias filter instead of aliasing at full power)."""
    radar = single_element(AWR, num_chirps=2)
    chained = radar.replace(if_filter=AWR.if_filter)
    h = independent_ti_chain(radar)
    n = radar.num_samples
    bins = np.array([1, 3, 8, 20, 60, 150, 200, 210, 220, 230, 245, 256 + 12, 256 + 40, 256 + 150])
    found = []
    for k in bins:
        echoes = tone(radar, on_bin(radar, k))
        raw = np.fft.fft(synthesize(echoes, radar, noise=False, method="direct")[0, 0, 0].astype(complex))
        filt = np.fft.fft(synthesize(echoes, chained, noise=False, method="direct")[0, 0, 0].astype(complex))
        found.append(filt[k % n] / raw[k % n])
    found = np.array(found)
    expected = h(bins * radar.fs / n)
    np.testing.assert_allclose(found, expected, rtol=1e-5, atol=1e-9)
    db = 20 * np.log10(np.abs(expected))
    assert db[0] < -20                       # 20 kHz: under both high-pass corners
    assert np.all(np.abs(db[5:7]) < 0.6)     # pass band, above the high-pass corners (ripple 0.5 dB)
    assert np.all(db[-3:] < -60)             # beyond F_s: 60 dB down where an ideal receiver aliases them whole
    # the same through the NUFFT with many contributions at once: one gain per contribution
    echoes = tone(radar, on_bin(radar, np.array([5.0, 40.3, 133.7, 251.2, 300.9])))
    fast = synthesize(echoes, chained, noise=False)
    slow = synthesize(echoes, chained, noise=False, method="direct")
    assert np.abs(fast - slow).max() < 1e-6 * np.abs(slow).max()


def test_if_chain_colours_the_noise_floor_as_its_aliased_power_response():
    """Noise only: the mean periodogram per bin is k T0 F (F_s / N) N sum_k |H(f + k F_s)|^2 of scipy's filter."""
    radar = single_element(AWR, num_chirps=512, if_filter=AWR.if_filter)
    cube = synthesize(tone(radar, on_bin(radar, 10), amplitude=0.0), radar, rng=9)[:, 0, 0, :]
    n = radar.num_samples
    power = (np.abs(np.fft.fft(cube.astype(np.complex128), axis=-1)) ** 2).mean(axis=0) / n
    h = independent_ti_chain(radar)
    f = np.arange(n) * radar.fs / n
    expected = radar.noise_power * sum(np.abs(h(f + k * radar.fs)) ** 2 for k in range(-4, 5))
    ratio = power / expected
    assert np.all(np.abs(np.log(ratio)) < 5 / math.sqrt(radar.num_chirps))          # every bin, 5 sigma
    assert abs(ratio.mean() - 1) < 5 / math.sqrt(radar.num_chirps * n)
    assert np.min(expected) < 1e-4 * radar.noise_power                               # the filter's notch is there
    assert noise_power(radar) == pytest.approx(np.mean(expected), rel=1e-3)


def test_steady_state_gain_leaves_out_at_most_the_stated_transient():
    """lsim of TI's high-pass pair driven by a tone switched on at the ramp start: at the ADC samples the
    output is H(f) e^{j 2 pi f t} up to if_filter.transient_bound (4.5e-4 of the tone at 7 us), and
    the bound is not vacuous (at 1 us the error is of its size)."""
    radar = AWR
    chain = ti.hpf_sections(0, 0)
    b, a = signal.zpk2tf(*[np.asarray(x) for x in if_filter.chain_zpk(chain, radar.fs)])
    for f in (0.3e6, 1e6, 3e6):
        t_end = radar.adc_start_time + 8 / radar.fs
        t = np.linspace(0.0, t_end, int(4000 * f * t_end) + 1)
        out = np.zeros(t.size, complex)
        for part, u in ((1.0, np.cos(2 * np.pi * f * t)), (1j, np.sin(2 * np.pi * f * t))):
            out += part * signal.lsim((b.real, a.real), u, t)[1]
        steady = if_filter.response(chain, f, radar.fs) * np.exp(2j * np.pi * f * t)
        error = np.abs(out - steady)
        for t_check in (radar.adc_start_time, 1e-6):
            i = np.searchsorted(t, t_check)
            bound = if_filter.transient_bound(chain, f, t[i], radar.fs)
            assert error[i] <= bound * 1.01 + 1e-5
            assert error[i] > 0.1 * bound
        assert if_filter.transient_bound(chain, f, radar.adc_start_time, radar.fs) < 1e-3


TABLE_CHAINS = {
    "ti": ti.if_chain(),
    "ti-hpf-3-3": ti.if_chain(3, 3),
    "butter-hp4+bessel-lp5": [{"kind": "butter", "type": "highpass", "order": 4, "corner": 2e5},
                              {"kind": "bessel", "type": "lowpass", "order": 5, "corner": 3e6}],
    "cheby1-lp6": [{"kind": "cheby1", "type": "lowpass", "order": 6, "corner_fs": 0.45, "ripple": 1.0}],
    "cheby2-hp3+shifted-ellip": [{"kind": "cheby2", "type": "highpass", "order": 3, "corner": 1e5, "attenuation": 40.0},
                                 {"kind": "ellip", "type": "lowpass", "order": 4, "corner_fs": 0.3, "centre_fs": 0.3,
                                  "ripple": 0.1, "attenuation": 50.0}],
}


@pytest.mark.parametrize("name", sorted(TABLE_CHAINS))
def test_tabulated_if_gain_is_within_its_bound_of_the_exact_response(name):
    """The table's gain (linear interpolation between exact nodes, if_filter.table_step) against the exact
    product over the chain's roots at 1e6 frequencies from -0.5 F_s to 1.6 F_s: within TABLE_TOLERANCE, and
    the derivation's curvature bound M2 above the second derivative found numerically on a 2 Hz grid."""
    fs = AWR.fs
    chain = if_filter.check_chain(TABLE_CHAINS[name])
    f = np.random.default_rng(3).uniform(-0.5 * fs, 1.6 * fs, 1_000_000)
    step = if_filter.table_step(chain, fs)
    assert step is not None and step > 10.0
    error = np.abs(if_filter.tabulated_response(chain, f, fs) - if_filter.response(chain, f, fs))
    assert error.max() <= if_filter.TABLE_TOLERANCE
    assert error.max() > 1e-3 * if_filter.TABLE_TOLERANCE      # it does interpolate (not the exact path)
    # the bound's premise: |d2H/dw2| <= M2 = 8 eps / (2 pi step)^2 everywhere on the axis
    m2 = 8 * if_filter.TABLE_TOLERANCE / (2 * np.pi * step) ** 2
    h = 2.0
    grid = np.arange(-0.5 * fs, 1.6 * fs, h)
    values = if_filter.response(chain, grid, fs)
    second = np.abs(values[2:] - 2 * values[1:-1] + values[:-2]) / (2 * np.pi * h) ** 2
    assert second.max() <= m2
    assert second.max() > 1e-3 * m2


def test_tabulated_if_gain_is_exact_where_its_bound_does_not_apply_and_per_frequency():
    """Repeated poles (two equal sections): no table, the exact response bit for bit; a few frequencies: the
    exact response; and a frequency's tabulated gain does not depend on the other frequencies asked with it."""
    fs = AWR.fs
    twice = if_filter.check_chain(ti.hpf_sections(0, 0)[:1] * 2)
    f = np.linspace(0.0, fs, 1001)
    assert if_filter.table_step(twice, fs) is None
    assert np.array_equal(if_filter.tabulated_response(twice, f, fs), if_filter.response(twice, f, fs))
    chain = ti.if_chain()
    few = f[:3]
    assert np.array_equal(if_filter.tabulated_response(chain, few, fs), if_filter.response(chain, few, fs))
    many = np.random.default_rng(5).uniform(0.0, fs, 100_000)
    whole = if_filter.tabulated_response(chain, many, fs)
    part = if_filter.tabulated_response(chain, np.concatenate([many[:40_000], [0.9 * fs] * 20_000]), fs)
    assert np.array_equal(whole[:40_000], part[:40_000])


def test_if_filter_spec_errors_name_the_section_and_field():
    good = ti.if_chain()
    for bad, match in (
        ([{**good[0], "kind": "chebyshev"}], r"if_filter\[0\]\.kind"),
        ([{**good[0], "order": 0}], r"if_filter\[0\]\.order"),
        ([{k: v for k, v in good[2].items() if k != "attenuation"}], r"needs attenuation"),
        ([{**good[0], "corner_fs": 0.1}], "exactly one of corner"),
        ([{**good[0], "centre": 1e5}], "only a lowpass"),
        ([{**good[0], "bandwidth": 1}], "unknown field"),
        ("butter", "must be a list"),
        ([good[2], good[2]], "at most one lowpass"),
        ([{**good[0], "corner": 175e9}], "beyond 50 F_s"),
    ):
        with pytest.raises(RadarConfigError, match=match):
            AWR.replace(if_filter=bad)


# ============================================================================ ADC and I/Q imbalance
def test_adc_quantisation_error_is_uniform_and_clipping_is_counted():
    """10-bit ADC: |error| <= step/2 on every I and Q, error power step^2/12 (a tone spanning many steps);
    an overdriven tone clips exactly the I/Q values beyond full scale, counted and warned about."""
    radar = single_element(WALK, num_chirps=64, adc_bits=10, rx_gain=30.0, adc_full_scale=1e-3)
    full = math.sqrt(1e-3) / 10 ** (30 / 20) / math.sqrt(radar.tx_power)    # echo amplitude of a full-scale tone
    echoes = tone(radar, on_bin(radar, 37.3), amplitude=0.6 * full)
    ideal = synthesize(echoes, radar.replace(adc_bits=None), noise=False).astype(np.complex128)
    stats = {}
    quantised = synthesize(echoes, radar, noise=False, stats=stats)
    assert stats == {"adc_clipped": 0, "adc_values": 2 * ideal.size}
    step = adc.step(radar)
    assert step == pytest.approx(2 ** 6 / adc.words_per_sqrt_watt(radar))
    error = quantised - ideal
    for part in (error.real, error.imag):
        assert np.abs(part).max() <= step / 2 * (1 + 1e-6)
        assert np.mean(part ** 2) == pytest.approx(step ** 2 / 12, rel=5 / math.sqrt(part.size / 10))
    loud = tone(radar, on_bin(radar, 37.3), amplitude=1.5 * full)
    ideal = synthesize(loud, radar.replace(adc_bits=None), noise=False).astype(np.complex128)
    top = 2 ** 9 * step
    codes = np.rint(np.stack([ideal.real, ideal.imag]) / step)
    expected = int(np.count_nonzero((codes > 2 ** 9 - 1) | (codes < -2 ** 9)))
    stats = {}
    with pytest.warns(AdcClippingWarning, match="clipped"):
        clipped = synthesize(loud, radar, noise=False, stats=stats)
    assert stats["adc_clipped"] == expected > 0
    assert clipped.real.max() == pytest.approx(top - step) and clipped.real.min() == pytest.approx(-top)


def test_sixteen_bit_cube_exports_word_for_word_on_the_radars_own_scale(tmp_path):
    """The preset's 16-bit ADC and the DCA1000 export share one scale: the capture holds the cube's words
    exactly and clips nothing more, even when the ADC in the cube clipped."""
    radar = AWR.replace(phase_noise=None)
    echoes = Echoes.point_targets(radar, [0.6, 3.0], [0.0, 1.0], [0.0, 0.2], rcs=[300.0, 1.0])  # a loud near target
    with pytest.warns(AdcClippingWarning):
        cube = synthesize(echoes, radar, rng=1)
    report = write_dca1000(cube, radar, tmp_path / "cap")
    assert report.clipped == 0
    words = read_dca1000(tmp_path / "cap")[0]
    c = adc.words_per_sqrt_watt(radar)
    np.testing.assert_array_equal(words, (cube.astype(np.complex128) * c).round().astype(np.complex64))
    assert np.abs(cube.real * c - np.rint(cube.real * c)).max() < 1e-2
    assert words.real.max() == 32767 or words.real.min() == -32768


def test_iq_imbalance_image_at_the_closed_form_rejection_ratio():
    spec = {"gain_db": 0.5, "phase_deg": 3.0}
    radar = single_element(WALK, num_chirps=2, iq_imbalance=spec)
    k = 23
    cube = synthesize(tone(radar, on_bin(radar, k)), radar, noise=False, method="direct")[0, 0, 0]
    spectrum = np.abs(np.fft.fft(cube.astype(np.complex128))) ** 2
    n = radar.num_samples
    measured = 10 * np.log10(spectrum[k] / spectrum[n - k])
    assert measured == pytest.approx(10 * np.log10(iq_imbalance.image_rejection_ratio(spec)), abs=1e-3)
    assert measured == pytest.approx(28.2, abs=0.05)
    with pytest.raises(RadarConfigError, match="iq_imbalance"):
        WALK.replace(iq_imbalance={"gain_db": 0.5})
    with pytest.raises(RadarConfigError, match="phase_deg"):
        WALK.replace(iq_imbalance={"gain_db": 0.5, "phase_deg": 95.0})


# ============================================================================ configuration
def test_receiver_fields_round_trip_and_old_dicts_still_load():
    for name in RadarConfig.presets():
        radar = RadarConfig.preset(name)
        assert RadarConfig.from_json(radar.to_json()) == radar
    old = WALK.to_dict()
    for key in ("phase_noise", "if_filter", "adc_bits", "adc_full_scale", "rx_gain", "iq_imbalance"):
        del old[key]
    assert RadarConfig.from_dict(old) == WALK                  # a run store written before these fields
    d = AWR.to_dict()
    d["if_filter"][0]["corner"] = 1.0                          # the dict never aliases the radar
    assert AWR.if_filter[0]["corner"] == 175e3
    for field, value, match in (("adc_bits", 17, "adc_bits"), ("adc_bits", 10.5, "adc_bits"),
                                ("adc_full_scale", 0.0, "adc_full_scale"), ("rx_gain", float("inf"), "rx_gain")):
        with pytest.raises(RadarConfigError, match=match):
            WALK.replace(**{field: value})


def test_defaults_off_for_walk_and_custom_on_for_ti_presets():
    assert summary(WALK) == {"phase_noise_1mhz_dbc_hz": None, "highpass_corners_hz": None, "lowpass_passband_hz": None,
                             "adc_bits": None, "iq_imbalance": None, "antenna_pattern": "tr38901"}
    for name in ("ti-awr1843boost", "ti-iwr6843isk", "ti-iwr1443boost"):
        s = summary(RadarConfig.preset(name))
        assert s["phase_noise_1mhz_dbc_hz"] == -93.0
        assert s["highpass_corners_hz"] == [175e3, 350e3]
        assert s["lowpass_passband_hz"] == pytest.approx([0.0, 0.8 * 5.209e6])
        assert s["adc_bits"] == 16 and s["antenna_pattern"] == name


def test_ti_cfg_carries_the_hpf_corners_and_rx_gain():
    from sionnafmcw.ti.cfg import TiCfgError, read_ti_cfg, write_ti_cfg

    radar = AWR.replace(if_filter=ti.if_chain(2, 3), rx_gain=36.0)
    text = write_ti_cfg(radar)
    assert "profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 2 3 36" in text
    back = read_ti_cfg(text)
    assert back == radar and back.if_filter[1]["corner"] == 2.8e6
    isk = read_ti_cfg(write_ti_cfg(RadarConfig.preset("ti-iwr6843isk")).replace(" 0 0 30\n", " 0 0 158\n"))
    assert isk.rx_gain == 30.0                                   # 158: RF gain target in bits 7:6, 30 dB
    with pytest.raises(TiCfgError, match="not TI's HPF1/HPF2 pair"):
        write_ti_cfg(AWR.replace(if_filter=[{**ti.hpf_sections()[0], "corner": 200e3}, ti.hpf_sections()[1]]))
    with pytest.raises(TiCfgError, match="hpfCornerFreq1 code 5"):
        read_ti_cfg(text.replace(" 2 3 36", " 5 3 36"))
    with pytest.raises(TiCfgError, match="adc_bits=12"):
        write_ti_cfg(AWR.replace(adc_bits=12))
    assert json.loads(json.dumps(back.to_dict()))["if_filter"] == back.if_filter


def test_static_block_cache_carries_the_filtered_and_delay_weighted_cubes():
    """With the TI receiver (IF chain, phase noise) a frame with a cached static block equals the frame
    synthesised whole (same seed): the static cube is filtered once and keeps its delay-weighted twin."""
    radar = AWR.replace(num_chirps=8, adc_bits=None)
    rng = np.random.default_rng(4)
    n = 60
    static = Echoes.point_targets(radar, rng.uniform(0.5, 10, n), np.zeros(n), np.deg2rad(rng.uniform(-60, 60, n)))
    static = Echoes(static.a, static.tau, static.doppler, static_count=n, static_key="room")
    movers = Echoes.point_targets(radar, [2.0, 4.0], [1.0, -0.5], [0.1, -0.2])
    whole = Echoes.concatenate([Echoes(static.a, static.tau, static.doppler), movers])
    cache = {}
    for seed in (1, 2):                     # the second frame reuses the cached static cubes
        cached = synthesize(Echoes.concatenate([static, movers]), radar, rng=seed, static_cache=cache)
        plain = synthesize(whole, radar, rng=seed)
        assert np.abs(cached - plain).max() < 1e-4 * np.abs(plain).max()
        entry = cache["room"]
        assert entry[3] is not None and entry[0] == radar


def test_cached_static_block_goes_through_the_if_chain_once(monkeypatch):
    """The IF chain's gain depends on each contribution alone, so the static block is filtered when its
    cube is computed and never again: a frame that reuses the cached cube filters its own contributions only."""
    import sionnafmcw.receiver as receiver

    radar = AWR.replace(num_chirps=8, adc_bits=None)
    rng = np.random.default_rng(5)
    n = 50
    static = Echoes.point_targets(radar, rng.uniform(0.5, 10, n), np.zeros(n), np.deg2rad(rng.uniform(-60, 60, n)))
    static = Echoes(static.a, static.tau, static.doppler, static_count=n, static_key="room")
    movers = Echoes.point_targets(radar, [2.0, 4.0, 6.0], [1.0, -0.5, 0.3], [0.1, -0.2, 0.0])
    filtered = []
    beat_frequency = receiver.beat_frequency
    monkeypatch.setattr(receiver, "beat_frequency",
                        lambda e, r: filtered.append(e.num_contributions) or beat_frequency(e, r))
    cache = {}
    synthesize(Echoes.concatenate([static, movers]), radar, rng=1, static_cache=cache)
    first = sum(filtered)
    filtered.clear()
    synthesize(Echoes.concatenate([static, movers]), radar, rng=2, static_cache=cache)
    assert first == n + 3                       # the first frame: the block and the movers
    assert sum(filtered) == 3                   # then the movers only
