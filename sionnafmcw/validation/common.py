r"""Shared steps of the validation experiments: scenes, runs, ground truth at the CPI centre.

Ground truth at the CPI centre
------------------------------
A CPI of frame :math:`n` spans :math:`[t_n, t_n + LMT_c]`; the slow-time phase of a target whose
range rate changes during the CPI is, to first order, that of its mean range rate, which for a
constant acceleration is the range rate at the CPI centre :math:`t_c = t_n + LMT_c/2`. The run
store holds position :math:`\mathbf p_n` and velocity :math:`\mathbf v_n` at :math:`t_n`. With
the acceleration :math:`\mathbf a_n` from central differences of the stored velocities, and
:math:`\Delta = t_c - t_n`,

.. math::
    \mathbf p_c = \mathbf p_n + \mathbf v_n\Delta + \tfrac12\mathbf a_n\Delta^2, \qquad
    \mathbf v_c = \mathbf v_n + \mathbf a_n\Delta, \qquad
    \dot R_c = \mathbf v_c\cdot\frac{\mathbf p_c - \mathbf c}{\lVert\mathbf p_c - \mathbf c\rVert},

with :math:`\mathbf c` the radar's phase centre. The residual is of the order of the jerk:
:math:`|\dddot{\mathbf p}|\Delta^2/2 = (v^3/r^2)\Delta^2/2 \approx 1` mm/s for the paper's circle
walk (4.52 m/s on a 3 m circle, :math:`\Delta` = 13.4 ms), while using :math:`\dot R(t_n)` instead
would be wrong by up to :math:`(v^2/r)\Delta \approx 0.09` m/s, most of the paper's-style error
budget of the path engine.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..geometry import phase_centre


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
    ``fresh=False``); returns (dataset, seconds)."""
    import shutil

    from ..simulation import simulate

    out = Path(out)
    if fresh and out.exists():
        shutil.rmtree(out)
    t0 = time.perf_counter()
    ds = simulate(animation, radar, engine=engine, out=out, frames=frames, progress=progress, seed=seed,
                  noise=noise, engine_options=engine_options)
    return ds, time.perf_counter() - t0


def truth_at_cpi_centre(ds, radar, obj: str, radar_pose=None) -> np.ndarray:
    """Radial velocity of ``obj`` at every CPI centre ``[frame]`` (see the module docstring).

    ``ds``: a run store opened with :func:`~sionnafmcw.open_run`.
    """
    names = [str(n) for n in ds["object"].values]
    if obj not in names:
        raise ValueError(f"object {obj!r} is not in the run's truth; it has {', '.join(names)}")
    k = names.index(obj)
    t = np.asarray(ds["frame_time"].values, float)
    p = np.asarray(ds["truth_position"].values[:, k, :], float)
    v = np.asarray(ds["truth_velocity"].values[:, k, :], float)
    a = np.gradient(v, t, axis=0) if t.size > 1 else np.zeros_like(v)
    if radar_pose is None:
        pose = ds.attrs["radar_pose"]
        position, orientation = np.asarray(pose["position"], float), np.asarray(pose["orientation"], float)
    else:
        position, orientation = radar_pose.position, radar_pose.orientation
    centre = phase_centre(radar, position, orientation)
    dt = radar.cpi_duration / 2.0
    pc = p + v * dt + 0.5 * a * dt**2
    vc = v + a * dt
    los = pc - centre
    return np.sum(vc * los, axis=-1) / np.linalg.norm(los, axis=-1)


def phase_centre_of(ds, radar) -> np.ndarray:
    """World position of the radar's phase centre in a run store (its ``radar_pose`` attribute)."""
    pose = ds.attrs["radar_pose"]
    return phase_centre(radar, np.asarray(pose["position"], float), np.asarray(pose["orientation"], float))


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
