"""The TI out-of-box demo's on-chip chain (sionnafmcw.ti.oob) on real synthesised cubes, both SDK
generations: points on the SDK's grid where the geometry puts them, the fixed-point peak value the
radar equation predicts, Doppler bins, the CFAR rule, peak grouping, multi-object beamforming, FOV
lines, and run stores that keep their radar's .cfg."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw import Echoes, synthesize
from sionnafmcw.ti.cfg import BOARDS, TiCfgError, board_for_radar, parse_ti_cfg, read_ti_cfg
from sionnafmcw.ti.oob import (ANGLE_FFT_SIZE, AZIMUTH_HWA_GAIN, blackman_q17, detect, hanning_q17, run_point_clouds)
from sionnafmcw.ti.processing import CfarConfig, processing_from_cfg

from test_ti_cfg import PROFILE_3D_18XX

RADHAR_CFG = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "radhar" / "1443es1_short_range_3d.cfg"
if not RADHAR_CFG.exists():
    RADHAR_CFG = Path("/work/shared/realdata/radhar/1443es1_short_range_3d.cfg")
RADHAR_TEXT = RADHAR_CFG.read_text() if RADHAR_CFG.exists() else None

#: SDK 2.x: RadHAR's IWR1443 .cfg with the CFAR line of the SDK 2.1 xWR14xx demo profiles
#: (``cfarCfg 0 2 8 4 3 0 1280``: 15 dB over the noise cells' mean; RadHAR's own line compares with
#: half that mean, see test_radhar_cfar_line_compares_with_half_the_noise_mean).
SDK2_TEXT = RADHAR_TEXT.replace("cfarCfg 0 2 8 4 4 0 4000", "cfarCfg 0 2 8 4 3 0 1280") if RADHAR_TEXT else None

GENERATIONS = {
    2: lambda: SDK2_TEXT,        # SDK 2.x: RadHAR's IWR1443 .cfg (TI's threshold)
    3: lambda: PROFILE_3D_18XX,  # SDK 3.x: the xWR18xx demo's profile_3d.cfg
}


#: Reflector RCS (m^2) per generation: small enough for SDK 2.x's azimuth magnitude (peakVal
#: ~300 at 2-3 m, far from its 32767 limit), SDK 3.x compares float powers.
RCS = {2: 0.01, 3: 1.0}


def setup(sdk):
    text = GENERATIONS[sdk]()
    if text is None:
        pytest.skip("RadHAR's .cfg is not on this machine")
    return read_ti_cfg(text), processing_from_cfg(text)


def angle_scale(radar):
    """Phase per element pitch over pi: the sweep-centre frequency over the board's design frequency
    (the elements are half a design wavelength apart)."""
    return radar.centre_frequency / board_for_radar(radar).design_frequency


def one_target(radar, processing, rng=1, noise=True, **target):
    echoes = Echoes.point_targets(radar, **{k: [v] for k, v in target.items()})
    return detect(synthesize(echoes, radar, noise=noise, rng=rng), radar, processing)


# ---------------------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("sdk", [2, 3])
@pytest.mark.parametrize("azimuth_deg, elevation_deg", [(20.0, 10.0), (-15.0, 5.0), (0.0, -8.0)])
def test_point_reflector_gives_one_point_at_its_position(sdk, azimuth_deg, elevation_deg):
    """x, y, z in the SDK's axes (x right = sionnafmcw's -y, y boresight, z up), within one range
    bin and one bin of the 64-point angle FFT (2/64 in sine), y from R^2 - x^2 - z^2."""
    radar, processing = setup(sdk)
    if sdk == 2:    # one point per target: group in range too (RadHAR's line groups in Doppler only)
        processing = processing.replace(peak_grouping=processing.peak_grouping.__class__(1, True, True, 1, 229))
    distance = 2.7
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    points = one_target(radar, processing, ranges=distance, radial_velocities=0.0, azimuths=az, elevations=el,
                        rcs=RCS[sdk])
    assert points.num_points == 1
    assert points.sdk == sdk
    r_step = points.range_step
    assert abs(points.range_index[0] * r_step - distance) <= r_step
    measured_range = points.range_index[0] * r_step
    scale = angle_scale(radar)
    wx_expected = -scale * math.cos(el) * math.sin(az)           # SDK x = sionnafmcw -y
    wz_expected = scale * math.sin(el)
    angle_bin = 2.0 / ANGLE_FFT_SIZE
    grid = 2.0 ** -points.xyz_q_format if sdk == 2 else 1e-6
    assert abs(points.x[0] / measured_range - wx_expected) <= angle_bin + grid / measured_range
    assert abs(points.z[0] / measured_range - wz_expected) <= angle_bin
    assert points.y[0] == pytest.approx(math.sqrt(max(measured_range ** 2 - points.x[0] ** 2 - points.z[0] ** 2, 0)),
                                        abs=2 * grid + 1e-5)
    if sdk == 2:    # int16 in Q(xyzQFormat): q = ceil(log2(16 / range step)); RadHAR's data is on 1/512 m
        assert points.xyz_q_format == math.ceil(math.log2(16 / r_step)) == 9
        for v in (points.x, points.y, points.z):
            assert np.all(v * 512 == np.round(v * 512))
        assert points.platform == 0xA1443
    else:
        assert points.platform == 0xA1843 and points.x.dtype == np.float32


# ---------------------------------------------------------------------------------------- Doppler
@pytest.mark.parametrize("sdk", [2, 3])
@pytest.mark.parametrize("bins", [0.0, 2.2, -3.3])
def test_moving_reflector_lands_in_its_doppler_bin(sdk, bins):
    """v = Doppler step x signed bin; the bin is the radial velocity over the step, rounded. The
    TDM slots' Doppler phase is compensated before the angle FFT: the moving reflector's x is where
    the static one's is (one angle bin)."""
    radar, processing = setup(sdk)
    step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * 16)
    velocity = bins * step
    azimuth = 0.35
    points = one_target(radar, processing, ranges=3.1, radial_velocities=velocity, azimuths=azimuth, elevations=0.0,
                        rcs=RCS[sdk])
    assert points.num_points >= 1
    assert points.doppler_step == pytest.approx(step, rel=1e-12)
    assert set(points.doppler_index.tolist()) == {round(bins)}
    np.testing.assert_allclose(points.velocity, round(bins) * step, rtol=1e-6)
    wx = points.x / (points.range_index * points.range_step)
    assert np.all(np.abs(wx + angle_scale(radar) * math.sin(azimuth)) <= 2.0 / ANGLE_FFT_SIZE)


