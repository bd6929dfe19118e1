r"""The scenario registry: names, typed parameters, and an atomic ``build``.

A scenario is a function ``builder(out: Path, **params) -> None`` that writes an animation
directory (layout: :mod:`sionnafmcw.animation`) into ``out`` (an empty directory it may fill), registered with its
parameters::

    @register("moving_plate", "A metal plate moving along the radar's line of sight.", {
        "speed": Parameter(1.0, float, "m/s", "radial speed, + receding"), ...})
    def moving_plate(out, speed, ...): ...

:func:`build` checks the parameters (unknown name or ill-typed value -> :class:`ValueError` that
names it and lists the valid ones), fills in the defaults, writes into a temporary sibling of
``out`` and renames it to ``out`` at the end (:func:`sionnafmcw.fs.atomic_directory`), so an
interrupted build never leaves a half-written directory at ``out``. It then records ``{"name", "parameters"}`` under the
``"scenario"`` key of ``animation.json`` (the loader ignores keys it does not know).

Parameter types are ``int``, ``float``, ``bool``, ``str`` and ``tuple`` (a tuple of floats, e.g.
the ranges of several reflectors). :func:`parse_value` turns command-line text into a value of
the parameter's type (``"3,4.5"`` for a tuple, ``true/false/1/0/yes/no`` for a bool), so a
command line can take ``--param speed=1.5``. ``low``/``high`` (inclusive bounds, for ``int``,
``float`` and every element of a ``tuple``) and ``choices`` (for ``str``) are checked by
:func:`build` and give a data-set generator its sampling range.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..fs import atomic_directory

TYPES = (int, float, bool, str, tuple)
_TYPE_NAMES = {int: "int", float: "float", bool: "bool", str: "str", tuple: "tuple of floats"}


@dataclass(frozen=True)
class Parameter:
    """One scenario parameter: ``default`` value, ``type`` (int, float, bool, str or tuple of
    floats), SI ``unit`` (``""`` when dimensionless), ``doc``; optional inclusive bounds ``low``,
    ``high`` and allowed ``choices``."""

    default: object
    type: type
    unit: str
    doc: str
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None

    def __post_init__(self):
        if self.type not in TYPES:
            raise TypeError(f"Parameter type must be one of {[_TYPE_NAMES[t] for t in TYPES]}, got {self.type!r}")

    @property
    def type_name(self) -> str:
        return _TYPE_NAMES[self.type]

    def describe(self) -> str:
        unit = f" [{self.unit}]" if self.unit else ""
        bounds = ""
        if self.low is not None or self.high is not None:
            bounds = f", range {self.low if self.low is not None else '-inf'}..{self.high if self.high is not None else 'inf'}"
        if self.choices:
            bounds = f", one of {', '.join(map(str, self.choices))}"
        return f"{self.type_name}{unit}, default {self.default!r}{bounds}: {self.doc}"


@dataclass(frozen=True)
class Scenario:
    name: str
    builder: Callable
    parameters: dict
    doc: str
    details: str = ""


_REGISTRY: dict[str, Scenario] = {}


def register(name: str, doc: str, parameters: dict, details: str = ""):
    """Decorator: register ``builder(out, **params)`` as scenario ``name``."""
    for key, p in parameters.items():
        if not isinstance(p, Parameter):
            raise TypeError(f"scenario {name!r}: parameter {key!r} must be a Parameter")
        # the default must pass the scenario's own checks
        check_value(name, key, p, p.default)

    def decorate(builder):
        if name in _REGISTRY and _REGISTRY[name].builder is not builder:
            raise ValueError(f"scenario {name!r} is registered twice")
        _REGISTRY[name] = Scenario(name, builder, dict(parameters), doc, details or (builder.__doc__ or ""))
        return builder

    return decorate


def _scenario(name) -> Scenario:
    if not isinstance(name, str) or name not in _REGISTRY:
        raise ValueError(f"unknown scenario {name!r}; valid scenarios: {', '.join(sorted(_REGISTRY))}")
    return _REGISTRY[name]


def names() -> list[str]:
    """Names of the registered scenarios, sorted."""
    return sorted(_REGISTRY)


def parameters(name: str) -> dict:
    """``{parameter name: Parameter(default, type, unit, doc, ...)}`` of scenario ``name``."""
    return dict(_scenario(name).parameters)


def describe(name: str) -> str:
    """A human-readable description of scenario ``name`` and its parameters."""
    sc = _scenario(name)
    lines = [f"{sc.name}: {sc.doc}", "", "parameters:"]
    width = max((len(k) for k in sc.parameters), default=0)
    for key, p in sc.parameters.items():
        lines.append(f"  {key:<{width}}  {p.describe()}")
    return "\n".join(lines)


def _bad(scenario, key, p, value, why) -> ValueError:
    return ValueError(f"scenario {scenario!r}: parameter {key!r}={value!r} {why} (expected {p.describe()})")


def check_value(scenario: str, key: str, p: Parameter, value):
    """``value`` converted to ``p``'s type (int -> float, list -> tuple), or :class:`ValueError`."""
    if p.type is bool:
        if not isinstance(value, bool):
            raise _bad(scenario, key, p, value, "is not a bool")
        return value
    if p.type is str:
        if not isinstance(value, str):
            raise _bad(scenario, key, p, value, "is not a string")
        if p.choices and value not in p.choices:
            raise _bad(scenario, key, p, value, "is not an allowed choice")
        return value
    if p.type is int:
        if isinstance(value, bool) or not isinstance(value, int):
            # accept integral numpy integers, refuse floats (3.0 is almost always a mistake)
            if type(value).__name__.startswith("int") and hasattr(value, "item"):
                value = int(value)
            else:
                raise _bad(scenario, key, p, value, "is not an integer")
        _check_bounds(scenario, key, p, value, value)
        return int(value)
    if p.type is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
            raise _bad(scenario, key, p, value, "is not a number")
        return _finite_number(scenario, key, p, value, value, ("is not a number", "is not finite"))
    # tuple of floats
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise _bad(scenario, key, p, value, "is not a sequence of numbers")
    out = []
    for v in value:
        if isinstance(v, bool):
            raise _bad(scenario, key, p, value, "holds a bool")
        out.append(_finite_number(scenario, key, p, value, v,
                                  ("holds a value that is not a number", "holds a non-finite value")))
    return tuple(out)


