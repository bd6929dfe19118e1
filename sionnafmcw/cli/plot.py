"""``sionnafmcw plot``: process a run store and write PNG figures, one function per figure kind
(:data:`KINDS`)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .common import UserError, corrupt_frame_message, load_scene, open_run_or_error, parse_interval, progress, ranges_text

HELP = "Process a run store and write PNG figures."
EPILOG = """\
Files: range_doppler_fNNNN.png, range_azimuth_fNNNN.png, doppler_time.png,
micro_doppler.png, scene_top_view.png (default: every kind; scene when the
recorded scene directory exists). Ground truth is drawn as red stars.

example:
  sionnafmcw plot runs/plate.zarr --out figures/plate --kind rd --kind doppler-time --frame 3
"""


@dataclass
class Figures:
    """What every figure kind needs: the opened run, the options, the frame and the truth to draw."""

    args: object
    run: object          # sionnafmcw.store.Run
    radar: object        # RadarConfig
    frame: int           # frame of the per-frame figures (rd, ra)
    shown: list          # objects whose truth is drawn
    gate: tuple | None   # --range-gate (m), (min | None, max | None)
    out: Path

    @property
    def done(self) -> np.ndarray:
        return self.run.done_frames

    @cached_property
    def times(self) -> np.ndarray:
        return self.run.frame_times

    @property
    def clutter_removal(self) -> bool:
        return not self.args.keep_clutter

    @cached_property
    def columns(self) -> list[int]:
        return [self.run.objects.index(n) for n in self.shown]

    @cached_property
    def truth_velocity(self):
        """Radial velocity truth ``[frame, shown object]`` (m/s), or None when no object is shown."""
        if not self.shown:
            return None
        return np.stack([self.run.truth(n) for n in self.shown], axis=1)

    def caption(self) -> str:
        clutter = "static clutter removed" if self.clutter_removal else "static clutter kept"
        return f"{self.run.engine.get('engine', '?')} engine, {clutter}"

    def cubes(self, desc: str):
        """The done frames' cubes, one at a time; an unreadable frame is a :class:`UserError` naming it
        and the fix (raised as such through the processing, which may catch ``ValueError``)."""
        from ..store import CorruptFrameError

        for i in progress(self.done, self.args.quiet, desc=desc, unit="frame"):
            try:
                cube = self.run.cube(i)
            except CorruptFrameError as err:
                raise UserError(corrupt_frame_message(err)) from None
            yield cube


def range_doppler(fig: Figures) -> Path:
    from .. import plots, processing

    rdmap = processing.range_doppler_map(fig.run.cube(fig.frame), fig.radar, clutter_removal=fig.clutter_removal)
    truth = None
    if fig.shown:
        ranges, _ = fig.run.truth_in_radar_frame(fig.frame)
        truth = list(zip(ranges[fig.columns], fig.truth_velocity[fig.frame]))
    ax = plots.plot_range_doppler(rdmap, truth=truth, dynamic_range=fig.args.dynamic_range,
                                  title=f"Range-Doppler, frame {fig.frame} (t = {fig.times[fig.frame]:.3f} s)\n"
                                        f"{fig.caption()}")
    if fig.args.max_range:
        ax.set_ylim(0.0, min(fig.args.max_range, float(rdmap.ranges[-1])))
    return plots.save(ax, fig.out / f"range_doppler_f{fig.frame:04d}.png")


def range_azimuth(fig: Figures) -> Path:
    from .. import plots, processing

    ramap = processing.range_azimuth_map(fig.run.cube(fig.frame), fig.radar, clutter_removal=fig.clutter_removal)
    truth = None
    if fig.shown:
        ranges, azimuths = fig.run.truth_in_radar_frame(fig.frame)
        truth = list(zip(ranges[fig.columns], azimuths[fig.columns]))
    ax = plots.plot_range_azimuth(ramap, truth=truth, cartesian=fig.args.cartesian, max_range=fig.args.max_range,
                                  dynamic_range=fig.args.dynamic_range,
                                  title=f"Range-azimuth, frame {fig.frame} (t = {fig.times[fig.frame]:.3f} s)\n"
                                        f"{fig.caption()}")
    return plots.save(ax, fig.out / f"range_azimuth_f{fig.frame:04d}.png")


def _window(fig: Figures) -> int:
    """``--window-chirps`` (default a quarter of the CPI's chirps per Tx), checked."""
    window = fig.args.window_chirps or max(1, fig.radar.num_chirps // 4)
    if not 1 <= window <= fig.radar.num_chirps:
        raise UserError(f"--window-chirps {window}: must be in 1..{fig.radar.num_chirps} (chirps per Tx in a CPI)")
    return window


def _spectrogram(fig: Figures, desc: str):
    """The micro-Doppler spectrogram of the done frames (``--range-gate``, ``--window-chirps``)."""
    from .. import processing

    window = _window(fig)
    try:
        return processing.micro_doppler_spectrogram(fig.cubes(desc), fig.radar, fig.times[fig.done],
                                                    range_gate=fig.gate, window_chirps=window,
                                                    clutter_removal=fig.clutter_removal)
    except ValueError as err:
        raise UserError(f"--range-gate/--window-chirps: {err}") from None


def doppler_time(fig: Figures) -> Path:
    from .. import plots, processing

    try:
        track = processing.doppler_time(fig.cubes("Doppler track"), fig.radar, clutter_removal=fig.clutter_removal,
                                        range_gate=fig.gate)
    except ValueError as err:  # an empty range gate
        raise UserError(f"--range-gate: {err}") from None
    spectrogram = _spectrogram(fig, "micro-Doppler (under the track)")
    truth = None if fig.truth_velocity is None else fig.truth_velocity[fig.done]
    ax = plots.plot_doppler_time(track, times=fig.times[fig.done], truth=truth, object_names=fig.shown,
                                 spectrogram=spectrogram, dynamic_range=fig.args.dynamic_range,
                                 velocity_limits=(-fig.radar.max_velocity, fig.radar.max_velocity),
                                 title=f"Doppler-time (strongest cell) over the micro-Doppler spectrogram\n"
                                       f"{fig.caption()}")
    return plots.save(ax, fig.out / "doppler_time.png")


def micro_doppler(fig: Figures) -> Path:
    from .. import plots

    window = _window(fig)
    spec = _spectrogram(fig, "micro-Doppler")
    truth = None if fig.truth_velocity is None else fig.truth_velocity[fig.done]
    ax = plots.plot_micro_doppler(spec, dynamic_range=fig.args.dynamic_range, truth=truth,
                                  truth_times=fig.times[fig.done], object_names=fig.shown,
                                  title=f"Micro-Doppler, {window}-chirp window\n{fig.caption()}")
    return plots.save(ax, fig.out / "micro_doppler.png")


def scene_top_view(fig: Figures) -> Path:
    from .. import plots

    recorded = fig.run.scene
    scene = fig.args.scene or (str(recorded) if recorded else None)
    if not scene:
        raise UserError(f"{fig.run.path} records no scene (attribute 'scene'); pass --scene DIR")
    if not Path(scene).is_dir():
        if fig.args.scene:
            raise UserError(f"--scene {scene}: no such directory")
        raise UserError(f"scene {scene} (recorded in {fig.run.path}) is not there any more; pass --scene DIR")
    animation = load_scene(scene, "--scene")
    frames = [int(f) for f in fig.done if f < animation.num_frames]
    pose = fig.run.poses() if fig.run.radar_moves and fig.run.num_frames == animation.num_frames else fig.run.pose
    ax = plots.plot_scene_top_view(animation, radar=fig.radar, radar_pose=pose, frames=frames or None,
                                   highlight=[n for n in fig.shown if n in animation.object_names] or None,
                                   title=f"Scene {Path(scene).name}, top view")
    return plots.save(ax, fig.out / "scene_top_view.png")


#: Figure kinds: ``--kind`` name -> function writing the figure (and returning its path).
KINDS = {
    "rd": range_doppler,
    "ra": range_azimuth,
    "doppler-time": doppler_time,
    "micro-doppler": micro_doppler,
    "scene": scene_top_view,
}


def add_parser(add) -> None:
    p = add("plot", HELP, EPILOG)
    p.add_argument("run", metavar="RUN", help="run store written by 'sionnafmcw simulate'")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the PNG files")
    p.add_argument("--kind", action="append", choices=tuple(KINDS), metavar="KIND",
                   help=f"figure, repeatable: {', '.join(KINDS)} (default: all)")
    p.add_argument("--frame", type=int, default=None, metavar="N",
                   help="frame for rd and ra (default: the middle finished frame)")
    p.add_argument("--keep-clutter", action="store_true",
                   help="do not remove static clutter (the slow-time mean) before processing")
    p.add_argument("--range-gate", metavar="MIN:MAX", help="only these ranges (m) for doppler-time and micro-doppler")
    p.add_argument("--window-chirps", type=int, default=None, metavar="W",
                   help="micro-Doppler STFT window in chirps (default: a quarter of the CPI)")
    p.add_argument("--dynamic-range", type=float, default=50.0, metavar="DB", help="colour scale span (default 50 dB)")
    p.add_argument("--max-range", type=float, default=None, metavar="M", help="crop rd and ra maps at this range (m)")
    p.add_argument("--cartesian", action="store_true",
                   help="range-azimuth map in x-y (top view) instead of range-angle")
    p.add_argument("--scene", default=None, metavar="DIR", help="scene for --kind scene (default: the one recorded)")
    p.add_argument("--truth", action="append", default=[], metavar="OBJECT",
                   help="object whose ground truth is drawn, repeatable (default: all when at most six, "
                        "else the torso); tracks of these are highlighted in the scene view")
    p.set_defaults(func=run)


def _kinds(args, run) -> list[str]:
    if args.kind:
        return list(dict.fromkeys(args.kind))
    kinds = [k for k in KINDS if k != "scene"]
    if run.scene is not None and run.scene.is_dir():
        kinds.append("scene")
    return kinds


def _frame(args, run, done) -> int:
    num_frames = run.frame_times.size
    if args.frame is None:
        return int(done[len(done) // 2])
    if not 0 <= args.frame < num_frames:
        raise UserError(f"--frame {args.frame}: {run.path} has frames 0..{num_frames - 1}")
    if args.frame not in done:
        raise UserError(f"--frame {args.frame}: this frame of {run.path} is not simulated yet "
                        f"(finished: {ranges_text(done)})")
    return int(args.frame)


def _shown(args, run) -> list[str]:
    objects = run.objects
    if args.truth:
        unknown = [n for n in args.truth if n not in objects]
        if unknown:
            raise UserError(f"--truth {unknown[0]}: {run.path} has no object {unknown[0]!r}; "
                            f"its objects: {', '.join(objects) or 'none'}")
        return list(dict.fromkeys(args.truth))
    # a few objects: all of them; a body: its torso (the paper's ground truth)
    return objects if len(objects) <= 6 else (["torso"] if "torso" in objects else objects[:1])


def run(args) -> int:
    from ..store import RunStoreError

    run = open_run_or_error(args.run)
    try:
        radar = run.radar
    except RunStoreError as err:
        raise UserError(str(err)) from None
    done = run.done_frames
    if done.size == 0:
        raise UserError(f"{args.run}: no frame is finished yet; run 'sionnafmcw simulate' (again) to fill the store")
    kinds = _kinds(args, run)
    frame = _frame(args, run, done)
    gate = parse_interval(args.range_gate, "--range-gate") if args.range_gate else None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: exists and is not a folder")
    fig = Figures(args, run, radar, frame, _shown(args, run), gate, out)
    for kind in kinds:
        print(KINDS[kind](fig))
    return 0