# ---------------------------------------------------------------------------------------- fixed point
def test_peak_value_is_the_radar_equation_through_the_fixed_point_chain():
    """SDK 2.x peakVal = |azimuth FFT| at the peak. A boresight reflector at a range-bin centre and
    zero velocity, noise off, ideal IF chain: per virtual antenna the ADC tone has amplitude
    A = sqrt(P_t) |a| c (c words per sqrt(W)); the range FFT multiplies it by sum(w_r) / 4 (Blackman
    in Q17, two butterfly stages halved), the single-range-bin Doppler FFT that feeds the angle
    estimation by sum(w_d) / N_d (Hanning in Q17, every stage halved), the 64-point azimuth FFT at
    bin 0 by the 8 azimuth antennas and the HWA's output shift by 1/8 (dstScale 3): peakVal =
    A sum(w_r) sum(w_d) / (4 N_d), the 8 antennas' sum taken back out. Each int16 output rounds I
    and Q by <= 1/2 and the last shift truncates: that bounds the difference."""
    radar, processing = setup(2)
    radar = radar.replace(if_filter=None, phase_noise=None)
    processing = processing.replace(multi_object=processing.multi_object.__class__(False, 0.5))
    n_range = 256
    step = 299792458.0 * radar.fs / (2 * radar.slope * n_range)
    distance = 150 * step                                 # a range-bin centre at 6.5 m (far field)
    echoes = Echoes.point_targets(radar, ranges=[distance], radial_velocities=[0.0], azimuths=[0.0], rcs=[0.3])
    points = detect(synthesize(echoes, radar, noise=False), radar, processing)
    from sionnafmcw.receiver.adc import words_per_sqrt_watt
    amplitude = math.sqrt(radar.tx_power) * np.abs(echoes.a).mean() * words_per_sqrt_watt(radar)
    range_gain = blackman_q17(radar.num_samples).sum() / 4
    doppler_gain = hanning_q17(radar.num_chirps).sum() / 16
    n_azimuth = 8
    assert AZIMUTH_HWA_GAIN == 1 / 8
    expected = amplitude * range_gain * doppler_gain * n_azimuth * AZIMUTH_HWA_GAIN
    rounding = AZIMUTH_HWA_GAIN * n_azimuth * (math.sqrt(0.5) * hanning_q17(16).sum() / 16 + 2 * math.sqrt(0.5)) + 1
    index = int(np.flatnonzero(points.range_index == 150)[0])
    assert 100 < expected < 32767
    assert abs(float(points.peak_value[index]) - expected) <= rounding + 1e-3 * expected


