"""``sionnafmcw scene list|build``: the scenarios of :mod:`sionnafmcw.scenes` and their parameters."""

from __future__ import annotations

from pathlib import Path

from .common import Parser, UserError, key_values

HELP = "Build or list the scenarios (animation directories written by code)."
EPILOG = """\
examples:
  sionnafmcw scene list
  sionnafmcw scene build moving_plate scenes/plate --param speed=-1.5 --param num_frames=24
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


def add_parser(add) -> None:
    p = add("scene", HELP, EPILOG)
    sub = p.add_subparsers(dest="scene_command", metavar="{build,list}", parser_class=Parser)
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
