"""The activity classifier's training and prediction: PyTorch's own thread count (A) against one thread (B), interleaved.

What it measures: ``WindowClassifier(5, threads=None)`` (A: PyTorch's default intra-op threads,
the machine's cores) and ``WindowClassifier(5, threads=1)`` (B: the default) fitted on the same
windows and predicting all of them, one after the other, ``--repeats`` times in one process; the
wall time of each, the ratio B/A, and the two models' training accuracy (the same seed: they differ
only by the order in which parallel reductions sum).

The windows are RadHAR's (60 frames, stride 10) of the real training split's recordings, or of its
``--per-class`` recordings of each class (``read_recordings``: from its sessions in turn).

    python benchmarks/har_classifier_threads.py [--real ../shared/realdata/radhar/train] [--window 60]
        [--stride 10] [--per-class N] [--repeats 2]

Measured
--------
``python benchmarks/har_classifier_threads.py --real /work/shared/realdata/radhar/train`` (7198
windows of 60 frames), 2-core AMD EPYC shared with two other engineers' work and a data-set
generation (load average 6-7.5); PyTorch's default: 2 threads::

    repeat  A (default) s  B (1 thread) s    B/A   acc A   acc B
         0          98.25            5.97  0.061  0.9528  0.9535
         1          89.66            5.13  0.057  0.9528  0.9535
    all: A 187.91 s, B 11.10 s, B/A 0.059

On a loaded machine PyTorch's second thread waits for a core at every one of the thousands of
small operations of a fit; the training accuracies differ in the fourth digit (the order of a
parallel sum), and each is the same from one repeat to the next.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv=None) -> int:
    import torch

    from sionnafmcw.validation.har_classifier import WindowClassifier, recording_windows
    from sionnafmcw.validation.sim_to_real_radhar import FOLDERS, read_recordings

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--real", type=Path, default=Path("../shared/realdata/radhar/train"))
    p.add_argument("--window", type=int, default=60)
    p.add_argument("--stride", type=int, default=10)
    p.add_argument("--per-class", type=int, default=None)
    p.add_argument("--repeats", type=int, default=2)
    a = p.parse_args(argv)
    if not a.real.is_dir():
        p.error(f"--real {a.real}: no such folder; give RadHAR's recordings (realdata/radhar/train)")
    x, y, _ = recording_windows(read_recordings(a.real, a.per_class), list(FOLDERS), a.window, a.stride)
    print(f"{len(x)} windows of {a.window} frames; PyTorch's default threads: {torch.get_num_threads()}")
    print(f"{'repeat':>6} {'A (default) s':>14} {'B (1 thread) s':>15} {'B/A':>6} {'acc A':>7} {'acc B':>7}")
    totals = [0.0, 0.0]
    for r in range(a.repeats):
        row = []
        for i, threads in enumerate((None, 1)):
            t0 = time.perf_counter()
            model = WindowClassifier(len(FOLDERS), threads=threads).fit(x, y)
            accuracy = float((model.predict(x) == y).mean())
            seconds = time.perf_counter() - t0
            totals[i] += seconds
            row.append((seconds, accuracy))
        print(f"{r:>6} {row[0][0]:>14.2f} {row[1][0]:>15.2f} {row[1][0] / row[0][0]:>6.3f} "
              f"{row[0][1]:>7.4f} {row[1][1]:>7.4f}")
    print(f"all: A {totals[0]:.2f} s, B {totals[1]:.2f} s, B/A {totals[1] / totals[0]:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