def test_sdk2_detection_matrix_is_the_hwa_log2_sum_in_q9():
    """SDK 2.x detection matrix of a Doppler spectrum with the same magnitude |X| on every one of
    N = 12 antennas: the Doppler paramset's log2 of its 24-bit word 2^8 |X| in Q11, summed over the
    antennas by a 16-point FFT with every stage halved, srcScale 2 and dstScale 8:
    D = floor(12 floor(2048 log2(256 |X|)) / 64) = 384 (log2|X| + 8) to a count; a zero spectrum
    gives 0, and |X| = 2^k gives exactly 384 (k + 8)."""
    from sionnafmcw.ti.oob import detection_matrix
    magnitudes = np.array([0.0, 1.0, 3.0, 17.5, 1000.0, 2.0 ** 12])
    phases = np.array([1, 1j, -1, -1j] * 3)                 # on the I/Q axes: exact words
    spectrum = magnitudes[:, None, None] * phases[None, None, :]
    det = detection_matrix(spectrum, 2)[:, 0].astype(np.int64)
    expected = [0] + [int(12 * math.floor(2048 * math.log2(256 * m)) // 64) for m in magnitudes[1:]]
    assert det.tolist() == expected
    assert det[1] == 384 * 8 and det[-1] == 384 * (12 + 8)
    assert np.all(np.abs(det[1:] - 384 * (np.log2(magnitudes[1:]) + 8)) <= 1)


def test_radhar_cfar_line_compares_with_half_the_noise_mean():
    """RadHAR's cfarCfg 0 2 8 4 4 0 4000 (CASO, 8 noise cells a side, divShift 4) compares a cell
    with half its noise cells' mean plus 4000 in the Q9 matrix D = 384 (mean log2|X| + 8): a
    detection needs mean log2|X| > (noise mean log2|X|) / 2 + 6.42. With TI's divShift 3 the same
    window gives the mean itself, and the log2 offset of 8 cancels. Checked on the heat map of a
    noise-only frame: no cell passes (noise alone is 2^6.4 below the threshold), and a reflector of
    0.1 m^2 at 2.5 m passes where its cell is above the rule's level."""
    radar, processing = setup(2)
    radhar = processing_from_cfg(RADHAR_TEXT)
    gui = radhar.gui_monitor.__class__(1, False, False, False, True, False)
    radhar = radhar.replace(gui_monitor=gui)
    assert (radhar.cfar_range.averaging, radhar.cfar_range.window, radhar.cfar_range.divide_shift) == (2, 8, 4)
    quiet = one_target(radar, radhar, ranges=2.5, radial_velocities=0.0, azimuths=0.0, rcs=0.0)
    assert quiet.num_points == 0
    det = quiet.range_doppler_heatmap.astype(np.int64)
    mean_log2 = det[40:200].mean() / 384 - 8
    assert 2.0 < mean_log2 < 5.0                        # the receiver noise, ~16 int16 counts rms
    loud = one_target(radar, radhar, ranges=2.5, radial_velocities=0.0, azimuths=0.0, rcs=0.1)
    det = loud.range_doppler_heatmap.astype(np.int64)
    r = int(np.argmax(det[:, 0]))
    assert det[r, 0] / 384 - 8 > mean_log2 / 2 + 4000 / 384 - 8 / 2
    assert np.any(loud.range_index == r)


def test_snr_side_info_is_the_radar_equation_in_the_sdks_log2_units():
    r"""SDK 3.x SNR (0.1 dB): 60 D/256 - 60 n/256 with D the detection matrix at the point and n the
    range CFAR's noise estimate, both sums of log2 magnitudes in Q8 over N = 12 antennas shifted by
    log2 N' = 4. So the device reports 6 (N/N') dB per unit of log2 (6 for 20 log10 2 = 6.02).

    Closed form, noise on, ideal IF chain, reflector at a range- and Doppler-bin centre: the
    per-antenna amplitude SNR after both FFTs is
    S/sigma = sqrt(P_t |a|^2 / (k T0 F Fs)) * G(w_r) * G(w_d) with the coherent window gains
    G(w) = sum(w) / sqrt(sum(w^2)). A noise cell's log2 magnitude has the mean
    log2 sigma - gamma / (2 ln 2) (|X|^2 exponential; gamma Euler's constant); the CASO estimate is
    the smaller of two side means of 8 cells, each cell a mean over 12 antennas: standard deviation
    s = pi / (sqrt(24) ln 2) / sqrt(12 * 8) log2 units per side and a bias of -s / sqrt(pi). The
    max + 3/8 min magnitude approximation biases target and noise alike. So
    SNR = 6 (N/N') (log2(S/sigma) + gamma/(2 ln 2) + s/sqrt(pi)), within three s and the 0.1 dB
    rounding of the two terms."""
    radar, processing = setup(3)
    radar = radar.replace(if_filter=None, phase_noise=None)
    n_range = 256
    step = 299792458.0 * radar.fs / (2 * radar.slope * n_range)
    distance = 120 * step
    echoes = Echoes.point_targets(radar, ranges=[distance], radial_velocities=[0.0], azimuths=[0.0], rcs=[0.05])
    points = detect(synthesize(echoes, radar, rng=11), radar, processing)
    index = np.flatnonzero(points.range_index == 120)
    assert index.size == 1
    gain = lambda w: w.sum() / np.sqrt((w ** 2).sum())      # noqa: E731
    snr_amplitude = math.sqrt(radar.tx_power * np.mean(np.abs(echoes.a) ** 2) / radar.noise_power) \
        * gain(blackman_q17(radar.num_samples)) * gain(hanning_q17(radar.num_chirps))
    s = math.pi / (math.sqrt(24) * math.log(2)) / math.sqrt(12 * 8)
    euler = 0.5772156649015329
    scale = 6 * 12 / 16
    expected = scale * (math.log2(snr_amplitude) + euler / (2 * math.log(2)) + s / math.sqrt(math.pi))
    assert 20 < expected < 60
    assert abs(float(points.snr_db[index[0]]) - expected) <= scale * 3 * s + 0.2


@pytest.mark.parametrize("sdk", [2, 3])
def test_raising_the_threshold_removes_the_point_as_the_cfar_rule_says(sdk):
    """A detection survives while D > noise + T: with the threshold one count below D - noise the
    point is there, at D - noise it is gone (noise from the heat map with the .cfg's window, guard,
    shift and averaging, written out here: noiseWin cells a side (SDK 2.x's HWA fields count pairs
    of cells); SDK 3.x's threshold in dB: T = dB * 256/6 * N/N')."""
    radar, processing = setup(sdk)
    gui = processing.gui_monitor.__class__(1, False, False, False, True, False)
    processing = processing.replace(gui_monitor=gui)
    target = dict(ranges=2.3, radial_velocities=0.0, azimuths=0.2, elevations=0.0, rcs=RCS[sdk])
    base = one_target(radar, processing, **target)
    det = base.range_doppler_heatmap.astype(np.int64)
    r = int(base.range_index[0])
    d = int(base.doppler_index[0]) % det.shape[1]
    cfg = processing.cfar_range
    column = det[:, d]
    win = cfg.window                    # both generations: noiseWin cells a side
    left = column[r - cfg.guard - win:r - cfg.guard].sum()
    right = column[r + cfg.guard + 1:r + cfg.guard + win + 1].sum()
    side = {0: left + right, 1: max(left, right), 2: min(left, right)}[cfg.averaging]
    margin = int(column[r] - (side >> cfg.divide_shift))          # D - noise
    n_virtual = radar.num_tx * radar.num_rx

    def with_threshold(counts):
        if sdk == 2:
            value = counts
        else:      # the dB value whose truncated counts are exactly `counts`
            scale = 256 / 6 * n_virtual / (1 << math.ceil(math.log2(n_virtual)))
            value = (counts + 0.5) / scale
        config = CfarConfig(**{**cfg.__dict__, "threshold": value})
        assert config.threshold_counts(sdk, n_virtual) == counts
        return processing.replace(cfar_range=config)

    if sdk == 3:     # the Doppler CFAR must not decide: threshold 0 dB skips it (the DSP chain)
        processing = processing.replace(cfar_doppler=CfarConfig(**{**processing.cfar_doppler.__dict__,
                                                                   "threshold": 0.0}))
    below = one_target(radar, with_threshold(margin - 1), **target)
    at = one_target(radar, with_threshold(margin), **target)
    assert np.any((below.range_index == r) & (below.doppler_index == base.doppler_index[0]))
    assert not np.any((at.range_index == r) & (at.doppler_index == base.doppler_index[0]))


# ---------------------------------------------------------------------------------------- grouping
@pytest.mark.parametrize("sdk", [2, 3])
def test_peak_grouping_keeps_local_maxima_only(sdk):
    """Two reflectors at different Doppler bins: with grouping in both directions each gives one
    point (its 3x3 maximum); without it, their range/Doppler neighbours above the threshold come too."""
    radar, processing = setup(sdk)
    step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * 16)
    echoes = Echoes.point_targets(radar, ranges=[2.0, 3.0], radial_velocities=[0.0, 4 * step],
                                  azimuths=[0.1, -0.2], rcs=[RCS[sdk], RCS[sdk]])
    cube = synthesize(echoes, radar, rng=3)
    if sdk == 2:
        pg = processing.peak_grouping
        grouped = processing.replace(peak_grouping=pg.__class__(1, True, True, 1, 229))
        ungrouped = processing.replace(peak_grouping=pg.__class__(1, False, False, 1, 229))
    else:
        on = lambda c, v: CfarConfig(**{**c.__dict__, "peak_grouping": v})   # noqa: E731
        grouped = processing.replace(cfar_range=on(processing.cfar_range, True),
                                     cfar_doppler=on(processing.cfar_doppler, True))
        ungrouped = processing.replace(cfar_range=on(processing.cfar_range, False),
                                       cfar_doppler=on(processing.cfar_doppler, False))
    a = detect(cube, radar, grouped.replace(multi_object=grouped.multi_object.__class__(False, 0.5)))
    b = detect(cube, radar, ungrouped.replace(multi_object=ungrouped.multi_object.__class__(False, 0.5)))
    cells = set(zip(a.range_index.tolist(), a.doppler_index.tolist()))
    assert len(cells) == 2 and {d for _, d in cells} == {0, 4}
    assert b.num_points > a.num_points
    assert cells <= set(zip(b.range_index.tolist(), b.doppler_index.tolist()))


@pytest.mark.parametrize("sdk", [2, 3])
def test_multi_object_beamforming_adds_the_second_azimuth_peak(sdk):
    """Two reflectors at the same range and velocity, at +-30 deg, the second with 0.64 of the
    first's RCS (azimuth-spectrum peaks 0.8 in amplitude, 0.64 in power: SDK 2.x compares
    magnitudes, SDK 3.x powers): threshold 0.5 gives both (same range and Doppler bin, x of opposite
    signs), 0.9 only the first, disabled only the first."""
    radar, processing = setup(sdk)
    if sdk == 2:
        processing = processing.replace(peak_grouping=processing.peak_grouping.__class__(1, True, True, 1, 229))
    echoes = Echoes.point_targets(radar, ranges=[3.0, 3.0], radial_velocities=[0.0, 0.0],
                                  azimuths=np.radians([30.0, -30.0]), rcs=[RCS[sdk], 0.64 * RCS[sdk]])
    cube = synthesize(echoes, radar, rng=5)
    mob = processing.multi_object.__class__
    both = detect(cube, radar, processing.replace(multi_object=mob(True, 0.5)))
    strict = detect(cube, radar, processing.replace(multi_object=mob(True, 0.9)))
    off = detect(cube, radar, processing.replace(multi_object=mob(False, 0.5)))
    assert off.num_points == 1 and strict.num_points == 1
    assert both.num_points == 2
    assert both.range_index[0] == both.range_index[1] and both.doppler_index[0] == both.doppler_index[1]
    assert both.x[0] < 0 < both.x[1]          # +30 deg (sionnafmcw +y) is SDK -x, the stronger one
    assert off.x[0] == both.x[0]


# ---------------------------------------------------------------------------------------- FOV
def test_fov_lines_drop_what_they_should():
    """SDK 3.x: cfarFovCfg range and Doppler windows (bins int(limit/step + 0.5)) and aoaFovCfg's
    azimuth limits (sin against W_x) drop the point; windows that hold it keep it."""
    radar, processing = setup(3)
    step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * 16)
    target = dict(ranges=3.0, radial_velocities=3 * step, azimuths=math.radians(-20), elevations=0.0, rcs=RCS[3])
    keep = one_target(radar, processing.replace(
        cfar_fov_doppler=processing.cfar_fov_doppler.__class__(1, -0.5, 0.5)), **target)
    assert keep.num_points == 1 and keep.doppler_index[0] == 3 and keep.x[0] > 0
    fov = processing.cfar_fov_range.__class__
    assert one_target(radar, processing.replace(cfar_fov_range=fov(0, 0.0, 2.5)), **target).num_points == 0
    assert one_target(radar, processing.replace(cfar_fov_range=fov(0, 3.5, 8.0)), **target).num_points == 0
    doppler = processing.cfar_fov_doppler.__class__
    assert one_target(radar, processing.replace(cfar_fov_doppler=doppler(1, -0.2, 0.2)), **target).num_points == 0
    aoa = processing.aoa_fov.__class__
    assert one_target(radar, processing.replace(aoa_fov=aoa(-90, 10, -90, 90)), **target).num_points == 0
    assert one_target(radar, processing.replace(aoa_fov=aoa(-10, 90, -90, 90)), **target).num_points == 1


