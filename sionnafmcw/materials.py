r"""Radio materials for radar scenes: human skin, and a carrier-frequency check of ITU materials.

Skin
----
Sionna RT ships no material for people. Skin is modelled with the four-term Cole-Cole
parametric model of

    S. Gabriel, R. W. Lau, C. Gabriel, "The dielectric properties of biological tissues: III.
    Parametric models for the dielectric spectrum of tissues", Phys. Med. Biol. 41 (1996)
    2271-2293, Table 1 (the model the IT'IS tissue database uses, valid 10 Hz - 100 GHz):

.. math::
    \hat\varepsilon(\omega) = \varepsilon_\infty + \sum_{n=1}^{4}
        \frac{\Delta\varepsilon_n}{1 + (j\omega\tau_n)^{1-\alpha_n}} + \frac{\sigma_i}{j\omega\varepsilon_0}
    = \varepsilon' - j\,\frac{\sigma}{\omega\varepsilon_0}

============  =====  ===== ======== ====== ====== ======== ====== ====== ====== ====== ======= ======
tissue        e_inf  de1   tau1     a1     de2    tau2     a2     sig_i  de3    tau3   de4     tau4
============  =====  ===== ======== ====== ====== ======== ====== ====== ====== ====== ======= ======
skin (dry)    4.0    32.0  7.23 ps  0.00   1100   32.48 ns 0.20   0.0002 0      --     0       --
skin (wet)    4.0    39.0  7.96 ps  0.10   280    79.58 ns 0.00   0.0004 3e4    1.59us 3e4     1.592ms
============  =====  ===== ======== ====== ====== ======== ====== ====== ====== ====== ======= ======

(:math:`\alpha_3 = 0.16, \alpha_4 = 0.20` for wet skin.) At 77 GHz this gives

* dry skin (``"skin"``, Gabriel's "Skin (Dry)", the IT'IS "Skin" entry):
  :math:`\hat\varepsilon = 6.57 - j8.92`, i.e. :math:`\varepsilon' = 6.57`, :math:`\sigma = 38.2` S/m
  (at 60 GHz the same model gives the widely quoted :math:`7.98 - j10.9`);
* wet skin (``"skin_wet"``): :math:`\varepsilon' = 8.54`, :math:`\sigma = 43.0` S/m.

Gabriel's fit rests on measurements up to 20 GHz and is an extrapolation at 77 GHz; millimetre-wave
measurements (e.g. Alekseev & Ziskin, Bioelectromagnetics 28 (2007) 331, in vivo 37-74 GHz;
Sasaki et al. 2014, in vitro 0.5-110 GHz) scatter by some tens of percent with body site,
hydration and temperature. The normal-incidence power reflectivity at 77 GHz is 0.34 (-4.7 dB)
for dry skin, so a person reflects about a third of the power a metal body of the same shape
would. The penetration depth (about 0.4 mm) is far below any body dimension, so the default slab
thickness (0.1 m) makes the slab a half-space.

Use it from a scene XML with the plugin this module registers::

    <bsdf type="skin-radio-material" id="mat-skin"/>                      <!-- dry skin -->
    <bsdf type="skin-radio-material" id="mat-skin-wet">
        <string name="tissue" value="wet"/>
    </bsdf>

or, for XML that must also load where this module is not imported, as a Sionna
``radio-material`` placeholder whose id names a known custom material (``skin``, ``skin_dry``,
``skin_wet``, optionally prefixed ``mat-``)::

    <bsdf type="radio-material" id="mat-skin"/>

:func:`apply_custom_materials` then attaches the Cole-Cole model to it after loading (the path
engine does this). The permittivity follows the scene frequency in both cases.

ITU materials and the carrier
-----------------------------
Sionna's ITU-R P.2040 table defines every material only inside some frequency ranges (brick: 1-40
and 110-330 GHz; marble: 1-60, 100-400 GHz...). :func:`check_itu_frequency` raises a
:class:`MaterialFrequencyError` naming the material and its valid ranges when the carrier is
outside them; :func:`check_scene_materials` applies it to every ITU material of a loaded scene.
At 77 GHz the valid ITU materials are: concrete, plasterboard, wood, glass, ceiling_board,
chipboard, floorboard, metal (and vacuum).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constants import VACUUM_PERMITTIVITY
from .sionna_rt import DEFAULT_THICKNESS, ITU_MATERIALS_PROPERTIES, ITURadioMaterial, RadioMaterial, mi

class MaterialError(ValueError):
    """A radio material that cannot be used; the message names it."""


class MaterialFrequencyError(MaterialError):
    """A material whose model is not defined at the requested frequency."""


# ---------------------------------------------------------------------------------- Cole-Cole
@dataclass(frozen=True)
class ColeColeTissue:
    """Four-term Cole-Cole parameters of Gabriel et al. (1996), Table 1 (SI units)."""

    name: str
    eps_inf: float
    delta: tuple
    tau: tuple
    alpha: tuple
    sigma_ionic: float
    min_frequency: float = 10.0
    max_frequency: float = 100e9

    def permittivity(self, frequency) -> np.ndarray:
        r"""Complex relative permittivity :math:`\varepsilon' - j\varepsilon''` at ``frequency`` (Hz)."""
        f = np.asarray(frequency, dtype=float)
        w = 2.0 * np.pi * f
        eps = np.full(f.shape, self.eps_inf, dtype=complex)
        for de, tau, alpha in zip(self.delta, self.tau, self.alpha):
            if de != 0.0:
                eps = eps + de / (1.0 + (1j * w * tau) ** (1.0 - alpha))
        return eps + self.sigma_ionic / (1j * w * VACUUM_PERMITTIVITY)

    def properties(self, frequency: float) -> tuple[float, float]:
        """``(relative_permittivity, conductivity)`` as Sionna wants them (real part, S/m)."""
        frequency = float(frequency)
        if not (self.min_frequency <= frequency <= self.max_frequency):
            raise MaterialFrequencyError(
                f"radio material {self.name!r}: the Gabriel (1996) Cole-Cole model is defined for "
                f"{self.min_frequency:g} Hz - {self.max_frequency / 1e9:g} GHz, not at {frequency / 1e9:g} GHz"
            )
        eps = complex(self.permittivity(frequency))
        sigma = -eps.imag * 2.0 * np.pi * frequency * VACUUM_PERMITTIVITY
        return eps.real, sigma


SKIN_DRY = ColeColeTissue(
    name="skin", eps_inf=4.0,
    delta=(32.0, 1100.0, 0.0, 0.0),
    tau=(7.23e-12, 32.48e-9, 159.15e-6, 15.915e-3),
    alpha=(0.00, 0.20, 0.20, 0.20),
    sigma_ionic=0.0002,
)
SKIN_WET = ColeColeTissue(
    name="skin_wet", eps_inf=4.0,
    delta=(39.0, 280.0, 3.0e4, 3.0e4),
    tau=(7.96e-12, 79.58e-9, 1.59e-6, 1.592e-3),
    alpha=(0.10, 0.00, 0.16, 0.20),
    sigma_ionic=0.0004,
)

#: Custom materials known by name (XML ids with or without the ``mat-`` prefix).
CUSTOM_MATERIALS = {"skin": SKIN_DRY, "skin_dry": SKIN_DRY, "skin_wet": SKIN_WET}
_TISSUES = {"dry": SKIN_DRY, "wet": SKIN_WET}


def skin_properties(frequency: float, tissue: str = "dry") -> tuple[float, float]:
    """Relative permittivity (real part) and conductivity (S/m) of skin at ``frequency`` (Hz).

    ``tissue`` is ``"dry"`` (Gabriel's "Skin (Dry)", the default) or ``"wet"``.
    """
    if tissue not in _TISSUES:
        raise MaterialError(f"skin tissue {tissue!r} is unknown; choose one of {', '.join(_TISSUES)}")
    return _TISSUES[tissue].properties(frequency)


def _custom_name(bsdf_id: str | None) -> str | None:
    if not bsdf_id:
        return None
    name = bsdf_id[4:] if bsdf_id.startswith("mat-") else bsdf_id
    name = name.replace("-", "_")
    return name if name in CUSTOM_MATERIALS else None


class SkinRadioMaterial(RadioMaterial):
    """Sionna radio material for human skin, following the scene frequency (Gabriel 1996 model).

    Parameters
    ----------
    name : str
        Material name (required unless built from XML properties).
    tissue : str
        ``"dry"`` (default) or ``"wet"``.
    thickness : float
        Slab thickness (m); the default 0.1 m is a half-space at millimetre waves.
    scattering_coefficient, xpd_coefficient : float
        As for :class:`sionna.rt.RadioMaterial` (0: purely specular skin).
    """

    def __init__(self, name: str | None = None, tissue: str = "dry", thickness: float = DEFAULT_THICKNESS,
                 scattering_coefficient: float = 0.0, xpd_coefficient: float = 0.0,
                 scattering_pattern: str = "lambertian", color=(0.85, 0.64, 0.52), props=None, **kwargs):
        if props is not None:
            if "tissue" in props:
                tissue = props["tissue"]
                del props["tissue"]
            for pname in ("relative_permittivity", "conductivity"):
                if pname in props:
                    raise MaterialError(
                        f"skin-radio-material {props.id()!r}: {pname} cannot be set, it follows the frequency"
                    )
        if tissue not in _TISSUES:
            raise MaterialError(f"skin-radio-material: tissue {tissue!r} is unknown; choose one of {', '.join(_TISSUES)}")
        self._tissue = tissue
        model = _TISSUES[tissue]
        if props is not None:
            super().__init__(scattering_pattern=scattering_pattern,
                             frequency_update_callback=_skin_callback(model), props=props, **kwargs)
        else:
            if name is None:
                raise MaterialError("SkinRadioMaterial: `name` is required")
            super().__init__(name=name, thickness=thickness, scattering_coefficient=scattering_coefficient,
                             xpd_coefficient=xpd_coefficient, scattering_pattern=scattering_pattern,
                             frequency_update_callback=_skin_callback(model), color=color, **kwargs)

    @property
    def tissue(self) -> str:
        return self._tissue


def _skin_callback(model: ColeColeTissue):
    def callback(frequency):
        f = float(frequency[0]) if hasattr(frequency, "__len__") else float(frequency)
        eps, sigma = model.properties(f)
        return mi.Float(eps), mi.Float(sigma)
    callback.model = model
    return callback


_REGISTERED = False


def register_plugins() -> None:
    """Register ``skin-radio-material`` with Mitsuba (idempotent; done on import)."""
    global _REGISTERED
    if not _REGISTERED:
        mi.register_bsdf("skin-radio-material", lambda props: SkinRadioMaterial(props=props))
        _REGISTERED = True


register_plugins()


# ---------------------------------------------------------------------------------- ITU check
def itu_valid_ranges(itu_type: str) -> list[tuple[float, float]]:
    """Frequency ranges (Hz, inclusive) in which Sionna defines ITU material ``itu_type``."""
    if itu_type not in ITU_MATERIALS_PROPERTIES:
        raise MaterialError(
            f"ITU material {itu_type!r} is unknown to Sionna; known: {', '.join(sorted(ITU_MATERIALS_PROPERTIES))}"
        )
    return sorted((lo * 1e9, hi * 1e9) for lo, hi in ITU_MATERIALS_PROPERTIES[itu_type])


def _ranges_text(ranges) -> str:
    return ", ".join(f"{lo / 1e9:g}-{hi / 1e9:g} GHz" for lo, hi in ranges)


def check_itu_frequency(itu_type: str, frequency: float, where: str = "") -> None:
    """Raise :class:`MaterialFrequencyError` if ITU material ``itu_type`` is undefined at ``frequency`` (Hz).

    Sionna itself would raise a terse error or, for a material built before the frequency was
    set, keep the parameters of another band; this names the material, where it is used and
    the valid ranges.
    """
    ranges = itu_valid_ranges(itu_type)
    f_ghz = float(frequency) / 1e9
    # same inclusive test as sionna.rt.radio_materials.itu.itu_material
    if any(lo / 1e9 <= f_ghz <= hi / 1e9 for lo, hi in ranges):
        return
    prefix = f"{where}: " if where else ""
    valid = [name for name, table in ITU_MATERIALS_PROPERTIES.items()
             if any(lo <= f_ghz <= hi for lo, hi in table) and name != "vacuum"]
    raise MaterialFrequencyError(
        f"{prefix}ITU material {itu_type!r} is not defined at {f_ghz:g} GHz (ITU-R P.2040 / Sionna "
        f"define it for {_ranges_text(ranges)}); use a material valid at the carrier "
        f"({', '.join(valid) or 'none'}) or a radio-material with explicit permittivity and conductivity"
    )


def check_scene_materials(scene, frequency: float | None = None) -> None:
    """Check every ITU / skin material of a loaded Sionna scene at ``frequency`` (default: the scene's)."""
    frequency = float(scene.frequency[0] if frequency is None else frequency)
    for name, mat in scene.radio_materials.items():
        if isinstance(mat, ITURadioMaterial):
            check_itu_frequency(mat.itu_type, frequency, where=f"radio material {name!r}")
        elif isinstance(mat, RadioMaterial):
            model = getattr(mat.frequency_update_callback, "model", None)
            if isinstance(model, ColeColeTissue):
                model.properties(frequency)


def apply_custom_materials(scene) -> list[str]:
    """Attach the known custom models to ``radio-material`` placeholders of a loaded scene.

    A plain ``radio-material`` whose id names a custom material (``skin``, ``mat-skin``, ...)
    gets the frequency callback of that material, so its permittivity and conductivity follow
    ``scene.frequency``. Returns the names of the materials it set.
    """
    done = []
    for name, mat in scene.radio_materials.items():
        key = _custom_name(name)
        if key is None or isinstance(mat, SkinRadioMaterial) or type(mat) is not RadioMaterial:
            continue
        if mat.frequency_update_callback is not None:
            continue
        mat.frequency_update_callback = _skin_callback(CUSTOM_MATERIALS[key])
        done.append(name)
    return done


# ---------------------------------------------------------------------------------- XML check
@dataclass(frozen=True)
class MaterialSpec:
    """What an XML ``<bsdf>`` stands for: ``kind`` is ``itu``, ``radio``, ``custom``, ``skin`` or ``absorber``."""

    kind: str
    id: str | None
    itu_type: str | None = None
    custom: str | None = None


def classify_bsdf(bsdf_type: str | None, bsdf_id: str | None, props: dict) -> MaterialSpec:
    """Classify a scene-XML BSDF as Sionna would load it; raise :class:`MaterialError` if it is unusable.

    ``props`` maps the BSDF's child property names to their string values.
    """
    name = bsdf_id or ""
    short = name[4:] if name.startswith("mat-") else name
    # Sionna's naming convention: ids "mat-itu_<type>" / "itu_<type>" become ITU materials
    if short.startswith("itu_") or short.startswith("itu-"):
        itu_type = props.get("type", short[4:])
        if itu_type not in ITU_MATERIALS_PROPERTIES:
            raise MaterialError(
                f"material {name!r}: ITU type {itu_type!r} is unknown to Sionna; "
                f"known: {', '.join(sorted(ITU_MATERIALS_PROPERTIES))}"
            )
        return MaterialSpec("itu", bsdf_id, itu_type=itu_type)
    if bsdf_type == "itu-radio-material":
        itu_type = props.get("type")
        if itu_type is None:
            raise MaterialError(f"itu-radio-material {name!r} has no <string name=\"type\" .../>")
        if itu_type not in ITU_MATERIALS_PROPERTIES:
            raise MaterialError(
                f"itu-radio-material {name!r}: type {itu_type!r} is unknown to Sionna; "
                f"known: {', '.join(sorted(ITU_MATERIALS_PROPERTIES))}"
            )
        return MaterialSpec("itu", bsdf_id, itu_type=itu_type)
    if bsdf_type == "radio-material":
        if "relative_permittivity" in props or "conductivity" in props:
            for key in ("relative_permittivity", "conductivity"):
                if key in props:
                    try:
                        value = float(props[key])
                    except ValueError:
                        raise MaterialError(f"radio-material {name!r}: {key}={props[key]!r} is not a number") from None
                    if not np.isfinite(value) or (key == "relative_permittivity" and value < 1) or value < 0:
                        raise MaterialError(f"radio-material {name!r}: {key}={props[key]!r} is out of range")
            return MaterialSpec("radio", bsdf_id)
        custom = _custom_name(bsdf_id)
        if custom is None:
            raise MaterialError(
                f"radio-material {name!r} has neither relative_permittivity nor conductivity and is not a "
                f"known custom material ({', '.join(sorted(CUSTOM_MATERIALS))}); it would load as vacuum"
            )
        return MaterialSpec("custom", bsdf_id, custom=custom)
    if bsdf_type == "skin-radio-material":
        tissue = props.get("tissue", "dry")
        if tissue not in _TISSUES:
            raise MaterialError(f"skin-radio-material {name!r}: tissue {tissue!r} is unknown; choose one of "
                                f"{', '.join(_TISSUES)}")
        return MaterialSpec("skin", bsdf_id, custom="skin" if tissue == "dry" else "skin_wet")
    if bsdf_type == "absorber-radio-material":
        return MaterialSpec("absorber", bsdf_id)
    raise MaterialError(
        f"BSDF {name!r} of type {bsdf_type!r} is not a radio material; use itu-radio-material, radio-material, "
        "skin-radio-material or an id of the form mat-itu_<type>"
    )


def check_material_frequency(spec: MaterialSpec, frequency: float, where: str = "") -> None:
    """Raise :class:`MaterialFrequencyError` if ``spec`` has no model at ``frequency`` (Hz)."""
    if spec.kind == "itu":
        check_itu_frequency(spec.itu_type, frequency, where=where)
    elif spec.kind in ("custom", "skin"):
        try:
            CUSTOM_MATERIALS[spec.custom].properties(frequency)
        except MaterialFrequencyError as err:
            raise MaterialFrequencyError(f"{where}: {err}" if where else str(err)) from None


__all__ = [
    "CUSTOM_MATERIALS", "ColeColeTissue", "MaterialError", "MaterialFrequencyError", "MaterialSpec",
    "SKIN_DRY", "SKIN_WET", "SkinRadioMaterial", "apply_custom_materials", "check_itu_frequency",
    "check_material_frequency", "check_scene_materials", "classify_bsdf", "itu_valid_ranges",
    "register_plugins", "skin_properties",
]
