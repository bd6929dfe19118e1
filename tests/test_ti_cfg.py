"""TI mmWave SDK .cfg in and out: round trips, TI's own derived figures, errors that name the line."""

from __future__ import annotations

import numpy as np
import pytest

from sionnafmcw import RadarConfig
from sionnafmcw.ti.cfg import (BOARDS, IGNORED_COMMANDS, TiCfgError, parse_ti_cfg, read_ti_cfg,
                                  write_ti_cfg)
from sionnafmcw.radar import RadarConfigError

C = 299792458.0

# The SDK demo profiles the presets quote (radar.py docstrings), with the demo's non-RF lines
# and TI's own % comments, as the SDK ships them.
PROFILE_3D_18XX = """\
% ***************************************************************
% Created for SDK ver:03.05
% Created using Visualizer ver:3.5.0.0
% Frequency:77
% Platform:xWR18xx
% Scene Classifier:best_range_res
% ***************************************************************
sensorStop
flushCfg
dfeDataOutputMode 1
channelCfg 15 7 0
adcCfg 2 1
adcbufCfg -1 0 1 1 1
profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 0 0 30
chirpCfg 0 0 0 0 0 0 0 1
chirpCfg 1 1 0 0 0 0 0 2
chirpCfg 2 2 0 0 0 0 0 4
frameCfg 0 2 16 0 100 1 0
lowPower 0 0
guiMonitor -1 1 1 0 0 0 1
cfarCfg -1 0 2 8 4 3 0 15 1
cfarCfg -1 1 0 4 2 3 1 15 1
multiObjBeamForming -1 1 0.5
clutterRemoval -1 0
calibDcRangeSig -1 0 -5 8 256
extendedMaxVelocity -1 0
lvdsStreamCfg -1 0 0 0
compRangeBiasAndRxChanPhase 0.0 1 0 1 0 1 0 1 0 1 0 1 0 1 0 1 0 1 0 1 0 1 0 1 0
measureRangeBiasAndRxChanPhase 0 1.5 0.2
CQRxSatMonitor 0 3 5 121 0
CQSigImgMonitor 0 127 4
analogMonitor 0 0
aoaFovCfg -1 -90 90 -90 90
cfarFovCfg -1 0 0 8.92
cfarFovCfg -1 1 -1 1.00
calibData 0 0 0
sensorStart
"""

SDK_PROFILES = {
    # preset: (board, .cfg text)
    "ti-awr1843boost": ("awr1843boost", PROFILE_3D_18XX),
    "ti-iwr6843isk": ("iwr6843isk", PROFILE_3D_18XX.replace("profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 0 0 30",
                                                            "profileCfg 0 60 359 7 57.14 0 0 70 1 256 5209 0 0 158")),
    "ti-iwr1443boost": ("iwr1443boost", PROFILE_3D_18XX
                        .replace("channelCfg 15 7 0", "channelCfg 15 5 0")
                        .replace("profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 0 0 30",
                                 "profileCfg 0 77 429 7 57.14 0 0 70 1 256 5209 0 0 30")
                        .replace("chirpCfg 1 1 0 0 0 0 0 2\nchirpCfg 2 2 0 0 0 0 0 4\n", "chirpCfg 1 1 0 0 0 0 0 4\n")
                        .replace("frameCfg 0 2 16", "frameCfg 0 1 16")),
}

RF_FIELDS = ("fc", "slope", "fs", "num_samples", "num_chirps", "chirp_interval", "adc_start_time", "ramp_end_time",
             "tx_order", "tx_power", "noise_figure", "antenna_pattern")


@pytest.mark.parametrize("preset", ["ti-awr1843boost", "ti-iwr6843isk", "ti-iwr1443boost"])
def test_preset_round_trip(preset, tmp_path):
    radar = RadarConfig.preset(preset)
    text = write_ti_cfg(radar)
    back = read_ti_cfg(text)
    assert back == radar
    assert write_ti_cfg(back) == text
    path = tmp_path / "radar.cfg"
    path.write_text(text)
    assert read_ti_cfg(path) == radar
    assert read_ti_cfg(str(path)) == radar
    assert RadarConfig.resolve(path) == radar          # the radar spec dispatches .cfg files here


@pytest.mark.parametrize("preset", list(SDK_PROFILES))
def test_sdk_profiles_give_the_presets(preset):
    board, text = SDK_PROFILES[preset]
    radar = read_ti_cfg(text, board=board)
    expected = RadarConfig.preset(preset)
    for name in RF_FIELDS:
        assert getattr(radar, name) == getattr(expected, name), name
    np.testing.assert_array_equal(radar.tx_positions, expected.tx_positions)
    np.testing.assert_array_equal(radar.rx_positions, expected.rx_positions)