# ---------------------------------------------------------------------------------------- gui monitor
def test_gui_monitor_selects_the_frame_data():
    radar, processing = setup(3)
    gui = processing.gui_monitor.__class__(1, True, True, True, True, False)
    points = one_target(radar, processing.replace(gui_monitor=gui), ranges=2.0, radial_velocities=0.0,
                        azimuths=0.0, elevations=0.0, rcs=RCS[3])
    heat = points.range_doppler_heatmap
    assert heat.shape == (256, 16) and heat.dtype == np.uint16
    np.testing.assert_array_equal(points.range_profile, heat[:, 0])
    np.testing.assert_array_equal(points.noise_profile, heat[:, 8])
    assert points.azimuth_static_heatmap.shape == (256, 8)
    r = int(points.range_index[0])
    assert np.argmax(np.abs(points.azimuth_static_heatmap).sum(axis=1)) in (r - 1, r, r + 1)
    plain = one_target(radar, processing, ranges=2.0, radial_velocities=0.0, azimuths=0.0, elevations=0.0, rcs=RCS[3])
    assert plain.range_doppler_heatmap is None and plain.azimuth_static_heatmap is None
    assert plain.range_profile is not None and plain.noise_profile is None     # guiMonitor -1 1 1 0 0 0 1


# ---------------------------------------------------------------------------------------- run stores
def write_run(path, radar, frames=2, rcs=1.0, leakage_db=None):
    from sionnafmcw.store import RunStore

    store = RunStore.open(path, radar, frames, ["a"], {"radar": radar.to_dict(), "seed": 0})
    for f in range(frames):
        echoes = Echoes.point_targets(radar, ranges=[2.0 + 0.1 * f], radial_velocities=[0.0], azimuths=[0.1],
                                      rcs=[rcs])
        store.write_frame(f, synthesize(echoes, radar, frame_time=0.1 * f, rng=f, leakage_db=leakage_db), 0.1 * f,
                          np.zeros((1, 3)), np.zeros((1, 3)), [0.0])


