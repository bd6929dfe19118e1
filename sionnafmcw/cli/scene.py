"""``sionnafmcw scene list|build|from-bvh``: the scenarios of :mod:`sionnafmcw.scenes` and their
parameters, and motion capture (a BVH file) as an animation directory (:mod:`sionnafmcw.mocap`)."""

from __future__ import annotations

from pathlib import Path

from .common import Parser, UserError, key_values
from ..scenes.meshes import BODY_MESH_EDGE

HELP = "Build or list the scenarios (animation directories written by code), or turn a BVH clip into one."
EPILOG = """\
examples:
  sionnafmcw scene list
  sionnafmcw scene build moving_plate scenes/plate --param speed=-1.5 --param num_frames=24
  sionnafmcw scene from-bvh walk.bvh scenes/walk --fps 30 --radar 4,1
"""
LIST_HELP = "The scenarios with their parameters (type, unit, default)."
LIST_EPILOG = """\
example:
  sionnafmcw scene list circle_walk
"""
BUILD_HELP = "Write scenario NAME as an animation directory OUT."
BUILD_EPILOG = """\
example:
  sionnafmcw scene build moving_plate scenes/plate --param speed=-1.5 --param num_frames=24
  sionnafmcw scene build corner_reflectors scenes/cr --param ranges=3,5,7 --overwrite
"""


FROM_BVH_HELP = ("Write a BVH motion-capture clip as an animation directory OUT: the segment body (tapered limbs "
                 "sized from the skeleton) moved by the clip, one rigid object per segment, and a radar.")
FROM_BVH_EPILOG = """\
The clip's frame 0 is skipped (the CMU database's added T-pose); units default to the CMU database's
(0.056444 m per BVH unit), Y up. The person starts at --start-pose X,Y,HEADING (m, m, degrees; the
facing direction from +x towards +y); the radar stands --radar DISTANCE,HEIGHT in front of that
position looking back at it, or at an explicit pose X,Y,Z,YAW,PITCH,ROLL (m, degrees). --route
blender drives the skeleton with Blender's own BVH importer (needs .venv-blender or a Python with bpy).

example:
  sionnafmcw scene from-bvh sionnafmcw/mocap/clips/90_18.bvh scenes/fall --fps 30 --radar 3,1.2
  sionnafmcw scene from-bvh clip.bvh scenes/clip --frames 60 --start 0.5 --start-pose 1,0,90 --route blender
"""


def add_parser(add) -> None:
    p = add("scene", HELP, EPILOG)
    sub = p.add_subparsers(dest="scene_command", metavar="{build,list,from-bvh}", parser_class=Parser)
    sub.required = True
    q = add("list", LIST_HELP, LIST_EPILOG, sub)
    q.add_argument("name", nargs="?", help="only this scenario")
    q.set_defaults(func=run_list)
    q = add("build", BUILD_HELP, BUILD_EPILOG, sub)
    q.add_argument("name", metavar="NAME", help="scenario name (see 'sionnafmcw scene list')")
    q.add_argument("out", metavar="OUT", help="output directory (must not exist or be empty, unless --overwrite)")
    q.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="scenario parameter, repeatable (tuples: comma-separated, e.g. ranges=3,5,7)")
    q.add_argument("--overwrite", action="store_true", help="replace an existing OUT")
    q.set_defaults(func=run_build)
    q = add("from-bvh", FROM_BVH_HELP, FROM_BVH_EPILOG, sub)
    q.add_argument("bvh", metavar="CLIP.bvh", help="BVH motion-capture file")
    q.add_argument("out", metavar="OUT", help="output directory (must not exist or be empty, unless --overwrite)")
    q.add_argument("--fps", type=float, default=30.0, help="frame rate of the animation (default 30)")
    q.add_argument("--frames", type=int, default=None, metavar="N",
                   help="number of frames (default: as many as the clip holds from --start)")
    q.add_argument("--start", type=float, default=None, metavar="SECONDS",
                   help="clip time of frame 0 (default: the clip's frame 1)")
    q.add_argument("--scale", type=float, default=None, metavar="M",
                   help="metres per BVH unit (default 0.056444, the CMU database's)")
    q.add_argument("--start-pose", default="0,0,0", metavar="X,Y,HEADING",
                   help="start position (m) and facing direction (degrees) of the person (default 0,0,0)")
    q.add_argument("--radar", default="3,1", metavar="D,H | X,Y,Z,YAW,PITCH,ROLL",
                   help="radar DISTANCE,HEIGHT in front of the person (m; default 3,1) or an explicit pose "
                        "(m, degrees)")
    q.add_argument("--height", type=float, default=None, metavar="M",
                   help="stature for the body's girths (default: from the skeleton's legs)")
    q.add_argument("--build", choices=("male", "female"), default="male", help="girths of men or women")
    q.add_argument("--mesh-edge", type=float, default=BODY_MESH_EDGE, metavar="M",
                   help=f"largest triangle edge of the body meshes (default {BODY_MESH_EDGE}: the engines render "
                        "their smooth surface)")
    q.add_argument("--room", action="store_true", help="put a closed room around the person and the radar")
    q.add_argument("--route", choices=("numpy", "blender"), default="numpy",
                   help="numpy forward kinematics (default) or Blender's BVH importer")
    q.add_argument("--overwrite", action="store_true", help="replace an existing OUT")
    q.set_defaults(func=run_from_bvh)


