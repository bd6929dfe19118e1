"""Tests of sionnafmcw.processing on cubes built from the closed-form beat model.

The cubes are NOT made by the synthesizer: :func:`beat_cube` evaluates the beat model of
:mod:`sionnafmcw.synthesis` directly, with exact per-element delays of moving point targets,

    x[l, m, n, k] = A exp(j 2 pi (f_c tau + mu tau t_k - mu tau^2 / 2)),
    tau = (|p(t) - tx_m| + |p(t) - rx_n|) / c,   p(t) = (R0 + v t) u(az, el),

with t the absolute time of sample k of chirp l of Tx m (TDM slot included) and t_k the fast time,
so that processing and synthesis are checked against the same physics independently.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from sionnafmcw import SPEED_OF_LIGHT as C
from sionnafmcw import RadarConfig, array
from sionnafmcw.echoes import target_direction
import sionnafmcw.processing as sp

WALK = RadarConfig.preset("walk-77ghz")  # 3 Tx x 4 Rx ULA, 256 chirps x 128 samples
TI = RadarConfig.preset("ti-awr1843boost")  # TI layout: Tx1 raised by lambda/2 (elevation aperture)

# no shrinking: a failing example is printed as found, and shrinking 0.1-s cubes takes minutes
SETTINGS = settings(max_examples=8, deadline=None,
                    phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.target])


def beat_cube(radar, targets, noise_std=0.0, seed=0, start_time=0.0):
    """Closed-form TDM-MIMO beat cube ``[chirp, tx, rx, sample]`` (complex64) of point targets.

    ``targets``: dicts with ``range`` (m at t=0), ``velocity`` (m/s, radial, + receding),
    ``azimuth``, ``elevation`` (rad), ``amplitude`` (complex). ``start_time`` is the CPI start
    (the targets keep moving between frames). ``noise_std``: complex white Gaussian noise std.
    """
    L, M, N, K = radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples
    t_fast = radar.adc_start_time + np.arange(K) / radar.fs
    t = start_time + radar.chirp_start_times()[:, :, None, None] + t_fast  # [L, M, 1, K]
    tx = radar.tx_positions[None, :, None, None, :]
    rx = radar.rx_positions[None, None, :, None, :]
    cube = np.zeros((L, M, N, K), complex)
    for tg in targets:
        u = target_direction(tg.get("azimuth", 0.0), tg.get("elevation", 0.0))
        p = (tg["range"] + tg.get("velocity", 0.0) * t[..., None]) * u
        tau = (np.linalg.norm(p - tx, axis=-1) + np.linalg.norm(p - rx, axis=-1)) / C
        phase = 2 * np.pi * (radar.fc * tau + radar.slope * tau * t_fast - radar.slope * tau**2 / 2)
        cube += tg.get("amplitude", 1.0) * np.exp(1j * phase)
    if noise_std:
        rng = np.random.default_rng(seed)
        cube += noise_std / np.sqrt(2) * (rng.standard_normal(cube.shape) + 1j * rng.standard_normal(cube.shape))
    return cube.astype(np.complex64)


def peak_time(radar):
    """Time the range-Doppler peak refers to: the periodic-Hann centre chirp L/2, ADC centre."""
    return (radar.num_chirps // 2) * radar.block_interval + radar.adc_centre_time


def true_range(radar, R0, v=0.0, az=0.0, el=0.0, t=0.0):
    """Range of the target at time t from the array phase centre (mean of tx_m + rx_n over 2)."""
    centre = (radar.tx_positions.mean(axis=0) + radar.rx_positions.mean(axis=0)) / 2
    return float(np.linalg.norm((R0 + v * t) * target_direction(az, el) - centre))


def rd_peak(cube, radar, **kw):
    """Interpolated (velocity, range, doppler index, range index) of the strongest map cell."""
    rdm = sp.range_doppler_map(cube, radar, **kw)
    i, k = rdm.peak()
    fi = sp.interpolate_peak(rdm.power, (i, k), axis=0, circular=True)
    fk = sp.interpolate_peak(rdm.power, (i, k), axis=1)
    return float(sp.uniform_axis_value(rdm.velocities, fi)), float(sp.uniform_axis_value(rdm.ranges, fk)), i, k


def fft_azimuth(snapshot, radar, n_fft=1024):
    """Azimuth (rad) of the angle-FFT peak of one ``[tx, rx]`` snapshot, interpolated in sin-space."""
    a = sp.angle_fft(snapshot, radar, n_fft=n_fft, tx_axis=0)
    q = int(np.argmax(np.abs(a.spectrum)))
    u = sp.uniform_axis_value(a.sin_azimuth, sp.interpolate_peak(a.spectrum, (q,), axis=0))
    return float(np.arcsin(np.clip(u, -1, 1)))


angles = st.floats(-50.0, 50.0).map(np.deg2rad)
phases = st.floats(0.0, 2 * np.pi).map(lambda p: np.exp(1j * p))


# ---------------------------------------------------------------------------------------- axes
def test_axes_and_virtual_array():
    r = sp.range_axis(WALK)
    assert r[0] == 0 and np.isclose(r[1], WALK.range_resolution) and r[-1] < WALK.max_range
    assert np.isclose(sp.range_axis(WALK, 512)[4], WALK.range_resolution)  # zero padding: 4 bins per bin
    v = sp.velocity_axis(WALK)
    assert v[WALK.num_chirps // 2] == 0 and np.isclose(v[1] - v[0], WALK.velocity_resolution)
    assert np.isclose(v[0], -WALK.max_velocity)
    p = array.virtual_array(TI)
    assert p.shape == (12, 3) and np.allclose(p[1 * 4 + 2], TI.tx_positions[1] + TI.rx_positions[2])
    idx, d = array.uniform_azimuth_row(TI)  # z = 0 row: TX0 and TX2 -> 8 elements lambda/2 apart
    assert len(idx) == 8 and np.allclose(p[idx, 2], 0) and np.isclose(d, TI.rx_positions[1, 1] - TI.rx_positions[0, 1])
    assert np.allclose(array.phase_centre(TI), p.mean(axis=0) / 2)
    assert len(array.uniform_azimuth_row(WALK)[0]) == 12
    assert array.has_elevation_aperture(TI) and not array.has_elevation_aperture(WALK)


def test_window_normalisation_and_jacobsen():
    n, k0 = 128, 20.3
    x = 0.7 * np.exp(2j * np.pi * k0 * np.arange(n) / n)
    for window in ("hann", None):
        X = sp.range_fft(x, window=window, n_fft=4 * n)
        assert abs(np.abs(X).max() - 0.7) < 0.7 * 0.01  # unit-sum window: amplitude kept (4x padding)
    X = sp.range_fft(x, window="hann")
    k = int(np.argmax(np.abs(X)))
    assert abs(sp.interpolate_peak(X, (k,), method="jacobsen", window="hann") - k0) < 1e-6  # exact for Hann
    assert abs(sp.interpolate_peak(np.abs(X) ** 2, (k,)) - k0) < 0.02  # log-parabolic, Hann bias < 0.016 bin


# ------------------------------------------------------------------------- range and velocity
@SETTINGS
@given(R0=st.floats(1.5, 10.0), v=st.floats(-8.5, 8.5), az=angles, amp=phases)
def test_range_velocity_within_a_tenth_of_a_bin(R0, v, az, amp):
    # Tolerance 0.1 bin (9.8 mm, 7.1 mm/s): the log-parabolic interpolation on a Hann-windowed
    # spectrum is biased by at most 0.016 bin; the noise here (per-cell SNR > 60 dB) adds
    # ~1e-3 bin; range migration over the CPI (up to 0.23 m = 2.3 bins at 8.5 m/s) blurs the range
    # peak symmetrically about the CPI centre. Measured worst case over 60 random draws of this
    # domain: 0.016 bin in velocity and 0.017 bin in range (150 hypothesis examples pass). The expected
    # range is the range at the peak time, from the array phase centre (the Rx row sits 2-3 cm
    # beside the Tx row: up to 0.1 bin), plus the range-Doppler coupling (up to 0.11 bin).
    cube = beat_cube(WALK, [dict(range=R0, velocity=v, azimuth=az, amplitude=amp)], noise_std=0.05)
    vel, rng, _, _ = rd_peak(cube, WALK)
    assert abs(vel - v) < 0.1 * WALK.velocity_resolution
    geometric = true_range(WALK, R0, v, az, t=peak_time(WALK))
    expected = geometric + sp.range_doppler_coupling(v, WALK)
    assert abs(rng - expected) < 0.1 * WALK.range_resolution
    # the coupling correction matters: without it a fast target is farther off
    if abs(v) > 3.0:
        assert abs(rng - geometric) > abs(rng - expected)


# ---------------------------------------------------------------------------------- azimuth
@SETTINGS
@given(R0=st.floats(2.0, 10.0), v=st.floats(-8.5, 8.5), az=angles, amp=phases)
def test_azimuth_fft_and_bartlett_within_one_degree(R0, v, az, amp):
    cube = beat_cube(WALK, [dict(range=R0, velocity=v, azimuth=az, amplitude=amp)], noise_std=0.05)
    vel, _, i, k = rd_peak(cube, WALK)
    rd = sp.range_doppler(cube, WALK)
    snap = sp.tdm_phase_compensation(rd[i, :, :, k], WALK, vel, tx_axis=0)
    assert abs(np.rad2deg(fft_azimuth(snap, WALK) - az)) < 1.0
    a_b, e_b, _ = sp.estimate_direction(sp.virtual_channels(snap, 0), WALK)
    assert e_b is None and abs(np.rad2deg(a_b - az)) < 1.0
    grid = np.deg2rad(np.arange(-90, 90.01, 0.25))
    p = sp.bartlett_spectrum(sp.virtual_channels(snap, 0), WALK, grid)
    assert abs(np.rad2deg(grid[np.argmax(p)] - az)) < 1.0


@SETTINGS
@given(v=st.floats(5.0, 8.5), sign=st.sampled_from([-1.0, 1.0]), az=st.floats(-40.0, 40.0).map(np.deg2rad))
def test_tdm_phase_compensation_fixes_fast_target_azimuth(v, sign, az):
    # Slot q of 3 transmits q*35 us later: at 5 m/s the uncompensated phase step between Tx groups
    # is 4 pi v T_c / lambda = 0.57 rad, which tilts the 12-element ULA by >= 2 degrees.
    v = sign * v
    cube = beat_cube(WALK, [dict(range=4.0, velocity=v, azimuth=az)], noise_std=0.05)
    vel, _, i, k = rd_peak(cube, WALK)
    rd = sp.range_doppler(cube, WALK)
    raw = rd[i, :, :, k]
    err_raw = abs(np.rad2deg(fft_azimuth(raw, WALK) - az))
    comp = sp.tdm_phase_compensation(rd, WALK, sp.velocity_axis(WALK))[i, :, :, k]  # per-bin velocity
    err_comp = abs(np.rad2deg(fft_azimuth(comp, WALK) - az))
    assert err_comp < 1.0
    assert err_raw > 1.0


@SETTINGS
@given(az=angles, amp=phases)
def test_bartlett_and_angle_fft_on_ti_layout(az, amp):
    # Raised Tx1: the angle FFT uses the 8-element z=0 row, Bartlett all 12 exact positions.
    cube = beat_cube(TI, [dict(range=3.0, velocity=0.4, azimuth=az, amplitude=amp)], noise_std=0.01)
    vel, _, i, k = rd_peak(cube, TI)
    snap = sp.tdm_phase_compensation(sp.range_doppler(cube, TI)[i, :, :, k], TI, vel, tx_axis=0)
    assert abs(np.rad2deg(fft_azimuth(snap, TI) - az)) < 1.0
    grid = np.deg2rad(np.arange(-90, 90.01, 0.25))
    p = sp.bartlett_spectrum(sp.virtual_channels(snap, 0), TI, grid)
    assert abs(np.rad2deg(grid[np.argmax(p)] - az)) < 1.0


def test_range_azimuth_map_peak():
    az = np.deg2rad(-30.0)
    cube = beat_cube(WALK, [dict(range=5.0, velocity=2.0, azimuth=az), dict(range=3.0, amplitude=5.0)],
                     noise_std=0.05)  # strong static target removed by clutter removal
    for method in ("fft", "bartlett"):
        ram = sp.range_azimuth_map(cube, WALK, method=method)
        r, a = np.unravel_index(np.argmax(ram.power), ram.power.shape)
        assert abs(ram.ranges[r] - true_range(WALK, 5.0, 2.0, az, t=peak_time(WALK))) < WALK.range_resolution
        assert abs(np.rad2deg(ram.azimuths[a] - az)) < 1.0
        assert np.all(np.diff(ram.azimuths) > 0)


# ------------------------------------------------------------------------------- resolution
def _two_targets(rel_phase):
    """Two static targets one range resolution apart at boresight, relative phase ``rel_phase`` at the ADC centre."""
    R1 = 5.0
    R2 = R1 + WALK.range_resolution
    t_mid = WALK.adc_centre_time

    def phase(R):  # beat phase of element pair (0, 0) at the ADC window centre
        tau = (np.linalg.norm(R * np.array([1.0, 0, 0]) - WALK.tx_positions[0])
               + np.linalg.norm(R * np.array([1.0, 0, 0]) - WALK.rx_positions[0])) / C
        return 2 * np.pi * (WALK.fc * tau + WALK.slope * tau * t_mid - WALK.slope * tau**2 / 2)

    a2 = np.exp(1j * (rel_phase - (phase(R2) - phase(R1))))
    cube = beat_cube(WALK, [dict(range=R1), dict(range=R2, amplitude=a2)], noise_std=0.01)
    rdm = sp.range_doppler_map(cube, WALK, window_range=None, n_range=8 * WALK.num_samples)
    profile = rdm.power[rdm.peak()[0]]
    peaks = np.flatnonzero((profile[1:-1] > profile[:-2]) & (profile[1:-1] >= profile[2:])) + 1
    peaks = peaks[profile[peaks] > 0.25 * profile.max()]
    return rdm.ranges[peaks], (R1, R2)


@SETTINGS
@given(rel=st.floats(np.deg2rad(100), np.deg2rad(260)))
def test_two_targets_one_range_bin_apart_are_resolved(rel):
    # Rayleigh spacing (one bin, c/2B) is resolvable only with the rectangular window (Hann's main
    # lobe is twice as wide) and, for two equal targets, only when they are not nearly in phase:
    # the mid-point sum |1 + e^{j phi}|^2 (2/pi)^2 dips below the peaks for cos(phi) < 0.23.
    found, (R1, R2) = _two_targets(rel)
    assert len(found) == 2
    assert abs(found[0] - R1) < 0.5 * WALK.range_resolution and abs(found[1] - R2) < 0.5 * WALK.range_resolution


def test_two_targets_in_phase_merge():
    # the counter-case of the test above: in phase, Rayleigh-spaced targets form one peak
    found, _ = _two_targets(0.0)
    assert len(found) == 1


# -------------------------------------------------------------------------------------- CFAR
@pytest.mark.parametrize("guard, train", [((2, 2), (4, 8)), ((1, 1), (1, 2))])
@pytest.mark.parametrize("kind", ["ca", "os"])
def test_cfar_false_alarm_rate_on_white_noise(kind, guard, train):
    # Complex white Gaussian noise -> exponential power: both detectors have an exact Pfa per cell.
    # The count over n cells is close to binomial (60 Monte-Carlo maps of 256x512 with the large
    # footprint gave std 11.4 against the binomial 11.4); we allow 5 binomial sigmas inflated by
    # 1.3 for the correlation between neighbouring decisions: a false test failure has probability
    # < 1e-4. The small footprint (N = 12) shows that the factor alpha matters: the fixed-noise
    # threshold -ln(Pfa) would give 4.3x the false alarms there.
    pfa = 1e-3
    rng = np.random.default_rng(1234 + len(kind) + sum(train))
    n_maps = 4 if kind == "ca" else 2
    count = cells = 0
    for _ in range(n_maps):
        z = rng.standard_normal((256, 512)) + 1j * rng.standard_normal((256, 512))
        p = np.abs(z) ** 2 / 2
        res = (sp.ca_cfar_2d if kind == "ca" else sp.os_cfar_2d)(p, guard=guard, train=train, pfa=pfa)
        count += int(res.detections.sum())
        cells += p.size
        assert abs(res.noise.mean() - 1.0) < 0.02  # unbiased noise estimate (unit noise power)
    expected = cells * pfa
    sigma = 1.3 * np.sqrt(cells * pfa * (1 - pfa))
    assert abs(count - expected) < 5 * sigma, (count, expected)
    if res.num_train == 12:
        assert res.factor > 1.3 * -np.log(pfa)


def test_cfar_factors():
    assert np.isclose(sp.ca_cfar_factor(16, 1e-4), 16 * (1e-4 ** (-1 / 16) - 1))
    n, k, pfa = 24, 18, 1e-4
    alpha = sp.os_cfar_factor(n, k, pfa)
    assert np.isclose(np.prod([(n - i) / (n - i + alpha) for i in range(k)]), pfa, rtol=1e-9)


@pytest.mark.parametrize("kind", ["ca", "os"])
def test_cfar_detects_strong_target(kind):
    cube = beat_cube(WALK, [dict(range=6.0, velocity=-1.5, azimuth=0.3, amplitude=0.1)], noise_std=1.0, seed=3)
    rdm = sp.range_doppler_map(cube, WALK)
    f = sp.ca_cfar_2d if kind == "ca" else sp.os_cfar_2d
    res = f(rdm.power, guard=(2, 2), train=(4, 8), pfa=1e-6)
    i = np.argmin(np.abs(rdm.velocities + 1.5))
    k = np.argmin(np.abs(rdm.ranges - 6.0 + 1.5 * peak_time(WALK)))
    assert res.detections[i - 1:i + 2, k - 1:k + 2].any()
    peaks = res.detections & sp.local_maxima(rdm.power)
    assert peaks.sum() <= 3  # the target (plus at most a stray sidelobe/noise peak)


# --------------------------------------------------------------------------- time series
@pytest.mark.parametrize("v", [-2.0, 2.5])
def test_doppler_time_sign_and_value(v):
    # strong static reflector (wall) + weaker mover: the paper's estimator needs clutter removal
    times = np.arange(3) / 24.0
    frames = np.stack([beat_cube(WALK, [dict(range=2.0, amplitude=10.0),
                                        dict(range=5.0, velocity=v, azimuth=0.2, amplitude=0.5)],
                                 noise_std=0.05, seed=j, start_time=t) for j, t in enumerate(times)])
    track = sp.doppler_time(frames, WALK)
    assert np.all(np.sign(track.velocities) == np.sign(v))
    assert np.all(np.abs(track.velocities - v) < 0.1 * WALK.velocity_resolution)
    expected = [true_range(WALK, 5.0, v, 0.2, t=t + peak_time(WALK)) + sp.range_doppler_coupling(v, WALK)
                for t in times]
    assert np.all(np.abs(track.ranges - expected) < 0.1 * WALK.range_resolution)
    static = sp.doppler_time(iter(frames), WALK, clutter_removal=False)  # iterable input
    assert np.all(np.abs(static.velocities) < WALK.velocity_resolution)  # the wall wins


def test_micro_doppler_spectrogram_peaks_at_target_velocity():
    times = np.arange(3) / 24.0
    speeds = [-3.0, 1.0, 4.0]
    frames = np.stack([beat_cube(WALK, [dict(range=2.0, amplitude=10.0), dict(range=4.0, velocity=s, amplitude=0.5)],
                                 noise_std=0.05, seed=j, start_time=t)
                       for j, (s, t) in enumerate(zip(speeds, times))])
    W, H = 64, 32
    spec = sp.micro_doppler_spectrogram(frames, WALK, times, range_gate=(3.0, 6.0), window_chirps=W, hop=H)
    per_frame = (WALK.num_chirps - W) // H + 1
    assert spec.power.shape == (W, 3 * per_frame) and spec.times.shape == (3 * per_frame,)
    assert np.all(np.diff(spec.times) > 0)
    bin_w = WALK.centre_wavelength / (2 * W * WALK.block_interval)
    assert np.isclose(spec.velocities[1] - spec.velocities[0], bin_w)
    truth = np.repeat(speeds, per_frame)
    assert np.all(np.abs(spec.peak_velocities() - truth) <= 0.5 * bin_w + 1e-9)  # nearest bin
    # column times: window centres inside each CPI
    first = spec.times[:per_frame]
    assert np.isclose(first[0], (W // 2) * WALK.block_interval) and first[-1] < WALK.cpi_duration
    whole = sp.micro_doppler_spectrogram(frames, WALK, times, range_gate=(3.0, 6.0))
    assert whole.power.shape == (WALK.num_chirps, 3)
    assert np.allclose(whole.times, times + (WALK.num_chirps // 2) * WALK.block_interval)
    assert np.all(np.abs(whole.peak_velocities() - speeds) <= 0.5 * WALK.velocity_resolution + 1e-9)


# ------------------------------------------------------------------------------ point cloud
def test_point_cloud_walk_preset():
    targets = [dict(range=3.0, velocity=-2.0, azimuth=np.deg2rad(-20), amplitude=0.2),
               dict(range=7.0, velocity=4.0, azimuth=np.deg2rad(35), amplitude=0.2),
               dict(range=2.0, amplitude=5.0)]  # static: removed
    cube = beat_cube(WALK, targets, noise_std=0.5, seed=7)
    pc = sp.detections_to_point_cloud(cube, WALK, pfa=1e-6)
    assert pc.elevation is None
    assert 2 <= len(pc) <= 4
    t_c = peak_time(WALK)
    for tg in targets[:2]:
        j = int(np.argmin(np.abs(pc.velocity - tg["velocity"])))
        R = tg["range"] + tg["velocity"] * t_c  # from the radar origin
        assert abs(pc.velocity[j] - tg["velocity"]) < 0.1 * WALK.velocity_resolution
        # coupling corrected, from the phase centre
        assert abs(pc.range[j] - true_range(WALK, R, az=tg["azimuth"])) < 0.1 * WALK.range_resolution
        assert abs(np.rad2deg(pc.azimuth[j] - tg["azimuth"])) < 1.0
        # 0.1 bin in range and 1 degree at 7 m: < 0.13 m; measured ~1 cm
        assert np.linalg.norm(pc.positions[j] - R * target_direction(tg["azimuth"], 0.0)) < 0.03
        assert pc.snr[j] > 20


def test_point_cloud_elevation_on_ti_layout():
    az, el = np.deg2rad(20.0), np.deg2rad(15.0)
    cube = beat_cube(TI, [dict(range=4.0, velocity=0.5, azimuth=az, elevation=el, amplitude=0.2)], noise_std=0.05)
    pc = sp.detections_to_point_cloud(cube, TI, cfar="os", guard=(1, 2), train=(3, 8), pfa=1e-5)
    assert pc.elevation is not None and len(pc) >= 1
    j = int(np.argmax(pc.power))
    assert abs(np.rad2deg(pc.azimuth[j] - az)) < 1.0
    assert abs(np.rad2deg(pc.elevation[j] - el)) < 2.0
    assert pc.z[j] > 0.8
