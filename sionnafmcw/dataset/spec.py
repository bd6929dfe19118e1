r"""Data-set specifications: parsing, validation and the reproducible draw of items.

A spec is a YAML or JSON file, or a dict::

    name: plates                      # a label for the data set (letters, digits, - _ .)
    scenario: moving_plate            # a builder of sionnafmcw.scenes (scenes.names())
    count: 100                        # number of items, >= 1
    seed: 7                           # master seed (int >= 0)
    radar: walk-77ghz                 # a preset, {"preset": name, field: value, ...} (a preset with
                                      # RadarConfig fields replaced), {"file": radar.json or TI .cfg,
                                      # field: value, ...} (relative to the spec's folder; a field's
                                      # value in either may be a draw,
                                      # {uniform: [lo, hi]}, {choice: [...]} or {range: [lo, hi, step]},
                                      # drawn per item), a full RadarConfig dict, or a list of these
                                      # (each item draws one, uniformly)
    engine: path                      # an engine of sionnafmcw.engines.names()
    engine_options: {samples_per_src: 20000}
    parameters:                       # scenario parameters; the others keep the builder's defaults
      speed: {uniform: [-3.0, 3.0]}   #   continuous, uniform on [lo, hi)
      start_range: [3.0, 4.0, 5.0]    #   a list: one of these, uniformly
      activity: {cycle: [walk, fall]} #   item i takes the (i mod n)-th: balanced classes
      subdiv: {range: [1, 4, 1]}      #   one of lo, lo+step, ..., up to hi (hi included when on the grid)
      num_frames: 8                   #   a fixed value ({"value": x} says the same explicitly)
      clip: {files: "clips/*.bvh"}    #   a string parameter: one of the files the pattern (or folder)
                                      #   matches, uniformly (relative to the spec file's folder)
    radar_pose: {position: [0, 0, 1], orientation: [0, 0, 0]}   # optional: overrides the scene's
    frames: 4                         # optional: simulate the first 4 frames, or a list of indices
    noise: true                       # optional (default true): receiver thermal noise
    label_object: plate               # optional: the object whose truth labels the item
                                      # (default: "torso" when there is one, else the first object)

A bare list is a set of choices, except for a ``tuple`` parameter (e.g. ``corner_reflectors``'
``ranges``) where a flat list of numbers is the value itself and a list of lists the choices;
``{"choice": [...]}`` and ``{"value": ...}`` are never ambiguous. ``{"cycle": [...]}`` takes the values
in turn, item :math:`i` the :math:`(i \bmod n)`-th (balanced classes: every activity as often).
``{"files": pattern}`` is a choice
among files: a glob pattern (``clips/*.bvh``) or a folder (every file in it), relative to the spec
file's folder (to the working directory for a dict), resolved when the spec is loaded into the
sorted list of absolute paths it matches (the canonical spec stores that list as a ``choice``, so a
folder whose files change makes another spec).

Reproducible draw: item :math:`i` has the id ``f"{i:06d}"``; its noise seed is the first draw of
``numpy.random.default_rng([seed, i])`` (an integer in :math:`[0, 2^{31})`), and every parameter
:math:`p` is drawn from its own generator ``default_rng([seed, i, crc32(p)])``. So an item does not
depend on ``count`` or on the other items, and adding, removing or changing one parameter leaves
the draws of the others (and the noise) unchanged. Every seed parameter of the scenario (``seed``,
and any named ``*_seed``, e.g. ``furniture_seed``) the spec does not set is drawn per item
(``default_rng([seed, i, crc32(name)])``), so random scene details (a gait, the placement of people
and furniture) differ between items. A list of radars is drawn the same way
under the key ``"radar"``; a drawn field of a radar entry (``{"preset": "walk-77ghz", "noise_figure":
{"uniform": [12, 18]}}``: domain randomisation of the receiver) from
``default_rng([seed, i, crc32("radar." + field)])``, every value it can give checked as a
:class:`RadarConfig` when the spec is loaded.
"""

from __future__ import annotations

import copy
import json
import math
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..radar import RadarConfig, RadarConfigError