def test_run_point_clouds_use_the_runs_own_cfg(tmp_path):
    if RADHAR_TEXT is None:
        pytest.skip("RadHAR's .cfg is not on this machine")
    radar = read_ti_cfg(RADHAR_CFG)
    assert radar.ti_processing[1] == "cfarCfg 0 2 8 4 4 0 4000"
    write_run(tmp_path / "run.zarr", radar)
    clouds = list(run_point_clouds(tmp_path / "run.zarr"))
    assert [c.frame_number for c in clouds] == [1, 2] and clouds[1].time == pytest.approx(0.1)
    direct = detect(__import__("sionnafmcw.store", fromlist=["open_run"]).open_run(tmp_path / "run.zarr").cube(1),
                    radar, processing_from_cfg(RADHAR_CFG), frame_number=2, time=0.1)
    np.testing.assert_array_equal(clouds[1].x, direct.x)
    assert clouds[1].range_index.max() > clouds[0].range_index.max()
    # another .cfg given explicitly wins; a run from a preset has none of its own
    assert next(run_point_clouds(tmp_path / "run.zarr", processing=PROFILE_3D_18XX, frames=[0])).sdk == 3
    plain = read_ti_cfg(PROFILE_3D_18XX).replace(ti_processing=None)
    write_run(tmp_path / "plain.zarr", plain, frames=1)
    with pytest.raises(TiCfgError, match=r"plain.zarr: the run's radar .*--cfg FILE"):
        next(run_point_clouds(tmp_path / "plain.zarr"))


