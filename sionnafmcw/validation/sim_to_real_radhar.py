"""Sim-to-real on RadHAR: a classifier trained on simulated point clouds only, evaluated on real ones.

The synthetic RadHAR is a data set of the ``radhar`` scenario (:mod:`sionnafmcw.scenes.radhar`,
the five classes in turn) with RadHAR's own radar (the sensor's ``.cfg``: TI IWR1443, 30 fps) and
the domain randomisation of :mod:`sionnafmcw.dataset.randomisation`, generated item by item on a
local Dask cluster (:func:`sionnafmcw.dataset.generate`). Every item's run goes through the board's
on-chip chain (:func:`sionnafmcw.ti.oob.run_point_clouds`) and the ROS driver's conversion
(:func:`~sionnafmcw.ti.formats.radhar.recording_from_frames`) and is exported as
``OUT/synthetic/<activity>/<item>.npz``, RadHAR's format (:mod:`sionnafmcw.ti.formats.radhar`).

Then:

* the point-cloud statistics per class, simulated against real
  (:mod:`sionnafmcw.validation.point_cloud_statistics`);
* a classifier (:mod:`sionnafmcw.validation.har_classifier`) trained on the synthetic windows only
  (60 frames, stride 10, as RadHAR) and evaluated on every window of the real recordings:
  accuracy, per-class recall, confusion matrix (``sim_to_real``);
* the ceiling: the same classifier trained on real recordings and tested on other sessions'
  recordings (``real_to_real``, sessions by the ``s<k>_`` prefix and the file-name pattern);
* an ablation: the synthetic set regenerated with one physics part off at a time (multipath,
  PO against Lambertian, receiver effects, room and furniture, randomisation), each classifier's
  accuracy on the real recordings.

No simulator setting is fitted to the real data and nothing but the ``real_to_real`` ceiling is
trained on it.

``OUT/metrics.json`` (also printed last, on one line) holds:

* ``sim_to_real``: :func:`~.har_classifier.scores` (``accuracy``, ``recall`` {class: r}, ``confusion``
  [true x predicted], ``windows``), ``train_windows``, ``train_accuracy``; with ``--classifier-seeds K``
  above 1 also ``seeds`` (:func:`seed_spread`);
* ``real_to_real``: the same scores, ``folds`` and ``sessions``;
* ``statistics`` (:func:`statistics`): ``simulated`` and ``real``, per class the
  :func:`~.point_cloud_statistics.recording_statistics` (``frames``, ``points``, ``points_per_frame``,
  ``zero_velocity_share``, ``intensity_db``, ``height_m``, ``forward_m``, and ``moving``:
  ``points_per_frame``, ``frames_without``, ``share_bin_1``, ``share_bin_2_or_more``); ``targets`` per
  class (``points_in_real_band``, ``zero_velocity_within_0.1``); ``doppler``: ``simulated`` and ``real``,
  per class the shares of the 16 Doppler bins (:func:`doppler_histograms`);
* ``ablation``: per variant ``off`` and ``accuracy``, ``recall`` (and ``seeds``), or ``error``; ``not_run``;
* with ``--learning-curve N1,N2,...``, ``learning_curve`` (:func:`learning_curve`): the accuracy on the real
  windows of classifiers trained on subsets of N items per class;
* ``synthetic`` (``folder``, ``recordings``, ``per_class``), ``real`` (``folder``, ``recordings``),
  ``window``, ``stride``, ``quick``, ``seconds`` (``generation``, ``total``), ``figures`` (the PNGs).

``OUT/statistics.md`` holds the two Markdown tables, :func:`statistics_table` and :func:`moving_table`.
``--statistics-only`` computes the statistics alone (no classifier, no ceiling, no ablation): its
``metrics.json`` has ``statistics``, ``synthetic``, ``real``, ``quick``, ``seconds``, ``figures``
(``doppler.png``, ``frames.png``) and ``statistics_only: true``.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from ..scenes import furniture as _furniture

#: RadHAR's folder names, in the data set's order.
FOLDERS = ("boxing", "jack", "jump", "squats", "walk")

#: The furniture counts of the room builders (:data:`sionnafmcw.scenes.furniture.PARAMETERS`; the others are
#: ``furniture_*`` settings): a scene without a room has none.
FURNITURE_COUNTS = tuple(n for n in _furniture.PARAMETERS if not n.startswith("furniture_"))

#: Ablation variants: name -> (what is off, changes to the data-set spec). ``full`` is the default set.
VARIANTS = {
    "full": ("nothing: every part on", {}),
    "no_multipath": ("multipath: one bounce (max_depth=1), no floor/wall/furniture-person paths",
                     {"engine_options": {"max_depth": 1}}),
    "lambertian": ("physical optics: the body and surfaces as Lambertian scatterers (physical_optics=False)",
                   {"engine_options": {"physical_optics": False}}),
    "no_receiver": ("receiver effects: no thermal noise, no phase noise, no noise-figure draw",
                    {"noise": False, "receiver": False}),
    "no_room": ("room and furniture clutter: the person alone in free space",
                {"fixed": {"room": False, **{n: 0 for n in FURNITURE_COUNTS}}}),
    "no_randomisation": ("domain randomisation: every item at the builder's defaults", {"randomise": False}),
}


def variant_spec(variant: str, cfg: Path, count: int, frames: int, seed: int = 0) -> dict:
    """The data-set spec of an ablation ``variant`` (:data:`VARIANTS`): RadHAR's ``cfg`` as the radar,
    ``count`` items (the classes in turn) of ``frames`` frames at 30 fps."""
    from ..dataset.randomisation import RADAR_RANGES, radhar_spec

    change = VARIANTS[variant][1]
    spec = radhar_spec(name=f"radhar-{variant}", count=count, seed=seed, radar=str(Path(cfg).resolve()),
                       num_frames=frames, fps=30.0, randomise=change.get("randomise", True),
                       engine_options=change.get("engine_options"), **change.get("fixed", {}))
    if change.get("receiver") is False:
        for name in RADAR_RANGES:
            spec["radar"].pop(name, None)           # the .cfg's radar: no phase noise, the default NF
    if "noise" in change:
        spec["noise"] = change["noise"]
    return spec


def export_radhar(data: Path, out: Path) -> Path:
    """Every complete item of the data set ``data`` as ``out/<RadHAR folder>/<item id>.npz``: the run
    through the on-chip chain and the ROS driver's conversion (crash-safe writes, existing files kept)."""
    from ..dataset.index import item_dir, read_json, store_state
    from ..radar import RadarConfig
    from ..scenes.radhar import RADHAR_FOLDERS
    from ..ti.formats.radhar import recording_from_frames, write_npz
    from ..ti.formats.ros_driver import DriverParams
    from ..ti.oob import run_point_clouds

    Path(out).mkdir(parents=True, exist_ok=True)
    for item in sorted((Path(data) / "items").iterdir()):
        record = read_json(item / "item.json") or {}
        store = item / "run.zarr"
        if record.get("status") != "complete" or not store_state(store)["complete"]:
            continue
        folder = RADHAR_FOLDERS[record["parameters"]["activity"]]
        path = Path(out) / folder / f"{item.name}.npz"
        if path.is_file():
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        radar = RadarConfig.from_dict(record["radar"])
        recording = recording_from_frames(run_point_clouds(store), DriverParams.from_radar(radar),
                                          activity=folder, source=f"sionnafmcw:radhar:{item.name}")
        write_npz(path, recording)
    return Path(out)


