r"""DCA1000EVM raw ADC captures in and out, and TI-layout ``.npz`` frames (numpy only).

What a capture holds
--------------------
The DCA1000EVM records the radar's LVDS stream; its ``adc_data.bin`` (the DCA1000 CLI's file,
or mmWave Studio's after packet re-ordering: no packet headers) is 16-bit two's complement
little-endian words, frames back to back, each frame its chirps in firing order (chirp
:math:`c = lM + q` is loop :math:`l` of the transmitter in slot :math:`q` of ``tx_order``), each
chirp all enabled receivers. Inside a chirp the word order depends on the device family
(TI SWRA581, "mmWave Radar Device ADC Raw Data Capture", sections on the xWR14xx and on the
xWR16xx/xWR18xx/IWR6843 data formats; OpenRadar's ``DCA1000.organize`` reads the latter):

* ``xWR16xx`` (xWR16xx, xWR18xx, xWR68xx; 2 LVDS lanes): receiver by receiver, each its samples
  two at a time as ``I[2n] I[2n+1] Q[2n] Q[2n+1]`` (lane 1 carries I, lane 2 Q);
* ``xWR14xx`` (4 LVDS lanes, one per receiver): sample by sample, first the I of every receiver,
  then their Q: ``I_rx0[n] .. I_rx3[n] Q_rx0[n] .. Q_rx3[n]``.

So one frame is :math:`L M N_{rx} N_s \cdot 2` words, :math:`4 L M N_{rx} N_s` bytes.

Scaling to ADC counts
---------------------
Our cube is the IF signal in :math:`\sqrt{\mathrm{W}}` at the receiver input (NOTES: the
received power is :math:`|x|^2`, thermal noise :math:`k T_0 F F_s`). The export option
:class:`AdcScale` maps it to counts through the receiver gain :math:`G` (dB, the ``rxGain`` of
``profileCfg``) and the ADC full scale :math:`P_{FS}` (dBm, the power at the ADC input of a complex
tone whose I and Q just reach :math:`\pm 2^{15}-1`):

.. math::
    x_{ADC} = \mathrm{round}\!\left( x\, \frac{10^{G/20}}{\sqrt{P_{FS}}}\,(2^{15}-1) \right),
    \quad\text{clipped to } [-2^{15}, 2^{15}-1] \text{ per I and Q}

The clipped I/Q values are counted per frame and reported (:class:`CaptureReport`, the sidecar).
By default the export uses the radar's own gain and full scale (``RadarConfig.rx_gain``,
``RadarConfig.adc_full_scale``: :func:`sionnafmcw.receiver.adc.export_scale`), the scale of the
ADC the cube may already hold (:mod:`sionnafmcw.receiver.adc`): a cube quantised by a 16-bit ADC
in the synthesis is then written word for word, with nothing rounded or clipped again.
``read_dca1000`` returns counts; divide by :attr:`AdcScale.counts_per_sqrt_watt` for
:math:`\sqrt{\mathrm{W}}` again.

A capture directory written here holds ``adc_data.bin``, ``capture.cfg`` (the mmWave SDK
``.cfg`` of the radar, :func:`sionnafmcw.ti.cfg.write_ti_cfg`) and ``capture.json`` (the
sidecar: format, board, scale, clipping, frame times, ground truth); the ``npz`` format holds
``adc_data.npz`` (``adc``: complex64 counts ``[frame, chirp, rx, sample]``, TI's frame layout,
the same quantised values the ``.bin`` holds) instead of the ``.bin``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..radar import RadarConfig
from ..receiver.adc import AdcScale, export_scale
from .cfg import board_for_radar, board_of, parse_ti_cfg, radar_from_ti_cfg, write_ti_cfg

FORMAT = "sionnafmcw-dca1000/1"
BIN_NAME = "adc_data.bin"
NPZ_NAME = "adc_data.npz"
CFG_NAME = "capture.cfg"
SIDECAR_NAME = "capture.json"
FAMILIES = ("xWR14xx", "xWR16xx")


class CaptureError(ValueError):
    """A capture that cannot be written or read; the message names the file and the sizes."""


# ---------------------------------------------------------------------------------------- scaling
# the scale of the export is the ADC's own (:class:`sionnafmcw.receiver.adc.AdcScale`)


def quantise(values: np.ndarray, scale: AdcScale | float) -> tuple[np.ndarray, int]:
    """Complex values (sqrt(W)) -> ``(int16 [..., 2] I/Q counts, number of clipped I/Q values)``."""
    factor = scale.counts_per_sqrt_watt if isinstance(scale, AdcScale) else float(scale)
    iq = np.stack([values.real, values.imag], axis=-1).astype(np.float64) * factor
    iq = np.rint(iq)
    clipped = int(np.count_nonzero((iq > 32767) | (iq < -32768)))
    return np.clip(iq, -32768, 32767).astype(np.int16), clipped


# ---------------------------------------------------------------------------------------- lane order
def family_of(board=None, family: str | None = None) -> str:
    """The LVDS family (``"xWR14xx"`` or ``"xWR16xx"``) from ``family`` or the board."""
    if family is not None:
        if family not in FAMILIES:
            raise CaptureError(f"unknown device family {family!r}; choose one of {', '.join(FAMILIES)} "
                               "(xWR18xx and xWR68xx devices use the xWR16xx format)")
        return family
    return board_of(board).family


def to_firing_order(cube: np.ndarray, radar: RadarConfig) -> np.ndarray:
    """``[..., chirp L, tx M (physical), rx, sample]`` -> TI's ``[..., chirp L*M (firing order), rx, sample]``."""
    fired = cube[..., radar.tx_order, :, :]
    return fired.reshape(*cube.shape[:-4], radar.num_chirps * radar.num_tx, radar.num_rx, radar.num_samples)