def _check_name(scenes, name) -> None:
    names = scenes.names()
    if name not in names:
        raise UserError(f"unknown scene {name!r}; choose one of {', '.join(names)} (list them with 'sionnafmcw scene list')")


def run_list(args) -> int:
    from .. import scenes

    names = scenes.names()
    if args.name:
        _check_name(scenes, args.name)
        names = [args.name]
    for i, name in enumerate(names):
        params = scenes.parameters(name)
        doc = scenes.describe(name).splitlines()[0].split(": ", 1)[-1]
        print(f"{name}: {doc}")
        width = max((len(k) for k in params), default=0)
        for key, p in params.items():
            print(f"    {key:<{width}}  {p.describe()}")
        if i + 1 < len(names):
            print()
    return 0


def _params(scenes, name, items) -> dict:
    params = scenes.parameters(name)
    out = {}
    for key, text in key_values(items, "--param"):
        if key not in params:
            raise UserError(f"scene {name!r} has no parameter {key!r}; valid parameters: {', '.join(params) or 'none'}")
        try:
            out[key] = scenes.parse_value(name, key, text)
        except ValueError as err:
            raise UserError(f"--param {key}={text}: {err}") from None
    return out


def run_build(args) -> int:
    from .. import scenes
    from ..animation import load_animation

    _check_name(scenes, args.name)
    params = _params(scenes, args.name, args.param)
    out = Path(args.out)
    if out.exists() and not args.overwrite and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"{out} exists and is not empty; pass --overwrite to replace it or choose another OUT")
    try:
        path = scenes.build(args.name, out, overwrite=args.overwrite, **params)
    except FileExistsError as err:
        raise UserError(f"{err}; pass --overwrite to replace it") from None
    except ValueError as err:
        raise UserError(f"scene build {args.name}: {err}") from None
    anim = load_animation(path, check_meshes=False)
    print(f"wrote scene {args.name!r} to {path}: {anim.num_frames} frames at {anim.fps:g} fps, "
          f"moving objects: {', '.join(anim.object_names) or 'none'}")
    return 0


def _numbers(text: str, option: str, counts) -> list[float]:
    import math

    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        raise UserError(f"{option} {text!r}: write {' or '.join(f'{n} comma-separated numbers' for n in counts)}") \
            from None
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        raise UserError(f"{option} {text!r}: write {' or '.join(f'{n} comma-separated finite numbers' for n in counts)}")
    return values


def run_from_bvh(args) -> int:
    import math

    from ..animation import load_animation
    from ..mocap import BvhError, bvh_to_animation
    from ..mocap.skeleton import CMU_UNIT

    out = Path(args.out)
    if out.exists() and not args.overwrite and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"{out} exists and is not empty; pass --overwrite to replace it or choose another OUT")
    x, y, heading = _numbers(args.start_pose, "--start-pose", (3,))
    radar = _numbers(args.radar, "--radar", (2, 6))
    kwargs = {}
    if len(radar) == 2:
        kwargs.update(radar_distance=radar[0], radar_height=radar[1])
    else:
        kwargs["radar_pose"] = (radar[:3], [math.radians(v) for v in radar[3:]])
    for option, value in (("--fps", args.fps), ("--scale", args.scale), ("--mesh-edge", args.mesh_edge),
                          ("--height", args.height)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UserError(f"{option} {value}: must be a positive number")
    try:
        path = bvh_to_animation(args.bvh, out, route=args.route, fps=args.fps, num_frames=args.frames,
                                start=args.start, unit=args.scale if args.scale is not None else CMU_UNIT,
                                position=(x, y), heading=math.radians(heading), height=args.height,
                                build=args.build, mesh_edge=args.mesh_edge, room=args.room, **kwargs)
    except BvhError as err:
        raise UserError(str(err)) from None
    except ValueError as err:
        raise UserError(f"{args.bvh}: {err}") from None
    except RuntimeError as err:   # the Blender route (BlenderExportError)
        raise UserError(f"--route blender: {err}") from None
    anim = load_animation(path, check_meshes=False)
    print(f"wrote {path} from {args.bvh} ({args.route} route): {anim.num_frames} frames at {anim.fps:g} fps, "
          f"{len(anim.object_names)} body segments")
    return 0