def session_of(source: str) -> str:
    """The recording session of a RadHAR file from its name (``source``: the repository path
    ``Data/Train/jump/___20_jump_1.txt``, or this project's ``s3_20_jump_1.npz``): the number of
    leading underscores (``s<k>_``, how RadHAR tells sessions apart) and the name pattern,
    ``20_<activity>_<n>`` or ``<activity>_20_<n>``; e.g. ``s3/20_act``."""
    import re

    name = Path(str(source)).stem
    m = re.match(r"s(\d+)_(.*)$", name)
    if m:
        k, rest = int(m.group(1)), m.group(2)
    else:
        rest = name.lstrip("_")
        k = len(name) - len(rest)
    return f"s{k}/{'20_act' if rest.startswith('20_') else 'act_20'}"


def session_folds(recordings, folds: int = 2) -> list[int]:
    """A fold per recording such that no session is in two folds: each class's sessions (sorted) go
    to folds 0, 1, ..., ``folds``-1 in turn, so that every fold tests every class that has at least
    ``folds`` sessions, on sessions its training never saw."""
    sessions = {}
    for rec in recordings:
        sessions.setdefault(rec.activity, set()).add(session_of(rec.source))
    fold_of = {(cls, s): i % folds for cls, ss in sessions.items() for i, s in enumerate(sorted(ss))}
    return [fold_of[(rec.activity, session_of(rec.source))] for rec in recordings]


