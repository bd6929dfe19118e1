"""The ``sionnafmcw`` command line.

::

    sionnafmcw presets [--json]                                  radar presets and their derived figures
    sionnafmcw scene list [NAME]                                 scenarios and their parameters
    sionnafmcw scene build NAME OUT [--param k=v ...]            write an animation directory
    sionnafmcw simulate SCENE --radar PRESET|FILE.json --out RUN.zarr [--engine path|pixel] ...
    sionnafmcw plot RUN --out DIR [--kind rd|ra|doppler-time|micro-doppler|scene ...] [--frame N]
    sionnafmcw validate NAME [ARGS ...]                          a validation experiment
    sionnafmcw dataset SPEC --out DIR [--scheduler ADDRESS | --workers N]

Global options: ``--quiet`` (no progress bars), ``--version``. A user error (a missing file, an
unknown preset, scene or parameter, bad ``--frames``, bad JSON, a CPI longer than the frame
period, ...) prints one line ``sionnafmcw: error: ...`` on stderr and exits with status 2; an
interrupted run exits with 130 (``simulate`` then resumes where it stopped). Heavy modules
(Sionna RT, Zarr, the scene builders) are imported inside the subcommands that need them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

PROG = "sionnafmcw"
EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
PLOT_KINDS = ("rd", "ra", "doppler-time", "micro-doppler", "scene")
ENGINE_NAMES = ("path", "pixel")


class UserError(Exception):
    """A mistake on the command line or in an input file: printed as one line, no traceback."""


# ============================================================================ parsing helpers
class _Parser(argparse.ArgumentParser):
    """Argument parser whose errors are one line (``UserError``) instead of usage + exit."""

    def error(self, message):
        raise UserError(f"{message} (see '{self.prog} --help')")


def _formatter(prog):
    return argparse.RawDescriptionHelpFormatter(prog, max_help_position=32, width=100)


def parse_frames(text: str, num_frames: int) -> list[int]:
    """Frame indices from ``--frames``: ``a:b`` (a..b-1), ``a:``, ``:b``, ``a:b:step``, ``n`` or ``i,j,k``.

    Indices are 0-based and must lie in ``0..num_frames-1``; raises :class:`UserError` naming the problem.
    """
    text = str(text).strip()
    where = f"--frames {text!r}"
    span = f"the scene has {num_frames} frame{'s' if num_frames != 1 else ''} (0..{num_frames - 1})"

    def integer(s, what):
        try:
            value = int(s)
        except ValueError:
            raise UserError(f"{where}: {what} {s!r} is not an integer; write a:b, a:b:step, n or i,j,k") from None
        return value

    if not text:
        raise UserError(f"{where} is empty; write a:b (frames a..b-1), a:, :b, n or i,j,k")
    if ":" in text:
        parts = text.split(":")
        if len(parts) > 3:
            raise UserError(f"{where}: too many ':'; write a:b or a:b:step")
        start = integer(parts[0], "start") if parts[0].strip() else 0
        stop = integer(parts[1], "stop") if parts[1].strip() else num_frames
        step = integer(parts[2], "step") if len(parts) == 3 and parts[2].strip() else 1
        if step < 1:
            raise UserError(f"{where}: step must be >= 1")
        if start < 0 or stop < 0:
            raise UserError(f"{where}: negative frame numbers are not allowed; {span}")
        if stop > num_frames:
            raise UserError(f"{where}: stop {stop} is past the end; {span}")
        if start >= stop:
            raise UserError(f"{where} selects no frame (start {start} >= stop {stop}); {span}")
        return list(range(start, stop, step))
    indices = [integer(p.strip(), "frame") for p in text.split(",") if p.strip()]
    bad = [i for i in indices if not 0 <= i < num_frames]
    if bad:
        raise UserError(f"{where}: frame(s) {', '.join(map(str, bad))} out of range; {span}")
    if len(set(indices)) != len(indices):
        raise UserError(f"{where} lists a frame twice")
    return indices


def _parse_interval(text: str, option: str) -> tuple:
    """``MIN:MAX`` (either side may be empty) as floats."""
    parts = str(text).split(":")
    if len(parts) != 2:
        raise UserError(f"{option} {text!r}: write MIN:MAX in metres, e.g. 0.5:8 (either side may be empty)")
    try:
        lo, hi = (float(p) if p.strip() else None for p in parts)
    except ValueError:
        raise UserError(f"{option} {text!r}: MIN and MAX must be numbers (metres)") from None
    if lo is not None and hi is not None and lo >= hi:
        raise UserError(f"{option} {text!r}: MIN must be below MAX")
    return lo, hi


def _key_values(items, option: str) -> list[tuple[str, str]]:
    out = []
    for item in items or []:
        if "=" not in item or not item.split("=", 1)[0].strip():
            raise UserError(f"{option} {item!r}: write key=value")
        key, value = item.split("=", 1)
        out.append((key.strip(), value.strip()))
    keys = [k for k, _ in out]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise UserError(f"{option}: {', '.join(dup)} given twice")
    return out


_TRUE = ("1", "true", "yes", "on")
_FALSE = ("0", "false", "no", "off")


def _coerce(text: str, like, where: str):
    """Command-line text as a value of the type of ``like`` (a default value; None: guess)."""
    low = text.lower()
    if isinstance(like, bool):
        if low in _TRUE:
            return True
        if low in _FALSE:
            return False
        raise UserError(f"{where}={text!r} is not a boolean; write true or false")
    if isinstance(like, int):
        try:
            value = float(text)
        except ValueError:
            raise UserError(f"{where}={text!r} is not an integer") from None
        if not value.is_integer():
            raise UserError(f"{where}={text!r} is not an integer")
        return int(value)
    if isinstance(like, float):
        try:
            return float(text)
        except ValueError:
            raise UserError(f"{where}={text!r} is not a number") from None
    if isinstance(like, str):
        return text
    if low in _TRUE[1:] or low in _FALSE[1:]:
        return low in _TRUE
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


# ============================================================================ shared loaders
def _load_radar(spec: str):
    """A RadarConfig from a preset name or a JSON file (a full config, or ``{"preset": NAME, field: value}``)."""
    from .radar import RadarConfig, RadarConfigError

    presets = RadarConfig.presets()
    if spec in presets:
        return RadarConfig.preset(spec)
    path = Path(spec)
    if not path.exists():
        if spec.endswith(".json"):
            raise UserError(f"--radar {spec}: no such file")
        raise UserError(f"--radar {spec!r} is neither a preset ({', '.join(presets)}) nor an existing JSON file")
    if path.is_dir():
        raise UserError(f"--radar {spec}: is a directory, expected a preset name or a JSON file")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise UserError(f"{spec}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise UserError(f"{spec}: cannot read the radar file ({getattr(err, 'strerror', None) or err})") from None
    if not isinstance(data, dict):
        raise UserError(f"{spec}: the radar file must hold a JSON object with RadarConfig fields "
                        "(see 'sionnafmcw presets --json') or {\"preset\": NAME, field: value, ...}")
    try:
        if "preset" in data:
            base = data.pop("preset")
            if base not in presets:
                raise UserError(f"{spec}: field 'preset' is {base!r}; choose one of {', '.join(presets)}")
            config = RadarConfig.preset(base).to_dict()
            unknown = sorted(set(data) - set(config))
            if unknown:
                raise UserError(f"{spec}: unknown RadarConfig field(s) {', '.join(unknown)}; "
                                f"known: {', '.join(sorted(config))}")
            config.update(data)
            if "name" not in data:
                config["name"] = f"{base}*" if data else base
            return RadarConfig.from_dict(config)
        return RadarConfig.from_dict(data)
    except RadarConfigError as err:
        raise UserError(f"{spec}: {err}") from None
    except (TypeError, ValueError) as err:  # e.g. a string where a number belongs
        raise UserError(f"{spec}: a RadarConfig field has the wrong type ({err})") from None


def _load_scene(path: str, option: str = "SCENE"):
    from .animation import AnimationError, load_animation

    p = Path(path)
    if not p.exists():
        raise UserError(f"{option} {path}: no such directory; build one with 'sionnafmcw scene build NAME {path}'")
    if p.is_dir() and not (p / "animation.json").is_file():
        raise UserError(f"{option} {path}: no animation.json in this directory; "
                        "build a scene with 'sionnafmcw scene build NAME DIR'")
    try:
        return load_animation(p)
    except AnimationError as err:
        raise UserError(str(err)) from None


def _progress(iterable, quiet: bool, **kwargs):
    from tqdm.auto import tqdm

    return tqdm(iterable, disable=quiet, **kwargs)


# ============================================================================ presets
def _preset_rows():
    from .radar import RadarConfig

    rows = []
    for name in RadarConfig.presets():
        radar = RadarConfig.preset(name)
        d = radar.derived()
        rows.append({
            "name": name, "fc": radar.fc, "centre_frequency": d["centre_frequency"], "bandwidth": d["bandwidth"],
            "range_resolution": d["range_resolution"], "max_range": d["max_range"],
            "max_velocity": d["max_velocity"], "velocity_resolution": d["velocity_resolution"],
            "cpi_duration": d["cpi_duration"], "num_tx": radar.num_tx, "num_rx": radar.num_rx,
            "num_virtual": d["num_virtual"], "num_samples": radar.num_samples, "num_chirps": radar.num_chirps,
            "config": radar.to_dict(),
        })
    return rows


def cmd_presets(args) -> int:
    rows = _preset_rows()
    if args.name:
        rows = [r for r in rows if r["name"] == args.name]
        if not rows:
            from .radar import RadarConfig

            raise UserError(f"presets: unknown preset {args.name!r}; choose one of {', '.join(RadarConfig.presets())}")
    if args.config:
        if not args.name:
            raise UserError("presets --config needs a preset NAME, e.g. 'sionnafmcw presets walk-77ghz --config'")
        print(json.dumps(rows[0]["config"], indent=1))
        return 0
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    columns = [  # header, unit, value, format
        ("preset", "", lambda r: r["name"], "{}"),
        ("fc", "GHz", lambda r: r["fc"] / 1e9, "{:.2f}"),
        ("bandwidth", "GHz", lambda r: r["bandwidth"] / 1e9, "{:.3f}"),
        ("range res.", "cm", lambda r: r["range_resolution"] * 100, "{:.2f}"),
        ("max range", "m", lambda r: r["max_range"], "{:.2f}"),
        ("max vel.", "m/s", lambda r: r["max_velocity"], "{:.2f}"),
        ("vel. res.", "m/s", lambda r: r["velocity_resolution"], "{:.3f}"),
        ("CPI", "ms", lambda r: r["cpi_duration"] * 1e3, "{:.2f}"),
        ("chirps", "per Tx", lambda r: r["num_chirps"], "{}"),
        ("samples", "per chirp", lambda r: r["num_samples"], "{}"),
        ("Tx x Rx", "", lambda r: f"{r['num_tx']} x {r['num_rx']}", "{}"),
        ("virtual", "channels", lambda r: r["num_virtual"], "{}"),
    ]
    cells = [[fmt.format(get(r)) for _, _, get, fmt in columns] for r in rows]
    widths = [max(len(h), len(u), *(len(c[i]) for c in cells)) for i, (h, u, _, _) in enumerate(columns)]

    def line(values):
        return "  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(values, widths))).rstrip()

    print(line([h for h, _, _, _ in columns]))
    print(line([u for _, u, _, _ in columns]))
    for c in cells:
        print(line(c))
    print("\nmax vel. is the TDM-aware unambiguous radial velocity (lambda_mid / 4 M T_c); a scene's frame period "
          "must be at least the CPI.")
    return 0


# ============================================================================ scene
def _scenes():
    try:
        from . import scenes
    except ModuleNotFoundError as err:
        if err.name and err.name.startswith("sionnafmcw.scenes"):
            raise UserError("the scene builders (sionnafmcw.scenes) are not available in this installation") from None
        raise
    return scenes


def _check_scene_name(scenes, name):
    names = scenes.names()
    if name not in names:
        raise UserError(f"unknown scene {name!r}; choose one of {', '.join(names)} (list them with 'sionnafmcw scene list')")


def _describe_parameter(p) -> str:
    if callable(getattr(p, "describe", None)):
        return p.describe()
    type_name = getattr(p, "type_name", getattr(p.type, "__name__", str(p.type)))
    unit = f" [{p.unit}]" if p.unit else ""
    return f"{type_name}{unit}, default {p.default!r}: {p.doc}"


def cmd_scene_list(args) -> int:
    scenes = _scenes()
    names = scenes.names()
    if args.name:
        _check_scene_name(scenes, args.name)
        names = [args.name]
    for i, name in enumerate(names):
        params = scenes.parameters(name)
        doc = ""
        describe = getattr(scenes, "describe", None)
        if describe is not None:
            doc = describe(name).splitlines()[0].split(": ", 1)[-1]
        print(f"{name}: {doc}" if doc else name)
        width = max((len(k) for k in params), default=0)
        for key, p in params.items():
            print(f"    {key:<{width}}  {_describe_parameter(p)}")
        if i + 1 < len(names):
            print()
    return 0


def _scene_params(scenes, name, items) -> dict:
    params = scenes.parameters(name)
    parse_value = getattr(scenes, "parse_value", None)
    out = {}
    for key, text in _key_values(items, "--param"):
        if key not in params:
            raise UserError(f"scene {name!r} has no parameter {key!r}; valid parameters: {', '.join(params) or 'none'}")
        if parse_value is not None:
            try:
                out[key] = parse_value(name, key, text)
            except ValueError as err:
                raise UserError(f"--param {key}={text}: {err}") from None
            continue
        p = params[key]
        if p.type is tuple:
            try:
                out[key] = tuple(float(x) for x in text.strip("()[] ").split(",") if x.strip())
            except ValueError:
                raise UserError(f"--param {key}={text!r} is not a comma-separated list of numbers") from None
        else:
            out[key] = _coerce(text, p.type() if p.type in (bool, int, float, str) else None, f"--param {key}")
    return out


def cmd_scene_build(args) -> int:
    scenes = _scenes()
    _check_scene_name(scenes, args.name)
    params = _scene_params(scenes, args.name, args.param)
    out = Path(args.out)
    if out.exists() and not args.overwrite and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"{out} exists and is not empty; pass --overwrite to replace it or choose another OUT")
    try:
        path = scenes.build(args.name, out, overwrite=args.overwrite, **params)
    except FileExistsError as err:
        raise UserError(f"{err}; pass --overwrite to replace it") from None
    except ValueError as err:
        raise UserError(f"scene build {args.name}: {err}") from None
    from .animation import load_animation

    anim = load_animation(path, check_meshes=False)
    print(f"wrote scene {args.name!r} to {path}: {anim.num_frames} frames at {anim.fps:g} fps, "
          f"moving objects: {', '.join(anim.object_names) or 'none'}")
    return 0


# ============================================================================ simulate
def _engine_class(name: str):
    """The engine class behind ``name`` (to check and type ``--engine-option``), or None."""
    import importlib

    candidates = {"path": [("sionnafmcw.engines.path", "PathEngine")],
                  "pixel": [("sionnafmcw.engines.pixel", "PixelEngine"), ("sionnafmcw.engines", "PixelEngine")]}
    for module, attribute in candidates.get(name, []):
        try:
            cls = getattr(importlib.import_module(module), attribute, None)
        except ModuleNotFoundError:
            continue
        if cls is not None:
            return cls
    return None


def _engine_options(engine: str, items) -> dict:
    import inspect

    pairs = _key_values(items, "--engine-option")
    if not pairs:
        return {}
    cls = _engine_class(engine)
    defaults = None
    if cls is not None:
        sig = inspect.signature(cls.__init__)
        if not any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
            defaults = {k: p.default for k, p in sig.parameters.items()
                        if k != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    out = {}
    for key, text in pairs:
        if defaults is not None and key not in defaults:
            raise UserError(f"--engine-option {key}: the {engine} engine has no option {key!r}; "
                            f"valid options: {', '.join(defaults)}")
        like = None if defaults is None or defaults[key] is inspect.Parameter.empty else defaults[key]
        out[key] = _coerce(text, like, f"--engine-option {key}")
    return out


def cmd_simulate(args) -> int:
    from .radar import RadarConfigError

    animation = _load_scene(args.scene)
    radar = _load_radar(args.radar)
    try:
        radar.validate(frame_period=animation.frame_period)
    except RadarConfigError as err:
        raise UserError(f"--radar {args.radar} with scene {args.scene} ({animation.fps:g} fps): {err}") from None
    frames = parse_frames(args.frames, animation.num_frames) if args.frames is not None else None
    if animation.radar_pose is None:
        raise UserError(f"{animation.path / 'animation.json'}: no field 'radar' (the radar pose); add "
                        '"radar": {"position": [x, y, z], "orientation": [yaw, pitch, roll]}')
    from .simulation import ENGINES

    if args.engine not in ENGINES:
        raise UserError(f"--engine {args.engine}: this engine is not available in this installation "
                        f"(available: {', '.join(ENGINES)})")
    options = _engine_options(args.engine, args.engine_option)
    from .simulation import simulate

    out = Path(args.out)
    try:
        ds = simulate(animation, radar, engine=args.engine, out=out, frames=frames, progress=not args.quiet,
                      seed=args.seed, noise=not args.no_noise, engine_options=options, leakage_db=args.leakage_db)
    except TypeError as err:
        if "unexpected keyword argument" in str(err):
            raise UserError(f"--engine-option: {err}") from None
        raise
    done = int(ds["frame_done"].values.sum())
    print(f"wrote {out}: {done} of {ds.sizes['frame']} frames done, radar {radar.name}, {args.engine} engine")
    return 0


# ============================================================================ plot
def _pose(ds):
    pose = ds.attrs.get("radar_pose")
    if not pose:
        return None
    import numpy as np

    return np.asarray(pose["position"], float), np.asarray(pose["orientation"], float)


def _truth_in_radar_frame(ds, radar, frame):
    """Per object: range from the virtual array's phase centre (m) and azimuth in the radar frame (rad)."""
    import numpy as np

    from .geometry import world_to_radar
    from .processing import array_phase_centre

    pose = _pose(ds)
    if pose is None or "truth_position" not in ds or ds.sizes.get("object", 0) == 0:
        return None
    positions = np.asarray(ds["truth_position"][frame].values, float)
    local = world_to_radar(positions, *pose) - array_phase_centre(radar)
    ranges = np.linalg.norm(local, axis=-1)
    azimuths = np.arctan2(local[:, 1], local[:, 0])
    return ranges, azimuths


