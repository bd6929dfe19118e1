"""Shared by the benchmarks that time parts of the circle walk's frames: the command-line
arguments that choose the walk, its frames and the repeats, the animation and radar they name,
and the process's CPU seconds."""

from __future__ import annotations

import resource
from pathlib import Path


def cpu_seconds() -> float:
    """User + system CPU seconds of this process, all its threads (Dr.Jit's, finufft's, the synthesis worker)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def add_arguments(parser, out: str, frames: list[int], repeats: int) -> None:
    """``--scene``, ``--out``, ``--frames``, ``--repeats`` and ``--radar`` (defaults as given)."""
    parser.add_argument("--scene", default=None, help="existing circle_walk animation directory (default: build one)")
    parser.add_argument("--out", default=out, help="where the scene is built when --scene is not given")
    parser.add_argument("--frames", type=int, nargs="+", default=frames)
    parser.add_argument("--repeats", type=int, default=repeats, help="timed runs per method (interleaved)")
    parser.add_argument("--radar", default="walk-77ghz")


def load(parser, args):
    """``(animation, radar)`` of the parsed arguments; a bad argument ends with ``parser.error``."""
    from sionnafmcw.animation import load_animation
    from sionnafmcw.radar import RadarConfig

    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    if args.scene:
        scene = Path(args.scene)
        if not (scene / "animation.json").is_file():
            parser.error(f"--scene {scene}: no animation.json there")
    else:
        from sionnafmcw.validation.common import build_scene
        scene = build_scene("circle_walk", Path(args.out) / "scene")
    animation = load_animation(scene)
    if max(args.frames) >= animation.num_frames or min(args.frames) < 0:
        parser.error(f"--frames: the scene has frames 0 to {animation.num_frames - 1}")
    return animation, RadarConfig.resolve(args.radar)