# ===================================================================================== experiment
#: The default run: items (the classes in turn) and frames per item; RadHAR's window and stride.
DEFAULT = {"items": 10, "frames": 60, "window": 60, "stride": 10, "engine_options": None, "real_per_class": None}
#: ``--quick``: a test's size (short items, a short window, a lighter render, a few real recordings).
QUICK = {"items": 5, "frames": 10, "window": 10, "stride": 10, "engine_options": {"samples_per_src": 20000},
         "real_per_class": 2}


def read_recordings(root: Path, per_class: int | None = None) -> list:
    """The RadHAR recordings under ``root`` (``.npz`` or text dumps), in the reader's order; with
    ``per_class``, at most that many of each class, taken from its sessions (:func:`session_of`) in
    turn, so that a few recordings still span several sessions and the session-wise ceiling
    (:func:`real_to_real`) has sessions to test on that its training did not see."""
    from ..ti.formats.radhar import read_dataset

    recordings = list(read_dataset(root))
    for rec in recordings:
        if rec.activity not in FOLDERS:
            raise ValueError(f"{root}: recording {rec.source} has activity {rec.activity!r}, not one of "
                             f"{', '.join(FOLDERS)} (RadHAR's folders)")
    if per_class is None:
        return recordings
    queues: dict = {}                                   # class -> session -> its recordings, in order
    for i, rec in enumerate(recordings):
        queues.setdefault(rec.activity, {}).setdefault(session_of(rec.source), []).append(i)
    chosen = set()
    for sessions in queues.values():
        turn = [list(q) for _, q in sorted(sessions.items())]
        picked: list = []
        while len(picked) < per_class and any(turn):
            for q in turn:
                if q and len(picked) < per_class:
                    picked.append(q.pop(0))
        chosen.update(picked)
    return [rec for i, rec in enumerate(recordings) if i in chosen]


def sim_to_real(synthetic: list, real: list, window: int, stride: int, seed: int = 0) -> dict:
    """Train on the windows of the ``synthetic`` recordings, score every window of ``real``; a
    ``ValueError`` naming the shortfall when no synthetic recording is as long as a window."""
    from .har_classifier import WindowClassifier, recording_windows, scores

    classes = list(FOLDERS)
    xs, ys, _ = recording_windows(synthetic, classes, window, stride)
    if not len(xs):
        longest = max((r.num_frames for r in synthetic), default=0)
        raise ValueError(f"the synthetic recordings have at most {longest} frames, fewer than a window of "
                         f"{window}: give a set of items of at least {window} frames")
    xr, yr, _ = recording_windows(real, classes, window, stride)
    model = WindowClassifier(len(classes), seed=seed).fit(xs, ys)
    result = scores(yr, model.predict(xr), classes)
    result["train_windows"] = int(len(xs))
    result["train_accuracy"] = scores(ys, model.predict(xs), classes)["accuracy"]
    return result


def seed_spread(results: list) -> dict:
    """The accuracies and recalls of :func:`sim_to_real` run with classifier seeds 0, 1, ... (``results`` in
    that order): ``{"accuracy": [...], "mean_accuracy", "min_accuracy", "max_accuracy", "mean_recall": {class:
    r}}``. A set of a few dozen windows does not pin the classifier down; the mean is the figure to compare."""
    import numpy as np

    acc = [float(r["accuracy"]) for r in results]
    return {"accuracy": acc, "mean_accuracy": float(np.mean(acc)), "min_accuracy": min(acc),
            "max_accuracy": max(acc),
            "mean_recall": {c: float(np.mean([r["recall"][c] for r in results])) for c in results[0]["recall"]}}


