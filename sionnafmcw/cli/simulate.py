"""``sionnafmcw simulate``: an animation directory through an engine into a run store."""

from __future__ import annotations

import inspect
from pathlib import Path

from .common import UserError, coerce, key_values, load_radar, load_scene, parse_frames

HELP = "Simulate a scene with a radar into a run store (Zarr)."
EPILOG = """\
The radar is a preset (sionnafmcw presets), a JSON file: a full RadarConfig
(sionnafmcw presets NAME --config writes one) or a preset with changes,
e.g. {"preset": "walk-77ghz", "num_chirps": 64}, or a TI mmWave SDK .cfg file.
The engine is a registered name (sionnafmcw.engines.names(): path, pixel, ...);
--engine-option sets its constructor options. An existing store written with the
same settings is resumed: finished frames are kept. Everything is checked before
the store is written; Ctrl-C (or SIGTERM) stops between frames and the same command
resumes; --repair first reads every done frame back and recomputes unreadable ones.

example:
  sionnafmcw simulate scenes/plate --radar walk-77ghz --engine path --out runs/plate.zarr \\
      --frames 0:12 --seed 1 --engine-option samples_per_src=20000
"""


def add_parser(add) -> None:
    p = add("simulate", HELP, EPILOG)
    p.add_argument("scene", metavar="SCENE", help="animation directory (with animation.json)")
    p.add_argument("--radar", required=True, metavar="PRESET|FILE",
                   help="radar preset, RadarConfig .json file or TI mmWave .cfg file")
    p.add_argument("--engine", default="path", metavar="NAME", help="ray-tracing engine (default: path)")
    p.add_argument("--out", required=True, metavar="RUN.zarr", help="run store to write (resumed if it exists)")
    p.add_argument("--frames", metavar="A:B", help="frames A..B-1 (also A:, :B, A:B:STEP, N or I,J,K; default all)")
    p.add_argument("--seed", type=int, default=0, help="receiver-noise seed, an integer >= 0 (default 0)")
    p.add_argument("--no-noise", action="store_true", help="no receiver thermal noise")
    p.add_argument("--leakage-db", type=float, default=None, metavar="DB",
                   help="add direct Tx-Rx coupling at this level (dB); default none")
    p.add_argument("--engine-option", action="append", default=[], metavar="KEY=VALUE",
                   help="engine setting, repeatable (path: samples_per_src, max_depth, diffuse, ...)")
    p.add_argument("--threads", type=int, default=None, metavar="N",
                   help="CPU threads of the run (default: this process's cores; the engine's Dr.Jit pool gets N - 1)")
    p.add_argument("--repair", action="store_true",
                   help="check every done frame of an existing store first; recompute the unreadable ones")
    p.set_defaults(func=run)


def cli_words(message: str, args) -> str:
    """A :class:`~sionnafmcw.simulation.SimulationError` in the command line's words (its options)."""
    message = message.removeprefix("simulate: ")
    for library, option in (("the radar's sample rate fs or lower its slope",
                             f"the sample rate fs or lower the slope in --radar {args.radar}"),
                            ("the radar's num_samples or num_chirps", f"num_samples or num_chirps in --radar {args.radar}"),
                            ("seed=", "--seed "), ("leakage_db=", "--leakage-db ")):
        message = message.replace(library, option)
    return message


def check_engine(name: str) -> None:
    """``--engine NAME`` must be a registered engine."""
    from .. import engines

    known = engines.names()
    if name not in known:
        raise UserError(f"argument --engine: invalid choice: {name!r} (choose from {', '.join(known)})")


def engine_options(engine: str, items) -> dict:
    """``--engine-option k=v`` as the engine's constructor options, typed like their defaults
    (:func:`sionnafmcw.engines.options`)."""
    from .. import engines

    pairs = key_values(items, "--engine-option")
    if not pairs:
        return {}
    defaults = engines.options(engine)
    out = {}
    for key, text in pairs:
        if key not in defaults:
            raise UserError(f"--engine-option {key}: the {engine} engine has no option {key!r}; "
                            f"valid options: {', '.join(defaults)}")
        like = None if defaults[key] is inspect.Parameter.empty else defaults[key]
        out[key] = coerce(text, like, f"--engine-option {key}")
    return out


def check_numbers(args) -> None:
    """``--seed`` >= 0, a finite ``--leakage-db``, ``--threads`` >= 1."""
    import math

    if args.seed < 0:
        raise UserError(f"--seed {args.seed}: must be an integer >= 0")
    if args.leakage_db is not None and not math.isfinite(args.leakage_db):
        raise UserError(f"--leakage-db {args.leakage_db}: must be a finite level in dB (leave it out for no leakage)")
    if args.threads is not None and args.threads < 1:
        raise UserError(f"--threads {args.threads}: must be an integer >= 1 (leave it out for every core)")


def run(args) -> int:
    from ..radar import RadarConfigError
    from ..simulation import SimulationError, SimulationInterrupted, simulate

    check_numbers(args)
    animation = load_scene(args.scene)
    radar = load_radar(args.radar)
    try:
        radar.validate(frame_period=animation.frame_period)
    except RadarConfigError as err:
        raise UserError(f"--radar {args.radar} with scene {args.scene} ({animation.fps:g} fps): {err}") from None
    frames = parse_frames(args.frames, animation.num_frames) if args.frames is not None else None
    if animation.radar_pose is None:
        raise UserError(f"{animation.path / 'animation.json'}: no field 'radar' (the radar pose); add "
                        '"radar": {"position": [x, y, z], "orientation": [yaw, pitch, roll]}')
    check_engine(args.engine)
    options = engine_options(args.engine, args.engine_option)
    out = Path(args.out)
    try:
        run = simulate(animation, radar, engine=args.engine, out=out, frames=frames, progress=not args.quiet,
                       seed=args.seed, noise=not args.no_noise, engine_options=options, leakage_db=args.leakage_db,
                       repair=args.repair, threads=args.threads)
    except SimulationInterrupted as exc:
        exc.unit = "frames"
        raise
    except SimulationError as err:
        raise UserError(cli_words(str(err), args)) from None
    print(f"wrote {out}: {run.done_frames.size} of {run.frame_times.size} frames done, radar {radar.name}, "
          f"{args.engine} engine")
    return 0