def from_firing_order(frames: np.ndarray, radar: RadarConfig) -> np.ndarray:
    """Inverse of :func:`to_firing_order`: ``[..., L*M, rx, sample]`` -> ``[..., L, M (physical), rx, sample]``."""
    shaped = frames.reshape(*frames.shape[:-3], radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
    return shaped[..., radar.tx_slot(), :, :]


def interleave(iq: np.ndarray, family: str) -> np.ndarray:
    """int16 I/Q ``[frame, chirp, rx, sample, 2]`` -> the capture's int16 word stream (1-D)."""
    frames, chirps, rx, samples, _ = iq.shape
    if family == "xWR16xx":
        if samples % 2:
            raise CaptureError(f"the xWR16xx LVDS format packs samples in pairs; {samples} samples per chirp is odd")
        words = iq.reshape(frames, chirps, rx, samples // 2, 2, 2)      # [.., n, pair, IQ]
        words = words.transpose(0, 1, 2, 3, 5, 4)                       # [.., n, IQ, pair]
    else:
        words = iq.transpose(0, 1, 3, 4, 2)                            # [.., sample, IQ, rx]
    return np.ascontiguousarray(words).reshape(-1)


def deinterleave(words: np.ndarray, family: str, chirps: int, rx: int, samples: int) -> np.ndarray:
    """The capture's int16 words -> complex64 counts ``[frame, chirp, rx, sample]`` (inverse of :func:`interleave`)."""
    if family == "xWR16xx":
        w = words.reshape(-1, chirps, rx, samples // 2, 2, 2)           # [.., n, IQ, pair]
        iq = w.transpose(0, 1, 2, 3, 5, 4).reshape(-1, chirps, rx, samples, 2)
    else:
        w = words.reshape(-1, chirps, samples, 2, rx)                  # [.., sample, IQ, rx]
        iq = w.transpose(0, 1, 4, 2, 3)
    out = np.empty(iq.shape[:-1], dtype=np.complex64)
    out.real = iq[..., 0]
    out.imag = iq[..., 1]
    return out


def frame_bytes(radar: RadarConfig) -> int:
    """Bytes of one frame: :math:`L M N_{rx} N_s` complex samples of 2 x 2 bytes."""
    return radar.num_chirps * radar.num_tx * radar.num_rx * radar.num_samples * 4


# ---------------------------------------------------------------------------------------- writing
@dataclass
class CaptureReport:
    """What an export wrote: frames, quantisation and clipping."""

    path: Path
    format: str
    num_frames: int = 0
    clipped_per_frame: list = field(default_factory=list)
    values_per_frame: int = 0
    peak_counts: int = 0

    @property
    def clipped(self) -> int:
        """Clipped I/Q values in the whole capture."""
        return int(sum(self.clipped_per_frame))

    @property
    def clipped_fraction(self) -> float:
        total = self.values_per_frame * self.num_frames
        return self.clipped / total if total else 0.0

    def to_dict(self) -> dict:
        return {"clipped_values": self.clipped, "total_values": self.values_per_frame * self.num_frames,
                "clipped_fraction": self.clipped_fraction, "clipped_per_frame": list(self.clipped_per_frame),
                "peak_counts": self.peak_counts}

    def summary(self) -> str:
        return (f"{self.path}: {self.num_frames} frames ({self.format}); {self.clipped} of "
                f"{self.values_per_frame * self.num_frames} I/Q values clipped ({100 * self.clipped_fraction:.3g} %), "
                f"peak |count| {self.peak_counts}")


def _truth_json(truth: dict | None) -> dict | None:
    if truth is None:
        return None
    return {key: (np.asarray(value).tolist() if not isinstance(value, (str, list)) else value)
            for key, value in truth.items()}


def write_capture(out_dir, radar: RadarConfig, frames, *, format: str = "dca1000", board=None,
                  family: str | None = None, scale: AdcScale | float | None = None, frame_times=None, truth=None,
                  frame_period: float | None = None, replace: bool = False, extra: dict | None = None) -> CaptureReport:
    """Write a capture directory atomically from an iterable of cubes ``[chirp, tx, rx, sample]``.

    Parameters
    ----------
    out_dir : path of the directory to create (whole or not at all, :func:`sionnafmcw.fs.atomic_directory`)
    radar : RadarConfig of the cubes
    frames : iterable of complex cubes ``[chirp, tx (physical order), rx, sample]`` (sqrt(W))
    format : ``"dca1000"`` (``adc_data.bin``) or ``"npz"`` (``adc_data.npz``, TI's ``[frame, chirp, rx, sample]``)
    board : TI board (name or :class:`~sionnafmcw.ti.cfg.Board`); default from the radar's preset name.
        Needed for ``dca1000`` (the lane order, the ``.cfg``); for ``npz`` without a board no ``.cfg`` is written.
    family : LVDS family overriding the board's
    scale : :class:`AdcScale` (default: the radar's ``rx_gain`` and ``adc_full_scale``, 30 dB and 0 dBm unless
        set), or a number: counts per sqrt(W)
        (1.0 re-writes a cube that already holds counts, e.g. from :func:`read_dca1000`)
    frame_times : ``[frame]`` CPI start times (s) for the sidecar
    truth : dict of ground-truth arrays for the sidecar (``objects``, ``position``, ``velocity``, ``radial_velocity``)
    frame_period : ``framePeriodicity`` of the ``.cfg`` (s); default from ``frame_times``, else 100 ms
    replace : replace an existing ``out_dir``
    """
    from ..fs import atomic_directory

    if format not in ("dca1000", "npz"):
        raise CaptureError(f"unknown capture format {format!r}; choose 'dca1000' or 'npz'")
    if scale is None:
        scale = export_scale(radar)
    scale_info = scale.to_dict() if isinstance(scale, AdcScale) else {"counts_per_sqrt_watt": float(scale)}
    if board is not None or format == "dca1000":
        board = board_for_radar(radar, board)
    fam = family_of(board, family) if (board is not None or family is not None) else None
    if format == "dca1000" and fam == "xWR16xx" and radar.num_samples % 2:
        raise CaptureError(f"the xWR16xx LVDS format packs samples in pairs; radar {radar.name!r} has "
                           f"{radar.num_samples} samples per chirp (odd)")
    if frame_period is None:
        times = None if frame_times is None else np.asarray(frame_times, dtype=float)
        frame_period = float(np.median(np.diff(times))) if times is not None and times.size > 1 else 0.1
    out_dir = Path(out_dir)
    report = CaptureReport(path=out_dir, format=format,
                           values_per_frame=2 * radar.num_chirps * radar.num_tx * radar.num_rx * radar.num_samples)
    shape = (radar.num_chirps, radar.num_tx, radar.num_rx, radar.num_samples)
    with atomic_directory(out_dir, replace=replace) as tmp:
        if board is not None:
            cfg_text = write_ti_cfg(radar, board, frame_period=max(frame_period, radar.cpi_duration),
                                    rx_gain_db=scale_info.get("rx_gain_db", radar.rx_gain))
            (tmp / CFG_NAME).write_text(cfg_text)
        collected = []
        sink = open(tmp / BIN_NAME, "wb") if format == "dca1000" else None
        try:
            for cube in frames:
                cube = np.asarray(cube)
                if cube.shape != shape:
                    raise CaptureError(f"frame {report.num_frames} has shape {cube.shape}; radar {radar.name!r} "
                                       f"needs [chirp, tx, rx, sample] = {shape}")
                iq, clipped = quantise(to_firing_order(cube, radar), scale)   # [C, N, S, 2]
                report.clipped_per_frame.append(clipped)
                report.peak_counts = max(report.peak_counts, int(np.abs(iq.astype(np.int32)).max(initial=0)))
                report.num_frames += 1
                if sink is not None:
                    sink.write(interleave(iq[None], fam).astype("<i2").tobytes())
                else:
                    frame = np.empty(iq.shape[:-1], dtype=np.complex64)
                    frame.real, frame.imag = iq[..., 0], iq[..., 1]
                    collected.append(frame)
        finally:
            if sink is not None:
                sink.close()
        if format == "npz":
            adc = np.stack(collected) if collected else np.zeros((0, shape[0] * shape[1], shape[2], shape[3]), np.complex64)
            arrays = {"adc": adc}
            if frame_times is not None:
                arrays["frame_time"] = np.asarray(frame_times, dtype=float)
            np.savez(tmp / NPZ_NAME, **arrays)
        sidecar = {
            "format": FORMAT,
            "data": BIN_NAME if format == "dca1000" else NPZ_NAME,
            "board": None if board is None else board.name,
            "family": fam,
            "num_frames": report.num_frames,
            "frame_layout": "[chirp (loop x tx slot, firing order), rx, sample]",
            "frame_shape": [radar.num_chirps * radar.num_tx, radar.num_rx, radar.num_samples],
            "bytes_per_frame": frame_bytes(radar),
            "sample_format": "int16 little-endian two's complement, I/Q word order of the family (TI SWRA581)",
            "tx_order": list(radar.tx_order),
            "scale": scale_info,
            "clipping": report.to_dict(),
            "frame_period": frame_period,
            "frame_time": None if frame_times is None else np.asarray(frame_times, dtype=float).tolist(),
            "truth": _truth_json(truth),
            "radar": radar.to_dict(),
            **(extra or {}),
        }
        (tmp / SIDECAR_NAME).write_text(json.dumps(sidecar, indent=1))
    return report


def write_dca1000(cube: np.ndarray, radar: RadarConfig, out_dir, **options) -> CaptureReport:
    """Write a cube ``[frame, chirp, tx, rx, sample]`` (or one frame ``[chirp, tx, rx, sample]``) as a
    DCA1000 capture directory; ``options`` as :func:`write_capture` (``board``, ``scale``,
    ``frame_times``, ``truth``, ``replace``, ``format``)."""
    cube = np.asarray(cube)
    if cube.ndim == 4:
        cube = cube[None]
    return write_capture(out_dir, radar, iter(cube), **{"format": "dca1000", **options})


# ---------------------------------------------------------------------------------------- reading
def _capture_files(path: Path):
    """``(bin path, cfg path or None, sidecar dict or None)`` of a capture directory or ``.bin`` file."""
    if path.is_dir():
        bin_path = path / BIN_NAME
        if not bin_path.exists():
            bins = sorted(path.glob("*.bin"))
            if len(bins) != 1:
                raise CaptureError(f"{path}: expected {BIN_NAME} (or exactly one .bin file), found "
                                   f"{[b.name for b in bins] or 'none'}")
            bin_path = bins[0]
        cfg = path / CFG_NAME if (path / CFG_NAME).exists() else None
        sidecar = json.loads((path / SIDECAR_NAME).read_text()) if (path / SIDECAR_NAME).exists() else None
        return bin_path, cfg, sidecar
    if not path.exists():
        raise CaptureError(f"{path}: no such capture (a capture directory or a .bin file)")
    return path, None, None


def read_dca1000(path, radar=None, board=None, family: str | None = None, num_frames: int | None = None) -> np.ndarray:
    """A DCA1000 capture (ours or a real board's) as our cube ``[frame, chirp, tx, rx, sample]``.

    Parameters
    ----------
    path : a capture directory (``adc_data.bin`` + ``capture.cfg``/``capture.json``) or a ``.bin`` file
        (packet headers already removed, as the DCA1000 CLI and mmWave Studio's post-processing write it)
    radar : RadarConfig, or the path/text of the mmWave ``.cfg`` the board ran; default: the
        directory's ``capture.cfg``
    board, family : the board (lane order, layout of a ``.cfg``); default: the sidecar's, else the radar's preset
    num_frames : expected frame count; default: the sidecar's, else ``numFrames`` of the ``.cfg`` when not 0,
        else any whole number of frames

    Returns
    -------
    ndarray
        complex64 ADC counts (I + jQ) ``[frame, chirp, tx, rx, sample]``, tx in physical element order.

    Raises
    ------
    CaptureError
        With the expected and the actual sizes, for a file that does not hold whole frames of this
        radar or not the expected number of frames.
    """
    path = Path(path)
    bin_path, cfg_path, sidecar = _capture_files(path)
    if board is None and sidecar is not None:
        board = sidecar.get("board")
    if family is None and sidecar is not None:
        family = sidecar.get("family")
    cfg_frames = 0
    if radar is None:
        if cfg_path is None:
            raise CaptureError(f"{path}: no {CFG_NAME} beside the capture; give the radar (a RadarConfig or the .cfg)")
        radar = cfg_path
    if not isinstance(radar, RadarConfig):
        cfg = parse_ti_cfg(radar)
        cfg_frames = cfg.num_frames
        radar = radar_from_ti_cfg(cfg, board)
    if family is None:
        family = family_of(board_for_radar(radar, board))
    family = family_of(None, family)
    if num_frames is None:
        num_frames = sidecar.get("num_frames") if sidecar is not None else (cfg_frames or None)

    per_frame = frame_bytes(radar)
    size = bin_path.stat().st_size
    if size % per_frame:
        raise CaptureError(
            f"{bin_path}: {size} bytes is not a whole number of frames of {per_frame} bytes "
            f"({radar.num_chirps} loops x {radar.num_tx} tx x {radar.num_rx} rx x {radar.num_samples} samples x 4 bytes): "
            f"{size // per_frame} whole frames ({size // per_frame * per_frame} bytes) and {size % per_frame} bytes over; "
            "the file is truncated or was recorded with another .cfg")
    if num_frames is not None and size != num_frames * per_frame:
        raise CaptureError(f"{bin_path}: expected {num_frames} frames = {num_frames * per_frame} bytes, "
                           f"the file has {size} bytes ({size // per_frame} frames)")
    words = np.fromfile(bin_path, dtype="<i2")
    frames = deinterleave(words, family, radar.num_chirps * radar.num_tx, radar.num_rx, radar.num_samples)
    return from_firing_order(frames, radar)


def read_npz(path) -> np.ndarray:
    """The ``adc`` array (complex64 counts ``[frame, chirp, rx, sample]``) of an ``npz`` capture (directory or file)."""
    path = Path(path)
    file = path / NPZ_NAME if path.is_dir() else path
    with np.load(file) as data:
        return data["adc"]


# ---------------------------------------------------------------------------------------- runs
def export_run(run_path, out_dir, format: str = "dca1000", board=None, scale: AdcScale | float | None = None,
               frames=None, replace: bool = False, family: str | None = None) -> CaptureReport:
    """Export a run store (:func:`sionnafmcw.store.open_run`) as a capture directory.

    Reads the cubes frame by frame (bounded memory), the frame times, the truth and the radar
    through the :class:`~sionnafmcw.store.Run` reader; writes ``out_dir`` atomically (see
    :func:`write_capture` for ``board``, ``scale``, ``family``). ``frames`` (indices; default all)
    must all be done in the store.
    """
    from ..store import open_run

    run = open_run(run_path)
    total = run.num_frames
    frames = np.arange(total) if frames is None else np.asarray(list(frames), dtype=int)
    if frames.size and (frames.min() < 0 or frames.max() >= total):
        raise CaptureError(f"{run_path}: frames must lie in 0..{total - 1}, got {frames.min()}..{frames.max()}")
    missing = frames[~run.done_mask[frames]]
    if missing.size:
        raise CaptureError(f"{run_path}: frames {missing[:10].tolist()}{'...' if missing.size > 10 else ''} are not "
                           "simulated yet; finish the run (simulate resumes it) or export only its done frames")
    truth = {"objects": list(run.objects), "frames": frames.tolist()}
    if run.objects:
        truth["position"] = np.stack([run.object_position(o) for o in run.objects], axis=1)[frames]
        truth["velocity"] = np.stack([run.object_velocity(o) for o in run.objects], axis=1)[frames]
        truth["radial_velocity"] = np.stack([run.truth(o) for o in run.objects], axis=1)[frames]
    keep = ("radar_pose", "engine", "scene", "seed", "noise", "leakage_db", "sionnafmcw_version")
    run_attrs = json.loads(json.dumps({k: run.attrs[k] for k in keep if k in run.attrs}, default=str))
    return write_capture(out_dir, run.radar, (run.cube(int(f)) for f in frames), format=format, board=board,
                         family=family, scale=scale, frame_times=run.frame_times[frames], truth=truth,
                         replace=replace, extra={"source_run": str(run_path), "run_attrs": run_attrs})


__all__ = ["AdcScale", "CaptureError", "CaptureReport", "FAMILIES", "deinterleave", "export_run", "frame_bytes",
           "from_firing_order", "interleave", "quantise", "read_dca1000", "read_npz", "to_firing_order",
           "write_capture", "write_dca1000"]