# ---------------------------------------------------------------------------------------- parser
def test_radhar_cfg_is_sdk2_with_its_lines():
    if RADHAR_TEXT is None:
        pytest.skip("RadHAR's .cfg is not on this machine")
    cfg = parse_ti_cfg(RADHAR_CFG)
    p = cfg.processing
    assert p.sdk == 2 and p.max_points == 100
    assert (p.cfar_range.averaging, p.cfar_range.window, p.cfar_range.guard, p.cfar_range.divide_shift,
            p.cfar_range.cyclic, p.cfar_range.threshold) == (2, 8, 4, 4, False, 4000)
    assert (p.peak_grouping.in_range, p.peak_grouping.in_doppler, p.peak_grouping.end_range_index) == (False, True, 229)
    assert p.multi_object.enabled and p.multi_object.threshold == 0.5 and not p.clutter_removal
    assert p.gui_monitor.detected_objects == 1 and not p.gui_monitor.range_doppler_heatmap
    assert p.range_bias_phase.range_bias == 0 and np.all(p.range_bias_phase.q15(12) == 32767 / 32768)
    assert [c for _, c in cfg.ignored] == ["measureRangeBiasAndRxChanPhase", "CQRxSatMonitor", "CQSigImgMonitor",
                                           "analogMonitor"]
    radar = read_ti_cfg(RADHAR_CFG)
    assert board_for_radar(radar) is BOARDS["iwr1443boost"] and radar.tx_order == [0, 2, 1]
    assert read_ti_cfg(radar.to_ti_cfg()) == radar              # the processing lines travel


def test_sdk3_profile_reads_every_line():
    p = processing_from_cfg(PROFILE_3D_18XX)
    assert p.sdk == 3 and p.max_points == 500
    assert p.cfar_range == CfarConfig(0, 2, 8, 4, 3, False, 15.0, True, p.cfar_range.line)
    assert p.cfar_doppler == CfarConfig(1, 0, 4, 2, 3, True, 15.0, True, p.cfar_doppler.line)
    assert p.cfar_fov_range.maximum == 8.92 and p.cfar_fov_doppler.minimum == -1.0
    assert p.aoa_fov.min_azimuth_deg == -90 and p.gui_monitor.log_mag_range and p.gui_monitor.stats
    assert p.cfar_range.threshold_counts(3, 12) == int(15 * 256 / 6 * 12 / 16)


def line_of(text, prefix):
    return next(i for i, line in enumerate(text.splitlines(), start=1) if line.startswith(prefix))


@pytest.mark.parametrize("change, prefix, words", [
    (("cfarCfg -1 0 2 8 4 3 0 15 1", "cfarCfg -1 0 2 8 4 3 0 15"), "cfarCfg -1 0", "takes 7 (SDK 1.x/2.x"),
    (("cfarCfg -1 1 0 4 2 3 1 15 1", "cfarCfg 1 0 4 2 3 1 1200"), "cfarCfg 1 0",
     "SDK 1.x/2.x (xWR14xx) syntax, but line"),
    (("multiObjBeamForming -1 1 0.5", "multiObjBeamForming 0 1 0.5"), "multiObjBeamForming", "subframe 0"),
    (("cfarCfg -1 0 2 8 4 3 0 15 1", "cfarCfg -1 0 5 8 4 3 0 15 1"), "cfarCfg -1 0", "averageMode"),
    (("cfarCfg -1 0 2 8 4 3 0 15 1", "cfarCfg -1 0 2 8 4 3 0 150 1"), "cfarCfg -1 0", "0..100 dB"),
    (("aoaFovCfg -1 -90 90 -90 90", "aoaFovCfg -1 90 -90 -90 90"), "aoaFovCfg", "min < max"),
    (("guiMonitor -1 1 1 0 0 0 1", "guiMonitor -1 1 1 0 0 0 x"), "guiMonitor", "must be numbers"),
    (("extendedMaxVelocity -1 0", "extendedMaxVelocity -1 1"), "extendedMaxVelocity", "not modelled"),
])
def test_sdk3_errors_name_the_line(change, prefix, words):
    text = PROFILE_3D_18XX.replace(*change)
    with pytest.raises(TiCfgError) as err:
        parse_ti_cfg(text)
    assert f"line {line_of(text, prefix)}: {prefix.split()[0]}" in str(err.value) and words in str(err.value)


