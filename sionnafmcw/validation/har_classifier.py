r"""A small activity classifier over TI point-cloud recordings: windows of frames, per-frame features, a 1-D CNN.

RadHAR (Singh et al., mmNets 2019) classifies windows of 60 frames (2 s at 30 fps), taken with a
stride of 10 frames, from the sensor's point clouds; its baselines voxelise each frame and run a
CNN/LSTM. Here each frame is summarised by features that do not depend on where the person
stands (:func:`frame_features`) and a window of them goes through a 1-D convolution over time:

.. math::
    h_t = \mathrm{ReLU}(W_1 f_t + b_1),\quad
    g_t = \mathrm{ReLU}\Big(\sum_{k=-2}^{2} W_2^{(k)} h_{t+k} + b_2\Big),\quad
    \hat y = \mathrm{softmax}\big(W_3 [\operatorname{mean}_t g_t;\ \max_t g_t] + b_3\big),

a few thousand weights, trained in seconds on a CPU. Its input is standardised by the mean and
standard deviation of the *training* windows' features only (so a model trained on simulated data
never sees a statistic of the real data).

Training and prediction run on one CPU thread by default (``threads=1``): a batch of this model is a
few small matrix products, too small for intra-op parallelism to pay for its synchronisation, and on
a machine whose cores are busy with other work PyTorch's waiting threads cost far more than they
give (``benchmarks/har_classifier_threads.py``); one thread also makes the result the same on every
machine, whatever its core count (a parallel reduction sums in another order).

Per frame :math:`t` (the points beyond ``near_range``, 0.3 m: the leakage/DC detections every real
frame has near the sensor say nothing of the person):

* :math:`\log(1 + n)`, :math:`n` the number of points, and the share of them that move (Doppler
  bin :math:`\neq` the zero bin);
* the Doppler histogram: the share of points in each of the ``num_doppler`` bins (the signed
  radial speed, what tells punches, jumps, squats and walking apart);
* of the moving points: the spread (standard deviation) of height :math:`z`, of cross-range
  :math:`y` and of range, the mean :math:`|v|`, and the mean height relative to that of all points
  (the moving part of the body above or below the static rest).
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

#: RadHAR's window (frames) and stride.
WINDOW = 60
STRIDE = 10
#: Points nearer than this (m) are left out (the sensor's leakage/DC detections).
NEAR_RANGE = 0.3


def frame_features(recording, num_doppler: int = 16, near_range: float = NEAR_RANGE) -> np.ndarray:
    """``[frames, 2 + num_doppler + 5]`` features of every frame from 0 to ``max(frame)`` of ``recording``
    (module docstring); a frame without points has all-zero features."""
    frame = np.asarray(recording.frame)
    num_frames = int(frame.max()) + 1 if frame.size else 0
    out = np.zeros((num_frames, 2 + num_doppler + 5), np.float32)
    keep = np.asarray(recording.range) >= near_range
    frame = frame[keep]
    if not frame.size:
        return out
    z, y, r = (np.asarray(a, np.float64)[keep] for a in (recording.z, recording.y, recording.range))
    v = np.asarray(recording.velocity, np.float64)[keep]
    dbin = np.clip(np.asarray(recording.doppler_bin)[keep], 0, num_doppler - 1)
    moving = v != 0
    count = np.bincount(frame, minlength=num_frames).astype(np.float64)
    safe = np.maximum(count, 1)
    nmov = np.bincount(frame, moving, num_frames)
    out[:, 0] = np.log1p(count)
    out[:, 1] = nmov / safe
    hist = np.zeros((num_frames, num_doppler))
    np.add.at(hist, (frame, dbin), 1.0)
    out[:, 2:2 + num_doppler] = hist / safe[:, None]

    def moving_std(a):
        w = moving.astype(np.float64)
        m = np.bincount(frame, w * a, num_frames) / np.maximum(nmov, 1)
        s = np.bincount(frame, w * a * a, num_frames) / np.maximum(nmov, 1) - m * m
        return np.sqrt(np.maximum(s, 0.0)), m

    k = 2 + num_doppler
    out[:, k], z_moving = moving_std(z)
    out[:, k + 1], _ = moving_std(y)
    out[:, k + 2], _ = moving_std(r)
    out[:, k + 3] = np.bincount(frame, moving * np.abs(v), num_frames) / np.maximum(nmov, 1)
    z_all = np.bincount(frame, z, num_frames) / safe
    out[:, k + 4] = np.where(nmov > 0, z_moving - z_all, 0.0)
    return out


def windows(features: np.ndarray, window: int = WINDOW, stride: int = STRIDE) -> np.ndarray:
    """``[n, window, F]``: every window of ``window`` frames of ``features`` starting at 0, stride, ...
    (those that fit whole; none for a recording shorter than a window)."""
    starts = range(0, features.shape[0] - window + 1, stride)
    if not len(starts):
        return np.zeros((0, window, features.shape[1]), np.float32)
    return np.stack([features[s:s + window] for s in starts])


def recording_windows(recordings, classes, window: int = WINDOW, stride: int = STRIDE):
    """``(X [n, window, F], y [n], group [n])`` over ``recordings``: every window, its class index in
    ``classes`` (the recording's ``activity``) and the index of the recording it came from."""
    xs, ys, gs = [], [], []
    for i, rec in enumerate(recordings):
        w = windows(frame_features(rec), window, stride)
        xs.append(w)
        ys.append(np.full(len(w), classes.index(rec.activity), np.int64))
        gs.append(np.full(len(w), i, np.int64))
    if not xs:
        raise ValueError("no recordings to make windows of")
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(gs)


class WindowClassifier:
    """The 1-D CNN of the module docstring, with its input standardisation; :meth:`fit`, :meth:`predict`.

    ``threads``: PyTorch's intra-op CPU threads while fitting and predicting (restored afterwards);
    ``None`` leaves PyTorch's setting (module docstring: why 1)."""

    def __init__(self, num_classes: int, hidden: int = 32, steps: int = 300, batch_size: int = 128,
                 learning_rate: float = 3e-3, weight_decay: float = 1e-3, dropout: float = 0.2, seed: int = 0,
                 threads: int | None = 1):
        self.num_classes, self.hidden, self.steps, self.batch_size = int(num_classes), int(hidden), int(steps), int(batch_size)
        self.learning_rate, self.weight_decay, self.dropout, self.seed = learning_rate, weight_decay, dropout, seed
        if threads is not None and (isinstance(threads, bool) or int(threads) < 1):
            raise ValueError(f"WindowClassifier: threads must be an integer >= 1 or None, got {threads!r}")
        self.threads = None if threads is None else int(threads)
        self.model = None

    @contextmanager
    def _torch_threads(self):
        """PyTorch's intra-op threads set to :attr:`threads` inside the block, restored after it."""
        import torch

        before = torch.get_num_threads()
        if self.threads is not None:
            torch.set_num_threads(self.threads)
        try:
            yield
        finally:
            torch.set_num_threads(before)

    def _build(self, num_features: int):
        import torch
        from torch import nn

        class Net(nn.Module):
            def __init__(s):
                super().__init__()
                s.frame = nn.Sequential(nn.Linear(num_features, self.hidden), nn.ReLU(), nn.Dropout(self.dropout))
                s.conv = nn.Sequential(nn.Conv1d(self.hidden, self.hidden, 5, padding=2), nn.ReLU())
                s.head = nn.Linear(2 * self.hidden, self.num_classes)

            def forward(s, x):                                   # x: [batch, time, features]
                g = s.conv(s.frame(x).transpose(1, 2))          # [batch, hidden, time]
                return s.head(torch.cat([g.mean(2), g.amax(2)], 1))

        return Net()

    def fit(self, x: np.ndarray, y: np.ndarray) -> "WindowClassifier":
        """Train on windows ``x [n, time, F]`` with labels ``y [n]``: ``steps`` Adam steps on random
        batches of ``batch_size`` windows (all of them when fewer), class-balanced cross-entropy."""
        if len(x) == 0:
            raise ValueError("no training windows")
        with self._torch_threads():
            return self._fit(x, y)

    def _fit(self, x: np.ndarray, y: np.ndarray) -> "WindowClassifier":
        import torch

        torch.manual_seed(self.seed)
        self.mean = x.reshape(-1, x.shape[-1]).mean(0)
        self.std = x.reshape(-1, x.shape[-1]).std(0) + 1e-6
        xt = torch.as_tensor((x - self.mean) / self.std, dtype=torch.float32)
        yt = torch.as_tensor(y, dtype=torch.int64)
        counts = np.bincount(y, minlength=self.num_classes).astype(np.float64)
        weight = torch.as_tensor(np.where(counts > 0, counts.sum() / np.maximum(counts, 1) / self.num_classes, 0.0),
                                 dtype=torch.float32)
        self.model = self._build(x.shape[-1])
        opt = torch.optim.Adam(self.model.parameters(), lr=self.learning_rate, weight_decay=self.weight_decay)
        loss_fn = torch.nn.CrossEntropyLoss(weight=weight)
        self.model.train()
        generator = torch.Generator().manual_seed(self.seed)
        for _ in range(self.steps):
            batch = torch.randperm(len(xt), generator=generator)[:self.batch_size]
            opt.zero_grad()
            loss = loss_fn(self.model(xt[batch]), yt[batch])
            loss.backward()
            opt.step()
        self.model.eval()
        return self

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Class index of every window of ``x``."""
        import torch

        with self._torch_threads(), torch.no_grad():
            out = self.model(torch.as_tensor((x - self.mean) / self.std, dtype=torch.float32))
        return out.argmax(1).numpy()


def scores(y_true: np.ndarray, y_pred: np.ndarray, classes) -> dict:
    """``{"accuracy", "recall": {class: r}, "confusion": [[true x predicted]], "windows"}`` (plain floats)."""
    n = len(classes)
    confusion = np.zeros((n, n), np.int64)
    np.add.at(confusion, (y_true, y_pred), 1)
    support = confusion.sum(1)
    return {"accuracy": float(np.trace(confusion) / max(confusion.sum(), 1)),
            "recall": {c: (float(confusion[i, i] / support[i]) if support[i] else float("nan"))
                       for i, c in enumerate(classes)},
            "confusion": confusion.tolist(), "windows": int(confusion.sum())}


__all__ = ["STRIDE", "WINDOW", "WindowClassifier", "frame_features", "recording_windows", "scores", "windows"]
