"""The TI output formats, each read back by a reader written here from the documented layout
(``struct`` for the UART stream, the ``rosbags`` reader for ROS 2 bags, PyYAML / ``np.load`` for
RadHAR), never by the writers' code; and RadHAR's real recordings through the project's reader."""

from __future__ import annotations

import math
import struct
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from sionnafmcw.ti.formats import (DriverParams, TlvError, read_dataset, read_recording,
                                   recording_from_frames, ros_scan, write_npz, write_rosbag2,
                                   write_text, write_tlv)
from sionnafmcw.ti.points import DetectedPoints, GuiMonitor

REALDATA = Path(__file__).resolve().parents[1] / ".." / ".." / "shared" / "realdata" / "radhar"
if not REALDATA.is_dir():
    REALDATA = Path("/work/shared/realdata/radhar")
needs_radhar = pytest.mark.skipif(not (REALDATA / "train").is_dir(),
                                  reason="RadHAR's real recordings (shared/realdata/radhar) absent")

#: RadHAR's .cfg (1443es1_short_range_3d.cfg) as the driver's ParameterParser reads it: profileCfg
#: startFreq 77 GHz, idle 7 us, adcStart 7 us, rampEnd 57.14 us, slope 70 MHz/us, 240 samples at
#: 4884 ksps; frameCfg chirps 0..2 (3 Tx), 16 loops.
RADHAR_PROFILE = SimpleNamespace(fc=77e9, chirp_interval=(7 + 57.14) * 1e-6, adc_start_time=7e-6,
                                 slope=70e12, num_samples=240, fs=4884e3, tx_order=[0, 2, 1],
                                 num_chirps=16)
Q = 9


