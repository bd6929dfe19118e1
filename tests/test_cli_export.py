"""``sionnafmcw export``: a simulated run as a TI DCA1000 capture, read back; one-line errors."""

import json

import numpy as np
import pytest

from sionnafmcw.cli import main
from sionnafmcw.ti.dca1000 import AdcScale, read_dca1000
from sionnafmcw.scenes import registry
from sionnafmcw.store import open_run


@pytest.fixture(scope="module")
def plate_run(tmp_path_factory):
    import sionnafmcw as sf

    tmp = tmp_path_factory.mktemp("export")
    scene = registry.build("moving_plate", tmp / "plate", num_frames=3, start_range=3.0, speed=0.5)
    out = tmp / "plate.zarr"
    sf.simulate(scene, "ti-awr1843boost", engine="pixel", out=out, progress=False, frames=[0, 1],
                engine_options={"n_az": 32, "n_el": 16, "scattering_coefficient": 1.0})
    return out


def test_export_writes_a_capture_that_reads_back_as_the_run(plate_run, tmp_path, capsys):
    out = tmp_path / "capture"
    assert main(["export", str(plate_run), "--out", str(out), "--frames", "0:2", "--rx-gain-db", "40"]) == 0
    printed = capsys.readouterr().out
    assert "2 frames" in printed and "clipped" in printed
    assert sorted(p.name for p in out.iterdir()) == ["adc_data.bin", "capture.cfg", "capture.json"]
    run = open_run(plate_run)
    cube = read_dca1000(out)                                 # counts, [frame, chirp, tx, rx, sample]
    scale = AdcScale(rx_gain_db=40.0).counts_per_sqrt_watt
    expected = run.cubes([0, 1]) * scale
    assert cube.shape == expected.shape
    # int16 quantisation: every I and Q within half a count of the scaled cube (nothing clipped here)
    sidecar = json.loads((out / "capture.json").read_text())
    assert sum(sidecar["clipping"]["clipped_per_frame"]) == 0
    assert np.max(np.abs(cube.real - expected.real)) <= 0.5 + 1e-3
    assert np.max(np.abs(cube.imag - expected.imag)) <= 0.5 + 1e-3
    np.testing.assert_allclose(sidecar["frame_time"], run.frame_times[[0, 1]])
    np.testing.assert_allclose(np.asarray(sidecar["truth"]["radial_velocity"])[:, 0], run.truth("plate")[[0, 1]])


@pytest.mark.parametrize("argv, culprit", [
    (["export", "missing.zarr", "--out", "x"], "missing.zarr"),
    (["export", "{run}", "--out", "{tmp}/c", "--frames", "2"], "frame"),      # frame 2 is not simulated
    (["export", "{run}", "--out", "{tmp}/c", "--frames", "7"], "--frames"),   # outside the run
    (["export", "{run}", "--out", "{tmp}/c", "--rx-gain-db", "nan"], "--rx-gain-db"),
    (["export", "{run}", "--out", "{tmp}/c", "--frames", "0", "--board", "ti-nonexistent"], "board"),
])
def test_export_bad_input_is_one_line_and_leaves_nothing(plate_run, tmp_path, capsys, argv, culprit):
    argv = [a.format(run=plate_run, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("sionnafmcw: error:") and culprit in err
    assert "Traceback" not in err
    assert not (tmp_path / "c").exists() and not any(p.name.startswith(".c.") for p in tmp_path.iterdir())


def test_export_refuses_to_overwrite_without_replace(plate_run, tmp_path, capsys):
    out = tmp_path / "capture"
    assert main(["export", str(plate_run), "--out", str(out), "--frames", "0"]) == 0
    before = (out / "adc_data.bin").read_bytes()
    assert main(["export", str(plate_run), "--out", str(out), "--frames", "0:2"]) == 2
    assert "exists" in capsys.readouterr().err
    assert (out / "adc_data.bin").read_bytes() == before
    assert main(["export", str(plate_run), "--out", str(out), "--frames", "0:2", "--replace"]) == 0
    assert len((out / "adc_data.bin").read_bytes()) == 2 * len(before)
