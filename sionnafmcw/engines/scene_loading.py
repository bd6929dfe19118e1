"""Loading an animation frame as a Sionna scene at the radar's carrier (shared by both engines).

Sionna builds every ITU material while the XML is parsed and evaluates it at the scene's
*default* frequency (3.5 GHz, ``sionna.rt.scene.DEFAULT_FREQUENCY``) before the caller can set
its own. Materials that ITU-R P.2040 defines only at millimetre waves (``floorboard`` is given for
50-100 GHz) then fail to load ("not defined for this frequency") although they are valid at
77 GHz. :func:`load_radar_scene` therefore sets that default to the carrier for the duration of
the load (restored afterwards, also on error), then attaches the custom materials (skin) and
checks every material at the carrier.
"""

from __future__ import annotations

import threading
from pathlib import Path

from .._llvm import configure_llvm

configure_llvm()

import mitsuba as mi  # noqa: E402
import sionna.rt.scene as _sionna_scene  # noqa: E402
from sionna.rt import load_scene  # noqa: E402

from ..materials import apply_custom_materials, check_scene_materials  # noqa: E402

_LOAD_LOCK = threading.Lock()


class SceneLoadError(ValueError):
    """Sionna could not load a frame's scene XML (the message names the file)."""


def load_radar_scene(xml, frequency: float):
    """Load ``xml`` with ``merge_shapes=False`` as a Sionna scene evaluated at ``frequency`` (Hz).

    Moving meshes stay separate objects (no merging), skin and other custom materials are attached
    (:func:`~sionnafmcw.materials.apply_custom_materials`) and every material is checked at
    ``frequency``. Raises :class:`SceneLoadError` naming the file when Sionna refuses it.
    """
    xml = Path(xml)
    old_level = mi.log_level()
    with _LOAD_LOCK:
        old_default = _sionna_scene.DEFAULT_FREQUENCY
        _sionna_scene.DEFAULT_FREQUENCY = float(frequency)
        mi.set_log_level(mi.LogLevel.Error)  # PLY vx/vy/vz properties make Mitsuba warn
        try:
            scene = load_scene(str(xml), merge_shapes=False)
        except Exception as err:  # noqa: BLE001
            raise SceneLoadError(f"{xml}: Sionna could not load the scene: {err}") from err
        finally:
            _sionna_scene.DEFAULT_FREQUENCY = old_default
            mi.set_log_level(old_level)
    apply_custom_materials(scene)
    check_scene_materials(scene, frequency)
    scene.frequency = frequency
    return scene


__all__ = ["SceneLoadError", "load_radar_scene"]
