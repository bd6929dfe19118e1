"""``sionnafmcw pointcloud``: a real run store through the board's chain into each format, read back
by independent readers; one-line errors that leave nothing behind."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.cli import main
from sionnafmcw.scenes import registry

RADHAR_CFG = Path("/work/shared/realdata/radhar/1443es1_short_range_3d.cfg")
if not RADHAR_CFG.is_file():
    RADHAR_CFG = Path(__file__).resolve().parents[3] / "shared" / "realdata" / "radhar" / RADHAR_CFG.name
needs_cfg = pytest.mark.skipif(not RADHAR_CFG.is_file(), reason="RadHAR's .cfg (shared/realdata/radhar) absent")


def _simulate(tmp, radar, name):
    import sionnafmcw as sf

    # three frames, two simulated: the third is not done
    scene = registry.build("moving_plate", tmp / f"{name}-scene", num_frames=3, start_range=2.0, speed=0.5)
    out = tmp / f"{name}.zarr"
    sf.simulate(scene, radar, engine="pixel", out=out, progress=False, frames=[0, 1],
                engine_options={"n_az": 32, "n_el": 16, "scattering_coefficient": 1.0})
    return out


@pytest.fixture(scope="module")
def radhar_run(tmp_path_factory):
    """A plate 2 m in front of the IWR1443BOOST with RadHAR's .cfg (the radar keeps its processing lines)."""
    if not RADHAR_CFG.is_file():
        pytest.skip("RadHAR's .cfg (shared/realdata/radhar) absent")
    return _simulate(tmp_path_factory.mktemp("pointcloud"), str(RADHAR_CFG), "radhar")


@pytest.fixture(scope="module")
def preset_run(tmp_path_factory):
    """A run whose radar is a preset: no .cfg processing lines to default to."""
    return _simulate(tmp_path_factory.mktemp("pointcloud-preset"), "ti-awr1843boost", "preset")


def _bad_cfg(tmp_path) -> str:
    text = RADHAR_CFG.read_text().replace("peakGrouping 1 0 1 1 229", "peakGrouping 1 0 1")
    path = tmp_path / "bad.cfg"
    path.write_text(text)
    return str(path)


@needs_cfg
@pytest.mark.parametrize("argv, culprit", [
    (["pointcloud", "missing.zarr", "--out", "{tmp}/o.npz"], "missing.zarr"),
    (["pointcloud", "{run}", "--out", "{tmp}/exists.npz"], "exists"),
    (["pointcloud", "{run}", "--out", "{tmp}/no/such/o.npz"], "does not exist"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--format", "pcd"], "pcd"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--cfg", "{tmp}/none.cfg"], "none.cfg"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--cfg", "{bad}"], "peakGrouping"),
    (["pointcloud", "{preset}", "--out", "{tmp}/o.npz"], "--cfg"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--frames", "5"], "--frames"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--frames", "1:3"], "not simulated"),
    (["pointcloud", "{run}", "--out", "{tmp}/o.npz", "--stamp0", "inf"], "--stamp0"),
])
def test_pointcloud_bad_input_is_one_line_and_leaves_nothing(radhar_run, preset_run, tmp_path, capsys,
                                                             argv, culprit):
    (tmp_path / "exists.npz").write_bytes(b"keep")
    argv = [a.format(run=radhar_run, preset=preset_run, tmp=tmp_path, bad=_bad_cfg(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("sionnafmcw: error:") and culprit in err, err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.cfg", "exists.npz"]
    assert (tmp_path / "exists.npz").read_bytes() == b"keep"


def test_pointcloud_help_ends_with_an_example(capsys):
    assert main(["pointcloud", "--help"]) == 0
    text = capsys.readouterr().out.rstrip()
    assert text.splitlines()[-2].strip() == "example:"
    assert text.splitlines()[-1].strip().startswith("sionnafmcw pointcloud ")


@needs_cfg
def test_pointcloud_end_to_end_in_every_format(radhar_run, tmp_path, capsys):
    """The plate at 2 m comes out of the SDK 1.x/2.x chain and lands, through each writer, where
    an independent reader finds it: forward (ROS x) within one range bin of the sensor's range."""
    import yaml
    from rosbags.rosbag2 import Reader

    from sionnafmcw.store import open_run

    truth = float(open_run(radhar_run).object_range("plate")[0])                   # 2.0 m
    outputs = {}
    for fmt, name in (("npz", "pc.npz"), ("radhar", "pc.txt"), ("tlv", "pc.bin"), ("rosbag2", "pc_bag")):
        out = tmp_path / name
        assert main(["pointcloud", str(radhar_run), "--out", str(out), "--format", fmt, "--quiet"]) == 0
        printed = capsys.readouterr().out
        assert "2 frames" in printed and "SDK 1.x/2.x" in printed, printed
        print(printed.strip())
        outputs[fmt] = out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pc.bin", "pc.npz", "pc.txt", "pc_bag"]
    bin_m = 3e8 * 4884e3 / (2 * 70e12 * 256)                                  # the device's range bin
    arrays = np.load(outputs["npz"])
    assert set(arrays["frame"].tolist()) <= {0, 1} and arrays["x"].size > 0
    assert np.min(np.abs(np.sqrt(arrays["x"] ** 2 + arrays["y"] ** 2 + arrays["z"] ** 2) - truth)) < 1.5 * bin_m
    messages = [yaml.safe_load(m) for m in outputs["radhar"].read_text().split("---\n") if m.strip()]
    assert [m["x"] for m in messages] == pytest.approx(arrays["x"].tolist())
    stream, pos, sensor = outputs["tlv"].read_bytes(), 0, []
    while pos < len(stream):                 # SDK 1.x/2.x packets: 36-byte header, TLV 1 in Q format
        assert stream[pos:pos + 8] == bytes([2, 1, 4, 3, 6, 5, 8, 7])
        version, total, platform, _, _, num_obj, num_tlv = struct.unpack_from("<7I", stream, pos + 8)
        assert version >> 24 == 2 and platform & 0xFFFF == 0x1443 and total % 32 == 0
        if num_tlv:
            kind, _ = struct.unpack_from("<2I", stream, pos + 36)
            count, q = struct.unpack_from("<2H", stream, pos + 44)
            assert kind == 1 and count == num_obj
            sensor += [np.array(struct.unpack_from("<3h", stream, pos + 48 + 12 * i + 6)) / 2**q
                       for i in range(count)]
        pos += total
    sensor = np.array(sensor)
    published = sensor[sensor[:, 1] != 0]                 # the driver drops points at sensor y = 0
    np.testing.assert_array_equal(arrays["x"], published[:, 1])
    np.testing.assert_array_equal(arrays["y"], -published[:, 0])
    np.testing.assert_array_equal(arrays["z"], published[:, 2])
    with Reader(outputs["rosbag2"]) as reader:
        topics = {c.topic for c in reader.connections}
        assert topics == {"/ti_mmwave/radar_scan_pcl", "/ti_mmwave/radar_scan"}
        assert sum(c.msgcount for c in reader.connections if c.topic == "/ti_mmwave/radar_scan") == arrays["x"].size
