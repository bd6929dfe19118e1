"""The sim-to-real experiment on RadHAR (sionnafmcw.validation.sim_to_real_radhar, .har_classifier):
the per-frame features against hand-computed values, RadHAR's windows, the session-wise split of
the real training split, and (slow) the whole experiment at ``--quick`` size: a real synthetic set
generated on a local Dask cluster, exported in RadHAR's format, trained on and scored on real
recordings."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sionnafmcw.ti.formats.radhar import Recording, read_recording, write_npz
from sionnafmcw.validation.har_classifier import (WINDOW, WindowClassifier, frame_features, scores,
                                                  windows)
from sionnafmcw.validation.sim_to_real_radhar import (FOLDERS, VARIANTS, learning_curve, main, moving_table,
                                                      read_recordings, session_folds, session_of, variant_spec)

RADHAR = next((p / "shared" / "realdata" / "radhar" for p in Path(__file__).resolve().parents
               if (p / "shared" / "realdata" / "radhar").is_dir()), Path("shared/realdata/radhar"))
needs_radhar = pytest.mark.skipif(not (RADHAR / "train").is_dir(), reason="shared/realdata/radhar is absent")


def recording(frames, doppler_bins, ranges, z, y=None, activity="jump", source="s0_20_jump_1.npz"):
    frame = np.asarray(frames, np.int32)
    n = frame.size
    point_id = np.concatenate([np.arange(c) for c in np.bincount(frame)]).astype(np.int32)
    dbin = np.asarray(doppler_bins, np.int32)
    r = np.asarray(ranges, np.float32)
    return Recording(frame=frame, point_id=point_id, x=r, y=np.zeros(n, np.float32) if y is None else
                     np.asarray(y, np.float32), z=np.asarray(z, np.float32), range=r,
                     velocity=((dbin - 8) * 0.6147).astype(np.float32), doppler_bin=dbin,
                     bearing=np.zeros(n, np.float32), intensity=np.full(n, 30, np.float32), stamp=np.zeros(n),
                     activity=activity, source=source)


def test_frame_features_of_a_known_recording():
    # frame 0: a near leakage point (left out), two static points and two moving ones (bins 10 and 6);
    # frame 1: no points at all; frame 2: one static point
    rec = recording([0, 0, 0, 0, 0, 2], [9, 8, 8, 10, 6, 8], [0.1, 2.0, 2.0, 2.2, 2.6, 3.0],
                    [5.0, 0.0, 0.2, 1.0, 0.4, 0.1], y=[0.0, 0.0, 0.0, 0.3, -0.1, 0.0])
    f = frame_features(rec)
    assert f.shape == (3, 2 + 16 + 5)
    assert f[0, 0] == pytest.approx(np.log1p(4))                       # the near point does not count
    assert f[0, 1] == pytest.approx(0.5)                                # 2 of 4 move
    assert f[0, 2 + 8] == pytest.approx(0.5) and f[0, 2 + 10] == pytest.approx(0.25)
    assert f[0, 2 + 6] == pytest.approx(0.25) and f[0, 2 + 9] == 0      # bin 9 was the near point's
    k = 18
    assert f[0, k] == pytest.approx(np.std([1.0, 0.4]), abs=1e-6)      # height spread of the moving points
    assert f[0, k + 1] == pytest.approx(np.std([0.3, -0.1]), abs=1e-6)
    assert f[0, k + 2] == pytest.approx(np.std([2.2, 2.6]), abs=1e-6)
    assert f[0, k + 3] == pytest.approx(2 * 0.6147, rel=1e-5)           # |v| of bins 10 and 6
    assert f[0, k + 4] == pytest.approx(0.7 - np.mean([0.0, 0.2, 1.0, 0.4]), abs=1e-6)
    assert not f[1].any()
    assert f[2, 0] == pytest.approx(np.log1p(1)) and f[2, 1] == 0 and f[2, 2 + 8] == 1


def test_radhar_windows_of_60_frames_stride_10():
    features = np.arange(600 * 2, dtype=np.float32).reshape(600, 2)
    w = windows(features)
    assert w.shape == (55, WINDOW, 2)                                   # (600 - 60) / 10 + 1
    assert np.array_equal(w[1], features[10:70]) and np.array_equal(w[-1], features[540:600])
    assert windows(features[:59]).shape[0] == 0


def test_scores_and_a_classifier_that_separates_what_is_separable():
    rng = np.random.default_rng(0)
    y = np.repeat(np.arange(5), 8)
    x = rng.normal(0, 0.1, (40, 20, 3)).astype(np.float32)
    x[:, :, 0] += y[:, None]                                            # the class in one feature
    pred = WindowClassifier(5, steps=150).fit(x, y).predict(x)
    s = scores(y, pred, list(FOLDERS))
    assert s["accuracy"] == 1.0 and np.trace(s["confusion"]) == 40
    s = scores(np.array([0, 0, 1, 1]), np.array([0, 1, 1, 1]), ["a", "b"])
    assert s["accuracy"] == 0.75 and s["recall"] == {"a": 0.5, "b": 1.0} and s["confusion"] == [[1, 1], [0, 2]]


def test_sessions_from_radhar_names():
    assert session_of("Data/Train/jump/___20_jump_1.txt") == "s3/20_act"
    assert session_of("Data/Train/walk/__walk_20_4.txt") == "s2/act_20"
    assert session_of("boxing_20_1.txt") == "s0/act_20"
    assert session_of("s3_jump_20_1.npz") == "s3/act_20"


@needs_radhar
def test_session_wise_split_of_the_real_training_split():
    real = read_recordings(RADHAR / "train")
    folds = session_folds(real)
    by_session = {}
    for rec, f in zip(real, folds):
        by_session.setdefault((rec.activity, session_of(rec.source)), set()).add(f)
    assert all(len(f) == 1 for f in by_session.values())               # no session in two folds
    for fold in (0, 1):                                                  # every class tested and trained in each
        assert {r.activity for r, f in zip(real, folds) if f == fold} == set(FOLDERS)


@needs_radhar
def test_a_few_recordings_per_class_span_its_sessions():
    """``read_recordings(root, 2)``: two recordings of each class from two of its sessions (every class
    of the training split has more than one), in the reader's order, so that the session-wise ceiling
    has a session to test on that its training did not see."""
    every = read_recordings(RADHAR / "train")
    few = read_recordings(RADHAR / "train", 2)
    chosen = {r.source for r in few}
    assert [r.source for r in few] == [r.source for r in every if r.source in chosen]
    for cls in FOLDERS:
        recs = [r for r in few if r.activity == cls]
        assert len(recs) == 2 and len({session_of(r.source) for r in recs}) == 2, cls


def test_classifier_threads_are_restored_and_checked():
    import torch

    before = torch.get_num_threads()
    rng = np.random.default_rng(1)
    x, y = rng.normal(size=(10, 4, 3)).astype(np.float32), np.arange(10) % 5
    WindowClassifier(5, steps=2).fit(x, y).predict(x)
    assert torch.get_num_threads() == before
    with pytest.raises(ValueError, match="threads must be"):
        WindowClassifier(5, threads=0)


@needs_radhar
def test_bad_arguments_are_one_line_errors(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["--real", str(tmp_path / "nope"), "--out", str(tmp_path / "o"), "--synthetic", str(tmp_path)])
    assert "--real" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o"), "--ablation", "nope"])
    assert "--ablation: unknown nope" in capsys.readouterr().err
    for bad, said in ((["--seed", "-1"], "--seed must be"), (["--classifier-seeds", "0"], "--classifier-seeds must")):
        with pytest.raises(SystemExit):
            main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o"), *bad])
        assert said in capsys.readouterr().err
    # OUT's data-set folder holds something else: one line naming it, nothing generated
    stray = tmp_path / "o3" / "datasets" / "full"
    stray.mkdir(parents=True)
    (stray / "notes.txt").write_text("mine")
    assert main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o3"), "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(stray) in err and "Traceback" not in err
    assert sorted(p.name for p in stray.iterdir()) == ["notes.txt"]
    # a synthetic set shorter than a window: one line naming the folder and the shortfall, no traceback
    short = tmp_path / "short"
    (short / "jump").mkdir(parents=True)
    write_npz(short / "jump" / "s0_20_jump_1.npz", recording([0, 1, 2, 3, 4], [8] * 5, [2.0] * 5, [0.0] * 5))
    assert main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o2"), "--quick",
                 "--synthetic", str(short)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(short) in err and "at most 5 frames, fewer than a window of 10" in err


@needs_radhar
def test_learning_curve_trains_on_subsets_per_class(tmp_path, capsys):
    """The learning curve on a hand-made set of three 12-frame recordings per class (one 10-frame window each),
    scored on one real recording per class: per size the draws x seeds accuracies, the training windows of n
    recordings per class; at the full size every draw is the whole set, so the draws repeat each seed's
    accuracy exactly; a size beyond a class's recordings is refused naming the class; the command line
    refuses a malformed size list and the curve with --statistics-only in one line."""
    rng = np.random.default_rng(0)
    synthetic = []
    for c, activity in enumerate(FOLDERS):
        for i in range(3):
            frames = np.repeat(np.arange(12), 4)
            synthetic.append(recording(frames, rng.integers(8 - c, 9 + c, frames.size), rng.uniform(1, 3, frames.size),
                                       rng.normal(0.2 * c, 0.3, frames.size), activity=activity,
                                       source=f"s0_20_{activity}_{i}.npz"))
    real = read_recordings(RADHAR / "train", per_class=1)
    curve = learning_curve(synthetic, real, 10, 10, [3, 1, 1], draws=2, seeds=2)
    assert curve["sizes"] == [1, 3] and curve["draws"] == 2 and curve["seeds"] == 2
    for n in (1, 3):
        row = curve["per_size"][str(n)]
        assert len(row["accuracy"]) == 4 and row["train_windows"] == 5 * n
        assert 0 <= row["min"] <= row["mean"] <= row["max"] <= 1
    whole = curve["per_size"]["3"]["accuracy"]
    assert whole[:2] == whole[2:]                       # draw 0 and draw 1: seeds 0, 1 on the same set
    with pytest.raises(ValueError, match="smallest class"):
        learning_curve(synthetic, real, 10, 10, [4])
    for bad, said in ((["--learning-curve", "2,x"], "--learning-curve '2,x'"),
                      (["--learning-curve", "2", "--statistics-only"], "--statistics-only trains none"),
                      (["--draws", "0"], "--draws must be")):
        with pytest.raises(SystemExit):
            main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o"), *bad])
        assert said in capsys.readouterr().err


def test_moving_table_rows():
    def stats(per_frame, without, b1, b2):
        return {"moving": {"points_per_frame": per_frame, "frames_without": without, "share_bin_1": b1,
                           "share_bin_2_or_more": b2}}

    table = moving_table({"boxing": stats(1.655, 0.6833, 0.03614, 0.05358), "jump": stats(0.5, 0.25, 0.1, 0.0)},
                         {"boxing": stats(3.179, 0.2464, 0.10988, 0.07822), "walk": stats(2.28, 0.45, 0.142, 0.0034)})
    rows = table.splitlines()
    assert len(rows) == 2 + 3                                           # jack and squats: on neither side
    assert rows[2] == "| boxing | 1.66 / 3.18 | 0.68 / 0.25 | 0.036 / 0.110 | 0.054 / 0.078 |"
    assert rows[3] == "| jump | 0.50 / - | 0.25 / - | 0.100 / - | 0.000 / - |"
    assert rows[4] == "| walk | - / 2.28 | - / 0.45 | - / 0.142 | - / 0.003 |"


@needs_radhar
def test_statistics_only_trains_nothing(tmp_path, capsys):
    """``--statistics-only`` on a hand-made synthetic jump recording: frames 0, 1 and 3 have points (2 none, not
    counted); beyond 0.3 m frame 0 has bins +1 and -2, frame 1 only a static point (its bin +1 point is near),
    frame 3 bin +2: 3 moving points in 3 frames, one frame without, 1 of 5 points at +-1, 2 at +-2 and beyond."""
    synthetic = tmp_path / "synthetic"
    (synthetic / "jump").mkdir(parents=True)
    write_npz(synthetic / "jump" / "s0_20_jump_1.npz",
              recording([0, 0, 0, 1, 1, 3], [8, 9, 6, 9, 8, 10], [2.0, 2.0, 2.5, 0.1, 2.0, 3.0], [0.0] * 6))
    out = tmp_path / "o"
    assert main(["--real", str(RADHAR / "train"), "--out", str(out), "--quick", "--statistics-only",
                 "--synthetic", str(synthetic)]) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    metrics = json.loads(printed[-1])
    assert metrics == json.loads((out / "metrics.json").read_text())
    assert metrics["statistics_only"] is True and "sim_to_real" not in metrics and "real_to_real" not in metrics
    moving = metrics["statistics"]["simulated"]["jump"]["moving"]
    assert moving == {"points_per_frame": 1.0, "frames_without": 1 / 3, "share_bin_1": 0.2,
                      "share_bin_2_or_more": 0.4}
    assert set(metrics["statistics"]["real"]) == set(FOLDERS) and metrics["real"]["recordings"] == 10
    report = (out / "statistics.md").read_text()
    assert "| jump | 1.00 / " in report and "| jump | simulated |" in report and report.strip() in "\n".join(printed)
    assert sorted(metrics["figures"]) == ["doppler.png", "frames.png"] and not (out / "confusion.png").exists()
    assert not (out / "datasets").exists()
    # a recording whose velocity is off its Doppler grid: one line naming it, no traceback
    bad = tmp_path / "bad"
    (bad / "jump").mkdir(parents=True)
    rec = recording([0, 0, 0], [8, 9, 10], [2.0] * 3, [0.0] * 3, source="s0_20_jump_9.npz")
    write_npz(bad / "jump" / "s0_20_jump_9.npz", Recording(**{**rec.arrays(), "activity": "jump",
                                                               "source": "s0_20_jump_9.npz"}
                                                            | {"velocity": np.array([0.0, 0.9, 1.2], np.float32)}))
    assert main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o2"), "--quick", "--statistics-only",
                 "--synthetic", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "s0_20_jump_9.npz: point 1 has velocity 0.9 m/s" in err and "Traceback" not in err
    # nothing to score: the classifier's options are refused
    for extra in (["--ablation", "no_room"], ["--classifier-seeds", "3"]):
        with pytest.raises(SystemExit):
            main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "o3"), "--statistics-only", *extra])
        assert "--statistics-only trains none" in capsys.readouterr().err


@needs_radhar
@pytest.mark.slow
def test_quick_experiment_end_to_end(tmp_path, capsys):
    out = tmp_path / "s2r"
    assert main(["--real", str(RADHAR / "train"), "--out", str(out), "--quick"]) == 0
    metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert metrics == json.loads((out / "metrics.json").read_text())
    # the synthetic set: one recording per class in RadHAR's layout, read back by RadHAR's reader
    files = sorted((out / "synthetic").glob("*/*.npz"))
    assert sorted(p.parent.name for p in files) == sorted(FOLDERS)
    for path in files:
        rec = read_recording(path)
        assert rec.activity == path.parent.name and rec.num_points > 0
        assert set(np.load(path).files) == set(np.load(next((RADHAR / "train").glob("jump/*.npz"))).files)
    s2r = metrics["sim_to_real"]
    assert s2r["train_windows"] == 5 and 0 <= s2r["accuracy"] <= 1 and set(s2r["recall"]) == set(FOLDERS)
    assert np.asarray(s2r["confusion"]).sum() == s2r["windows"] > 0
    assert 0 <= metrics["real_to_real"]["accuracy"] <= 1
    assert set(metrics["statistics"]["simulated"]) == set(FOLDERS) == set(metrics["statistics"]["targets"])
    assert metrics["ablation"]["full"]["accuracy"] == s2r["accuracy"]
    assert (out / "confusion.png").is_file() and (out / "statistics.md").is_file()
    assert "moving points a frame, sim / real" in (out / "statistics.md").read_text()
    assert set(metrics["statistics"]["simulated"]["jump"]["moving"]) == {"points_per_frame", "frames_without",
                                                                        "share_bin_1", "share_bin_2_or_more"}
    # --synthetic reuses the set: nothing is generated, the same training data gives the same scores
    assert main(["--real", str(RADHAR / "train"), "--out", str(tmp_path / "again"), "--quick",
                 "--synthetic", str(out / "synthetic"), "--classifier-seeds", "3"]) == 0
    again = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert not (tmp_path / "again" / "datasets").exists()
    assert again["sim_to_real"]["confusion"] == s2r["confusion"]
    # the classifier's seeds: seed 0's figure first, the mean within the spread
    seeds = again["sim_to_real"]["seeds"]
    assert len(seeds["accuracy"]) == 3 and seeds["accuracy"][0] == s2r["accuracy"]
    assert seeds["min_accuracy"] <= seeds["mean_accuracy"] <= seeds["max_accuracy"]
    assert set(seeds["mean_recall"]) == set(FOLDERS)


@needs_radhar
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_every_ablation_variant_draws_items_that_build(tmp_path, variant):
    """Each variant's spec gives, for every class, an item whose scene builds (a variant that switches the
    room off must switch its furniture off too)."""
    from sionnafmcw import scenes
    from sionnafmcw.dataset.spec import load_spec

    spec = load_spec(variant_spec(variant, RADHAR / "1443es1_short_range_3d.cfg", 5, 2, seed=1))
    for i in range(5):
        item = spec.item(i)
        params = item["parameters"] if isinstance(item, dict) else item.parameters
        scenes.build("radhar", tmp_path / f"{i}", **{**params, "body_mesh_edge": 0.06})
