"""Blender scenes -> animation directories, from the simulator's environment.

The exporter itself, :file:`sionnafmcw/blender/export.py`, runs inside Blender's Python (``bpy``
needs numpy < 2, the simulator numpy 2), so this module never imports ``bpy``: it runs the
exporter as a subprocess in

1. the Python interpreter given as ``python=`` (one that can ``import bpy``), or the Blender
   binary given as ``blender=``;
2. else ``$SIONNAFMCW_BLENDER_PYTHON`` (a Python with bpy) or ``$BLENDER`` (a Blender binary);
3. else the project's ``.venv-blender`` (``make .venv-blender/.installed`` or
   ``bash scripts/setup_blender.sh``: bpy 4.5 from PyPI);
4. else a ``blender`` binary on ``PATH``.

::

    from sionnafmcw.blender import export_blend
    from sionnafmcw import load_animation, simulate

    scene = export_blend("room.blend", "scenes/room", frames=(1, 48))
    simulate(load_animation(scene), "walk-77ghz", out="runs/room.zarr")

What is written (materials, velocities, the radar pose) is described in the docstring of the
exporter script, :func:`script_path`. The exporter imports the numpy-only writers of
:mod:`sionnafmcw.animation` and :mod:`sionnafmcw.fs` (from this checkout); :func:`addon_zip`
bundles them with it as a Blender add-on.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ERROR_MARKER = "sionnafmcw-export: error: "
REPO_ROOT = Path(__file__).resolve().parents[2]
BLENDER_VENV = REPO_ROOT / ".venv-blender"


class BlenderExportError(RuntimeError):
    """The exporter failed (or could not be started); the message is the exporter's own.

    ``returncode``, ``stdout`` and ``stderr`` hold the subprocess's exit status and output
    (None when it could not be started).
    """

    def __init__(self, message, returncode=None, stdout=None, stderr=None):
        super().__init__(message)
        self.returncode = returncode
        self.stdout = stdout
        self.stderr = stderr


def script_path() -> Path:
    """Path of the exporter script (``sionnafmcw/blender/export.py``), for ``blender -P`` or an add-on install."""
    return Path(__file__).resolve().with_name("export.py")


#: Name of the add-on package inside :func:`addon_zip`'s zip.
ADDON_NAME = "sionnafmcw_export"
#: Modules of ``sionnafmcw`` the exporter imports (numpy and the standard library only), bundled in the add-on.
ADDON_MODULES = ("__init__.py", "_llvm.py", "fs.py", "animation/*.py")


def addon_zip(path) -> Path:
    """Write the Blender add-on (Edit > Preferences > Add-ons > Install from disk) to the zip ``path``.

    The zip holds the package ``sionnafmcw_export``: the exporter script as its ``__init__.py``
    and, under ``sionnafmcw_export/sionnafmcw/``, the modules it imports (:data:`ADDON_MODULES`),
    so the installed add-on needs nothing but Blender. Returns ``path``.
    """
    path = Path(path)
    package = Path(__file__).resolve().parents[1]
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.write(script_path(), f"{ADDON_NAME}/__init__.py")
        for pattern in ADDON_MODULES:
            for file in sorted(package.glob(pattern)):
                zf.write(file, f"{ADDON_NAME}/sionnafmcw/{file.relative_to(package).as_posix()}")
    return path


def _venv_python(venv: Path) -> Path:
    return venv / ("Scripts/python.exe" if sys.platform == "win32" else "bin/python")


def find_runner(python=None, blender=None) -> tuple[str, str]:
    """``("python" | "blender", executable)`` that will run the exporter (see the module docstring)."""
    if python is not None:
        return "python", str(python)
    if blender is not None:
        return "blender", str(blender)
    if os.environ.get("SIONNAFMCW_BLENDER_PYTHON"):
        return "python", os.environ["SIONNAFMCW_BLENDER_PYTHON"]
    if os.environ.get("BLENDER"):
        return "blender", os.environ["BLENDER"]
    venv_python = _venv_python(BLENDER_VENV)
    if venv_python.exists():
        return "python", str(venv_python)
    found = shutil.which("blender")
    if found:
        return "blender", found
    raise BlenderExportError(
        f"no Blender to run the exporter: {venv_python} does not exist and there is no 'blender' on PATH. "
        "Create the bpy environment with 'make .venv-blender/.installed' (or 'bash scripts/setup_blender.sh'), "
        "install Blender, or pass python= (a Python with bpy) / blender= (a Blender binary)"
    )


def _frames_arg(frames) -> str | None:
    if frames is None:
        return None
    if isinstance(frames, str):
        return frames
    if isinstance(frames, int):
        return f"{frames}:{frames}"
    start, end = frames
    return f"{'' if start is None else int(start)}:{'' if end is None else int(end)}"


def export_command(blend_file, out, frames=None, python=None, blender=None, radar=None,
                   velocity_step=None) -> list[str]:
    """The command line :func:`export_blend` runs."""
    kind, exe = find_runner(python, blender)
    opts = [str(Path(out))]
    if frames is not None:
        opts += ["--frames", _frames_arg(frames)]
    if radar is not None:
        opts += ["--radar", str(radar)]
    if velocity_step is not None:
        opts += ["--velocity-step", repr(float(velocity_step))]
    script = str(script_path())
    if kind == "python":
        return [exe, script, str(blend_file)] + opts
    return [exe, "-b", "--factory-startup", str(blend_file), "--python-exit-code", "1", "-P", script, "--"] + opts


def export_blend(blend_file, out, frames=None, python=None, blender=None, radar=None, velocity_step=None,
                 timeout: float | None = None) -> Path:
    """Export ``blend_file`` to the animation directory ``out`` with Blender in a subprocess; returns ``out``.

    Parameters
    ----------
    blend_file : path of the ``.blend`` file
    out : output directory (written atomically: a failed export leaves nothing half-written)
    frames : ``(start, end)`` Blender frames, both included, or ``"A:B"``; default the scene's range
    python : a Python interpreter that can ``import bpy`` (default: see the module docstring)
    blender : a Blender binary (used with ``-b -P``) instead of a Python with bpy
    radar : name of the radar object (default ``radar``, else the scene camera)
    velocity_step : central-difference half-width in frames (default 0.5)
    timeout : seconds before the export is abandoned

    Raises
    ------
    BlenderExportError
        With the exporter's message (e.g. which object has an unmapped material) when it fails.
    """
    blend_file = Path(blend_file)
    if not blend_file.is_file():
        raise BlenderExportError(f"{blend_file}: no such .blend file")
    out = Path(out).resolve()
    cmd = export_command(blend_file.resolve(), out, frames, python, blender, radar, velocity_step)
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
    except FileNotFoundError as err:
        raise BlenderExportError(f"cannot run the exporter with {cmd[0]!r}: {err.strerror or err}") from None
    except subprocess.TimeoutExpired as err:
        raise BlenderExportError(f"the Blender export of {blend_file} took longer than {timeout} s",
                                 stdout=err.stdout, stderr=err.stderr) from None
    messages = [line[len(ERROR_MARKER):].strip() for line in (proc.stderr or "").splitlines()
                if line.startswith(ERROR_MARKER)]
    if proc.returncode != 0 or messages:
        if messages:
            text = "; ".join(messages)
        else:
            tail = "\n".join(((proc.stderr or "") + (proc.stdout or "")).strip().splitlines()[-20:])
            text = f"the exporter exited with status {proc.returncode}:\n{tail}"
        raise BlenderExportError(f"{blend_file}: {text}", proc.returncode, proc.stdout, proc.stderr)
    if not (out / "animation.json").is_file():
        raise BlenderExportError(f"{blend_file}: the exporter finished but wrote no {out / 'animation.json'}",
                                 proc.returncode, proc.stdout, proc.stderr)
    return out


__all__ = ["ADDON_NAME", "BLENDER_VENV", "BlenderExportError", "addon_zip", "export_blend", "export_command",
           "find_runner", "script_path"]