def learning_curve(synthetic: list, real: list, window: int, stride: int, sizes, draws: int = 5,
                   seeds: int = 1) -> dict:
    """Accuracy on ``real`` against the size of the synthetic training set: for every ``n`` of ``sizes`` (items
    per class), ``draws`` subsets of ``n`` recordings of each class drawn without replacement from
    ``synthetic`` (a generator seeded by ``n`` and the draw), each trained with the classifier seeds 0 to
    ``seeds`` - 1 (:func:`sim_to_real`). ``{"sizes": [...], "draws", "seeds", "per_size": {n: {"accuracy":
    [...], "mean", "min", "max", "train_windows"}}}``. How the transfer grows with the set's size says
    whether more of the same simulation would close a gap: a curve still rising at the set's full size
    does; a flat one does not. A ``ValueError`` names a size larger than a class has recordings."""
    import numpy as np

    by_class = {c: [r for r in synthetic if r.activity == c] for c in FOLDERS}
    sizes = sorted({int(n) for n in sizes})
    smallest = min(len(v) for v in by_class.values())
    if not sizes or sizes[0] < 1 or sizes[-1] > smallest:
        raise ValueError(f"learning curve sizes {sizes} must lie in 1..{smallest}, the recordings of the "
                         f"smallest class ({min(by_class, key=lambda c: len(by_class[c]))})")
    per_size = {}
    for n in sizes:
        acc, windows = [], 0
        for d in range(int(draws)):
            rng = np.random.default_rng([n, d])
            subset = [r for c in FOLDERS for r in (by_class[c][i] for i in
                                                   np.sort(rng.choice(len(by_class[c]), n, replace=False)))]
            for k in range(int(seeds)):
                result = sim_to_real(subset, real, window, stride, seed=k)
                acc.append(float(result["accuracy"]))
                windows = result["train_windows"]
        per_size[str(n)] = {"accuracy": acc, "mean": float(np.mean(acc)), "min": min(acc), "max": max(acc),
                            "train_windows": int(windows)}
    return {"sizes": sizes, "draws": int(draws), "seeds": int(seeds), "per_size": per_size}


def real_to_real(real: list, window: int, stride: int, folds: int = 2, seed: int = 0) -> dict:
    """The ceiling: the same classifier trained on real recordings, tested on the windows of the
    sessions it did not see (:func:`session_folds`; every window tested once, scores pooled)."""
    import numpy as np

    from .har_classifier import WindowClassifier, recording_windows, scores

    classes = list(FOLDERS)
    x, y, g = recording_windows(real, classes, window, stride)
    fold = np.asarray(session_folds(real, folds))[g]
    pred = np.full_like(y, -1)
    for f in range(folds):
        test = fold == f
        if test.any() and (~test).any():
            pred[test] = WindowClassifier(len(classes), seed=seed).fit(x[~test], y[~test]).predict(x[test])
    tested = pred >= 0
    result = scores(y[tested], pred[tested], classes)
    result["folds"] = folds
    result["sessions"] = sorted({f"{r.activity}:{session_of(r.source)}" for r in real})
    return result


def statistics_table(simulated: dict, real: dict) -> str:
    """Per class, simulated against real, as a Markdown table (points per frame, zero-velocity share,
    intensity, height and forward extent), and whether the two targets are met."""
    rows = ["| class | side | points/frame median (5-95 %) | zero-velocity share | intensity median, dB "
            "| height 5-95 %, m | forward 5-95 %, m |", "|---|---|---|---|---|---|---|"]
    for cls in FOLDERS:
        for side, table in (("simulated", simulated), ("real", real)):
            if cls not in table:
                continue
            s = table[cls]
            p = s["points_per_frame"]
            rows.append(f"| {cls} | {side} | {p['median']:.0f} ({p['p05']:.0f}-{p['p95']:.0f}) "
                        f"| {s['zero_velocity_share']:.2f} | {s['intensity_db']['median']:.1f} "
                        f"| {s['height_m']['p05']:.2f} to {s['height_m']['p95']:.2f} "
                        f"| {s['forward_m']['p05']:.2f} to {s['forward_m']['p95']:.2f} |")
    return "\n".join(rows) + "\n"


