"""sionnafmcw: a physically grounded FMCW TDM-MIMO radar simulator on Sionna RT.

Pipeline (NOTES section 1): animation on disk -> engine (path or pixel) -> :class:`Echoes`
-> :func:`synthesize` (TDM-MIMO beat cube) -> run store -> :mod:`sionnafmcw.processing`.

Importing the package points ``DRJIT_LIBLLVM_PATH`` at a libLLVM >= 16 when it is unset
(Dr.Jit's LLVM backend crashes with libLLVM-15) and raises :class:`LLVMNotFoundError` with the
install command when there is none.
"""

from ._llvm import LLVMNotFoundError, configure_llvm

LIBLLVM_PATH = configure_llvm()

from .constants import BOLTZMANN, SPEED_OF_LIGHT, T0  # noqa: E402
from .echoes import Echoes  # noqa: E402
from .radar import RadarConfig, RadarConfigError  # noqa: E402
from .synthesis import synthesize  # noqa: E402
from . import plots, processing  # noqa: E402

__version__ = "0.1.0"

# Heavy parts (Sionna RT, Mitsuba, Zarr) load on first use.
_LAZY = {
    "simulate": ("simulation", "simulate"),
    "load_animation": ("animation", "load_animation"),
    "Animation": ("animation", "Animation"),
    "AnimationError": ("animation", "AnimationError"),
    "PathEngine": ("engines.path", "PathEngine"),
    "PixelEngine": ("engines.pixel", "PixelEngine"),
    "open_run": ("store", "open_run"),
}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attribute = _LAZY[name]
        value = getattr(importlib.import_module(f".{module}", __name__), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sionnafmcw' has no attribute {name!r}")


__all__ = [
    "BOLTZMANN",
    "Echoes",
    "LIBLLVM_PATH",
    "LLVMNotFoundError",
    "RadarConfig",
    "RadarConfigError",
    "SPEED_OF_LIGHT",
    "T0",
    "synthesize",
    "__version__",
    *_LAZY,
]
