"""RadarConfig: presets, derived figures, round trip, validation; libLLVM discovery."""

import json
import os

import numpy as np
import pytest

import sionnafmcw
from sionnafmcw import SPEED_OF_LIGHT, RadarConfig, RadarConfigError
from sionnafmcw._llvm import find_libllvm


def test_presets_listed_and_loadable():
    names = RadarConfig.presets()
    assert set(names) >= {"ti-awr1843boost", "ti-iwr6843isk", "ti-iwr1443boost", "walk-77ghz"}
    for name in names:
        radar = RadarConfig.preset(name)
        assert radar.name == name
        radar.validate()


def test_awr1843_profile_figures():
    """profile_3d.cfg of the xwr18xx demo: the SDK visualiser's own figures (0.044 m, 9.02 m, 1 m/s, 0.13 m/s)."""
    radar = RadarConfig.preset("ti-awr1843boost")
    assert radar.num_tx == 3 and radar.num_rx == 4
    assert radar.range_resolution == pytest.approx(0.044, abs=0.001)  # c / (2 * 70 MHz/us * 256 / 5.209 Msps)
    assert radar.max_range == pytest.approx(11.16, abs=0.01)  # complex sampling: c Fs / (2 mu); TI quotes 80 %: 9.02 m
    assert radar.max_velocity == pytest.approx(1.0, abs=0.05)
    assert radar.velocity_resolution == pytest.approx(0.13, abs=0.01)
    # elevated middle Tx: lambda/2 above the others
    assert radar.tx_positions[1, 2] == pytest.approx(SPEED_OF_LIGHT / 77e9 / 2)


def test_walk_preset_sees_the_walking_person():
    radar = RadarConfig.preset("walk-77ghz")
    assert radar.max_velocity > 5.0
    assert radar.max_range >= 10.0
    assert radar.cpi_duration < 1 / 24
    radar.validate(frame_period=1 / 24)


def test_derived_figures_closed_form():
    radar = RadarConfig.preset("walk-77ghz")
    t_mid = radar.adc_start_time + (radar.num_samples - 1) / (2 * radar.fs)
    lam_mid = SPEED_OF_LIGHT / (radar.fc + radar.slope * t_mid)
    t_b = radar.num_tx * radar.chirp_interval
    assert radar.bandwidth == pytest.approx(radar.slope * radar.num_samples / radar.fs)
    assert radar.range_resolution == pytest.approx(SPEED_OF_LIGHT / (2 * radar.bandwidth))
    assert radar.max_velocity == pytest.approx(lam_mid / (4 * t_b))
    assert radar.velocity_resolution == pytest.approx(lam_mid / (2 * radar.num_chirps * t_b))
    assert radar.cpi_duration == pytest.approx(radar.num_chirps * t_b)


def test_chirp_start_times_follow_tx_order():
    radar = RadarConfig.preset("walk-77ghz").replace(tx_order=[2, 0, 1])
    starts = radar.chirp_start_times()
    tc = radar.chirp_interval
    # Tx 2 fires first, then Tx 0, then Tx 1
    assert starts[0].tolist() == pytest.approx([tc, 2 * tc, 0.0])
    assert starts[3, 2] == pytest.approx(3 * 3 * tc)


def test_dict_and_json_round_trip():
    for name in RadarConfig.presets():
        radar = RadarConfig.preset(name)
        again = RadarConfig.from_json(json.dumps(radar.to_dict()))
        assert again == radar
        assert np.array_equal(again.tx_positions, radar.tx_positions)


@pytest.mark.parametrize(
    "change, field",
    [
        ({"fc": -1.0}, "fc"),
        ({"num_samples": 0}, "num_samples"),
        ({"num_samples": 4096}, "ADC window"),
        ({"ramp_end_time": 50e-6}, "ramp_end_time"),
        ({"tx_order": [0, 0, 1]}, "tx_order"),
        ({"antenna_pattern": "horn"}, "antenna_pattern"),
        ({"rx_positions": np.zeros((4, 2))}, "rx_positions"),
        ({"noise_figure": float("nan")}, "noise_figure"),
    ],
)
def test_validation_names_the_field(change, field):
    with pytest.raises(RadarConfigError, match=field):
        RadarConfig.preset("walk-77ghz").replace(**change)


def test_cpi_longer_than_frame_period_rejected():
    radar = RadarConfig.preset("walk-77ghz").replace(num_chirps=512)
    with pytest.raises(RadarConfigError, match="frame period"):
        radar.validate(frame_period=1 / 24)


def test_from_dict_names_unknown_and_missing_fields():
    data = RadarConfig.preset("walk-77ghz").to_dict()
    with pytest.raises(RadarConfigError, match="carrier"):
        RadarConfig.from_dict({**data, "carrier": 1.0})
    del data["slope"]
    with pytest.raises(RadarConfigError, match="slope"):
        RadarConfig.from_dict(data)


# ============================================================================ RadarConfig.resolve
def test_resolve_every_form_gives_the_same_radar(tmp_path):
    preset = RadarConfig.preset("walk-77ghz")
    assert RadarConfig.resolve(preset) is preset
    assert RadarConfig.resolve("walk-77ghz") == preset
    assert RadarConfig.resolve(preset.to_dict()) == preset
    full = tmp_path / "full.json"
    full.write_text(preset.to_json())
    assert RadarConfig.resolve(full) == preset and RadarConfig.resolve(str(full)) == preset
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps({"preset": "walk-77ghz", "num_chirps": 64, "noise_figure": 10.0}))
    expected = preset.replace(num_chirps=64, noise_figure=10.0, name="walk-77ghz*")
    assert RadarConfig.resolve(changed) == expected
    assert RadarConfig.resolve({"preset": "walk-77ghz", "num_chirps": 64, "noise_figure": 10.0}) == expected
    assert RadarConfig.resolve({"preset": "walk-77ghz"}).name == "walk-77ghz"
    assert RadarConfig.resolve({"preset": "walk-77ghz", "num_chirps": 64, "name": "mine"}).name == "mine"