def sdk2_frame(frame_number=7, time=0.2, n_range=8, n_doppler=16):
    """Three SDK 1.x/2.x points on the Q9 grid; the second at sensor y = 0 (the driver drops it)."""
    x = np.array([0.5, -0.25, -1.0], np.float32)
    y = np.array([2.0, 0.0, 3.5], np.float32)
    z = np.array([0.125, 0.0, -0.5], np.float32)
    det = (np.arange(n_range * n_doppler, dtype=np.uint16) * 3).reshape(n_range, n_doppler)
    return DetectedPoints(
        frame_number=frame_number, time=time, sdk=2, platform=0xA1443, x=x, y=y, z=z,
        velocity=np.array([0.0, -0.6, 1.2], np.float32),
        range_index=np.array([49, 6, 87], np.uint16),
        doppler_index=np.array([0, -1, 2], np.int16),
        peak_value=np.array([1185, 600, 4000], np.uint16),
        snr_db=np.array([20.0, 10.0, 30.0], np.float32),
        noise_db=np.array([40.0, 40.0, 40.0], np.float32), xyz_q_format=Q,
        range_step=0.04, doppler_step=0.6, range_profile=det[:, 0].copy(),
        noise_profile=det[:, n_doppler // 2 - 1].copy(), range_doppler_heatmap=det)


def sdk3_frame(frame_number=3, time=0.1, n=2, n_range=8, n_virtual=8):
    heat = (np.arange(n_range * n_virtual).reshape(n_range, n_virtual)
            + 1j * -np.arange(n_range * n_virtual).reshape(n_range, n_virtual)).astype(np.complex64)
    return DetectedPoints(
        frame_number=frame_number, time=time, sdk=3, platform=0xA1843,
        x=np.array([0.3, -1.1], np.float32)[:n], y=np.array([2.2, 4.4], np.float32)[:n],
        z=np.array([0.0, 0.7], np.float32)[:n], velocity=np.array([-0.5, 0.25], np.float32)[:n],
        range_index=np.array([50, 100], np.uint16)[:n], doppler_index=np.array([-2, 1], np.int16)[:n],
        peak_value=np.array([3000, 2000], np.uint16)[:n], snr_db=np.array([23.4, 15.1], np.float32)[:n],
        noise_db=np.array([61.2, 60.0], np.float32)[:n], range_profile=np.arange(n_range, dtype=np.uint16),
        noise_profile=np.arange(n_range, dtype=np.uint16) + 100, azimuth_static_heatmap=heat,
        range_doppler_heatmap=np.ones((n_range, 16), np.uint16))


# ------------------------------------------------------------------- an independent UART parser
def parse_uart(stream: bytes):
    """Split a UART capture into packets as the SDK documents it (not the writer's code)."""
    magic = bytes([2, 1, 4, 3, 6, 5, 8, 7])
    packets, pos = [], 0
    while pos < len(stream):
        assert stream[pos:pos + 8] == magic, f"no magic word at byte {pos}"
        version, total, platform = struct.unpack_from("<3I", stream, pos + 8)
        sdk3 = (platform & 0xFFFF) != 0x1443
        names = ["frame", "cycles", "num_obj", "num_tlv"] + (["subframe"] if sdk3 else [])
        values = struct.unpack_from(f"<{len(names)}I", stream, pos + 20)
        head = dict(zip(names, values), version=version, total=total, platform=platform)
        off = pos + (40 if sdk3 else 36)
        tlvs = []
        for _ in range(head["num_tlv"]):
            kind, length = struct.unpack_from("<2I", stream, off)
            tlvs.append((kind, stream[off + 8: off + 8 + length]))
            off += 8 + length
        head["padding"] = stream[off: pos + total]
        packets.append((head, tlvs))
        pos += total
    return packets


def test_tlv_sdk2_layout(tmp_path):
    gui = GuiMonitor(detected_objects=1, log_mag_range=True, noise_profile=True,
                     range_doppler_heatmap=True, stats=True)
    frames = [sdk2_frame(7, 0.2), sdk2_frame(8, 0.2 + 1 / 30)]
    out = tmp_path / "uart.bin"
    assert write_tlv(out, frames, gui) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["uart.bin"]      # no temporary left
    packets = parse_uart(out.read_bytes())
    assert len(packets) == 2
    for (head, tlvs), frame in zip(packets, frames):
        assert head["version"] >> 24 == 2 and head["platform"] == 0xA1443
        assert head["total"] % 32 == 0 and set(head["padding"]) <= {0}
        assert len(head["padding"]) < 32
        assert head["frame"] == frame.frame_number and head["num_obj"] == 3
        assert head["cycles"] == round(frame.time * 200e6)
        assert [k for k, _ in tlvs] == [1, 2, 3, 5, 6]
        body = tlvs[0][1]
        n, q = struct.unpack_from("<2H", body)
        assert (n, q) == (3, Q) and len(body) == 4 + 12 * n
        for i in range(n):
            r, d, peak, x, y, z = struct.unpack_from("<HhHhhh", body, 4 + 12 * i)
            assert (r, d, peak) == (frame.range_index[i], frame.doppler_index[i], frame.peak_value[i])
            assert (x / 2**q, y / 2**q, z / 2**q) == (frame.x[i], frame.y[i], frame.z[i])
        assert np.array_equal(np.frombuffer(tlvs[1][1], "<u2"), frame.range_profile)
        assert np.array_equal(np.frombuffer(tlvs[2][1], "<u2"), frame.noise_profile)
        assert np.array_equal(np.frombuffer(tlvs[3][1], "<u2").reshape(8, 16),
                              frame.range_doppler_heatmap)
        assert tlvs[4][1] == bytes(24)


def test_tlv_sdk3_layout(tmp_path):
    gui = GuiMonitor(detected_objects=1, log_mag_range=True, noise_profile=True,
                     range_azimuth_heatmap=True, range_doppler_heatmap=True, stats=True)
    frame = sdk3_frame()
    out = tmp_path / "uart.bin"
    write_tlv(out, [frame, sdk3_frame(4, 0.2, n=0)], gui)
    (head, tlvs), (empty_head, empty_tlvs) = parse_uart(out.read_bytes())
    assert head["version"] >> 24 == 3 and head["subframe"] == 0 and head["total"] % 32 == 0
    assert [k for k, _ in tlvs] == [1, 7, 2, 3, 4, 5, 6, 9]
    pts = np.frombuffer(tlvs[0][1], "<f4").reshape(-1, 4)
    assert np.array_equal(pts, np.stack([frame.x, frame.y, frame.z, frame.velocity], -1))
    side = np.frombuffer(tlvs[1][1], "<i2").reshape(-1, 2)
    assert side.tolist() == [[234, 612], [151, 600]]            # 0.1 dB steps
    heat = np.frombuffer(tlvs[4][1], "<i2").reshape(8, 8, 2)    # cmplx16ImRe_t: imag first
    assert np.array_equal(heat[..., 1] + 1j * heat[..., 0], frame.azimuth_static_heatmap)
    valid, = struct.unpack_from("<i", tlvs[7][1])
    assert len(tlvs[7][1]) == 28 and valid == -1
    # no point: the SDK still sends TLV 1 (empty) for detectedObjects = 1, but no side info
    assert empty_head["num_obj"] == 0 and [(k, len(p)) for k, p in empty_tlvs][:2] == [(1, 0), (2, 16)]


def test_tlv_points_only_and_errors(tmp_path):
    gui = GuiMonitor(detected_objects=1)
    empty = sdk2_frame()
    empty = DetectedPoints(**{**empty.__dict__, **{k: getattr(empty, k)[:0] for k in (
        "x", "y", "z", "velocity", "range_index", "doppler_index", "peak_value", "snr_db",
        "noise_db")}})
    out = tmp_path / "uart.bin"
    write_tlv(out, [empty], gui)
    (head, tlvs), = parse_uart(out.read_bytes())
    assert head["num_tlv"] == 0 and head["total"] == 64       # 36-byte header padded to 64
    frame = sdk2_frame()
    bare = DetectedPoints(**{**frame.__dict__, "range_profile": None})
    with pytest.raises(TlvError, match="logMagRange"):
        write_tlv(tmp_path / "bad.bin", [bare], GuiMonitor(log_mag_range=True))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["uart.bin"]      # nothing of bad.bin
    other = DetectedPoints(**{**frame.__dict__, "platform": 0xA1843})
    with pytest.raises(TlvError, match="platform"):     # readers size the header by the platform
        write_tlv(tmp_path / "bad.bin", [other], gui)
    far = DetectedPoints(**{**frame.__dict__, "x": np.array([70.0, 0, 0], np.float32)})
    with pytest.raises(TlvError, match="int16"):
        write_tlv(tmp_path / "bad.bin", [far], gui)


# ------------------------------------------------------------------------------ the ROS driver
def test_driver_params_reproduce_radhar_grid():
    """The driver's float32 steps from RadHAR's .cfg are the real dumps' printed steps."""
    params = DriverParams.from_radar(RADHAR_PROFILE)
    assert "%.12g" % params.range_resolution == "0.0435769706964"
    assert "%.12g" % params.doppler_vel_resolution == "0.614668667316"
    assert params.num_loops == 16
    cfg = REALDATA / "1443es1_short_range_3d.cfg"
    if cfg.is_file():                                  # the same through the project's .cfg reader
        from sionnafmcw.ti import read_ti_cfg

        assert DriverParams.from_radar(read_ti_cfg(cfg)) == params


def test_ros_scan_axes_and_filter():
    params = DriverParams.from_radar(RADHAR_PROFILE)
    frame = sdk2_frame()
    scan = ros_scan(frame, params)
    assert scan.point_id.tolist() == [0, 2]                      # sensor y = 0 is not published
    assert np.array_equal(scan.x, frame.y[[0, 2]]) and np.array_equal(scan.y, -frame.x[[0, 2]])
    assert scan.doppler_bin.tolist() == [8, 10]
    np.testing.assert_allclose(scan.bearing, np.degrees(np.arctan2(-frame.x, frame.y))[[0, 2]],
                               rtol=1e-6)
    np.testing.assert_allclose(scan.intensity, 10 * np.log10(frame.peak_value[[0, 2]] + 1.0),
                               rtol=1e-6)
    np.testing.assert_allclose(scan.range, frame.range_index[[0, 2]] * params.range_resolution,
                               rtol=1e-6)
    narrow = DriverParams(params.range_resolution, params.doppler_vel_resolution, 16,
                          max_azimuth_deg=15.0)
    # azimuths atan(0.5 / 2) = 14.0 deg (kept) and atan(1 / 3.5) = 15.9 deg (dropped)
    assert ros_scan(frame, narrow).point_id.tolist() == [0]


@needs_radhar
def test_real_radhar_follows_the_driver_rules():
    """Every real point obeys the driver's rules: range and velocity on its grid, doppler_bin
    = index + 8, bearing = atan2(y, x), intensity = 10 log10(integer peakVal + 1) (to the float32
    rounding of the stored dB value)."""
    params = DriverParams.from_radar(RADHAR_PROFILE)
    for rec in list(read_dataset(REALDATA / "train"))[::10]:
        k = rec.range / np.float32(params.range_resolution)
        assert np.abs(k - np.round(k)).max() < 1e-4
        v = (rec.doppler_bin - 8) * np.float32(params.doppler_vel_resolution)
        assert np.abs(rec.velocity - v).max() < 1e-6
        b = np.degrees(np.arctan2(rec.y.astype(float), rec.x.astype(float)))
        assert np.abs(rec.bearing - b).max() < 1e-4
        peak = 10 ** (rec.intensity.astype(float) / 10) - 1
        ulp = (peak + 1) * math.log(10) / 10 * np.abs(rec.intensity) * 2.0**-22
        assert np.all(np.abs(peak - np.round(peak)) <= ulp + 1e-9)
        assert np.all(rec.x != 0)


# ------------------------------------------------------------------------------------ RadHAR
#: The first two messages of RadHAR's Data/Train/boxing/20_boxing_1.txt (nesl/RadHAR), from
#: ``point_id`` on (the header's seq and nanosecond stamp are not in the .npz).
REAL_TEXT = """point_id: 0
x: 0.01171875
y: -0.0390625
z: -0.0078125
range: 0.0435769706964
velocity: 0.0
doppler_bin: 8
bearing: -73.3007583618
intensity: 30.7445068359
---
point_id: 1
x: 0.017578125
y: -0.080078125
z: -0.0078125
range: 0.0871539413929
velocity: 0.0
doppler_bin: 8
bearing: -77.6192398071
intensity: 31.9865703583
---
"""


#: The same two messages verbatim, headers included (RadHAR's own layout, trailing spaces kept).
REAL_DUMP = ("header: \n  seq: 3026037\n  stamp: \n    secs: 1561686032\n    nsecs: 152442104\n"
             '  frame_id: "ti_mmwave"\n' + REAL_TEXT.split("---\n")[0] + "---\n"
             "header: \n  seq: 3026038\n  stamp: \n    secs: 1561686032\n    nsecs: 152517238\n"
             '  frame_id: "ti_mmwave"\n' + REAL_TEXT.split("---\n")[1] + "---\n")


def test_reader_reads_radhar_text_layout(tmp_path):
    path = tmp_path / "Data" / "Train" / "boxing" / "20_boxing_1.txt"
    path.parent.mkdir(parents=True)
    path.write_text(REAL_DUMP)
    rec = read_recording(path)
    assert rec.activity == "boxing" and rec.source == "Data/Train/boxing/20_boxing_1.txt"
    assert rec.point_id.tolist() == [0, 1] and rec.frame.tolist() == [0, 0]
    assert rec.x.tolist() == [0.01171875, 0.017578125] and rec.doppler_bin.tolist() == [8, 8]
    assert rec.stamp[1] - rec.stamp[0] == pytest.approx(75.134e-6, abs=1e-6)
    assert [r.num_points for r in read_dataset(tmp_path / "Data")] == [2]


@needs_radhar
def test_radhar_text_matches_the_real_dump(tmp_path):
    rec = read_recording(REALDATA / "train" / "boxing" / "s0_20_boxing_1.npz")
    assert rec.activity == "boxing" and rec.source == "Data/Train/boxing/20_boxing_1.txt"
    out = tmp_path / "20_boxing_1.txt"
    write_text(out, rec)
    lines = out.read_text().splitlines(keepends=True)
    assert lines[0] == "header: \n" and lines[2] == "  stamp: \n"
    assert lines[5] == '  frame_id: "ti_mmwave"\n'
    body = [line for line in lines[:32] if not line.startswith((" ", "header"))]
    assert "".join(body) == REAL_TEXT
    back = read_recording(out)                     # the project's reader of the text layout
    for name in ("frame", "point_id", "x", "y", "z", "range", "velocity", "doppler_bin",
                 "bearing", "intensity"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name), err_msg=name)
    np.testing.assert_allclose(back.stamp, rec.stamp, atol=1e-6)


def test_radhar_text_of_simulated_frames(tmp_path):
    params = DriverParams.from_radar(RADHAR_PROFILE)
    frames = [sdk2_frame(1, 0.0), sdk2_frame(2, 1 / 30)]
    rec = recording_from_frames(frames, params, stamp0=1000.0, activity="walk", source="sim")
    out = tmp_path / "sim.txt"
    write_text(out, rec)
    messages = [yaml.safe_load(m) for m in out.read_text().split("---\n") if m.strip()]
    assert len(messages) == 4                                 # 2 published points per frame
    first, third = messages[0], messages[2]
    assert first["header"]["frame_id"] == "ti_mmwave" and first["header"]["stamp"]["secs"] == 1000
    assert third["header"]["stamp"]["nsecs"] == round(1e9 / 30)
    assert [m["point_id"] for m in messages] == [0, 2, 0, 2]
    assert (first["x"], first["y"], first["z"]) == (2.0, -0.5, 0.125)
    assert messages[1]["doppler_bin"] == 10
    assert messages[1]["velocity"] == pytest.approx(2 * params.doppler_vel_resolution, rel=1e-6)
    assert first["intensity"] == pytest.approx(10 * math.log10(1186), rel=1e-6)


@needs_radhar
def test_npz_has_the_real_arrays(tmp_path):
    params = DriverParams.from_radar(RADHAR_PROFILE)
    rec = recording_from_frames([sdk2_frame(1, 0.0), sdk2_frame(2, 1 / 30)], params,
                                activity="walk", source="sim.zarr")
    out = tmp_path / "sim.npz"
    write_npz(out, rec)
    real = np.load(REALDATA / "train" / "walk" / "s2_20_walk_1.npz")
    sim = np.load(out)
    assert sorted(sim.files) == sorted(real.files)
    for name in real.files:
        assert sim[name].dtype.kind == real[name].dtype.kind, name
        if real[name].ndim:
            assert sim[name].dtype == real[name].dtype, name
    assert sim["frame"].tolist() == [0, 0, 1, 1] and str(sim["activity"]) == "walk"
    assert read_recording(out).num_frames == 2


@needs_radhar
def test_real_radhar_training_split_loads():
    """All real training recordings load; points per frame as the data set's README measured."""
    recs = list(read_dataset(REALDATA / "train"))
    assert len(recs) == 131
    assert {r.activity for r in recs} == {"boxing", "jack", "jump", "squats", "walk"}
    boxing = np.concatenate([r.points_per_frame() for r in recs if r.activity == "boxing"])
    assert round(float(boxing.mean()), 1) == 23.2 and np.median(boxing) == 23
    for r in recs[::13]:
        starts = np.flatnonzero(np.diff(r.frame)) + 1
        assert np.all(np.diff(r.point_id.astype(int))[starts - 1] <= 0)   # ids restart per frame


def test_reader_rejects_non_radhar(tmp_path):
    bad = tmp_path / "walk" / "x.txt"
    bad.parent.mkdir()
    bad.write_text("header: \npoint_id: 0\ncolour: red\n---\n")
    with pytest.raises(ValueError, match=r"x\.txt:3: unknown field 'colour'"):
        read_recording(bad)
    np.savez(tmp_path / "y.npz", frame=np.zeros(1))
    with pytest.raises(ValueError, match="missing arrays"):
        read_recording(tmp_path / "y.npz")


# ------------------------------------------------------------------------------------ ROS 2 bag
def test_rosbag2_read_back_with_rosbags(tmp_path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    params = DriverParams.from_radar(RADHAR_PROFILE)
    frames = [sdk2_frame(1, 0.0), sdk3_frame(2, 0.05)]
    out = tmp_path / "bag"
    assert write_rosbag2(out, frames, params, stamp0=10.0) == 2
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(out) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert conns["/ti_mmwave/radar_scan_pcl"].msgtype == "sensor_msgs/msg/PointCloud2"
        scan_conn = conns["/ti_mmwave/radar_scan"]
        assert scan_conn.msgtype == "ti_mmwave_rospkg_msgs/msg/RadarScan"
        store.register(get_types_from_msg(scan_conn.msgdef.data, scan_conn.msgtype))
        clouds, scans = [], []
        for conn, t_ns, raw in reader.messages():
            msg = store.deserialize_cdr(raw, conn.msgtype)
            (clouds if conn.topic.endswith("_pcl") else scans).append((t_ns, msg))
    assert [t for t, _ in clouds] == [10_000_000_000, 10_050_000_000]
    t0, cloud = clouds[0]
    assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == [
        ("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 16, 7), ("velocity", 20, 7)]
    assert cloud.point_step == 32 and cloud.width == 2 and cloud.height == 1
    assert cloud.header.frame_id == "ti_mmwave" and cloud.header.stamp.sec == 10
    data = np.frombuffer(cloud.data.tobytes(), "<f4").reshape(-1, 8)
    sdk2 = frames[0]
    assert np.array_equal(data[:, 0], sdk2.y[[0, 2]]) and np.array_equal(data[:, 1], -sdk2.x[[0, 2]])
    np.testing.assert_allclose(data[:, 4], 10 * np.log10(sdk2.peak_value[[0, 2]] + 1.0), rtol=1e-6)
    np.testing.assert_allclose(data[:, 5], sdk2.doppler_index[[0, 2]] * params.doppler_vel_resolution,
                               rtol=1e-6)
    sdk3 = np.frombuffer(clouds[1][1].data.tobytes(), "<f4").reshape(-1, 8)
    assert np.array_equal(sdk3[:, 5], frames[1].velocity)
    np.testing.assert_allclose(sdk3[:, 4], [23.4, 15.1], rtol=1e-6)        # snr / 10
    assert [m.point_id for _, m in scans] == [0, 2, 0, 1]
    assert scans[1][1].doppler_bin == 10 and scans[1][1].stamp == 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]
    assert sorted(p.name for p in out.iterdir()) == ["bag.db3", "metadata.yaml"]


def test_rosbag2_interrupted_leaves_nothing(tmp_path):
    params = DriverParams.from_radar(RADHAR_PROFILE)

    def frames():
        yield sdk2_frame(1, 0.0)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_rosbag2(tmp_path / "bag", frames(), params)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "bag").mkdir()
    with pytest.raises(FileExistsError, match="bag exists"):
        write_rosbag2(tmp_path / "bag", [sdk2_frame()], params)