FIELDS = ("name", "scenario", "count", "seed", "radar", "engine", "engine_options", "parameters", "radar_pose",
          "frames", "noise", "label_object")
REQUIRED = ("name", "scenario", "count", "seed", "radar")
MAX_GRID = 1_000_000  # values of one {"range": ...}
SEED_SPACE = 2**31


class SpecError(ValueError):
    """A data-set spec that cannot be used; the message names the field (and the file) and the fix."""


# ===================================================================================== distributions
@dataclass(frozen=True)
class Draw:
    """How one parameter is drawn: ``kind`` in value/choice/cycle/uniform/range and its ``args``."""

    kind: str
    args: tuple

    def to_json(self):
        if self.kind == "value":
            return {"value": _plain(self.args[0])}
        return {self.kind: [_plain(a) for a in self.args]}

    def sample(self, rng: np.random.Generator, index: int = 0):
        """One value: from ``rng``, or for ``cycle`` the ``index``-th (item ``index``)."""
        if self.kind == "value":
            return self.args[0]
        if self.kind == "choice":
            return self.args[int(rng.integers(len(self.args)))]
        if self.kind == "cycle":
            return self.args[int(index) % len(self.args)]
        if self.kind == "uniform":
            lo, hi = self.args
            return float(rng.uniform(lo, hi))
        grid = _grid(*self.args)
        return grid[int(rng.integers(len(grid)))]

    def support(self) -> list:
        """Every value this draw can give (the endpoints for ``uniform``), for checking them all."""
        if self.kind == "value":
            return [self.args[0]]
        if self.kind in ("choice", "cycle"):
            return list(self.args)
        if self.kind == "uniform":
            return list(self.args)
        return _grid(*self.args)


def _grid(lo, hi, step) -> list:
    n = int(math.floor((hi - lo) / step * (1 + 1e-12) + 1e-9)) + 1
    if all(isinstance(x, int) for x in (lo, hi, step)):
        return [lo + k * step for k in range(n)]
    return [float(lo + k * step) for k in range(n)]