@pytest.mark.parametrize("preset", list(SDK_PROFILES))
def test_derived_figures_are_tis(preset):
    """TI's formulas on the .cfg numbers (mmWave SDK demo, visualiser), written out here."""
    board, text = SDK_PROFILES[preset]
    radar = read_ti_cfg(text, board=board)
    profile = next(line.split() for line in text.splitlines() if line.startswith("profileCfg"))
    frame = next(line.split() for line in text.splitlines() if line.startswith("frameCfg"))
    start_ghz, idle_us, adc_start_us, ramp_end_us = (float(x) for x in profile[2:6])
    slope_mhz_us, num_samples, rate_ksps = float(profile[8]), int(profile[10]), float(profile[11])
    num_tx = int(frame[2]) - int(frame[1]) + 1
    num_loops = int(frame[3])

    bandwidth = slope_mhz_us * 1e12 * num_samples / (rate_ksps * 1e3)               # Hz
    range_resolution = C / (2 * bandwidth)
    max_range = C * rate_ksps * 1e3 / (2 * slope_mhz_us * 1e12)                      # complex baseband
    # the demo's centre frequency: startFreq + adcStart * slope + bandwidth / 2
    f_centre = start_ghz * 1e9 + slope_mhz_us * 1e12 * adc_start_us * 1e-6 + bandwidth / 2
    chirp_interval = (idle_us + ramp_end_us) * 1e-6
    velocity_resolution = C / (2 * f_centre * num_loops * num_tx * chirp_interval)
    max_velocity = C / (4 * f_centre * num_tx * chirp_interval)

    assert radar.range_resolution == pytest.approx(range_resolution, rel=1e-12)
    assert radar.max_range == pytest.approx(max_range, rel=1e-12)
    # we centre the ADC window at (N-1)/2 samples, TI at N/2: f_mid differs by slope/(2 Fs)
    # (6.7 MHz: 8.5e-5 of 79 GHz, 1.1e-4 of 62 GHz); nothing else may differ
    half_sample = slope_mhz_us * 1e12 / (2 * rate_ksps * 1e3)
    ratio = f_centre / (f_centre - half_sample)
    assert radar.velocity_resolution == pytest.approx(velocity_resolution * ratio, rel=1e-12)
    assert radar.max_velocity == pytest.approx(max_velocity * ratio, rel=1e-12)
    assert abs(radar.velocity_resolution / velocity_resolution - 1) < 1.2e-4


def test_visualiser_header_figures_of_profile_3d():
    """TI's mmWave visualiser prints its figures in the header of the xWR18xx profile it writes:
    ``Range Resolution(m): 0.044``, ``Maximum Radial Velocity(m/s): 1``,
    ``Radial velocity resolution(m/s): 0.13`` (rounded as TI prints them). The visualiser takes
    the wavelength at startFreq (the demo firmware, above, and we: at the sweep centre), so its
    velocity figures are ours times f_mid / f_start (79.2 / 77 GHz)."""
    radar = read_ti_cfg(PROFILE_3D_18XX, board="awr1843boost")
    to_visualiser = radar.centre_frequency / radar.fc
    assert round(radar.range_resolution, 3) == 0.044
    assert round(radar.max_velocity * to_visualiser, 0) == 1
    assert round(radar.velocity_resolution * to_visualiser, 2) == 0.13
    assert round(radar.velocity_resolution, 2) == 0.12       # the firmware's (and our) figure


def test_ignored_commands_are_listed_with_their_lines():
    """Ignored: what changes neither the RF signal nor the detected points; the processing lines
    are read, not ignored."""
    cfg = parse_ti_cfg(PROFILE_3D_18XX)
    ignored = dict((command, line) for line, command in cfg.ignored)
    lines = PROFILE_3D_18XX.splitlines()
    for command in ("lvdsStreamCfg", "calibData", "lowPower", "CQRxSatMonitor", "measureRangeBiasAndRxChanPhase"):
        assert command in IGNORED_COMMANDS
        assert lines[ignored[command] - 1].startswith(command)
    for command in ("guiMonitor", "cfarCfg", "multiObjBeamForming", "aoaFovCfg", "cfarFovCfg"):
        assert command not in IGNORED_COMMANDS and command not in ignored
    assert cfg.processing.sdk == 3 and cfg.processing.cfar_doppler.threshold == 15
    assert cfg.frame_period == pytest.approx(0.1) and cfg.rx_gain_db == 30


def line_of(text, command):
    return next(i for i, line in enumerate(text.splitlines(), start=1) if line.startswith(command))