def test_missing_lines_are_named():
    with pytest.raises(TiCfgError, match=r"no cfarFovCfg for the Doppler direction.*cfarFovCfg -1 1"):
        processing_from_cfg(PROFILE_3D_18XX.replace("cfarFovCfg -1 1 -1 1.00\n", ""))
    with pytest.raises(TiCfgError, match=r"no cfarCfg for the Doppler direction"):
        processing_from_cfg(PROFILE_3D_18XX.replace("cfarCfg -1 1 0 4 2 3 1 15 1\n", ""))
    if RADHAR_TEXT is not None:
        with pytest.raises(TiCfgError, match=r"no peakGrouping line.*peakGrouping 1 1 1 1 229"):
            processing_from_cfg(RADHAR_TEXT.replace("peakGrouping 1 0 1 1 229\n", ""))
    rf_only = "\n".join(line for line in PROFILE_3D_18XX.splitlines()
                        if line.split(" ")[0] not in ("guiMonitor", "cfarCfg", "multiObjBeamForming", "clutterRemoval",
                                                      "calibDcRangeSig", "extendedMaxVelocity", "aoaFovCfg",
                                                      "cfarFovCfg", "compRangeBiasAndRxChanPhase"))
    assert parse_ti_cfg(rf_only).processing is None
    with pytest.raises(TiCfgError, match="no processing lines"):
        processing_from_cfg(rf_only)


# ---------------------------------------------------------------------------------------- static paths
@pytest.mark.parametrize("sdk", [2, 3])
def test_clutter_removal_drops_the_static_reflector_keeps_the_moving_one(sdk):
    """clutterRemoval 1 subtracts the mean over chirps per range bin and antenna: a static
    reflector's echo is that mean (it leaves nothing), a moving one's is not (it stays)."""
    radar, processing = setup(sdk)
    step = radar.centre_wavelength / (2 * radar.num_tx * radar.chirp_interval * 16)
    echoes = Echoes.point_targets(radar, ranges=[2.0, 3.0], radial_velocities=[0.0, 3 * step],
                                  azimuths=[0.1, -0.2], rcs=[RCS[sdk], RCS[sdk]])
    cube = synthesize(echoes, radar, rng=7)
    kept = detect(cube, radar, processing)
    removed = detect(cube, radar, processing.replace(clutter_removal=True))
    assert set(kept.doppler_index.tolist()) == {0, 3}
    assert removed.num_points >= 1 and set(removed.doppler_index.tolist()) == {3}


@pytest.mark.parametrize("sdk", [2, 3])
def test_dc_range_calibration_removes_the_leakage_points(sdk):
    """Direct Tx-Rx coupling is a static tone in the first range bins: without calibDcRangeSig
    it is detected at range < 0.3 m (as in RadHAR's recordings); with it on, the mean of bins
    negBin..posBin learnt from the run's first chirps is subtracted and no point is left there, while
    a reflector at 2 m stays."""
    radar, processing = setup(sdk)
    if sdk == 3:    # range bin 0 has R = 0, so y = 0 and SDK 3.x drops it; without grouping bin 1 shows
        off = lambda c: CfarConfig(**{**c.__dict__, "peak_grouping": False})   # noqa: E731
        processing = processing.replace(cfar_range=off(processing.cfar_range),
                                        cfar_doppler=off(processing.cfar_doppler))
    echoes = Echoes.point_targets(radar, ranges=[2.0], radial_velocities=[0.0], azimuths=[0.1], rcs=[RCS[sdk]])
    cube = synthesize(echoes, radar, rng=9, leakage_db=-40.0)
    plain = detect(cube, radar, processing)
    dc = processing.dc_calibration.__class__(True, -5, 8, 256)
    calibrated = detect(cube, radar, processing.replace(dc_calibration=dc))
    near = lambda points: points.range_index * points.range_step < 0.3     # noqa: E731
    assert np.any(near(plain))
    assert not np.any(near(calibrated))
    assert np.any(np.abs(calibrated.range_index * calibrated.range_step - 2.0) <= calibrated.range_step)