@pytest.mark.parametrize("content, match", [
    ('{"preset": "walk-77ghz",\n "num_chirps": 64,,}', r"bad\.json: invalid JSON at line 2, column 19"),
    ('[1, 2]', r"bad\.json: the radar file must hold a JSON object"),
    ('{"preset": "walk-77ghz", "chirps": 8}', r"bad\.json: unknown RadarConfig field\(s\) chirps; known: .*num_chirps"),
    ('{"preset": "awr9999"}', r"bad\.json: field 'preset' is 'awr9999'; choose one of .*walk-77ghz"),
    ('{"preset": "walk-77ghz", "fc": "77 GHz"}', r"bad\.json: RadarConfig\.fc must be a number"),
    ('{"preset": "walk-77ghz", "num_chirps": 6.5}', r"bad\.json: RadarConfig\.num_chirps must be an integer"),
    ('{"preset": "walk-77ghz", "tx_positions": [[0, 0]]}', r"bad\.json: RadarConfig\.tx_positions must be a list of \[x, y, z\]"),
    ('{"preset": "walk-77ghz", "tx_order": ["a"]}', r"bad\.json: RadarConfig\.tx_order must be a list of Tx indices"),
    ('{"preset": "walk-77ghz", "num_samples": 100000}', r"bad\.json: RadarConfig: the ADC window"),
])
def test_resolve_file_errors_name_the_file_and_the_field(tmp_path, content, match):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(RadarConfigError, match=match):
        RadarConfig.resolve(path)


def test_resolve_names_what_is_not_a_radar(tmp_path):
    with pytest.raises(RadarConfigError, match=r"'awr9999' is neither a preset \(.*walk-77ghz.*\) nor an existing"):
        RadarConfig.resolve("awr9999")
    with pytest.raises(RadarConfigError, match=r"missing\.json: no such radar file"):
        RadarConfig.resolve(str(tmp_path / "missing.json"))
    with pytest.raises(RadarConfigError, match=r"is a directory"):
        RadarConfig.resolve(tmp_path)
    with pytest.raises(RadarConfigError, match=r"got int"):
        RadarConfig.resolve(3)


def test_resolve_reads_a_ti_cfg_through_the_io_package(tmp_path):
    from sionnafmcw.ti.cfg import write_ti_cfg

    preset = RadarConfig.preset("ti-awr1843boost")
    path = tmp_path / "profile_3d.cfg"
    path.write_text(write_ti_cfg(preset))
    assert RadarConfig.resolve(path) == preset and RadarConfig.resolve(str(path)) == preset
    bad = tmp_path / "empty.cfg"
    bad.write_text("% no profileCfg here\n")
    with pytest.raises(RadarConfigError, match=r"empty\.cfg"):
        RadarConfig.resolve(bad)


# ============================================================================ virtual array
def test_virtual_array_and_phase_centre_properties():
    from sionnafmcw import array
    from sionnafmcw.geometry import rotation_matrix, world_phase_centre

    radar = RadarConfig.preset("ti-awr1843boost")
    p = radar.virtual_array
    assert p.shape == (radar.num_tx * radar.num_rx, 3)
    # tx-major: element m*N + n is tx m + rx n
    assert np.allclose(p[1 * radar.num_rx + 2], radar.tx_positions[1] + radar.rx_positions[2])
    assert np.allclose(radar.phase_centre, p.mean(axis=0) / 2)
    assert np.allclose(array.phase_centre(radar), radar.phase_centre)
    position, orientation = np.array([1.0, 2.0, 0.5]), np.array([0.3, 0.0, 0.0])
    assert np.allclose(world_phase_centre(radar, position, orientation),
                       position + rotation_matrix(orientation) @ radar.phase_centre)


def test_libllvm_found_and_configured(tmp_path):
    path = find_libllvm()
    assert path is not None and os.path.isfile(path)
    assert os.environ["DRJIT_LIBLLVM_PATH"] == sionnafmcw.LIBLLVM_PATH
    # only version >= 16 qualifies
    (tmp_path / "libLLVM-15.so").write_bytes(b"")
    assert find_libllvm(search_dirs=[str(tmp_path)]) is None
    (tmp_path / "libLLVM-17.so").write_bytes(b"")
    assert find_libllvm(search_dirs=[str(tmp_path)]).endswith("libLLVM-17.so")


def test_missing_libllvm_is_a_clear_error(tmp_path):
    """A fresh interpreter with no libLLVM >= 16 to find: import fails with the install command."""
    import subprocess
    import sys

    code = (
        "import sionnafmcw._llvm as l; l.SEARCH_DIRS=(); "
        "import os; os.environ.pop('DRJIT_LIBLLVM_PATH', None)\n"
        "try:\n    l.configure_llvm.__defaults__\n    l.find_libllvm.__defaults__ = (16, ())\n    l.configure_llvm()\n"
        "except l.LLVMNotFoundError as e:\n    print('ERR', e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "ERR" in out and "apt-get install -y libllvm19" in out