def _plain(value):
    """JSON-able form of a parameter value (tuples -> lists, numpy scalars -> Python)."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        return value.item()
    return value


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


# ===================================================================================== items
@dataclass(frozen=True)
class Item:
    """One item of a data set: ``index``, ``id`` (``f"{index:06d}"``), its concrete scenario
    ``parameters`` (only those the spec sets, plus a drawn ``seed``), the ``radar`` (a
    :class:`RadarConfig` dict), ``radar_name`` and the receiver-noise ``noise_seed``."""

    index: int
    id: str
    parameters: dict
    radar: dict
    radar_name: str
    noise_seed: int

    def to_dict(self) -> dict:
        return {"index": self.index, "id": self.id, "parameters": {k: _plain(v) for k, v in self.parameters.items()},
                "radar": self.radar, "radar_name": self.radar_name, "noise_seed": self.noise_seed}


def _stream(seed: int, index: int, key: str) -> np.random.Generator:
    return np.random.default_rng([int(seed), int(index), zlib.crc32(key.encode())])


# ===================================================================================== the spec
@dataclass
class DatasetSpec:
    """A validated data-set spec (see the module docstring); build it with :func:`load_spec`."""

    name: str
    scenario: str
    count: int
    seed: int
    radars: list                      # [(name, RadarConfig dict, canonical entry, {field: Draw})], one per choice
    radar_entries: list               # the spec's own entries (canonical), for to_dict
    engine: str = "path"
    engine_options: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)   # {name: Draw}
    radar_pose: dict | None = None
    frames: list | None = None
    noise: bool = True
    label_object: str | None = None
    source: str = "<dict>"
    scenario_seed: bool = False       # the builder has a `seed` the spec leaves to the draw
    drawn_seeds: tuple = ()           # the builder's seed parameters (seed, *_seed) the spec leaves to the draw

    # ------------------------------------------------------------------ canonical form
    def to_dict(self) -> dict:
        """The canonical spec (every field, explicit draw forms): what the data set stores and compares."""
        radar = self.radar_entries[0] if len(self.radar_entries) == 1 else list(self.radar_entries)
        return {"name": self.name, "scenario": self.scenario, "count": self.count, "seed": self.seed,
                "radar": copy.deepcopy(radar), "engine": self.engine, "engine_options": dict(self.engine_options),
                "parameters": {k: d.to_json() for k, d in sorted(self.parameters.items())},
                "radar_pose": copy.deepcopy(self.radar_pose), "frames": self.frames, "noise": self.noise,
                "label_object": self.label_object}

    def to_json(self, **kwargs) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, **kwargs)

    # ------------------------------------------------------------------ items
    def item(self, index: int) -> Item:
        """Item ``index`` (0 <= index < count), drawn from ``(seed, index)`` only."""
        if not 0 <= index < self.count:
            raise IndexError(f"item {index} is outside 0..{self.count - 1}")
        noise_seed = int(np.random.default_rng([self.seed, index]).integers(SEED_SPACE))
        params = {}
        for name in sorted(self.parameters):
            value = self.parameters[name].sample(_stream(self.seed, index, name), index)
            params[name] = _plain(value)
        for name in sorted(set(self.drawn_seeds) | ({"seed"} if self.scenario_seed else set())):
            params[name] = int(_stream(self.seed, index, name).integers(SEED_SPACE))
        k = int(_stream(self.seed, index, "radar").integers(len(self.radars))) if len(self.radars) > 1 else 0
        radar_name, radar, entry, draws = self.radars[k]
        if draws:
            drawn = {f: _plain(d.sample(_stream(self.seed, index, f"radar.{f}"), index)) for f, d in draws.items()}
            if "file" in entry:      # the first draw's config holds the file's radar and the fixed changes
                radar = RadarConfig.from_dict({**radar, **drawn}).to_dict()
            else:
                fixed = {f: v for f, v in entry.items() if f not in draws}
                radar = RadarConfig.resolve({"name": entry["preset"], **fixed, **drawn}).to_dict()
        return Item(index, f"{index:06d}", params, radar, radar_name, noise_seed)

    def items(self) -> list[Item]:
        return [self.item(i) for i in range(self.count)]


# ===================================================================================== parsing
def _read(spec) -> tuple[dict, str]:
    if isinstance(spec, DatasetSpec):
        return spec.to_dict(), spec.source
    if isinstance(spec, dict):
        return copy.deepcopy(spec), "<dict>"
    if isinstance(spec, (str, Path)):
        path = Path(spec)
        if not path.exists():
            raise SpecError(f"data-set spec {path}: no such file; pass a YAML/JSON file or a dict")
        text = path.read_text()
        try:
            if path.suffix.lower() == ".json":
                data = json.loads(text)
            else:
                import yaml

                data = yaml.safe_load(text)
        except Exception as exc:
            raise SpecError(f"data-set spec {path} cannot be parsed: {exc}") from exc
        if not isinstance(data, dict):
            raise SpecError(f"data-set spec {path}: the top level must be a mapping of fields "
                            f"({', '.join(REQUIRED)}, ...), got {type(data).__name__}")
        return data, str(path)
    raise SpecError(f"data-set spec must be a file path, a dict or a DatasetSpec, got {type(spec).__name__}")


_RADAR_DRAWS = ("uniform", "choice", "range")


def _is_draw(value) -> bool:
    return isinstance(value, dict) and len(value) == 1 and next(iter(value)) in _RADAR_DRAWS


def _radar_draw(field_name: str, raw: dict, where: str) -> Draw:
    """A :class:`Draw` of one RadarConfig field (``uniform``, ``choice`` or ``range``)."""
    kind, args = next(iter(raw.items()))
    at = f"{where}: {field_name}"
    if kind == "choice":
        if not isinstance(args, (list, tuple)) or not args:
            raise SpecError(f"{at}: 'choice' needs a non-empty list of values, got {args!r}")
        return Draw("choice", tuple(args))
    n = 2 if kind == "uniform" else 3
    if not isinstance(args, (list, tuple)) or len(args) != n or not all(_is_number(a) for a in args):
        raise SpecError(f"{at}: {kind!r} needs {'[lo, hi]' if n == 2 else '[lo, hi, step]'} (finite numbers), "
                        f"got {args!r}")
    if not args[0] < args[1] or (n == 3 and not args[2] > 0):
        raise SpecError(f"{at}: {kind!r} needs lo < hi{' and step > 0' if n == 3 else ''}, got {list(args)}")
    return Draw(kind, tuple(float(a) for a in args) if kind == "uniform" else tuple(args))


def _radar_file_entry(entry: dict, where: str, base: Path) -> tuple[str, dict, object, dict]:
    """A radar entry ``{"file": path, field: value or draw, ...}``: the radar of a ``.json`` or TI ``.cfg``
    file (relative to the spec's folder), with fields replaced or drawn per item."""
    raw = entry["file"]
    if not isinstance(raw, str) or not raw:
        raise SpecError(f"{where}: 'file' needs the path of a radar .json or TI .cfg file, got {raw!r}")
    path = Path(raw).expanduser()
    path = (path if path.is_absolute() else base / path).resolve()
    changes = {k: v for k, v in entry.items() if k != "file"}
    draws = {k: _radar_draw(k, v, where) for k, v in changes.items() if _is_draw(v)}
    fixed = {k: v for k, v in changes.items() if k not in draws}
    try:
        config = RadarConfig.resolve(path).to_dict()
        unknown = sorted(set(changes) - set(config) - {"ti_processing"})
        if unknown:
            raise RadarConfigError(f"unknown RadarConfig field(s) {', '.join(unknown)}")
        for k, d in draws.items():
            for v in d.support():
                RadarConfig.from_dict({**config, **fixed, k: v})
        first = RadarConfig.from_dict({**config, **fixed, **{k: d.support()[0] for k, d in draws.items()}})
    except RadarConfigError as exc:
        raise SpecError(f"{where}: {exc}") from exc
    label = path.name + ("(" + ",".join(f"{k}={_plain(changes[k])}" for k in sorted(changes)) + ")" if changes else "")
    canonical = {"file": str(path), **{k: (draws[k].to_json() if k in draws else _plain(v))
                                       for k, v in sorted(changes.items())}}
    return label, first.to_dict(), canonical, draws


def _radar_entry(entry, where: str, base: Path = Path(".")) -> tuple[str, dict, object, dict]:
    """``(name, RadarConfig dict, canonical entry, {field: Draw})`` of one radar entry (read by
    :meth:`RadarConfig.resolve`).

    A preset with changes keeps the preset's ``name`` unless ``name`` is one of the changes; its
    label lists the changes, e.g. ``walk-77ghz(num_chirps=64)``. Changes that are draws
    (:func:`_is_draw`) are drawn per item; every value they can give is checked here, and the
    returned dict holds their first.
    """
    if isinstance(entry, dict) and "file" in entry:
        return _radar_file_entry(entry, where, base)
    if isinstance(entry, str) and entry not in RadarConfig.presets():
        raise SpecError(f"{where}: unknown radar preset {entry!r}; choose one of "
                        f"{', '.join(RadarConfig.presets())}, or give a RadarConfig dict")
    if not isinstance(entry, (str, dict)):
        raise SpecError(f"{where} must be a preset name, a dict ({{'preset': name, field: value}} or a full RadarConfig "
                        f"dict) or a list of these, got {type(entry).__name__}")
    if isinstance(entry, dict) and "preset" in entry:
        name = entry["preset"]
        changes = {k: v for k, v in entry.items() if k != "preset"}
        draws = {k: _radar_draw(k, v, where) for k, v in changes.items() if _is_draw(v)}
        fixed = {k: v for k, v in entry.items() if k not in draws}
        try:
            for k, d in draws.items():      # every value a draw can give, as a radar
                for v in d.support():
                    RadarConfig.resolve({"name": name, **fixed, k: v} if isinstance(name, str) else {**fixed, k: v})
            first = {k: d.support()[0] for k, d in draws.items()}
            config = RadarConfig.resolve({"name": name, **fixed, **first} if isinstance(name, str) else
                                         {**fixed, **first})
        except RadarConfigError as exc:
            raise SpecError(f"{where}: {exc}") from exc
        label = name
        if changes:
            label += "(" + ",".join(f"{k}={_plain(changes[k])}" for k in sorted(changes)) + ")"
        canonical = {"preset": name, **{k: (draws[k].to_json() if k in draws else _plain(v))
                                        for k, v in sorted(changes.items())}}
        return label, config.to_dict(), canonical, draws
    try:
        config = RadarConfig.resolve(entry)
    except RadarConfigError as exc:
        raise SpecError(f"{where}: {exc}") from exc
    canonical = entry if isinstance(entry, str) else config.to_dict()
    return config.name, config.to_dict(), canonical, {}


def _files(pattern, base: Path, where: str) -> list[str]:
    """The sorted absolute paths of the files ``pattern`` (a glob or a folder, relative to ``base``) matches."""
    import glob

    if not isinstance(pattern, str) or not pattern:
        raise SpecError(f"{where}: 'files' needs a glob pattern or a folder (a string), got {pattern!r}")
    path = Path(pattern).expanduser()
    path = path if path.is_absolute() else base / path
    if path.is_dir():
        found = [p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")]
    else:
        found = [Path(p) for p in glob.glob(str(path)) if Path(p).is_file()]
    if not found:
        raise SpecError(f"{where}: {{'files': {pattern!r}}} matches no file (looked for {path}); give a folder of "
                        "files or a pattern such as clips/*.bvh")
    return sorted(str(p.resolve()) for p in found)


def _draw(scenario: str, key: str, param, raw, where: str, base: Path = Path(".")) -> Draw:
    """Parse one parameter entry into a :class:`Draw` and check every value it can give (``base``: the
    folder that relative ``files`` patterns start from)."""
    from ..scenes.registry import check_value

    if isinstance(raw, dict):
        if len(raw) != 1 or next(iter(raw)) not in ("value", "choice", "cycle", "uniform", "range", "files"):
            raise SpecError(f"{where}: a dict must have exactly one key among value, choice, cycle, uniform, range, "
                            f"files (e.g. {{'uniform': [0.5, 2.0]}}), got keys {sorted(raw)}")
        kind, args = next(iter(raw.items()))
        if kind == "files":
            if param.type is not str:
                raise SpecError(f"{where}: {{'files': pattern}} draws file paths but {key!r} has type "
                                f"{param.type_name}; use it for a string parameter (such as a clip)")
            kind, args = "choice", _files(args, base, where)
    elif isinstance(raw, (list, tuple)):
        if param.type is tuple and not any(isinstance(v, (list, tuple)) for v in raw):
            kind, args = "value", raw
        else:
            kind, args = "choice", raw
    else:
        kind, args = "value", raw

    if kind == "value":
        values = [args]
        draw_args = (args,)
    elif kind in ("choice", "cycle"):
        if not isinstance(args, (list, tuple)) or not args:
            raise SpecError(f"{where}: '{kind}' needs a non-empty list of values, got {args!r}")
        values = list(args)
        draw_args = tuple(values)
    elif kind == "uniform":
        if param.type is not float:
            raise SpecError(f"{where}: {{'uniform': [lo, hi]}} draws real numbers but {key!r} has type "
                            f"{param.type_name}; "
                            "use a list of values" + (" or {'range': [lo, hi, step]}" if param.type is int else ""))
        if (not isinstance(args, (list, tuple)) or len(args) != 2 or not all(_is_number(a) for a in args)):
            raise SpecError(f"{where}: 'uniform' needs [lo, hi] (two finite numbers), got {args!r}")
        lo, hi = float(args[0]), float(args[1])
        if not lo < hi:
            raise SpecError(f"{where}: 'uniform' needs lo < hi, got [{lo}, {hi}]; for a fixed value write {key}: {lo}")
        values = [lo, hi]
        draw_args = (lo, hi)
    else:  # range
        if param.type not in (int, float):
            raise SpecError(f"{where}: {{'range': [lo, hi, step]}} needs a numeric parameter, {key!r} has "
                            f"type {param.type_name}; use a list of values")
        if (not isinstance(args, (list, tuple)) or len(args) != 3 or not all(_is_number(a) for a in args)):
            raise SpecError(f"{where}: 'range' needs [lo, hi, step] (three finite numbers), got {args!r}")
        lo, hi, step = args
        if param.type is int and not all(isinstance(a, int) for a in args):
            raise SpecError(f"{where}: {key!r} has type int, so 'range' needs integer lo, hi and step, "
                            f"got {list(args)}")
        if step <= 0:
            raise SpecError(f"{where}: 'range' step must be > 0, got {step}")
        if hi < lo:
            raise SpecError(f"{where}: 'range' needs lo <= hi, got lo={lo} > hi={hi}")
        if (hi - lo) / step + 1 > MAX_GRID:
            raise SpecError(f"{where}: 'range' {list(args)} has more than {MAX_GRID} values; use a larger step "
                            "or {'uniform': [lo, hi]} for a float")
        draw_args = tuple(args)
        values = _grid(*draw_args)
        if len(values) > 64:  # check the ends and a few inside: the grid is monotonic
            values = values[:2] + values[-2:]
    checked = []
    for v in values:
        try:
            checked.append(check_value(scenario, key, param, v))
        except ValueError as exc:
            raise SpecError(f"{where}: {exc}") from None
    if kind == "value":
        draw_args = (checked[0],)
    elif kind in ("choice", "cycle"):
        draw_args = tuple(checked)
    return Draw(kind, draw_args)


def _vector3(value, where):
    if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(_is_number(v) for v in value):
        raise SpecError(f"{where} must be three finite numbers, got {value!r}")
    return [float(v) for v in value]


def load_spec(spec) -> DatasetSpec:
    """Read and validate a data-set spec (file path, dict or :class:`DatasetSpec`).

    Raises :class:`SpecError` naming the source, the field and the fix: missing or unknown fields,
    an unknown scenario or parameter, ill-typed or out-of-bounds values (the scenario's own
    :class:`~sionnafmcw.scenes.Parameter` bounds and choices), an empty or reversed range, an
    unknown radar preset or RadarConfig field, an unknown engine or engine option, ``count < 1``.
    """
    from .. import scenes
    from ..engines import names as engine_names

    data, source = _read(spec)
    where = f"data-set spec {source}"
    unknown = sorted(set(data) - set(FIELDS))
    if unknown:
        raise SpecError(f"{where}: unknown field(s) {', '.join(unknown)}; the fields are {', '.join(FIELDS)}")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise SpecError(f"{where}: missing field(s) {', '.join(missing)} (required: {', '.join(REQUIRED)})")

    name = data["name"]
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.\-]*", name):
        raise SpecError(f"{where}: name must be a non-empty string of letters, digits, '-', '_' or '.', got {name!r}")
    scenario = data["scenario"]
    if scenario not in scenes.names():
        raise SpecError(f"{where}: scenario {scenario!r} is unknown; choose one of {', '.join(scenes.names())}")
    count = data["count"]
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise SpecError(f"{where}: count must be an integer >= 1, got {count!r}")
    seed = data["seed"]
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SpecError(f"{where}: seed must be an integer >= 0, got {seed!r}")

    base = Path(source).resolve().parent if source != "<dict>" else Path.cwd()
    raw_radar = data["radar"]
    entries = raw_radar if isinstance(raw_radar, list) else [raw_radar]
    if not entries:
        raise SpecError(f"{where}: radar is an empty list; give a preset name, a dict or a non-empty list")
    radars, canon = [], []
    for k, entry in enumerate(entries):
        field_name = f"radar[{k}]" if isinstance(raw_radar, list) else "radar"
        label, config, entry_canon, radar_draws = _radar_entry(entry, f"{where}: {field_name}", base)
        radars.append((label, config, entry_canon, radar_draws))
        canon.append(entry_canon)

    engine = data.get("engine", "path")
    if engine not in engine_names():
        raise SpecError(f"{where}: engine {engine!r} is not available; choose one of {', '.join(engine_names())}")
    options = data.get("engine_options") or {}
    if not isinstance(options, dict):
        raise SpecError(f"{where}: engine_options must be a mapping of option: value, got {type(options).__name__}")
    _check_engine_options(engine, options, where)

    params_raw = data.get("parameters") or {}
    if not isinstance(params_raw, dict):
        raise SpecError(f"{where}: parameters must be a mapping of parameter: value/choices/distribution")
    declared = scenes.parameters(scenario)
    unknown = sorted(set(params_raw) - set(declared))
    if unknown:
        raise SpecError(f"{where}: scenario {scenario!r} has no parameter {', '.join(map(repr, unknown))}; "
                        f"its parameters: {', '.join(declared)}")
    draws = {key: _draw(scenario, key, declared[key], raw, f"{where}: parameters.{key}", base)
             for key, raw in params_raw.items()}
    if "fps" in declared:  # every radar's CPI must fit in the shortest frame period an item can draw
        fps = max(draws["fps"].support()) if "fps" in draws else declared["fps"].default
        for label, config, *_ in radars:
            try:
                RadarConfig.from_dict(config).validate(frame_period=1.0 / fps)
            except RadarConfigError as exc:
                raise SpecError(f"{where}: radar {label!r} with fps up to {fps:g}: {exc}") from None

    pose = data.get("radar_pose")
    if pose is not None:
        if not isinstance(pose, dict) or set(pose) != {"position", "orientation"}:
            raise SpecError(f"{where}: radar_pose must be {{'position': [x, y, z] (m), "
                            f"'orientation': [yaw, pitch, roll] (rad)}}, got {pose!r}")
        pose = {"position": _vector3(pose["position"], f"{where}: radar_pose.position"),
                "orientation": _vector3(pose["orientation"], f"{where}: radar_pose.orientation")}

    frames = data.get("frames")
    if frames is not None:
        if isinstance(frames, int) and not isinstance(frames, bool):
            if frames < 1:
                raise SpecError(f"{where}: frames must be >= 1 (the first N frames) or a list of frame indices, "
                                f"got {frames}")
            frames = list(range(frames))
        elif isinstance(frames, list) and frames and all(isinstance(f, int) and not isinstance(f, bool) and f >= 0
                                                          for f in frames):
            if len(set(frames)) != len(frames):
                raise SpecError(f"{where}: frames lists a frame twice: {frames}")
            frames = sorted(frames)
        else:
            raise SpecError(f"{where}: frames must be an integer N >= 1 (the first N frames) or a non-empty list of "
                            f"frame indices >= 0, got {frames!r}")
        n_param = params_raw.get("num_frames") if "num_frames" in draws else None
        if "num_frames" in declared:
            least = min(draws["num_frames"].support()) if "num_frames" in draws else declared["num_frames"].default
            if max(frames) >= least:
                raise SpecError(f"{where}: frames reach index {max(frames)} but an item can have only {least} frames "
                                f"(num_frames{' = ' + repr(n_param) if n_param is not None else ' default'}); "
                                "lower frames or raise num_frames")

    noise = data.get("noise", True)
    if not isinstance(noise, bool):
        raise SpecError(f"{where}: noise must be true or false, got {noise!r}")
    label_object = data.get("label_object")
    if label_object is not None and not isinstance(label_object, str):
        raise SpecError(f"{where}: label_object must be an object name (string), got {label_object!r}")

    return DatasetSpec(name=name, scenario=scenario, count=count, seed=seed, radars=radars, radar_entries=canon,
                       engine=engine, engine_options=dict(options), parameters=draws, radar_pose=pose, frames=frames,
                       noise=noise, label_object=label_object, source=source,
                       scenario_seed="seed" in declared and "seed" not in draws,
                       drawn_seeds=tuple(sorted(k for k, p in declared.items() if (k == "seed" or k.endswith("_seed"))
                                                and p.type is int and k not in draws)))


def _check_engine_options(engine: str, options: dict, where: str) -> None:
    """Option names against the engine's constructor (values are checked by the engine itself)."""
    import importlib
    import inspect

    classes = {"path": ("..engines.path", "PathEngine"), "pixel": ("..engines.pixel", "PixelEngine")}
    if engine not in classes:  # pragma: no cover - an engine added later is checked when it is built
        return
    module, name = classes[engine]
    cls = getattr(importlib.import_module(module, __package__), name)
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise SpecError(f"{where}: engine_options {', '.join(unknown)} are not options of the {engine!r} engine; "
                        f"its options: {', '.join(accepted)}")


__all__ = ["DatasetSpec", "Draw", "Item", "SpecError", "load_spec"]