def _finite_number(scenario, key, p, value, v, problems) -> float:
    """``float(v)``, finite and within ``p``'s bounds; ``problems`` = (not a number, not finite) messages."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise _bad(scenario, key, p, value, problems[0]) from None
    if not math.isfinite(x):
        raise _bad(scenario, key, p, value, problems[1])
    _check_bounds(scenario, key, p, value, x)
    return x


def _check_bounds(scenario, key, p, value, x):
    if (p.low is not None and x < p.low) or (p.high is not None and x > p.high):
        raise _bad(scenario, key, p, value, "is out of range")


def parse_value(name: str, key: str, text: str):
    """Command-line text for parameter ``key`` of scenario ``name`` as a checked value."""
    params = _scenario(name).parameters
    if key not in params:
        raise ValueError(f"scenario {name!r} has no parameter {key!r}; valid parameters: {', '.join(params) or 'none'}")
    p = params[key]
    text = text.strip()
    try:
        if p.type is bool:
            low = text.lower()
            if low in ("1", "true", "yes", "on"):
                value = True
            elif low in ("0", "false", "no", "off"):
                value = False
            else:
                raise ValueError
        elif p.type is int:
            value = int(text)
        elif p.type is float:
            value = float(text)
        elif p.type is str:
            value = text
        else:
            value = tuple(float(x) for x in text.strip("()[] ").replace(";", ",").split(",") if x.strip())
    except ValueError:
        raise _bad(name, key, p, text, "cannot be parsed") from None
    return check_value(name, key, p, value)


def parse_params(name: str, items) -> dict:
    """``["k=v", ...]`` (``--param k=v`` of a command line) as a checked parameter dict."""
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"scenario parameter {item!r} must be written key=value")
        key, text = item.split("=", 1)
        out[key.strip()] = parse_value(name, key.strip(), text)
    return out


def resolve(name: str, params: dict) -> dict:
    """All parameters of scenario ``name``: the defaults updated with ``params`` (checked)."""
    sc = _scenario(name)
    unknown = [k for k in params if k not in sc.parameters]
    if unknown:
        raise ValueError(f"scenario {name!r} has no parameter {', '.join(map(repr, unknown))}; "
                         f"valid parameters: {', '.join(sc.parameters) or 'none'}")
    return {k: check_value(name, k, p, params.get(k, p.default)) for k, p in sc.parameters.items()}


def _jsonable(v):
    return list(v) if isinstance(v, tuple) else v


def build(name: str, out, overwrite: bool = False, **params) -> Path:
    """Write scenario ``name`` as an animation directory at ``out``; returns ``out`` as a Path.

    Refuses (:class:`FileExistsError`) an ``out`` that exists and is not an empty directory unless
    ``overwrite=True``. Unknown scenario, unknown or ill-typed parameter: :class:`ValueError`
    naming it and listing the valid ones. The scenario is written into a temporary sibling
    directory and renamed to ``out`` only when complete.
    """
    sc = _scenario(name)
    values = resolve(name, params)
    out = Path(out)
    if out.exists() and not overwrite:
        if not out.is_dir() or any(out.iterdir()):
            raise FileExistsError(f"{out} exists and is not empty; pass overwrite=True to replace it")
    with atomic_directory(out, replace=overwrite) as tmp:
        sc.builder(tmp, **values)
        manifest_path = tmp / "animation.json"
        manifest = json.loads(manifest_path.read_text())
        manifest["scenario"] = {"name": name, "parameters": {k: _jsonable(v) for k, v in values.items()}}
        manifest_path.write_text(json.dumps(manifest, indent=1))
    return out


__all__ = ["Parameter", "Scenario", "build", "check_value", "describe", "names", "parameters", "parse_params",
           "parse_value", "register", "resolve"]
