"""The ``sionnafmcw`` command line: in-process through ``cli.main`` and once through the installed script.

User errors must give exactly one line ``sionnafmcw: error: ...`` on stderr, exit status 2 and no
traceback. The end-to-end tests build a three-frame moving plate, simulate it with a 32-chirp
radar and few rays, and plot every figure kind from the store.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from animation_helpers import write_plate_animation
from sionnafmcw import RadarConfig, cli
from sionnafmcw.cli import UserError, main, parse_frames

SMALL_RADAR = {"preset": "walk-77ghz", "num_chirps": 32}
FAST_PATH = ["--engine-option", "samples_per_src=5000"]


def run_cli(capsys, *argv):
    """``(status, stdout, stderr)`` of ``main(argv)`` in this process."""
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def assert_user_error(status, err, *fragments):
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == cli.EXIT_USER_ERROR, err
    assert len(lines) == 1, f"expected one line on stderr, got:\n{err}"
    assert lines[0].startswith("sionnafmcw: error: "), lines[0]
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], f"{fragment!r} not in {lines[0]!r}"


@pytest.fixture(scope="module")
def plate_scene(tmp_path_factory):
    """A hand-written 3-frame animation (plate at 4 m receding at 1 m/s, 24 fps): no scene builder needed."""
    root = tmp_path_factory.mktemp("scene") / "plate"
    return write_plate_animation(root, distance=4.0, velocity=(1.0, 0.0, 0.0), num_frames=3, fps=24.0,
                                 size=(0.5, 0.5))


@pytest.fixture(scope="module")
def small_radar_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("radar") / "radar.json"
    path.write_text(json.dumps(SMALL_RADAR))
    return path


# ============================================================================ version, help, script
def test_version(capsys):
    from sionnafmcw import __version__

    status, out, _ = run_cli(capsys, "--version")
    assert status == 0
    assert out.strip() == f"sionnafmcw {__version__}"


@pytest.mark.parametrize("command", [[], ["presets"], ["scene"], ["scene", "list"], ["scene", "build"],
                                     ["simulate"], ["plot"], ["validate"], ["dataset"], ["check"]])
def test_help_ends_with_an_example(capsys, command):
    status, out, _ = run_cli(capsys, *command, "--help")
    assert status == 0
    tail = out[out.rindex("example"):]
    assert tail.splitlines()[1].strip().startswith("sionnafmcw "), tail


def test_console_script(tmp_path):
    """The installed ``sionnafmcw`` script, once: one error line on stderr, status 2, nothing written."""
    script = Path(sys.executable).parent / "sionnafmcw"
    if not script.exists():
        script = shutil.which("sionnafmcw")
    assert script, "the console script 'sionnafmcw' is not installed (pip install -e .)"
    bad = subprocess.run([str(script), "simulate", str(tmp_path / "nowhere"), "--radar", "walk-77ghz",
                          "--out", str(tmp_path / "x.zarr")], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "Traceback" not in bad.stderr
    assert bad.stderr.startswith("sionnafmcw: error: SCENE ") and "no such directory" in bad.stderr
    assert bad.stdout == "" and not (tmp_path / "x.zarr").exists()


def test_output_piped_into_a_reader_that_stops(tmp_path):
    """``sionnafmcw scene list | head -0``: the reader closes the pipe before the output; the command ends
    quietly (no BrokenPipeError traceback) with status 141 (128 + SIGPIPE)."""
    proc = subprocess.Popen([sys.executable, "-m", "sionnafmcw.cli", "scene", "list"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the command writes (its imports take ~1 s)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141
    assert "Traceback" not in err and "BrokenPipe" not in err, err


# ============================================================================ presets
def _table_row(out, name):
    rows = [line.split() for line in out.splitlines() if line.startswith(name + " ")]
    assert len(rows) == 1, out
    return rows[0]


def test_presets_table_has_the_derived_figures(capsys):
    status, out, _ = run_cli(capsys, "presets")
    assert status == 0
    header = out.splitlines()[0]
    for column in ("fc", "bandwidth", "range res.", "max range", "max vel.", "vel. res.", "CPI", "virtual"):
        assert column in header
    units = out.splitlines()[1]
    for unit in ("GHz", "cm", "m/s", "ms"):
        assert unit in units
    for name in RadarConfig.presets():
        r = RadarConfig.preset(name)
        row = _table_row(out, name)
        # preset fc B dR Rmax vmax dv CPI chirps samples M x N virtual, then the receiver
        expected = [name, f"{r.fc / 1e9:.2f}", f"{r.bandwidth / 1e9:.3f}", f"{r.range_resolution * 100:.2f}",
                    f"{r.max_range:.2f}", f"{r.max_velocity:.2f}", f"{r.velocity_resolution:.3f}",
                    f"{r.cpi_duration * 1e3:.2f}", str(r.num_chirps), str(r.num_samples), str(r.num_tx), "x",
                    str(r.num_rx), str(r.num_tx * r.num_rx)]
        if name.startswith("ti-"):     # data-sheet receiver: PN at 1 MHz, HPF corners, IF band, ADC bits, pattern
            expected += ["-93", "175+350", f"0-{0.8 * r.fs / 1e6:.2f}", "16", name]
        else:
            expected += ["off", "off", "off", "off", r.antenna_pattern]
        assert row == expected


def test_presets_json_and_config(capsys, tmp_path):
    status, out, _ = run_cli(capsys, "presets", "--json")
    assert status == 0
    rows = {row["name"]: row for row in json.loads(out)}
    assert sorted(rows) == sorted(RadarConfig.presets())
    for name, row in rows.items():
        r = RadarConfig.preset(name)
        for key, value in r.derived().items():
            if key in row:
                assert row[key] == pytest.approx(value, rel=1e-12), key
        assert row["fc"] == r.fc and row["num_virtual"] == r.num_tx * r.num_rx
        assert RadarConfig.from_dict(row["config"]) == r
        assert row["receiver"]["adc_bits"] == r.adc_bits and row["receiver"]["antenna_pattern"] == r.antenna_pattern
    # --config writes a file that --radar reads back as the same radar
    status, out, _ = run_cli(capsys, "presets", "ti-iwr6843isk", "--config")
    assert status == 0
    path = tmp_path / "r.json"
    path.write_text(out)
    assert cli.common.load_radar(str(path)) == RadarConfig.preset("ti-iwr6843isk")


def test_presets_from_ti_cfg(capsys, tmp_path):
    """A TI mmWave .cfg shows the figures of the radar it describes (a preset's .cfg: that preset's)."""
    from sionnafmcw.ti.cfg import write_ti_cfg

    radar = RadarConfig.preset("ti-iwr6843isk")
    path = tmp_path / "profile.cfg"
    path.write_text(write_ti_cfg(radar))
    status, out, _ = run_cli(capsys, "presets", "--from-cfg", path, "--json")
    assert status == 0
    (row,) = json.loads(out)
    assert RadarConfig.from_dict(row["config"]).derived() == radar.derived()
    status, _, err = run_cli(capsys, "presets", "--from-cfg", tmp_path / "none.cfg")
    assert_user_error(status, err, "--from-cfg", "none.cfg")


def test_radar_file_with_preset_and_changes(tmp_path):
    path = tmp_path / "r.json"
    path.write_text(json.dumps({"preset": "walk-77ghz", "num_chirps": 64, "noise_figure": 10.0}))
    radar = cli.common.load_radar(str(path))
    assert radar == RadarConfig.preset("walk-77ghz").replace(num_chirps=64, noise_figure=10.0, name="walk-77ghz*")


# ============================================================================ --frames
@pytest.mark.parametrize("text, expected", [
    ("0:3", [0, 1, 2]), ("2:", [2, 3, 4, 5]), (":2", [0, 1]), ("0:6:2", [0, 2, 4]), ("4", [4]),
    ("0,2,5", [0, 2, 5]), (" 1 : 3 ", [1, 2]), ("5:6", [5]),
])
def test_parse_frames(text, expected):
    assert parse_frames(text, 6) == expected


@pytest.mark.parametrize("text, fragment", [
    ("a:b", "not an integer"), ("2:1", "selects no frame"), ("0:7", "past the end"), ("6", "out of range"),
    ("-1", "out of range"), ("0:4:0", "step must be >= 1"), ("", "is empty"), ("1,1", "twice"),
    ("1:2:3:4", "too many"), ("-2:3", "negative"),
])
def test_parse_frames_errors(text, fragment):
    with pytest.raises(UserError, match=fragment) as info:
        parse_frames(text, 6)
    assert "--frames" in str(info.value) and "\n" not in str(info.value)


# ============================================================================ user errors
def test_user_errors_are_one_line(capsys, tmp_path, plate_scene, small_radar_file):
    scene = str(plate_scene)
    out = str(tmp_path / "run.zarr")
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{"preset": "walk-77ghz", "num_chirps": ')
    unknown_field = tmp_path / "unknown.json"
    unknown_field.write_text('{"preset": "walk-77ghz", "chirps": 64}')
    long_cpi = tmp_path / "long.json"
    long_cpi.write_text('{"preset": "walk-77ghz", "num_chirps": 512}')  # 53.8 ms CPI > 41.7 ms at 24 fps
    cases = [
        ([], "required: COMMAND"),
        (["presets", "nope"], "unknown preset 'nope'"),
        (["simulate"], "required: SCENE, --radar, --out"),
        (["simulate", scene, "--radar", "walk-77ghz"], "--out"),
        (["simulate", str(tmp_path / "nowhere"), "--radar", "walk-77ghz", "--out", out], "no such directory"),
        (["simulate", str(tmp_path), "--radar", "walk-77ghz", "--out", out], "no animation.json"),
        (["simulate", scene, "--radar", "nope", "--out", out], "neither a preset"),
        (["simulate", scene, "--radar", str(tmp_path / "missing.json"), "--out", out],
         "missing.json: no such radar file"),
        (["simulate", scene, "--radar", bad_json, "--out", out], "bad.json: invalid JSON at line 1"),
        (["simulate", scene, "--radar", unknown_field, "--out", out], "unknown RadarConfig field(s) chirps"),
        (["simulate", scene, "--radar", long_cpi, "--out", out], "longer than the frame period"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--frames", "0:9"], "--frames '0:9'"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--engine", "raster"], "invalid choice"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--engine-option", "foo=1"],
         "has no option 'foo'"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--engine-option", "samples_per_src=1.5"],
         "samples_per_src='1.5' is not an integer"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--engine-option", "max_depth"],
         "write key=value"),
        (["simulate", scene, "--radar", small_radar_file, "--out", out, "--threads", "0"], "--threads 0: must be"),
        (["plot", str(tmp_path / "missing.zarr"), "--out", tmp_path / "figs"], "no such run store"),
        (["plot", scene, "--out", tmp_path / "figs"], "not a readable run store"),
        (["plot", out, "--out", tmp_path / "figs", "--kind", "polar"], "invalid choice"),
        (["validate", "nope"], "unknown validation experiment 'nope'"),
        (["dataset", tmp_path / "missing.yaml", "--out", tmp_path / "data"], "no such data-set specification"),
        (["dataset", tmp_path / "missing.yaml", "--out", tmp_path / "data", "--workers", "1", "--scheduler", "x"],
         "not allowed with argument"),
    ]
    for argv, fragment in cases:
        status, _, err = run_cli(capsys, *argv)
        assert_user_error(status, err, fragment)
    assert not Path(out).exists() and not (tmp_path / "figs").exists() and not (tmp_path / "data").exists()


def test_scene_user_errors(capsys, tmp_path):
    pytest.importorskip("sionnafmcw.scenes")
    out = tmp_path / "scene"
    for argv, fragment in [
        (["scene", "build", "nope", out], "unknown scene 'nope'"),
        (["scene", "list", "nope"], "unknown scene 'nope'"),
        (["scene", "build", "moving_plate", out, "--param", "sped=1"], "has no parameter 'sped'"),
        (["scene", "build", "moving_plate", out, "--param", "speed=fast"], "speed=fast"),
        (["scene", "build", "moving_plate", out, "--param", "speed"], "write key=value"),
        (["scene", "build", "moving_plate", out, "--param", "speed=1", "--param", "speed=2"], "given twice"),
        (["scene", "build", "moving_plate", out, "--param", "speed=1e6"], "out of range"),
        (["scene"], "required"),
    ]:
        status, _, err = run_cli(capsys, *argv)
        assert_user_error(status, err, fragment)
    assert not out.exists()
    out.mkdir()
    (out / "keep.txt").write_text("x")
    status, _, err = run_cli(capsys, "scene", "build", "moving_plate", out)
    assert_user_error(status, err, "exists and is not empty", "--overwrite")
    assert (out / "keep.txt").exists()


def test_interrupt_and_internal_errors(capsys, monkeypatch):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli.presets, "run", interrupted)
    status, _, err = run_cli(capsys, "presets")
    assert status == cli.EXIT_INTERRUPTED and "interrupted" in err and "Traceback" not in err

    def broken(args):
        raise RuntimeError("a bug")

    monkeypatch.setattr(cli.presets, "run", broken)
    with pytest.raises(RuntimeError, match="a bug"):  # internal errors are not dressed up as user errors
        main(["presets"])


def test_engine_options_are_typed_from_the_engine():
    options = cli.simulate.engine_options("path", ["samples_per_src=2e4", "diffuse=false", "max_depth=3", "label=first"])
    assert options == {"samples_per_src": 20000, "diffuse": False, "max_depth": 3, "label": "first"}
    assert type(options["samples_per_src"]) is int and type(options["diffuse"]) is bool
    with pytest.raises(UserError, match="not a boolean"):
        cli.simulate.engine_options("path", ["diffuse=maybe"])


# ============================================================================ validate, scene list
def test_validate_list_and_pass_through(capsys, monkeypatch):
    from sionnafmcw import validation

    status, out, _ = run_cli(capsys, "validate", "--list")
    assert status == 0
    assert [line.split(":")[0] for line in out.splitlines()] == validation.names()
    seen = {}

    def fake_run(name, argv):
        seen["call"] = (name, argv)
        return 1

    monkeypatch.setattr(validation, "run", fake_run)
    status, _, _ = run_cli(capsys, "validate", "point_targets", "--out", "somewhere", "--seed", "3")
    assert status == 1  # the experiment's own status (1 = a target missed)
    assert seen["call"] == ("point_targets", ["--out", "somewhere", "--seed", "3"])


def test_scene_list(capsys):
    scenes = pytest.importorskip("sionnafmcw.scenes")
    status, out, _ = run_cli(capsys, "scene", "list")
    assert status == 0
    for name in scenes.names():
        assert any(line.startswith(f"{name}:") or line == name for line in out.splitlines()), name
        for key, p in scenes.parameters(name).items():
            assert any(line.split()[:1] == [key] and repr(p.default) in line for line in out.splitlines()), key
    status, out, _ = run_cli(capsys, "scene", "list", "moving_plate")
    assert status == 0 and out.splitlines()[0].startswith("moving_plate") and "speed" in out
    assert "circle_walk" not in out


# ============================================================================ end to end
@pytest.fixture(scope="module")
def simulated_run(tmp_path_factory, plate_scene, small_radar_file):
    """Simulate frames 0:2 of the plate, then resume with frame 2 (both through the CLI)."""
    out = tmp_path_factory.mktemp("run") / "plate.zarr"
    argv = ["-q", "simulate", str(plate_scene), "--radar", str(small_radar_file), "--out", str(out),
            "--seed", "7", *FAST_PATH]
    assert main(argv + ["--frames", "0:2"]) == 0
    import xarray as xr

    first = xr.open_zarr(out).frame_done.values.copy()
    assert main(argv + ["--frames", "2"]) == 0
    return out, first


def test_simulate_writes_the_store(simulated_run):
    from sionnafmcw import open_run

    out, first = simulated_run
    assert first.tolist() == [True, True, False]
    ds = open_run(out)
    assert ds.frame_done.values.tolist() == [True, True, True]
    assert ds.attrs["seed"] == 7 and ds.attrs["engine"]["samples_per_src"] == 5000
    assert RadarConfig.from_dict(ds.attrs["radar"]).num_chirps == 32
    # dR/dt seen from the virtual array's phase centre, a few cm off boresight: cos(off-axis angle) ~ 1 - 2e-5
    np.testing.assert_allclose(ds.truth_radial_velocity.values[:, 0], 1.0, atol=1e-4)
    assert np.abs(ds.iq.values).max() > 0


def test_simulate_refuses_other_settings_on_resume(capsys, simulated_run, plate_scene, small_radar_file):
    out, _ = simulated_run
    status, _, err = run_cli(capsys, "-q", "simulate", plate_scene, "--radar", small_radar_file, "--out", out,
                             "--seed", "8", *FAST_PATH)
    assert_user_error(status, err, "different 'seed'")


def test_plot_every_kind(capsys, tmp_path, simulated_run):
    out, _ = simulated_run
    figs = tmp_path / "figs"
    status, stdout, err = run_cli(capsys, "--quiet", "plot", out, "--out", figs, "--frame", "1")
    assert status == 0, err
    names = sorted(p.name for p in figs.iterdir())
    assert names == ["doppler_time.png", "micro_doppler.png", "range_azimuth_f0001.png", "range_doppler_f0001.png",
                     "scene_top_view.png"]
    for p in figs.iterdir():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000
    assert sorted(Path(line).name for line in stdout.split()) == names
    assert err == ""  # --quiet: no progress bars


def test_plot_options_and_errors(capsys, tmp_path, simulated_run):
    out, _ = simulated_run
    figs = tmp_path / "figs"
    status, stdout, _ = run_cli(capsys, "-q", "plot", out, "--out", figs, "--kind", "ra", "--cartesian",
                                "--max-range", "6", "--kind", "rd")
    assert status == 0
    assert sorted(p.name for p in figs.iterdir()) == ["range_azimuth_f0001.png", "range_doppler_f0001.png"]
    for argv, fragment in [
        (["--frame", "5"], "--frame 5"),
        (["--kind", "doppler-time", "--range-gate", "30:40"], "holds no range bin"),
        (["--kind", "doppler-time", "--range-gate", "4"], "MIN:MAX"),
        (["--kind", "micro-doppler", "--window-chirps", "64"], "--window-chirps 64"),
        (["--kind", "scene", "--scene", tmp_path / "gone"], "--scene"),
    ]:
        status, _, err = run_cli(capsys, "-q", "plot", out, "--out", tmp_path / "other", *argv)
        assert_user_error(status, err, fragment)
    assert not (tmp_path / "other").exists()


def test_scene_build_simulate_plot(capsys, tmp_path, small_radar_file):
    """The scene builder through the CLI, then simulate and one plot of it."""
    scenes = pytest.importorskip("sionnafmcw.scenes")
    if "moving_plate" not in scenes.names():
        pytest.skip("no moving_plate scenario")
    scene = tmp_path / "plate"
    status, out, err = run_cli(capsys, "scene", "build", "moving_plate", scene, "--param", "num_frames=2",
                               "--param", "speed=-1.5", "--param", "start_range=3.5")
    assert status == 0, err
    assert "2 frames" in out and (scene / "animation.json").is_file()
    manifest = json.loads((scene / "animation.json").read_text())
    assert manifest["scenario"]["parameters"]["speed"] == -1.5
    status, _, err = run_cli(capsys, "scene", "build", "moving_plate", scene, "--param", "num_frames=3",
                             "--overwrite")
    assert status == 0, err
    assert len(json.loads((scene / "animation.json").read_text())["frames"]) == 3
    run = tmp_path / "run.zarr"
    status, _, err = run_cli(capsys, "-q", "simulate", scene, "--radar", small_radar_file, "--out", run,
                             "--frames", "0:3:2", "--no-noise", *FAST_PATH)
    assert status == 0, err
    from sionnafmcw import open_run

    ds = open_run(run)
    assert ds.frame_done.values.tolist() == [True, False, True] and ds.attrs["noise"] is False
    status, stdout, err = run_cli(capsys, "plot", run, "--out", tmp_path / "figs", "--kind", "doppler-time",
                                  "--kind", "scene", "--quiet")  # --quiet after the subcommand works too
    assert status == 0 and err == "", err
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == ["doppler_time.png", "scene_top_view.png"]


def test_simulate_pixel_engine(capsys, tmp_path, plate_scene, small_radar_file):
    from sionnafmcw.engines import names

    assert "pixel" in names()
    run = tmp_path / "pixel.zarr"
    status, _, err = run_cli(capsys, "-q", "simulate", plate_scene, "--radar", small_radar_file, "--out", run,
                             "--engine", "pixel", "--frames", "0", "--no-noise", "--engine-option", "n_az=64",
                             "--engine-option", "n_el=32", "--engine-option", "scattering_coefficient=0.5")
    assert status == 0, err
    from sionnafmcw import open_run

    ds = open_run(run)
    assert ds.attrs["engine"]["engine"] == "pixel" and ds.frame_done.values.tolist() == [True, False, False]
    assert ds.attrs["engine"]["n_az"] == 64 and ds.attrs["engine"]["n_el"] == 32
    assert ds.attrs["engine"]["scattering_coefficient"] == 0.5
    assert np.abs(ds.iq.values[0]).max() > 0  # noise off: the plate's echo


@pytest.mark.slow
def test_validate_point_targets(capsys, tmp_path):
    status, out, _ = run_cli(capsys, "validate", "point_targets", "--out", tmp_path / "pt")
    assert status == 0
    metrics = json.loads(out.strip().splitlines()[-1])
    assert metrics["passed"] is True
    assert (tmp_path / "pt" / "range_doppler.png").stat().st_size > 10_000


@pytest.mark.slow
def test_dataset_generate(capsys, tmp_path):
    pytest.importorskip("sionnafmcw.dataset")
    spec = tmp_path / "tiny.json"
    spec.write_text(json.dumps({
        "name": "tiny", "scenario": "moving_plate", "count": 2, "seed": 1, "radar": SMALL_RADAR,
        "engine": "path", "engine_options": {"samples_per_src": 5000},
        "parameters": {"speed": {"uniform": [-2.0, 2.0]}, "num_frames": 2},
    }))
    status, out, err = run_cli(capsys, "-q", "dataset", spec, "--out", tmp_path / "data", "--workers", "1")
    assert status == 0, err
    assert "2 complete" in out
    status, out, err = run_cli(capsys, "-q", "dataset", spec, "--out", tmp_path / "data")  # resumes: nothing to do
    assert status == 0, err
    assert "2 complete" in out
