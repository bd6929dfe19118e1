"""OpenRadar's reader and DSP on DCA1000 captures; runs inside .venv-openradar (numpy < 1.24).

Usage: ``python tests/openradar_harness.py JOB.json RESULT.json``. It imports nothing of
sionnafmcw: a user with a TI board and an OpenRadar pipeline sees only the capture directory
(``adc_data.bin``) and what they know of their board and .cfg, which the job gives per case:

``{"cases": [{"name", "capture", "family", "num_tx", "num_rx", "num_loops", "num_samples",
"range_resolution", "velocity_resolution", "azimuth_channels", "num_targets"}]}``

``azimuth_channels`` are the virtual channels (OpenRadar's order after ``separate_tx``:
``slot * num_rx + rx``) of the board's azimuth row, in order along the row (the user's knowledge
of the antenna layout). The chain is OpenRadar's, as in its ``demo/visualizer/main.py``:
``DCA1000.organize`` -> ``dsp.range_processing`` -> ``dsp.doppler_processing`` (TDM
de-interleave) -> ``dsp.ca_`` CFAR along range and Doppler -> ``dsp.gen_steering_vec`` +
``dsp.aoa_bartlett`` on the azimuth row. For each frame it reports the ``num_targets`` strongest
CFAR detections that are local maxima of the range-Doppler map: range, radial velocity and
azimuth.

Workarounds for OpenRadar 1.0.1's own bugs (not for our format):

1. Its demos read the ``.bin`` with ``dtype=np.uint16``: negative samples wrap to 65535 - |x| and
   the spectrum is wrong. TI's samples are int16 two's complement, so we read ``np.int16`` and
   hand that to ``DCA1000.organize`` (pure arithmetic, dtype-agnostic).
2. ``DCA1000.organize`` knows only the xWR16xx/18xx/68xx 2-lane format; OpenRadar has no reader
   for the xWR14xx 4-lane format (TI SWRA581: per sample ``I_rx0..I_rx3 Q_rx0..Q_rx3``), so the
   harness de-interleaves xWR14xx itself, as TI's script does.
3. ``dsp.add_doppler_compensation`` (TDM phase correction before the angle FFT) fails on
   Python 3 (a float slice index ``num_antennas/num_tx_antennas``) and would rotate every
   non-first transmitter by the same phase; the harness rotates slot ``q``'s channels by
   ``exp(-j 2 pi k q / (M L))`` (k the signed Doppler bin), what the function means to do.
4. ``dsp.doppler_processing`` returns ``log2|X|`` summed over channels; a channel with an exact
   zero gives ``-inf`` and a numpy warning; we silence the warning (the map is unchanged).
5. ``mmwave`` imports scipy and scikit-learn without declaring them (the set-up installs them) and
   ``gen_steering_vec`` calls ``np.complex`` (gone in numpy 1.24: hence numpy < 1.24).
"""

import json
import sys
import warnings

import numpy as np
import mmwave.dsp as dsp
from mmwave.dataloader import DCA1000
from mmwave.dsp.utils import Window

ANGLE_RANGE_DEG = 90
ANGLE_STEP_DEG = 0.5
#: CA-CFAR threshold above the local noise floor, per virtual channel (dB), on the
#: channel-summed log2 map: l_bound = V * log2(10 ** (dB / 20)).
CFAR_DB = 12.0


def read_frames(path, family, num_chirps, num_rx, num_samples):
    """``adc_data.bin`` -> complex ``[frame, chirp, rx, sample]`` (workarounds 1 and 2)."""
    words = np.fromfile(path, dtype=np.int16)
    per_frame = num_chirps * num_rx * num_samples * 2
    if words.size % per_frame:
        raise SystemExit(f"{path}: {words.size * 2} bytes is not a whole number of {per_frame * 2}-byte frames")
    words = words.reshape(-1, per_frame)
    if family == "xWR16xx":
        return np.stack([DCA1000.organize(f, num_chirps, num_rx, num_samples) for f in words])
    w = words.reshape(words.shape[0], num_chirps, num_samples, 2, num_rx).astype(np.float64)
    return (w[:, :, :, 0, :] + 1j * w[:, :, :, 1, :]).transpose(0, 1, 3, 2)


