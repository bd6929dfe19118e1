"""sionnafmcw: a physically grounded FMCW TDM-MIMO radar simulator on Sionna RT.

Pipeline: animation directory on disk (:mod:`sionnafmcw.animation`) -> engine
(:mod:`sionnafmcw.engines`: path or pixel) -> :class:`Echoes` -> :func:`synthesize` (the
TDM-MIMO beat cube) -> run store (:mod:`sionnafmcw.store`) -> :mod:`sionnafmcw.processing` ->
:mod:`sionnafmcw.plots`; :func:`simulate` runs the chain.

Importing the package imports nothing heavy: every name below and every subpackage
(``sf.scenes``, ``sf.dataset``, ``sf.validation``, ``sf.tf``, ``sf.processing``, ``sf.plots``,
``sf.engines``, ``sf.ti``, ...) is loaded on first use, so ``import sionnafmcw.animation`` works
in an environment without Sionna, Dr.Jit or finufft (the Blender exporter's). It only points
``DRJIT_LIBLLVM_PATH`` at a libLLVM >= 16 when the variable is unset (Dr.Jit's LLVM backend
crashes with libLLVM-15, and Dr.Jit reads the variable once, when it is first imported);
:data:`LIBLLVM_PATH` is that library, or None when there is none, in which case
:class:`LLVMNotFoundError`, with the install command, is raised when Dr.Jit is needed
(:mod:`sionnafmcw.sionna_rt`).
"""

from __future__ import annotations

import importlib

from ._llvm import LLVMNotFoundError, configure_llvm

try:
    LIBLLVM_PATH = configure_llvm()
except LLVMNotFoundError:  # raised again, with the install command, where Dr.Jit is imported
    LIBLLVM_PATH = None

__version__ = "0.1.0"

#: Names reachable as ``sionnafmcw.<name>``: {name: (module, attribute)}, imported on first use.
_LAZY = {
    "BOLTZMANN": ("constants", "BOLTZMANN"),
    "SPEED_OF_LIGHT": ("constants", "SPEED_OF_LIGHT"),
    "T0": ("constants", "T0"),
    "Echoes": ("echoes", "Echoes"),
    "RadarConfig": ("radar", "RadarConfig"),
    "RadarConfigError": ("radar", "RadarConfigError"),
    "synthesize": ("synthesis", "synthesize"),
    "simulate": ("simulation", "simulate"),
    "load_animation": ("animation", "load_animation"),
    "Animation": ("animation", "Animation"),
    "AnimationError": ("animation", "AnimationError"),
    "PathEngine": ("engines.path", "PathEngine"),
    "PixelEngine": ("engines.pixel", "PixelEngine"),
    "open_run": ("store", "open_run"),
}

#: Subpackages and modules reachable as ``sionnafmcw.<name>``, imported on first use.
_SUBMODULES = (
    "animation", "array", "blender", "cli", "constants", "dataset", "echoes", "engines", "fs", "geometry",
    "materials", "plots", "processing", "radar", "scenes", "simulation", "sionna_rt", "store", "synthesis", "tf", "ti", "torch",
    "validation",
)


def __getattr__(name):
    if name in _LAZY:
        module, attribute = _LAZY[name]
        value = getattr(importlib.import_module(f".{module}", __name__), attribute)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'sionnafmcw' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | set(_SUBMODULES))


__all__ = ["LIBLLVM_PATH", "LLVMNotFoundError", "__version__", *_LAZY]