def moving_table(simulated: dict, real: dict) -> str:
    """Per class, the moving points beyond 0.3 m (``moving`` of
    :func:`~.point_cloud_statistics.recording_statistics`), simulated / real, as a Markdown table: moving
    points a frame, the share of frames without one, and the shares of the points beyond 0.3 m at Doppler
    bin +-1 and at +-2 and beyond (``-`` where a side has no recording of the class)."""
    rows = ["| class | moving points a frame, sim / real | frames without a moving point, sim / real "
            "| share at Doppler bin +-1, sim / real | at +-2 and beyond, sim / real |", "|---|---|---|---|---|"]
    columns = (("points_per_frame", "{:.2f}"), ("frames_without", "{:.2f}"), ("share_bin_1", "{:.3f}"),
               ("share_bin_2_or_more", "{:.3f}"))
    for cls in FOLDERS:
        if cls not in simulated and cls not in real:
            continue
        cells = [" / ".join(fmt.format(table[cls]["moving"][key]) if cls in table else "-"
                            for table in (simulated, real)) for key, fmt in columns]
        rows.append(f"| {cls} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


def statistics_markdown(stats: dict) -> str:
    """``statistics.md``: :func:`statistics_table` and :func:`moving_table` of ``stats`` (:func:`statistics`)."""
    return (statistics_table(stats["simulated"], stats["real"]) + "\n"
            + moving_table(stats["simulated"], stats["real"]))


def statistics(synthetic: list, real: list) -> dict:
    """``{"simulated": {class: stats}, "real": {...}, "targets": {class: {...}}}``: the statistics of
    :mod:`.point_cloud_statistics` per class and the two targets per class (the simulated
    median points per frame inside the real 5-95 % band; zero-velocity shares within 0.1)."""
    from .point_cloud_statistics import recording_statistics

    def per_class(recs):
        return {c: recording_statistics([r for r in recs if r.activity == c]) for c in FOLDERS
                if any(r.activity == c for r in recs)}

    sim, rl = per_class(synthetic), per_class(real)
    targets = {}
    for c in sorted(set(sim) & set(rl)):
        p = sim[c]["points_per_frame"]["median"]
        targets[c] = {"points_in_real_band": bool(rl[c]["points_per_frame"]["p05"] <= p
                                                  <= rl[c]["points_per_frame"]["p95"]),
                      "zero_velocity_within_0.1": bool(abs(sim[c]["zero_velocity_share"]
                                                           - rl[c]["zero_velocity_share"]) <= 0.1)}
    return {"simulated": sim, "real": rl, "targets": targets}


def doppler_histograms(recordings, near_range: float = 0.3) -> dict:
    """``{class: share of the points beyond near_range in each Doppler bin}`` (16 bins)."""
    import numpy as np

    out = {}
    for c in FOLDERS:
        bins = [np.asarray(r.doppler_bin)[np.asarray(r.range) >= near_range] for r in recordings if r.activity == c]
        if bins:
            h = np.bincount(np.clip(np.concatenate(bins), 0, 15), minlength=16).astype(float)
            out[c] = (h / max(h.sum(), 1)).tolist()
    return out


def confusion_figure(metrics: dict):
    """The confusion matrices of ``metrics["sim_to_real"]`` and ``metrics["real_to_real"]`` side by
    side, each row (a true class) as shares of its real windows; a matplotlib ``Figure``."""
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    for ax, key, title in ((axes[0], "sim_to_real", "trained on simulated"),
                           (axes[1], "real_to_real", "trained on real (other sessions)")):
        c = np.asarray(metrics[key]["confusion"], float)
        share = c / np.maximum(c.sum(1, keepdims=True), 1)
        ax.imshow(share, vmin=0, vmax=1, cmap="Blues")
        for i in range(len(FOLDERS)):
            for j in range(len(FOLDERS)):
                ax.text(j, i, f"{share[i, j]:.2f}", ha="center", va="center",
                        color="white" if share[i, j] > 0.5 else "black", fontsize=8)
        ax.set_xticks(range(len(FOLDERS)), FOLDERS, rotation=45)
        ax.set_yticks(range(len(FOLDERS)), FOLDERS)
        ax.set_xlabel("predicted")
        ax.set_ylabel("true (real windows)")
        ax.set_title(f"{title}: {metrics[key]['accuracy']:.2f}", fontsize=10)
    fig.tight_layout()
    return fig


def doppler_figure(synthetic: list, real: list):
    """The Doppler histograms per class (:func:`doppler_histograms`), simulated against real, on the
    radial-velocity axis of RadHAR's Doppler bins; a matplotlib ``Figure``."""
    import matplotlib.pyplot as plt
    import numpy as np

    sim_h, real_h = doppler_histograms(synthetic), doppler_histograms(real)
    fig, axes = plt.subplots(1, len(FOLDERS), figsize=(15, 3), sharey=True)
    v = (np.arange(16) - 8) * 0.6147
    for ax, c in zip(axes, FOLDERS):
        for h, label in ((sim_h.get(c), "simulated"), (real_h.get(c), "real")):
            if h is not None:
                ax.semilogy(v, np.maximum(h, 1e-4), "o-" if label == "real" else "s--", label=label, ms=3)
        ax.set_title(c)
        ax.set_xlabel("radial velocity, m/s")
    axes[0].set_ylabel("share of points (range > 0.3 m)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def frames_figure(synthetic: list, real: list):
    """One frame per class, simulated above real: the side view (forward x, height z) of the middle
    frame of each class's first recording, moving points red; a matplotlib ``Figure``."""
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(2, len(FOLDERS), figsize=(15, 6), sharex=True, sharey=True)
    for row, (recs, label) in enumerate(((synthetic, "simulated"), (real, "real"))):
        for ax, c in zip(axes[row], FOLDERS):
            rec = next((r for r in recs if r.activity == c), None)
            if rec is None:
                continue
            frame = np.asarray(rec.frame)
            k = np.sort(np.unique(frame))[len(np.unique(frame)) // 2]
            m = frame == k
            moving = np.asarray(rec.velocity)[m] != 0
            x, z = np.asarray(rec.x)[m], np.asarray(rec.z)[m]
            ax.scatter(x[~moving], z[~moving], s=8, c="0.4", label="static")
            ax.scatter(x[moving], z[moving], s=12, c="r", label="moving")
            ax.set_title(f"{label} {c}, frame {k}", fontsize=9)
            ax.set_xlabel("forward x, m")
    for ax in axes[:, 0]:
        ax.set_ylabel("height z, m")
    labelled = next((ax for ax in axes.flat if ax.get_legend_handles_labels()[0]), None)
    if labelled is not None:             # the first panel with a frame (a class may be missing)
        labelled.legend(fontsize=7)
    fig.tight_layout()
    return fig


def figures(out: Path, metrics: dict, synthetic: list, real: list) -> list[str]:
    """:func:`confusion_figure` (where ``metrics`` has ``sim_to_real``), :func:`doppler_figure` and
    :func:`frames_figure` as PNGs in ``out`` (``confusion.png``, ``doppler.png``, ``frames.png``); returns
    their names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    makers = [("confusion.png", lambda: confusion_figure(metrics), 120)] if "sim_to_real" in metrics else []
    makers += [("doppler.png", lambda: doppler_figure(synthetic, real), 120),
               ("frames.png", lambda: frames_figure(synthetic, real), 110)]
    for name, make, dpi in makers:
        fig = make()
        fig.savefig(Path(out) / name, dpi=dpi)
        plt.close(fig)
        written.append(name)
    return written


def main(argv=None) -> int:
    import argparse
    import sys

    from ..dataset.index import DatasetError
    from ..interrupts import Interrupted

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--real", type=Path, default=Path("../shared/realdata/radhar/train"),
                   help="real RadHAR recordings (the .npz folder or a clone's Data/Train)")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--synthetic", type=Path, default=None,
                   help="reuse a synthetic set (RadHAR layout, <activity>/*.npz): only train and evaluate")
    p.add_argument("--cfg", type=Path, default=None,
                   help="the sensor's .cfg (default: REAL/../1443es1_short_range_3d.cfg)")
    p.add_argument("--quick", action="store_true", help="a test's size: " + json.dumps(QUICK))
    p.add_argument("--items", type=int, default=None, help=f"synthetic items (default {DEFAULT['items']})")
    p.add_argument("--ablation", default="", help=f"variants to regenerate and score, comma-separated, of "
                   f"{', '.join(v for v in VARIANTS if v != 'full')} (each costs a synthetic set)")
    p.add_argument("--workers", type=int, default=1, help="local Dask workers for the generation")
    p.add_argument("--seed", type=int, default=0, help="the synthetic set's seed (other draws of the same ranges)")
    p.add_argument("--classifier-seeds", type=int, default=1, metavar="K",
                   help="train the sim-to-real classifier with seeds 0..K-1 and report each and their mean "
                        "(a small set's accuracy moves with the seed)")
    p.add_argument("--learning-curve", default="", metavar="N1,N2,...",
                   help="also train on subsets of N items per class (--draws subsets each, every classifier "
                        "seed) and report the accuracy per size (metrics.json learning_curve)")
    p.add_argument("--draws", type=int, default=5, help="subsets drawn per learning-curve size")
    p.add_argument("--statistics-only", action="store_true",
                   help="only the point-cloud statistics, simulated against real (statistics.md, metrics.json, "
                        "doppler.png, frames.png): no classifier, no ceiling, no ablation")
    a = p.parse_args(argv)
    if not 0 <= a.seed < 2**31:
        p.error(f"--seed must be in 0..2**31-1, got {a.seed}")
    if a.classifier_seeds < 1:
        p.error(f"--classifier-seeds must be >= 1, got {a.classifier_seeds}")
    size = dict(QUICK if a.quick else DEFAULT)
    if a.items is not None:
        if a.items < 1:
            p.error(f"--items must be >= 1, got {a.items}")
        size["items"] = a.items
    cfg = a.cfg or a.real.resolve().parent / "1443es1_short_range_3d.cfg"
    if a.synthetic is None and not cfg.is_file():
        p.error(f"{cfg}: no such .cfg; give the sensor's .cfg with --cfg")
    if not a.real.exists():
        p.error(f"--real {a.real}: no such folder; give RadHAR's recordings (realdata/radhar/train or Data/Train)")
    if a.synthetic is not None and not a.synthetic.is_dir():
        p.error(f"--synthetic {a.synthetic}: no such folder; give a synthetic set in RadHAR's layout")
    ablation = [v for v in a.ablation.split(",") if v]
    unknown = sorted(set(ablation) - set(VARIANTS) | ({"full"} & set(ablation)))
    if unknown:
        p.error(f"--ablation: unknown {', '.join(unknown)} (choose from "
                f"{', '.join(v for v in VARIANTS if v != 'full')})")
    if a.statistics_only and ablation:
        p.error("--ablation scores classifiers; --statistics-only trains none: give one of them")
    if a.statistics_only and a.classifier_seeds > 1:
        p.error("--classifier-seeds seeds the classifier; --statistics-only trains none: give one of them")
    try:
        curve = [int(n) for n in a.learning_curve.split(",") if n.strip()]
    except ValueError:
        p.error(f"--learning-curve {a.learning_curve!r}: give items per class as integers, e.g. 2,4,8")
    if a.statistics_only and curve:
        p.error("--learning-curve trains classifiers; --statistics-only trains none: give one of them")
    if a.draws < 1:
        p.error(f"--draws must be >= 1, got {a.draws}")
    a.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    try:
        real = read_recordings(a.real, size["real_per_class"])
        if a.synthetic is None:
            synthetic_dir = _generate(a, "full", cfg, size)
        else:
            synthetic_dir = a.synthetic
        synthetic = read_recordings(synthetic_dir)
    except (OSError, ValueError, DatasetError) as e:
        print(f"sim_to_real_radhar: {e}", file=sys.stderr)
        return 2
    except Interrupted as e:     # Ctrl-C / kill during the generation: one line, the set resumes
        print(f"sim_to_real_radhar: {e}", file=sys.stderr)
        return e.exit_status
    t_generate = time.perf_counter() - t0
    try:
        stats = statistics(synthetic, real)
    except ValueError as e:              # a recording whose Doppler fields are not the driver's
        print(f"sim_to_real_radhar: {e}", file=sys.stderr)
        return 2
    stats["doppler"] = {"simulated": doppler_histograms(synthetic), "real": doppler_histograms(real)}
    sets = {"synthetic": {"folder": str(synthetic_dir), "recordings": len(synthetic),
                          "per_class": {c: sum(r.activity == c for r in synthetic) for c in FOLDERS}},
            "real": {"folder": str(a.real), "recordings": len(real)}}
    if a.statistics_only:
        metrics = {"statistics": stats, "statistics_only": True, **sets, "quick": bool(a.quick)}
        return _write_report(a.out, metrics, synthetic, real, t0, t_generate)
    window, stride = size["window"], size["stride"]
    try:
        s2r = sim_to_real(synthetic, real, window, stride)
    except ValueError as e:
        print(f"sim_to_real_radhar: {synthetic_dir}: {e}", file=sys.stderr)
        return 2
    if a.classifier_seeds > 1:
        s2r["seeds"] = seed_spread([s2r] + [sim_to_real(synthetic, real, window, stride, seed=k)
                                            for k in range(1, a.classifier_seeds)])
    metrics = {"sim_to_real": s2r,
               "real_to_real": real_to_real(real, window, stride),
               "statistics": stats,
               "ablation": {}, **sets,
               "window": window, "stride": stride, "quick": bool(a.quick)}
    metrics["ablation"]["full"] = {"off": VARIANTS["full"][0], "accuracy": metrics["sim_to_real"]["accuracy"]}
    if curve:
        try:
            metrics["learning_curve"] = learning_curve(synthetic, real, window, stride, curve, a.draws,
                                                       a.classifier_seeds)
        except ValueError as e:
            print(f"sim_to_real_radhar: --learning-curve: {e}", file=sys.stderr)
            return 2
    for variant in ablation:
        try:
            folder = _generate(a, variant, cfg, size)
            s = sim_to_real(read_recordings(folder), real, window, stride)
        except (OSError, ValueError, DatasetError) as e:     # e.g. every item failed: say so, go on
            print(f"sim_to_real_radhar: ablation {variant}: {e}", file=sys.stderr)
            metrics["ablation"][variant] = {"off": VARIANTS[variant][0], "error": str(e)}
            continue
        metrics["ablation"][variant] = {"off": VARIANTS[variant][0], "accuracy": s["accuracy"], "recall": s["recall"]}
        if a.classifier_seeds > 1:
            metrics["ablation"][variant]["seeds"] = seed_spread(
                [s] + [sim_to_real(read_recordings(folder), real, window, stride, seed=k)
                       for k in range(1, a.classifier_seeds)])
    metrics["ablation"]["not_run"] = [v for v in VARIANTS if v != "full" and v not in ablation]
    return _write_report(a.out, metrics, synthetic, real, t0, t_generate)


def _write_report(out: Path, metrics: dict, synthetic: list, real: list, t0: float, t_generate: float) -> int:
    """``statistics.md``, the figures and ``metrics.json`` in ``out`` (crash-safe writes); print the tables,
    then the metrics JSON on one line."""
    from ..fs import atomic_write_text

    metrics["seconds"] = {"generation": t_generate, "total": time.perf_counter() - t0}
    report = statistics_markdown(metrics["statistics"])
    atomic_write_text(out / "statistics.md", report)
    metrics["figures"] = figures(out, metrics, synthetic, real)
    atomic_write_text(out / "metrics.json", json.dumps(metrics, indent=2))
    print(report)
    print(json.dumps(metrics))
    return 0


def _generate(a, variant: str, cfg: Path, size: dict) -> Path:
    """Generate the set of ``variant`` at ``size`` under ``a.out`` and export it (RadHAR layout)."""
    change = VARIANTS[variant][1]
    options = {**(size["engine_options"] or {}), **change.get("engine_options", {})}
    root = a.out
    spec = variant_spec(variant, cfg, size["items"], size["frames"], seed=a.seed)
    if options:
        spec["engine_options"] = options
    from ..dataset import generate
    from ..dataset.generate import DatasetWarning
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DatasetWarning)
        generate(spec, root / "datasets" / variant, workers=a.workers, progress=False)
    return export_radhar(root / "datasets" / variant,
                         root / ("synthetic" if variant == "full" else f"synthetic_{variant}"))
