"""Shared steps of the validation experiments: scenes, runs and the metrics file.

The ground truth the experiments compare with is read from the run store by
:class:`sionnafmcw.store.Run` (``run.truth(obj)``, ``run.truth_at_cpi_centre(obj)``,
``run.phase_centre``), whose docstrings carry the maths.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np


def build_scene(name: str, out: Path, params: dict | None = None, rebuild: bool = False) -> Path:
    """Build scenario ``name`` into ``out`` unless the same scenario with the same parameters is there."""
    from .. import scenes

    out = Path(out)
    params = dict(params or {})
    manifest = out / "animation.json"
    if manifest.exists() and not rebuild:
        try:
            recorded = json.loads(manifest.read_text()).get("scenario", {})
        except (OSError, ValueError):
            recorded = {}
        wanted = {k: v for k, v in params.items()}
        have = recorded.get("parameters", {}) if recorded.get("name") == name else None
        if have is not None and all(_same(have.get(k), v) for k, v in wanted.items()):
            return out
    return scenes.build(name, out, overwrite=True, **params)


def _same(a, b) -> bool:
    try:
        return bool(np.allclose(np.asarray(a, float), np.asarray(b, float)))
    except (TypeError, ValueError):
        return a == b


def run_engine(animation, radar, engine, out: Path, engine_options: dict | None = None, frames=None,
               seed: int = 0, noise: bool = True, progress: bool = True, fresh: bool = True):
    """``simulate`` with ``engine`` (a name or an engine object) into ``out`` (a fresh store unless
    ``fresh=False``); returns (:class:`~sionnafmcw.store.Run`, seconds)."""
    import shutil

    from ..simulation import simulate

    out = Path(out)
    if fresh and out.exists():
        shutil.rmtree(out)
    t0 = time.perf_counter()
    run = simulate(animation, radar, engine=engine, out=out, frames=frames, progress=progress, seed=seed,
                   noise=noise, engine_options=engine_options)
    return run, time.perf_counter() - t0


def write_metrics(out: Path, metrics: dict) -> None:
    """``metrics.json`` in ``out`` and the same JSON on stdout as the last line."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(metrics, default=_json_default)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=1, default=_json_default))
    print(text, flush=True)


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
