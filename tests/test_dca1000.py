"""DCA1000 raw captures: TI's lane order, bit-exact round trips, counted clipping, refused bad files, run export."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sionnafmcw import Echoes, RadarConfig, synthesize
from sionnafmcw.ti import dca1000
from sionnafmcw.ti.dca1000 import (AdcScale, CaptureError, export_run, read_dca1000, read_npz, write_capture,
                                   write_dca1000)


def small(preset="ti-awr1843boost", **changes):
    """A TI preset with a short frame (4 loops, 16 samples) for hand-checkable files."""
    radar = RadarConfig.preset(preset)
    return radar.replace(**{"num_chirps": 4, "num_samples": 16, **changes})


def counting_cube(radar, frames=2):
    """Cube whose value encodes its index: I = 1000 f + 100 l + 10 tx + rx, Q = sample (already counts)."""
    f, l, t, r, s = np.meshgrid(*(np.arange(n) for n in (frames, radar.num_chirps, radar.num_tx, radar.num_rx,
                                                          radar.num_samples)), indexing="ij")
    return ((1000 * f + 100 * l + 10 * t + r) + 1j * s).astype(np.complex64)


def test_xwr16xx_lane_order_is_tis(tmp_path):
    """xWR16xx/18xx/68xx: chirps in firing order, rx by rx, samples as I0 I1 Q0 Q1 (TI SWRA581)."""
    radar = small(tx_order=[0, 2, 1])
    cube = counting_cube(radar)
    write_dca1000(cube, radar, tmp_path / "cap", scale=1.0)
    words = np.fromfile(tmp_path / "cap" / "adc_data.bin", dtype="<i2")
    assert words.size == 2 * cube.size
    # frame 0, loop 0, slot 0 (tx 0), rx 0: I(s0) I(s1) Q(s0) Q(s1) I(s2) I(s3) ...
    assert words[:8].tolist() == [0, 0, 0, 1, 0, 0, 2, 3]
    # rx 1 follows rx 0 after 2 * 16 words
    assert words[32:36].tolist() == [1, 1, 0, 1]
    # the second chirp is slot 1 = tx 2 (firing order), the fourth is loop 1 of tx 0
    chirp_words = 2 * radar.num_rx * radar.num_samples
    assert words[chirp_words] == 20 and words[3 * chirp_words] == 100
    # OpenRadar's DCA1000.organize formula (its xWR16xx reader), applied to one frame
    frame = words[: words.size // 2]
    organised = np.zeros(frame.size // 2, dtype=complex)
    organised[0::2] = frame[0::4] + 1j * frame[2::4]
    organised[1::2] = frame[1::4] + 1j * frame[3::4]
    organised = organised.reshape(radar.num_chirps * radar.num_tx, radar.num_rx, radar.num_samples)
    expected = cube[0][:, radar.tx_order].reshape(organised.shape)
    np.testing.assert_array_equal(organised, expected)


def test_xwr14xx_lane_order_is_tis(tmp_path):
    """xWR14xx, 4 lanes (one per rx): per sample I_rx0..I_rx3 then Q_rx0..Q_rx3 (TI SWRA581)."""
    radar = small("ti-iwr1443boost")
    cube = counting_cube(radar)
    write_dca1000(cube, radar, tmp_path / "cap", scale=1.0)
    words = np.fromfile(tmp_path / "cap" / "adc_data.bin", dtype="<i2")
    assert words[:8].tolist() == [0, 1, 2, 3, 0, 0, 0, 0]
    assert words[8:16].tolist() == [0, 1, 2, 3, 1, 1, 1, 1]
    chirp_words = 2 * radar.num_rx * radar.num_samples
    assert words[chirp_words:chirp_words + 4].tolist() == [10, 11, 12, 13]


@pytest.mark.parametrize("preset", ["ti-awr1843boost", "ti-iwr6843isk", "ti-iwr1443boost"])
def test_round_trip_is_bit_exact(preset, tmp_path):
    radar = RadarConfig.preset(preset)
    echoes = Echoes.point_targets(radar, ranges=[2.0, 3.5], radial_velocities=[0.3, -0.5],
                                  azimuths=np.deg2rad([-10, 20]), rcs=[1.0, 3.0])
    cube = np.stack([synthesize(echoes, radar, frame_time=0.05 * i, rng=i) for i in range(2)])
    scale = AdcScale(rx_gain_db=36.0)
    report = write_dca1000(cube, radar, tmp_path / "a", scale=scale, frame_times=[0.0, 0.05])
    assert report.num_frames == 2 and report.clipped == 0
    counts = read_dca1000(tmp_path / "a")                          # radar from capture.cfg
    assert counts.dtype == np.complex64 and counts.shape == cube.shape
    expected = np.rint(cube.real * np.float64(scale.counts_per_sqrt_watt)) + 1j * np.rint(
        cube.imag * np.float64(scale.counts_per_sqrt_watt))
    np.testing.assert_array_equal(counts, expected.astype(np.complex64))
    assert read_dca1000(tmp_path / "a", radar) .tobytes() == counts.tobytes()
    # re-writing what was read gives the same bytes: the int16 level is exact both ways
    write_dca1000(counts, radar, tmp_path / "b", scale=1.0)
    assert (tmp_path / "b" / "adc_data.bin").read_bytes() == (tmp_path / "a" / "adc_data.bin").read_bytes()
    sidecar = json.loads((tmp_path / "a" / "capture.json").read_text())
    assert sidecar["frame_time"] == [0.0, 0.05] and sidecar["scale"]["rx_gain_db"] == 36.0
    assert sidecar["family"] == ("xWR14xx" if preset == "ti-iwr1443boost" else "xWR16xx")
    assert "profileCfg" in (tmp_path / "a" / "capture.cfg").read_text()


def test_bare_bin_with_the_boards_own_cfg(tmp_path):
    """A real board's capture: a bare adc_data.bin and the SDK .cfg it ran (no sidecar, no comments of ours)."""
    radar = small()
    cube = counting_cube(radar, frames=2)
    write_dca1000(cube, radar, tmp_path / "cap", scale=1.0)
    sdk_cfg = tmp_path / "profile.cfg"
    sdk_cfg.write_text("\n".join(line for line in (tmp_path / "cap" / "capture.cfg").read_text().splitlines()
                                 if not line.startswith("%")).replace("frameCfg 0 2 4 0", "frameCfg 0 2 4 2"))
    bare = tmp_path / "adc_data.bin"
    bare.write_bytes((tmp_path / "cap" / "adc_data.bin").read_bytes())
    np.testing.assert_array_equal(read_dca1000(bare, sdk_cfg), cube)
    bare.write_bytes(bare.read_bytes()[: bare.stat().st_size // 2])        # numFrames 2 in the .cfg
    with pytest.raises(CaptureError, match="expected 2 frames"):
        read_dca1000(bare, sdk_cfg)


def test_receiver_noise_in_counts(tmp_path):
    """Thermal noise k T0 F B_n lands at sqrt(P_n) * 10^(G/20) * 32767 / sqrt(P_FS) counts rms.

    B_n is the noise bandwidth of the preset's IF chain (HPF 175 + 350 kHz, the complex-1x anti-alias
    filter passing 0..0.8 Fs: 0.66 Fs, sionnafmcw.receiver.if_filter.noise_bandwidth); it was F_s
    when the cube had no IF chain (-1.8 dB since: the filters remove that much of the white noise
    on the board too). The cube already holds the preset's 16-bit ADC words at this scale."""
    from sionnafmcw.receiver.if_filter import noise_bandwidth

    radar = RadarConfig.preset("ti-awr1843boost")
    silent = Echoes.point_targets(radar, ranges=[2.0], radial_velocities=[0.0], azimuths=[0.0], rcs=[0.0])
    cube = synthesize(silent, radar, rng=3)
    scale = AdcScale(rx_gain_db=30.0, adc_full_scale_dbm=0.0)
    write_dca1000(cube, radar, tmp_path / "cap", scale=scale)
    counts = read_dca1000(tmp_path / "cap")
    bandwidth = noise_bandwidth(radar.if_filter, radar.fs)
    assert 0.6 * radar.fs < bandwidth < 0.8 * radar.fs
    noise_dbm = 10 * np.log10(1.380649e-23 * 290 * 1e3) + radar.noise_figure + 10 * np.log10(bandwidth)
    expected_rms = 10 ** ((noise_dbm + 30.0 - 0.0) / 20) * 32767            # -63.6 dBm at the ADC: 22 counts
    rms = np.sqrt(np.mean(np.abs(counts.astype(np.complex128)) ** 2))
    # 196608 complex samples: the rms estimate is good to 0.3 %; the rounding adds 1/6 count^2
    assert rms == pytest.approx(np.sqrt(expected_rms ** 2 + 1 / 6), rel=0.01)
    assert 20 < expected_rms < 35


def test_overdriven_capture_counts_its_clipping(tmp_path):
    radar = small()
    rng = np.random.default_rng(7)
    shape = (3, radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
    cube = (rng.normal(scale=20000, size=shape) + 1j * rng.normal(scale=20000, size=shape)).astype(np.complex64)
    report = write_dca1000(cube, radar, tmp_path / "cap", scale=1.0)
    iq = np.stack([cube.real, cube.imag]).astype(np.float64)
    over = np.rint(iq)
    expected = int(np.count_nonzero((over > 32767) | (over < -32768)))
    assert expected > 0 and report.clipped == expected
    per_frame = [int(np.count_nonzero((over[:, f] > 32767) | (over[:, f] < -32768))) for f in range(3)]
    assert report.clipped_per_frame == per_frame
    assert report.clipped_fraction == pytest.approx(expected / iq.size)
    assert report.peak_counts == 32768
    sidecar = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert sidecar["clipping"]["clipped_values"] == expected
    assert sidecar["clipping"]["clipped_per_frame"] == per_frame
    back = read_dca1000(tmp_path / "cap")
    assert back.real.max() == 32767 and back.real.min() == -32768
    assert f"{expected} of {iq.size} I/Q values clipped" in report.summary()


def test_bad_captures_are_refused_with_sizes(tmp_path):
    radar = small()
    write_dca1000(counting_cube(radar, frames=2), radar, tmp_path / "cap", scale=1.0)
    data = tmp_path / "cap" / "adc_data.bin"
    frame_bytes = radar.num_chirps * radar.num_tx * radar.num_rx * radar.num_samples * 4
    assert data.stat().st_size == 2 * frame_bytes

    truncated = tmp_path / "truncated.bin"
    truncated.write_bytes(data.read_bytes()[:-100])
    with pytest.raises(CaptureError) as err:
        read_dca1000(truncated, radar)
    message = str(err.value)
    assert f"{2 * frame_bytes - 100} bytes is not a whole number of frames of {frame_bytes} bytes" in message
    assert f"1 whole frames ({frame_bytes} bytes) and {frame_bytes - 100} bytes over" in message

    # a capture recorded with another .cfg: 32 samples per chirp where the file holds 16
    other = radar.replace(num_samples=32, num_chirps=3)
    with pytest.raises(CaptureError, match=rf"{2 * frame_bytes} bytes is not a whole number of frames of "
                                           rf"{frame_bytes * 2 * 3 // 4} bytes"):
        read_dca1000(data, other)

    # whole frames but not as many as the sidecar says
    data.write_bytes(data.read_bytes() + data.read_bytes()[:frame_bytes])
    with pytest.raises(CaptureError, match=rf"expected 2 frames = {2 * frame_bytes} bytes, the file has "
                                           rf"{3 * frame_bytes} bytes \(3 frames\)"):
        read_dca1000(tmp_path / "cap")
    with pytest.raises(CaptureError, match="expected 4 frames"):
        read_dca1000(truncated.parent / "cap" / "adc_data.bin", radar, num_frames=4)
    with pytest.raises(CaptureError, match="no such capture"):
        read_dca1000(tmp_path / "nothing.bin", radar)


def test_odd_sample_counts_are_refused_for_two_lanes(tmp_path):
    radar = small(num_samples=15)
    with pytest.raises(CaptureError, match="15 samples per chirp \\(odd\\)"):
        write_dca1000(np.zeros((1, 4, 3, 4, 15), np.complex64), radar, tmp_path / "cap")
    assert not (tmp_path / "cap").exists()


def test_npz_frames_in_ti_layout(tmp_path):
    radar = small(tx_order=[1, 0, 2])
    cube = counting_cube(radar, frames=2)
    write_dca1000(cube, radar, tmp_path / "bin", scale=1.0)
    write_dca1000(cube, radar, tmp_path / "npz", scale=1.0, format="npz", frame_times=[0.0, 0.1])
    adc = read_npz(tmp_path / "npz")
    assert adc.shape == (2, radar.num_chirps * radar.num_tx, radar.num_rx, radar.num_samples)
    assert adc[0, 1, 2, 3] == cube[0, 0, 0, 2, 3]            # chirp 1 = loop 0, slot 1 = tx 0
    np.testing.assert_array_equal(dca1000.from_firing_order(adc, radar), read_dca1000(tmp_path / "bin"))
    with np.load(tmp_path / "npz" / "adc_data.npz") as data:
        assert data["frame_time"].tolist() == [0.0, 0.1]


def write_run(path, radar, frames=3, done=None):
    """A run store written with the store's own writer: point targets at 2 m and 3 m."""
    from sionnafmcw.store import RunStore

    store = RunStore.open(path, radar, frames, ["a", "b"], {"radar": radar.to_dict(), "seed": 0})
    cubes = []
    for f in range(frames):
        echoes = Echoes.point_targets(radar, ranges=[2.0 + 0.01 * f, 3.0], radial_velocities=[0.2, -0.4],
                                      azimuths=[0.1, -0.2], rcs=[1.0, 1.0])
        cube = synthesize(echoes, radar, frame_time=0.1 * f, rng=f)
        cubes.append(cube)
        if done is None or f in done:
            store.write_frame(f, cube, 0.1 * f, np.full((2, 3), f, float), np.ones((2, 3)), [0.2, -0.4])
    return np.stack(cubes)


def test_export_run_dca1000_and_npz(tmp_path):
    radar = small()
    cubes = write_run(tmp_path / "run.zarr", radar)
    report = export_run(tmp_path / "run.zarr", tmp_path / "cap")
    assert report.num_frames == 3 and report.clipped == 0
    counts = read_dca1000(tmp_path / "cap")
    k = AdcScale().counts_per_sqrt_watt
    expected = np.rint(cubes.real.astype(np.float64) * k) + 1j * np.rint(cubes.imag.astype(np.float64) * k)
    np.testing.assert_array_equal(counts, expected.astype(np.complex64))
    sidecar = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert sidecar["frame_time"] == pytest.approx([0.0, 0.1, 0.2])
    assert sidecar["truth"]["objects"] == ["a", "b"]
    assert np.asarray(sidecar["truth"]["radial_velocity"]).tolist() == [[0.2, -0.4]] * 3
    assert np.asarray(sidecar["truth"]["position"])[2, 1].tolist() == [2.0, 2.0, 2.0]
    assert sidecar["source_run"].endswith("run.zarr") and sidecar["run_attrs"]["seed"] == 0

    npz = export_run(tmp_path / "run.zarr", tmp_path / "npz", format="npz", frames=[1, 2])
    assert npz.num_frames == 2
    np.testing.assert_array_equal(read_npz(tmp_path / "npz"), dca1000.to_firing_order(counts[1:], radar))

    # the target exists: refused, nothing half-written beside it
    with pytest.raises(FileExistsError):
        export_run(tmp_path / "run.zarr", tmp_path / "cap")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cap", "npz", "run.zarr"]
    with pytest.raises(CaptureError, match="unknown capture format 'tar'"):
        export_run(tmp_path / "run.zarr", tmp_path / "tar", format="tar")


def test_export_run_refuses_unfinished_frames(tmp_path):
    radar = small()
    write_run(tmp_path / "run.zarr", radar, frames=3, done={0, 2})
    with pytest.raises(CaptureError, match=r"frames \[1\] are not simulated yet"):
        export_run(tmp_path / "run.zarr", tmp_path / "cap")
    assert not (tmp_path / "cap").exists()
    assert export_run(tmp_path / "run.zarr", tmp_path / "cap", frames=[0, 2]).num_frames == 2


def test_write_capture_checks_frame_shapes(tmp_path):
    radar = small()
    with pytest.raises(CaptureError, match=r"frame 0 has shape \(4, 3, 4, 8\)"):
        write_capture(tmp_path / "cap", radar, [np.zeros((4, 3, 4, 8), np.complex64)])
    assert not (tmp_path / "cap").exists()