@pytest.mark.parametrize("change, command, words", [
    (("guiMonitor -1 1 1 0 0 0 1", "fancyNewCmd 1 2 3"), "fancyNewCmd", "unknown command"),
    (("dfeDataOutputMode 1", "dfeDataOutputMode 3"), "dfeDataOutputMode", "not supported"),
    (("adcCfg 2 1", "adcCfg 2 0"), "adcCfg", "real ADC data"),
    (("adcCfg 2 1", "adcCfg 1 1"), "adcCfg", "14 bit"),
    (("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 3"), "chirpCfg 1", "exactly one transmitter"),
    (("chirpCfg 2 2 0 0 0 0 0 4", "chirpCfg 2 2 0 0 0 0.5 0 4"), "chirpCfg 2", "variations"),
    (("profileCfg 0 77 267 7 57.14 0 0 70 1 256 5209 0 0 30", "profileCfg 0 77 267 7 57.14 0 0 70 1 256"),
     "profileCfg", "takes 14 arguments"),
    (("channelCfg 15 7 0", "channelCfg 15 x 0"), "channelCfg", "must be numbers"),
])
def test_unsupported_lines_are_named(change, command, words):
    text = PROFILE_3D_18XX.replace(*change)
    with pytest.raises(TiCfgError) as err:
        read_ti_cfg(text)
    message = str(err.value)
    assert f"line {line_of(text, command)}: {command.split()[0]}" in message and words in message
    assert isinstance(err.value, RadarConfigError)


def test_frame_and_channel_mismatches_are_named(tmp_path):
    with pytest.raises(TiCfgError, match=r"frameCfg uses chirp 3, which no chirpCfg defines"):
        read_ti_cfg(PROFILE_3D_18XX.replace("frameCfg 0 2 16", "frameCfg 0 3 16"))
    with pytest.raises(TiCfgError, match=r"chirpCfg enables TX2, which channelCfg txChannelEn 3 disables"):
        read_ti_cfg(PROFILE_3D_18XX.replace("channelCfg 15 7 0", "channelCfg 15 3 0"))
    with pytest.raises(TiCfgError, match=r"fire transmitter indices \[0, 1, 1\]"):
        read_ti_cfg(PROFILE_3D_18XX.replace("chirpCfg 2 2 0 0 0 0 0 4", "chirpCfg 2 2 0 0 0 0 0 2"))
    with pytest.raises(TiCfgError, match=r"no frameCfg command"):
        read_ti_cfg(PROFILE_3D_18XX.replace("frameCfg 0 2 16 0 100 1 0\n", ""))
    with pytest.raises(TiCfgError, match=r"ADC window .* longer than the ramp"):
        read_ti_cfg(PROFILE_3D_18XX.replace(" 57.14 0 0 70 1 256 ", " 40 0 0 70 1 256 "))
    missing = tmp_path / "missing.cfg"
    with pytest.raises(TiCfgError, match="missing.cfg: cannot read"):
        read_ti_cfg(missing)


def test_channel_subsets_and_firing_order():
    """Rx/Tx subsets pick the board's elements; chirp order becomes tx_order, and back."""
    text = (PROFILE_3D_18XX.replace("channelCfg 15 7 0", "channelCfg 5 7 0")
            .replace("chirpCfg 0 0 0 0 0 0 0 1", "chirpCfg 0 0 0 0 0 0 0 4")
            .replace("chirpCfg 2 2 0 0 0 0 0 4", "chirpCfg 2 2 0 0 0 0 0 1"))
    radar = read_ti_cfg(text, board="awr1843boost")
    board_tx, board_rx = BOARDS["awr1843boost"].layout()
    np.testing.assert_array_equal(radar.rx_positions, board_rx[[0, 2]])
    assert radar.tx_order == [2, 1, 0]
    again = read_ti_cfg(write_ti_cfg(radar, board="awr1843boost"))
    assert again.tx_order == [2, 1, 0] and again == radar


def test_tx_power_back_off_round_trip():
    radar = RadarConfig.preset("ti-awr1843boost")
    lowered = radar.replace(tx_power=radar.tx_power * 10 ** (-0.3))
    text = write_ti_cfg(lowered)
    assert "profileCfg 0 77 267 7 57.14 3 0 70" in text
    assert read_ti_cfg(text).tx_power == pytest.approx(lowered.tx_power, rel=1e-12)
    with pytest.raises(TiCfgError, match="whole number of dB"):
        write_ti_cfg(radar.replace(tx_power=radar.tx_power * 0.9))


def test_write_refuses_radars_no_board_has():
    with pytest.raises(TiCfgError, match="not a TI board preset; say which board"):
        write_ti_cfg(RadarConfig.preset("walk-77ghz"))
    with pytest.raises(TiCfgError, match="is not an element of the awr1843boost"):
        write_ti_cfg(RadarConfig.preset("walk-77ghz"), board="awr1843boost")
    with pytest.raises(TiCfgError, match="unknown TI board 'awr9999'"):
        write_ti_cfg(RadarConfig.preset("ti-awr1843boost"), board="awr9999")


@pytest.mark.parametrize("name", ["ti-awr1843boost", "ti-iwr6843isk", "ti-iwr1443boost"])
def test_radarconfig_ti_cfg_methods_round_trip(name):
    """``RadarConfig.to_ti_cfg`` / ``from_ti_cfg`` (the spelling of the issue) are the io functions."""
    radar = RadarConfig.preset(name)
    text = radar.to_ti_cfg()
    assert text == write_ti_cfg(radar)
    assert RadarConfig.from_ti_cfg(text) == radar