def local_maxima(det_matrix, mask):
    """Detections that are maxima of their 3 x 3 range-Doppler neighbourhood (Doppler wraps)."""
    padded = np.pad(det_matrix, ((1, 1), (0, 0)), mode="constant", constant_values=-np.inf)
    best = np.full(det_matrix.shape, -np.inf)
    for dr in (-1, 0, 1):
        for dd in (-1, 0, 1):
            if dr == 0 and dd == 0:
                continue
            shifted = np.roll(padded, dd, axis=1)[1 + dr:1 + dr + det_matrix.shape[0]]
            best = np.maximum(best, shifted)
    return mask & (det_matrix > best)


def process_frame(frame, case, steering):
    num_tx, num_rx, loops = case["num_tx"], case["num_rx"], case["num_loops"]
    radar_cube = dsp.range_processing(frame, window_type_1d=Window.HANNING)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # workaround 4
        det_matrix, aoa_input = dsp.doppler_processing(radar_cube, num_tx_antennas=num_tx,
                                                       clutter_removal_enabled=False,
                                                       window_type_2d=Window.HANNING)
    det_matrix = np.where(np.isfinite(det_matrix), det_matrix, np.nanmin(det_matrix[np.isfinite(det_matrix)]))
    l_bound = num_tx * num_rx * np.log2(10 ** (CFAR_DB / 20))
    # as the demo: CA-CFAR along Doppler (the transposed map) and along range, both must pass
    thr_doppler, _ = np.apply_along_axis(dsp.ca_, 0, det_matrix.T, l_bound=l_bound, guard_len=2, noise_len=4)
    thr_range, _ = np.apply_along_axis(dsp.ca_, 0, det_matrix, l_bound=l_bound, guard_len=4, noise_len=16)
    mask = (det_matrix > thr_doppler.T) & (det_matrix > thr_range)
    peaks = np.argwhere(local_maxima(det_matrix, mask))
    order = np.argsort(det_matrix[peaks[:, 0], peaks[:, 1]])[::-1]
    peaks = peaks[order]

    detections = []
    for r_bin, d_bin in peaks[:case["num_targets"]]:
        k = d_bin - loops if d_bin >= loops // 2 else d_bin
        snapshot = aoa_input[r_bin, :, d_bin].copy()
        slot = np.arange(num_tx * num_rx) // num_rx
        snapshot *= np.exp(-2j * np.pi * k * slot / (num_tx * loops))  # workaround 3
        row = snapshot[case["azimuth_channels"]]
        spectrum = dsp.aoa_bartlett(steering, row[:, None], axis=0)[:, 0]
        azimuth = -ANGLE_RANGE_DEG + ANGLE_STEP_DEG * int(np.argmax(spectrum))
        detections.append({
            "range_bin": int(r_bin), "doppler_bin": int(k),
            "range": float(r_bin * case["range_resolution"]),
            "velocity": float(k * case["velocity_resolution"]),
            "azimuth_deg": float(azimuth),
            "power_log2": float(det_matrix[r_bin, d_bin]),
        })
    return {"detections": detections, "num_cfar_peaks": int(len(peaks))}


def main(job_path, result_path):
    job = json.load(open(job_path))
    results = {}
    for case in job["cases"]:
        frames = read_frames(case["capture"], case["family"], case["num_loops"] * case["num_tx"],
                             case["num_rx"], case["num_samples"])
        _, steering = dsp.gen_steering_vec(ANGLE_RANGE_DEG, ANGLE_STEP_DEG, len(case["azimuth_channels"]))
        results[case["name"]] = [process_frame(f, case, steering) for f in frames]
    json.dump(results, open(result_path, "w"), indent=1)


if __name__ == "__main__":
    main(*sys.argv[1:3])
