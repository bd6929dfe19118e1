"""Crash safety: ``simulate`` and ``dataset`` killed (SIGKILL) or interrupted (SIGINT,
SIGTERM) at exact instants, then resumed and compared bit for bit with an uninterrupted run; every
bad input refused with one line, before anything is written.

The instants are the fault points of :mod:`sionnafmcw._faults` (armed through the environment of a
``python -m sionnafmcw.cli`` subprocess, :mod:`faults`): ``store-created`` (the store is complete in
its temporary folder, not yet at its path), ``chunk-written`` (a frame's arrays are written, its done
flag not yet), ``frame-done``, and for data sets ``item-simulated`` (in a worker: the item's store is
complete, its ``item.json`` not yet) and ``item-recorded`` (in the driver, after an item's record).

Scene: a hand-written 3-frame plate at 4 m receding at 1 m/s (24 fps); radar walk-77ghz cut to 16
chirps x 64 samples; the pixel engine with scattering coefficient 0.5 (deterministic), noise on
with seed 3; one case with the path engine, ``deterministic=True`` and 2000 rays per source. The
resumes run in this process through ``cli.main`` (so the engines load once).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from animation_helpers import write_plate_animation
from faults import assert_same_store, fault_log, leftovers, sionnafmcw, stderr_lines
from sionnafmcw import cli, dataset, open_run
from sionnafmcw.cli import main

RADAR = {"preset": "walk-77ghz", "num_chirps": 16, "num_samples": 64}
PIXEL = ["--engine", "pixel", "--engine-option", "scattering_coefficient=0.5"]
PATH_DET = ["--engine", "path", "--engine-option", "deterministic=true", "--engine-option", "samples_per_src=2000"]
INTERRUPTED = re.compile(r"^sionnafmcw: interrupted after (\d+) of (\d+) (frames|items); run the same command to resume$")


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    root = tmp_path_factory.mktemp("crash")
    scene = write_plate_animation(root / "plate", distance=4.0, velocity=(1.0, 0.0, 0.0), num_frames=3, fps=24.0,
                                  size=(0.5, 0.5))
    radar = root / "radar.json"
    radar.write_text(json.dumps(RADAR))
    return scene, radar


def simulate_args(plate, out, engine=PIXEL):
    scene, radar = plate
    return ["-q", "simulate", scene, "--radar", radar, "--out", out, "--seed", "3", *engine]


@pytest.fixture(scope="module")
def reference(plate, tmp_path_factory):
    """Uninterrupted runs: {engine name: store}."""
    root = tmp_path_factory.mktemp("reference")
    out = {}
    for name, engine in (("pixel", PIXEL), ("path", PATH_DET)):
        out[name] = root / f"{name}.zarr"
        assert main([str(a) for a in simulate_args(plate, out[name], engine)]) == 0
    return out


def resume(plate, out, engine=PIXEL, capsys=None) -> None:
    status = main([str(a) for a in simulate_args(plate, out, engine)])
    if capsys is not None:
        _, err = capsys.readouterr()
        assert "Traceback" not in err
    assert status == 0


# ===================================================================================== simulate
KILL_POINTS = [
    # point, signal, exit status, frames done when the one line is printed
    ("store-created", "KILL", -9, None),
    ("store-created", "INT", 130, 0),
    ("store-created", "TERM", 143, 0),
    ("chunk-written@2", "KILL", -9, None),   # frame 1 written, its done flag not
    ("chunk-written@2", "INT", 130, 2),      # the signal waits for the done flag: 2 frames done
    ("frame-done@1", "KILL", -9, None),
    ("frame-done@1", "TERM", 143, 1),
]


@pytest.mark.parametrize("point, signal, status, done", KILL_POINTS, ids=[f"{p}-{s}" for p, s, *_ in KILL_POINTS])
def test_simulate_killed_resumes_bit_for_bit(tmp_path, plate, reference, capsys, point, signal, status, done):
    out = tmp_path / "run.zarr"
    proc = sionnafmcw(*simulate_args(plate, out), fault=point, signal=signal)
    assert proc.returncode == status, proc.stderr
    lines = stderr_lines(proc)
    if signal == "KILL":
        assert lines == [], proc.stderr
    else:  # one line, no traceback, no warning (un-awaited coroutines included)
        assert len(lines) == 1 and INTERRUPTED.match(lines[0]), proc.stderr
        assert INTERRUPTED.match(lines[0]).groups() == (str(done), "3", "frames")
        assert open_run(out).done_frames.size == done  # a valid store
        assert leftovers(out) == []
    if point == "store-created" and signal == "KILL":
        assert not out.exists()  # the store appears only when complete
        assert any(".partial-" in p.name for p in leftovers(out))
    if point.startswith("chunk-written") and signal == "KILL":
        assert open_run(out).done_frames.tolist() == [0]
        # what a kill inside Zarr's own chunk write leaves: a temporary chunk file
        (out / "iq" / "c" / "2" / "0" / "0" / "0" / "0.0123456789abcdef.partial").parent.mkdir(parents=True,
                                                                                             exist_ok=True)
        (out / "iq" / "c" / "2" / "0" / "0" / "0" / "0.0123456789abcdef.partial").write_bytes(b"half a chunk")
    resume(plate, out, capsys=capsys)
    assert leftovers(out) == []
    assert_same_store(reference["pixel"], out)


def test_path_engine_deterministic_killed_between_chunk_and_done_flag(tmp_path, plate, reference, capsys):
    out = tmp_path / "path.zarr"
    proc = sionnafmcw(*simulate_args(plate, out, PATH_DET), fault="chunk-written@2", signal="KILL")
    assert proc.returncode == -9, proc.stderr
    assert open_run(out).done_frames.tolist() == [0]
    resume(plate, out, PATH_DET, capsys)
    assert leftovers(out) == []
    assert_same_store(reference["path"], out)


def test_resume_never_redoes_a_done_frame(tmp_path, plate, reference):
    """Frames marked done before a kill are not written again by the resume (the log of done flags)."""
    out, log = tmp_path / "run.zarr", tmp_path / "faults.log"
    proc = sionnafmcw(*simulate_args(plate, out), fault="frame-done@2", signal="KILL", log=log)
    assert proc.returncode == -9
    proc = sionnafmcw(*simulate_args(plate, out), log=log)
    assert proc.returncode == 0, proc.stderr
    done = [int(e["frame"]) for e in fault_log(log) if e["point"] == "frame-done"]
    assert sorted(done) == [0, 1, 2]
    assert_same_store(reference["pixel"], out)


def test_a_live_writer_is_not_disturbed(tmp_path, plate):
    """A second simulate of a store that a live process holds is refused in one line, touching nothing."""
    import os

    out = tmp_path / "run.zarr"
    lock = tmp_path / ".run.zarr.lock"
    lock.write_text(json.dumps({"host": __import__("socket").gethostname(), "pid": os.getppid()}))
    status = main([str(a) for a in simulate_args(plate, out)])
    assert status == cli.EXIT_USER_ERROR
    assert not out.exists() and lock.exists()


def test_drjit_wrapped_keyboard_interrupt_is_an_interrupt(capsys, monkeypatch):
    """Ctrl-C inside a Dr.Jit call comes back as RuntimeError (cause: KeyboardInterrupt): one line, 130."""
    import sionnafmcw.sionna_rt  # noqa: F401  (the LLVM set-up)
    import drjit as dr
    from drjit.llvm import UInt32

    from sionnafmcw.interrupts import is_interrupt

    def body(i):
        raise KeyboardInterrupt

    def traced(args):
        dr.while_loop(state=(UInt32(0),), cond=lambda i: i < 10, body=body, mode="symbolic")

    with pytest.raises(RuntimeError) as info:
        traced(None)
    assert is_interrupt(info.value) and not is_interrupt(RuntimeError("dr.while_loop(): another failure"))
    monkeypatch.setattr(cli.presets, "run", traced)
    status = main(["presets"])
    _, err = capsys.readouterr()
    assert status == 130 and len(stderr_lines_of(err)) == 1 and "interrupted" in err and "Traceback" not in err


def stderr_lines_of(text):
    return [line for line in text.splitlines() if line.strip()]


# ===================================================================================== damaged stores
def test_corrupt_chunk_named_in_one_line_and_check_repairs_it(tmp_path, plate, reference, capsys):
    out = tmp_path / "run.zarr"
    shutil.copytree(reference["pixel"], out)
    chunk = out / "iq" / "c" / "1" / "0" / "0" / "0" / "0"
    chunk.write_bytes(b"\x00garbage, not zstd" * 8)
    status = main(["-q", "plot", str(out), "--out", str(tmp_path / "fig"), "--kind", "doppler-time"])
    _, err = capsys.readouterr()
    lines = stderr_lines_of(err)
    assert status == cli.EXIT_USER_ERROR and len(lines) == 1 and "Traceback" not in err, err
    assert "frame 1 cannot be read" in lines[0] and f"sionnafmcw check {out}" in lines[0]

    status = main(["check", str(out)])
    text, _ = capsys.readouterr()
    assert status == 1 and "frames 1" in text and "marked for recomputation" in text
    assert open_run(out).done_frames.tolist() == [0, 2]
    assert main(["check", str(out)]) == 0
    capsys.readouterr()
    resume(plate, out, capsys=capsys)
    assert_same_store(reference["pixel"], out)


def test_simulate_repair_recomputes_unreadable_frames(tmp_path, plate, reference, capsys):
    out = tmp_path / "run.zarr"
    shutil.copytree(reference["pixel"], out)
    (out / "truth_position" / "c" / "2" / "0" / "0").write_bytes(b"broken")
    assert main([str(a) for a in simulate_args(plate, out)] + ["--repair"]) == 0
    capsys.readouterr()
    assert_same_store(reference["pixel"], out)


# ===================================================================================== bad inputs
def assert_refused(status, err, *fragments):
    lines = stderr_lines_of(err)
    assert status == cli.EXIT_USER_ERROR, err
    assert len(lines) == 1 and lines[0].startswith("sionnafmcw: error: ") and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def assert_nothing_left(out: Path):
    assert not out.exists(), f"{out} was created"
    assert list(out.parent.glob(f".{out.name}*")) == [], list(out.parent.glob(f".{out.name}*"))


def test_bad_numbers_are_refused_before_anything_is_written(tmp_path, plate, capsys):
    out = tmp_path / "run.zarr"
    status = main([str(a) for a in simulate_args(plate, out)] + ["--seed", "-1"])
    assert_refused(status, capsys.readouterr()[1], "--seed -1", ">= 0")
    assert_nothing_left(out)
    status = main([str(a) for a in simulate_args(plate, out)] + ["--leakage-db", "nan"])
    assert_refused(status, capsys.readouterr()[1], "--leakage-db nan", "finite")
    assert_nothing_left(out)


def test_library_refuses_bad_arguments_and_frames(tmp_path, plate):
    from sionnafmcw.simulation import SimulationError, simulate

    scene, radar = plate
    out = tmp_path / "run.zarr"
    for kwargs, fragment in (({"frames": slice(50, 60)}, "selects no frame"), ({"frames": [5]}, "outside"),
                             ({"seed": -1}, "seed=-1"), ({"leakage_db": float("nan")}, "leakage_db=nan"),
                             ({"seed": 1.5}, "seed=1.5")):
        with pytest.raises(SimulationError, match=re.escape(fragment)):
            simulate(scene, str(radar), engine="pixel", out=out, progress=False, **kwargs)
        assert_nothing_left(out)


def test_radar_whose_cube_cannot_fit_in_memory(tmp_path, plate, capsys):
    radar = tmp_path / "huge.json"
    radar.write_text(json.dumps({"preset": "walk-77ghz", "num_samples": 1_000_000_000, "fs": 5e13}))
    out = tmp_path / "run.zarr"
    scene, _ = plate
    status = main(["-q", "simulate", str(scene), "--radar", str(radar), "--out", str(out), *PIXEL])
    err = capsys.readouterr()[1]
    assert_refused(status, err, "GiB", "num_samples or num_chirps in --radar", "available")
    figures = re.findall(r"about ([\d.]+) GiB", err)
    # 256 chirps x 3 Tx x 4 Rx x 1e9 samples x 48 bytes
    assert float(figures[0]) == pytest.approx(256 * 12 * 1e9 * 48 / 2**30, rel=1e-4)
    assert_nothing_left(out)


def test_moving_object_beyond_the_maximum_range(tmp_path, plate, capsys):
    radar = tmp_path / "short.json"
    # max range c fs / (2 slope) = 3e8 * 5e6 / 5e14 = 3.0 m; the plate is at 4.0-4.1 m
    radar.write_text(json.dumps({**RADAR, "slope": 2.5e14}))
    out = tmp_path / "run.zarr"
    scene, _ = plate
    status = main(["-q", "simulate", str(scene), "--radar", str(radar), "--out", str(out), *PIXEL])
    assert_refused(status, capsys.readouterr()[1], "'plate'", "maximum range 3.00 m", "fs", "slope")
    assert_nothing_left(out)


def test_material_undefined_at_the_carrier(tmp_path, capsys):
    scene = write_plate_animation(tmp_path / "ground", distance=4.0, num_frames=2, fps=24.0, size=(0.5, 0.5),
                                  materials={"mat-ground": ("itu-radio-material", {"type": "very_dry_ground"})},
                                  material="mat-ground")
    radar = tmp_path / "radar.json"
    radar.write_text(json.dumps(RADAR))
    out = tmp_path / "run.zarr"
    status = main(["-q", "simulate", str(scene), "--radar", str(radar), "--out", str(out), *PIXEL])
    assert_refused(status, capsys.readouterr()[1], "very_dry_ground", "77 GHz")
    assert_nothing_left(out)


def test_validate_with_a_missing_scene_makes_no_output_folder(tmp_path, capsys):
    out = tmp_path / "validation"
    status = main(["validate", "circle_walk", "--scene", str(tmp_path / "missing"), "--out", str(out)])
    assert_refused(status, capsys.readouterr()[1], str(tmp_path / "missing"))
    assert_nothing_left(out)


# ===================================================================================== data sets
SPEC = {"name": "plates", "scenario": "moving_plate", "count": 2, "seed": 4, "radar": RADAR, "engine": "pixel",
        "engine_options": {"scattering_coefficient": 0.5},
        "parameters": {"speed": {"uniform": [0.5, 2.0]}, "start_range": 3.0, "num_frames": 2}}


@pytest.fixture(scope="module")
def scheduler():
    """An in-process LocalCluster reached over TCP: the resumes and the reference data set."""
    import logging

    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        yield cluster.scheduler_address


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "plates.json"
    path.write_text(json.dumps(SPEC))
    return path


@pytest.fixture(scope="module")
def reference_dataset(tmp_path_factory, spec_file, scheduler):
    out = tmp_path_factory.mktemp("dataset") / "reference"
    index = dataset.generate(SPEC, out, scheduler=scheduler, progress=False)
    assert (index.status.values == "complete").all()
    return out


DATASET_POINTS = [
    # point, signal, where it fires, exit status of the killed command
    pytest.param("item-recorded@1", "INT", "driver", 130, id="driver-INT-after-an-item"),
    pytest.param("chunk-written@2", "KILL", "worker", 0, id="worker-KILL-between-chunk-and-done-flag"),
    pytest.param("item-recorded@1", "KILL", "driver", -9, id="driver-KILL-after-an-item", marks=pytest.mark.slow),
    pytest.param("store-created@1", "KILL", "worker", 0, id="worker-KILL-creating-an-item-store",
                 marks=pytest.mark.slow),
    pytest.param("item-simulated@1", "KILL", "worker", 0, id="worker-KILL-after-an-item-before-item.json",
                 marks=pytest.mark.slow),
]


@pytest.mark.parametrize("point, signal, where, status", DATASET_POINTS)
def test_dataset_killed_resumes_bit_for_bit(tmp_path, monkeypatch, spec_file, scheduler, reference_dataset, point,
                                            signal, where, status):
    """The local cluster's worker restarts after a worker kill and Dask reruns the item (the first command
    finishes); after a driver kill the same command resumes. Every item store equals the reference, the
    index says complete and names a worker, and no frame got its done flag twice."""
    out, log = tmp_path / "data", tmp_path / "faults.log"
    proc = sionnafmcw("-q", "dataset", spec_file, "--out", out, "--workers", "1", fault=point, signal=signal,
                      once=tmp_path / "fired", log=log)
    assert proc.returncode == status, proc.stderr
    assert (tmp_path / "fired").exists()  # the point was reached
    if signal == "INT":
        lines = stderr_lines(proc)
        assert len(lines) == 1 and INTERRUPTED.match(lines[0]), proc.stderr
        assert INTERRUPTED.match(lines[0]).group(2, 3) == ("2", "items")
    monkeypatch.setenv("SIONNAFMCW_FAULT_LOG", str(log))  # the resume's done flags go to the log too
    index = dataset.generate(SPEC, out, scheduler=scheduler, progress=False)
    assert (index.status.values == "complete").all()
    assert all(w for w in index.worker.values)
    for item in index.item.values:
        store = out / "items" / item / "run.zarr"
        assert_same_store(reference_dataset / "items" / item / "run.zarr", store)
        assert leftovers(store) == []
        assert json.loads((out / "items" / item / "item.json").read_text())["status"] == "complete"
    assert not (out / ".lock").exists()
    done = [(Path(e["store"]).parent.name, e["frame"]) for e in fault_log(log) if e["point"] == "frame-done"]
    assert len(done) == len(set(done)), f"a frame was marked done twice: {sorted(done)}"


def test_interrupt_inside_a_drjit_call_during_a_frame(tmp_path, plate, reference):
    """A KeyboardInterrupt raised inside Dr.Jit during frame 1 (it comes back as Dr.Jit's RuntimeError)
    stops simulate with SimulationInterrupted after 1 of 3 frames, a valid store that resumes bit for bit."""
    import sionnafmcw.sionna_rt  # noqa: F401  (the LLVM set-up)
    import drjit as dr
    from drjit.llvm import UInt32

    from sionnafmcw.engines import PixelEngine
    from sionnafmcw.simulation import SimulationInterrupted, simulate

    class CtrlCInFrameOne(PixelEngine):
        def _frame_echoes(self, animation, radar, frame, pose):
            if frame == 1:
                def body(i):
                    raise KeyboardInterrupt

                dr.while_loop(state=(UInt32(0),), cond=lambda i: i < 10, body=body, mode="symbolic")
            return super()._frame_echoes(animation, radar, frame, pose)

    scene, radar = plate
    out = tmp_path / "run.zarr"
    with pytest.raises(SimulationInterrupted) as info:
        simulate(scene, str(radar), engine=CtrlCInFrameOne(scattering_coefficient=0.5), out=out, seed=3,
                 progress=False)
    assert (info.value.done, info.value.total, info.value.exit_status) == (1, 3, 130)
    assert open_run(out).done_frames.tolist() == [0] and leftovers(out) == []
    simulate(scene, str(radar), engine=CtrlCInFrameOne.__mro__[1](scattering_coefficient=0.5), out=out, seed=3,
             progress=False)
    assert_same_store(reference["pixel"], out)


def test_engine_error_keeps_the_frames_done_before(tmp_path, plate, reference):
    """An engine error in frame 2 while frame 1 is being synthesised (simulate overlaps the synthesis of
    frame n with the engine's frame n + 1): frames 0 and 1 are written, the error reaches the caller,
    and the store resumes to the uninterrupted run bit for bit."""
    from sionnafmcw.engines import EngineError, PixelEngine
    from sionnafmcw.simulation import simulate

    class FailsInFrameTwo(PixelEngine):
        def _frame_echoes(self, animation, radar, frame, pose):
            if frame == 2:
                raise EngineError("frame 2 cannot be done")
            return super()._frame_echoes(animation, radar, frame, pose)

    scene, radar = plate
    out = tmp_path / "run.zarr"
    with pytest.raises(EngineError, match="frame 2"):
        simulate(scene, str(radar), engine=FailsInFrameTwo(scattering_coefficient=0.5), out=out, seed=3,
                 progress=False)
    assert open_run(out).done_frames.tolist() == [0, 1] and leftovers(out) == []
    simulate(scene, str(radar), engine=PixelEngine(scattering_coefficient=0.5), out=out, seed=3, progress=False)
    assert_same_store(reference["pixel"], out)