def cmd_plot(args) -> int:
    import numpy as np

    from . import plots, processing
    from .radar import RadarConfig, RadarConfigError
    from .store import RunStoreError, open_run

    run = Path(args.run)
    try:
        ds = open_run(run)
    except RunStoreError as err:
        raise UserError(f"{err}; write one with 'sionnafmcw simulate SCENE --radar PRESET --out {run}'") from None
    try:
        radar = RadarConfig.from_dict(ds.attrs["radar"])
    except (KeyError, RadarConfigError, TypeError) as err:
        raise UserError(f"{run}: attribute 'radar' is missing or invalid ({err})") from None
    kinds = list(dict.fromkeys(args.kind)) if args.kind else [k for k in PLOT_KINDS if k != "scene"]
    if not args.kind and ds.attrs.get("scene") and Path(ds.attrs["scene"]).is_dir():
        kinds.append("scene")
    done = np.nonzero(np.asarray(ds["frame_done"].values, bool))[0]
    if done.size == 0:
        raise UserError(f"{run}: no frame is finished yet; run 'sionnafmcw simulate' (again) to fill the store")
    if args.frame is not None:
        if not 0 <= args.frame < ds.sizes["frame"]:
            raise UserError(f"--frame {args.frame}: {run} has frames 0..{ds.sizes['frame'] - 1}")
        if args.frame not in done:
            raise UserError(f"--frame {args.frame}: this frame of {run} is not simulated yet "
                            f"(finished: {_ranges_text(done)})")
        frame = int(args.frame)
    else:
        frame = int(done[len(done) // 2])
    gate = _parse_interval(args.range_gate, "--range-gate") if args.range_gate else None
    clutter = not args.keep_clutter
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: exists and is not a folder")
    engine = (ds.attrs.get("engine") or {}).get("engine", "?")
    objects = [str(o) for o in ds["object"].values] if "object" in ds.coords or "object" in ds else []
    times = np.asarray(ds["frame_time"].values, float)
    suffix = ", static clutter removed" if clutter else ", static clutter kept"
    written = []

    def cube(i):
        return np.asarray(ds["iq"][int(i)].values)

    def cubes(desc):
        return (cube(i) for i in _progress(done, args.quiet, desc=desc, unit="frame"))

    truth_v = None
    if args.truth:
        unknown = [n for n in args.truth if n not in objects]
        if unknown:
            raise UserError(f"--truth {unknown[0]}: {run} has no object {unknown[0]!r}; "
                            f"its objects: {', '.join(objects) or 'none'}")
        shown = list(dict.fromkeys(args.truth))
    else:  # a few objects: all of them; a body: its torso (the paper's ground truth)
        shown = objects if len(objects) <= 6 else (["torso"] if "torso" in objects else objects[:1])
    columns = [objects.index(n) for n in shown]
    if shown and "truth_radial_velocity" in ds:
        truth_v = np.asarray(ds["truth_radial_velocity"].values, float)[:, columns]

    for kind in kinds:
        if kind == "rd":
            rdmap = processing.range_doppler_map(cube(frame), radar, clutter_removal=clutter)
            truth = None
            geo = _truth_in_radar_frame(ds, radar, frame)
            if geo is not None and truth_v is not None:
                truth = list(zip(geo[0][columns], truth_v[frame]))
            ax = plots.plot_range_doppler(rdmap, truth=truth, dynamic_range=args.dynamic_range,
                                          title=f"Range-Doppler, frame {frame} (t = {times[frame]:.3f} s)\n"
                                                f"{engine} engine{suffix}")
            if args.max_range:
                ax.set_ylim(0.0, min(args.max_range, float(rdmap.ranges[-1])))
            written.append(plots.save(ax, out / f"range_doppler_f{frame:04d}.png"))
        elif kind == "ra":
            ramap = processing.range_azimuth_map(cube(frame), radar, clutter_removal=clutter)
            geo = _truth_in_radar_frame(ds, radar, frame)
            truth = list(zip(geo[0][columns], geo[1][columns])) if geo is not None and columns else None
            ax = plots.plot_range_azimuth(ramap, truth=truth, cartesian=args.cartesian, max_range=args.max_range,
                                          dynamic_range=args.dynamic_range,
                                          title=f"Range-azimuth, frame {frame} (t = {times[frame]:.3f} s)\n"
                                                f"{engine} engine{suffix}")
            written.append(plots.save(ax, out / f"range_azimuth_f{frame:04d}.png"))
        elif kind == "doppler-time":
            try:
                track = processing.doppler_time(cubes("Doppler track"), radar, clutter_removal=clutter,
                                                range_gate=gate)
            except ValueError as err:  # an empty range gate
                raise UserError(f"--range-gate: {err}") from None
            ax = plots.plot_doppler_time(track, times=times[done],
                                         truth=None if truth_v is None else truth_v[done], object_names=shown,
                                         velocity_limits=(-radar.max_velocity, radar.max_velocity),
                                         title=f"Doppler-time (strongest cell)\n{engine} engine{suffix}")
            written.append(plots.save(ax, out / "doppler_time.png"))
        elif kind == "micro-doppler":
            window = args.window_chirps or max(1, radar.num_chirps // 4)
            if not 1 <= window <= radar.num_chirps:
                raise UserError(f"--window-chirps {window}: must be in 1..{radar.num_chirps} (chirps per Tx in a CPI)")
            try:
                spec = processing.micro_doppler_spectrogram(cubes("micro-Doppler"), radar, times[done],
                                                            range_gate=gate, window_chirps=window,
                                                            clutter_removal=clutter)
            except ValueError as err:
                raise UserError(f"--range-gate/--window-chirps: {err}") from None
            ax = plots.plot_micro_doppler(spec, dynamic_range=args.dynamic_range,
                                          truth=None if truth_v is None else truth_v[done], truth_times=times[done],
                                          object_names=shown,
                                          title=f"Micro-Doppler, {window}-chirp window\n{engine} engine{suffix}")
            written.append(plots.save(ax, out / "micro_doppler.png"))
        elif kind == "scene":
            scene = args.scene or ds.attrs.get("scene")
            if not scene:
                raise UserError(f"{run} records no scene (attribute 'scene'); pass --scene DIR")
            if not Path(scene).is_dir():
                if args.scene:
                    raise UserError(f"--scene {scene}: no such directory")
                raise UserError(f"scene {scene} (recorded in {run}) is not there any more; pass --scene DIR")
            animation = _load_scene(scene, "--scene")
            pose = ds.attrs.get("radar_pose")
            frames = [int(f) for f in done if f < animation.num_frames]
            ax = plots.plot_scene_top_view(animation, radar=radar, radar_pose=pose, frames=frames or None,
                                           highlight=[n for n in shown if n in animation.object_names] or None,
                                           title=f"Scene {Path(scene).name}, top view")
            written.append(plots.save(ax, out / "scene_top_view.png"))
    for path in written:
        print(path)
    return 0


def _ranges_text(indices) -> str:
    """``[0, 1, 2, 5]`` -> ``"0-2, 5"``."""
    indices = sorted(int(i) for i in indices)
    parts, start = [], None
    for k, i in enumerate(indices):
        if start is None:
            start = i
        if k + 1 == len(indices) or indices[k + 1] != i + 1:
            parts.append(str(start) if start == i else f"{start}-{i}")
            start = None
    return ", ".join(parts)


# ============================================================================ validate
def cmd_validate(args) -> int:
    from . import validation

    if args.list or not args.name:
        for name in validation.names():
            print(f"{name}: {validation.EXPERIMENTS.get(name, '')}")
        return 0
    if args.name not in validation.names():
        raise UserError(f"unknown validation experiment {args.name!r}; choose one of {', '.join(validation.names())}")
    argv0 = sys.argv[0] if sys.argv else PROG
    if sys.argv:
        sys.argv[0] = f"{PROG} validate {args.name}"  # the experiment's usage lines name the command
    try:
        return int(validation.run(args.name, list(args.args)) or 0)
    finally:
        if sys.argv:
            sys.argv[0] = argv0


# ============================================================================ dataset
def cmd_dataset(args) -> int:
    try:
        from . import dataset
    except ModuleNotFoundError as err:
        if err.name and err.name.startswith("sionnafmcw.dataset"):
            raise UserError("the data-set generator (sionnafmcw.dataset) is not available in this installation") from None
        raise
    spec_path = Path(args.spec)
    if not spec_path.is_file():
        raise UserError(f"{args.spec}: no such data-set specification file")
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers}: must be >= 1")
    parse_errors: tuple = (ValueError,)
    if "yaml" in sys.modules:
        parse_errors += (sys.modules["yaml"].YAMLError,)
    try:
        spec = dataset.load_spec(spec_path)
    except parse_errors as err:
        message = str(err)
        raise UserError(message if str(spec_path) in message else f"{args.spec}: {message}") from None
    import inspect

    kwargs = {"scheduler": args.scheduler, "progress": not args.quiet}
    cluster = None
    try:
        if args.workers is not None:
            if "workers" in inspect.signature(dataset.generate).parameters:
                kwargs["workers"] = args.workers
            else:  # an older generate(): start the local cluster here
                from distributed import LocalCluster

                cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                kwargs["scheduler"] = cluster.scheduler_address
        index = dataset.generate(spec, Path(args.out), **kwargs)
    finally:
        if cluster is not None:
            cluster.close()
    summary = ""
    if index is not None and hasattr(index, "variables") and "status" in index.variables:
        import collections

        counts = collections.Counter(str(s) for s in index["status"].values)
        summary = ": " + ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
    print(f"wrote data set {getattr(spec, 'name', '?')} to {args.out}{summary}")
    return 1 if "failed" in summary else 0


# ============================================================================ the parser
EPILOGS = {
    "presets": """\
example:
  sionnafmcw presets
  sionnafmcw presets --json
  sionnafmcw presets walk-77ghz --config > walk.json   # edit, then: simulate ... --radar walk.json
""",
    "scene": """\
examples:
  sionnafmcw scene list
  sionnafmcw scene build moving_plate scenes/plate --param speed=-1.5 --param num_frames=24
""",
    "scene list": """\
example:
  sionnafmcw scene list circle_walk
""",
    "scene build": """\
example:
  sionnafmcw scene build moving_plate scenes/plate --param speed=-1.5 --param num_frames=24
  sionnafmcw scene build corner_reflectors scenes/cr --param ranges=3,5,7 --overwrite
""",
    "simulate": """\
The radar is a preset (sionnafmcw presets) or a JSON file: a full RadarConfig
(sionnafmcw presets NAME --config writes one) or a preset with changes,
e.g. {"preset": "walk-77ghz", "num_chirps": 64}. An existing store written with the
same settings is resumed: finished frames are kept.

example:
  sionnafmcw simulate scenes/plate --radar walk-77ghz --engine path --out runs/plate.zarr \\
      --frames 0:12 --seed 1 --engine-option samples_per_src=20000
""",
    "plot": """\
Files: range_doppler_fNNNN.png, range_azimuth_fNNNN.png, doppler_time.png,
micro_doppler.png, scene_top_view.png (default: every kind; scene when the
recorded scene directory exists). Ground truth is drawn as red stars.

example:
  sionnafmcw plot runs/plate.zarr --out figures/plate --kind rd --kind doppler-time --frame 3
""",
    "validate": """\
example:
  sionnafmcw validate --list
  sionnafmcw validate point_targets --out out/point_targets
""",
    "dataset": """\
A finished run with the same SPEC and DIR resumes: complete items are skipped. Exit status 1
when some items failed (they are listed in DIR's index with their error).

example:
  sionnafmcw dataset specs/walkers.yaml --out data/walkers --workers 2
  sionnafmcw dataset specs/walkers.yaml --out data/walkers --scheduler tcp://10.0.0.5:8786
""",
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``sionnafmcw`` command (subcommands in :data:`EPILOGS`)."""
    from . import __version__

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                        help="no progress bars")
    parser = _Parser(prog=PROG, formatter_class=_formatter,
                     description="Physically grounded FMCW TDM-MIMO radar simulator on Sionna RT.",
                     epilog="example:\n  sionnafmcw scene build moving_plate scenes/plate\n"
                            "  sionnafmcw simulate scenes/plate --radar walk-77ghz --out runs/plate.zarr\n"
                            "  sionnafmcw plot runs/plate.zarr --out figures/plate\n\n"
                            "'sionnafmcw COMMAND --help' explains each command.")
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    def add(name, help_text, subparsers=sub, key=None):
        return subparsers.add_parser(name, help=help_text, description=help_text, epilog=EPILOGS[key or name],
                                     formatter_class=_formatter, parents=[common])

    p = add("presets", "Table of the radar presets with their derived figures.")
    p.add_argument("name", nargs="?", help="only this preset")
    p.add_argument("--json", action="store_true", help="JSON (SI units) with each preset's full configuration")
    p.add_argument("--config", action="store_true",
                   help="only the RadarConfig JSON of preset NAME (a --radar file to edit)")
    p.set_defaults(func=cmd_presets)

    p = add("scene", "Build or list the scenarios (animation directories written by code).")
    scene_sub = p.add_subparsers(dest="scene_command", metavar="{build,list}", parser_class=_Parser)
    scene_sub.required = True
    q = add("list", "The scenarios with their parameters (type, unit, default).", scene_sub, "scene list")
    q.add_argument("name", nargs="?", help="only this scenario")
    q.set_defaults(func=cmd_scene_list)
    q = add("build", "Write scenario NAME as an animation directory OUT.", scene_sub, "scene build")
    q.add_argument("name", metavar="NAME", help="scenario name (see 'sionnafmcw scene list')")
    q.add_argument("out", metavar="OUT", help="output directory (must not exist or be empty, unless --overwrite)")
    q.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="scenario parameter, repeatable (tuples: comma-separated, e.g. ranges=3,5,7)")
    q.add_argument("--overwrite", action="store_true", help="replace an existing OUT")
    q.set_defaults(func=cmd_scene_build)

    p = add("simulate", "Simulate a scene with a radar into a run store (Zarr).")
    p.add_argument("scene", metavar="SCENE", help="animation directory (with animation.json)")
    p.add_argument("--radar", required=True, metavar="PRESET|FILE.json", help="radar preset or RadarConfig JSON file")
    p.add_argument("--engine", choices=ENGINE_NAMES, default="path", help="ray-tracing engine (default: path)")
    p.add_argument("--out", required=True, metavar="RUN.zarr", help="run store to write (resumed if it exists)")
    p.add_argument("--frames", metavar="A:B", help="frames A..B-1 (also A:, :B, A:B:STEP, N or I,J,K; default all)")
    p.add_argument("--seed", type=int, default=0, help="receiver-noise seed (default 0)")
    p.add_argument("--no-noise", action="store_true", help="no receiver thermal noise")
    p.add_argument("--leakage-db", type=float, default=None, metavar="DB",
                   help="add direct Tx-Rx coupling at this level (dB); default none")
    p.add_argument("--engine-option", action="append", default=[], metavar="KEY=VALUE",
                   help="engine setting, repeatable (path: samples_per_src, max_depth, diffuse, ...)")
    p.set_defaults(func=cmd_simulate)

    p = add("plot", "Process a run store and write PNG figures.")
    p.add_argument("run", metavar="RUN", help="run store written by 'sionnafmcw simulate'")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the PNG files")
    p.add_argument("--kind", action="append", choices=PLOT_KINDS, metavar="KIND",
                   help=f"figure, repeatable: {', '.join(PLOT_KINDS)} (default: all)")
    p.add_argument("--frame", type=int, default=None, metavar="N",
                   help="frame for rd and ra (default: the middle finished frame)")
    p.add_argument("--keep-clutter", action="store_true",
                   help="do not remove static clutter (the slow-time mean) before processing")
    p.add_argument("--range-gate", metavar="MIN:MAX", help="only these ranges (m) for doppler-time and micro-doppler")
    p.add_argument("--window-chirps", type=int, default=None, metavar="W",
                   help="micro-Doppler STFT window in chirps (default: a quarter of the CPI)")
    p.add_argument("--dynamic-range", type=float, default=50.0, metavar="DB", help="colour scale span (default 50 dB)")
    p.add_argument("--max-range", type=float, default=None, metavar="M", help="crop rd and ra maps at this range (m)")
    p.add_argument("--cartesian", action="store_true", help="range-azimuth map in x-y (top view) instead of range-angle")
    p.add_argument("--scene", default=None, metavar="DIR", help="scene for --kind scene (default: the one recorded)")
    p.add_argument("--truth", action="append", default=[], metavar="OBJECT",
                   help="object whose ground truth is drawn, repeatable (default: all when at most six, "
                        "else the torso); tracks of these are highlighted in the scene view")
    p.set_defaults(func=cmd_plot)

    p = add("validate", "Run a validation experiment (writes figures and metrics.json).")
    p.add_argument("name", nargs="?", metavar="NAME", help="experiment (see --list)")
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARGS", help="the experiment's own options")
    p.add_argument("--list", action="store_true", help="list the experiments")
    p.set_defaults(func=cmd_validate)

    p = add("dataset", "Generate a data set from a specification file.")
    p.add_argument("spec", metavar="SPEC", help="data-set specification (YAML or JSON)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786")
    group.add_argument("--workers", type=int, default=None, metavar="N", help="start a local Dask cluster of N workers")
    p.set_defaults(func=cmd_dataset)
    return parser


def _user_error_types() -> tuple:
    """Exceptions that mean bad input: the project's own error classes (from modules already
    loaded: only those can have raised) and the file-system errors of a wrong path."""
    types = [UserError, FileNotFoundError, FileExistsError, NotADirectoryError, IsADirectoryError, PermissionError]
    for module, name in (("sionnafmcw.radar", "RadarConfigError"), ("sionnafmcw.animation", "AnimationError"),
                         ("sionnafmcw.store", "RunStoreError"), ("sionnafmcw.materials", "MaterialError"),
                         ("sionnafmcw.engines.path", "PathEngineError"),
                         ("sionnafmcw.engines.scene_loading", "SceneLoadError"),
                         ("sionnafmcw.engines.pixel", "PixelEngineError"),
                         ("sionnafmcw.dataset.spec", "SpecError"), ("sionnafmcw.dataset.index", "DatasetError")):
        mod = sys.modules.get(module)
        if mod is not None and hasattr(mod, name):
            types.append(getattr(mod, name))
    return tuple(types)


def _one_line(err: BaseException) -> str:
    if isinstance(err, OSError) and err.strerror and err.filename:
        return f"{err.filename}: {err.strerror}"
    text = " ".join(str(err).split()) or type(err).__name__
    return text


def main(argv=None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    try:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help, --version
            return int(exc.code or 0) if not isinstance(exc.code, str) else 1
        if not hasattr(args, "quiet"):
            args.quiet = False
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted (a simulate run resumes where it stopped when started again)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except _user_error_types() as err:
        print(f"{PROG}: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":
    sys.exit(main())