# ---------------------------------------------------------------------------------------- compensation
def test_range_bias_and_channel_phase_coefficients():
    """compRangeBiasAndRxChanPhase: the bias is subtracted from every range; coefficients that
    form a linear phase ramp exp(j 2 pi m c / 64) over the virtual antennas' azimuth columns c move
    the azimuth FFT peak by m bins (the shift theorem), i.e. W_x by 2 m / 64."""
    radar, processing = setup(3)
    target = dict(ranges=3.0, radial_velocities=0.0, azimuths=0.0, elevations=0.0, rcs=RCS[3])
    plain = one_target(radar, processing, **target)
    bias_line = processing.range_bias_phase
    biased = one_target(radar, processing.replace(range_bias_phase=bias_line.__class__(0.05, bias_line.coefficients)),
                        **target)
    assert biased.range[0] == pytest.approx(plain.range[0] - 0.05, abs=1e-5)
    tx = radar.tx_positions[radar.tx_order]
    virtual = (tx[:, None, :] + radar.rx_positions[None, :, :]).reshape(-1, 3)
    columns = np.rint((virtual[:, 1] - virtual[:, 1].min()) / np.min(np.diff(radar.rx_positions[:, 1])))
    m = 5
    ramp = np.exp(2j * np.pi * m * columns / ANGLE_FFT_SIZE)
    coefficients = tuple(np.stack([ramp.real, ramp.imag], axis=1).reshape(-1))
    steered = one_target(radar, processing.replace(range_bias_phase=bias_line.__class__(0.0, coefficients)), **target)
    assert steered.num_points == 1
    wx_plain = plain.x[0] / (plain.range_index[0] * plain.range_step)
    wx_steered = steered.x[0] / (steered.range_index[0] * steered.range_step)
    assert wx_steered - wx_plain == pytest.approx(2 * m / ANGLE_FFT_SIZE, abs=1e-5)


def test_presets_from_cfg_reads_radhars_file(capsys, tmp_path):
    """``sionnafmcw presets --from-cfg`` on RadHAR's SDK 2.x file (line 14 used to stop it); a .cfg with
    a broken processing line is one error line naming it."""
    import json

    from test_cli import assert_user_error, run_cli

    if RADHAR_TEXT is None:
        pytest.skip("RadHAR's .cfg is not on this machine")
    status, out, _ = run_cli(capsys, "presets", "--from-cfg", RADHAR_CFG, "--json")
    assert status == 0
    (row,) = json.loads(out)
    assert row["config"]["num_samples"] == 240 and row["config"]["ti_processing"][2] == "peakGrouping 1 0 1 1 229"
    broken = tmp_path / "broken.cfg"
    broken.write_text(RADHAR_TEXT.replace("peakGrouping 1 0 1 1 229", "peakGrouping 1 0 1 1"))
    status, _, err = run_cli(capsys, "presets", "--from-cfg", broken)
    assert_user_error(status, err, "broken.cfg", "line 14: peakGrouping takes 5")


def test_run_point_clouds_learn_the_dc_signature_from_the_first_chirps(tmp_path):
    """calibDcRangeSig over a run: the signature is the mean of the first numAvg chirps (here 64:
    21 loops of 3 slots, from the first two frames of 16 loops), learnt once and subtracted from
    every frame: the leakage points are gone in every frame, the reflector stays."""
    radar, processing = setup(2)
    write_run(tmp_path / "leak.zarr", radar, frames=3, rcs=RCS[2], leakage_db=-40.0)
    plain = list(run_point_clouds(tmp_path / "leak.zarr", processing=processing))
    calibrated = list(run_point_clouds(tmp_path / "leak.zarr", processing=processing.replace(
        dc_calibration=processing.dc_calibration.__class__(True, -5, 8, 64))))
    for before, after in zip(plain, calibrated):
        assert np.any(before.range_index * before.range_step < 0.3)
        assert not np.any(after.range_index * after.range_step < 0.3)
        assert np.any(np.abs(after.range_index * after.range_step - before.range_index.max() * before.range_step)
                      <= after.range_step)


def test_detect_refuses_a_cube_of_another_radar():
    from sionnafmcw.ti.oob import OobError

    radar, processing = setup(3)
    with pytest.raises(OobError, match=r"does not match the radar's \[chirp, tx, rx, sample\]"):
        detect(np.zeros((16, 3, 4, 128), np.complex64), radar, processing)


def test_sdk2_angle_inputs_follow_the_demos_integer_rules():
    """SDK 2.x: the channel coefficients multiply in Q15 with (x c + 2^14) >> 15 (so 0.5 halves
    rounding half up, -1 + 0j negates with the -32768 coefficient), saturated; then the TDM Doppler
    rotation is computed in float and cast to int16 (truncated to zero)."""
    from sionnafmcw.ti.oob import _phase_q15_sdk2, _rotate_sdk2
    x = np.array([3 + 5j, -3 - 5j, 32767 + 0j, -7 + 1j])
    half = _phase_q15_sdk2(x, np.full(4, 0.5 + 0j))
    np.testing.assert_array_equal(half, np.floor((x.real + 1) / 2) + 1j * np.floor((x.imag + 1) / 2))
    negated = _phase_q15_sdk2(x, np.full(4, -1.0 + 0j))
    np.testing.assert_array_equal(negated, np.clip(-x.real, -32768, 32767) + 1j * np.clip(-x.imag, -32768, 32767))
    rotated = _rotate_sdk2(np.array([10 + 0j, 10 + 0j]), np.exp(-1j * np.array([0.3, -2.0])))
    exact = 10 * np.exp(-1j * np.array([0.3, -2.0]))
    np.testing.assert_array_equal(rotated, np.trunc(exact.real) + 1j * np.trunc(exact.imag))
