r"""The pixel engine's camera: its equiangular pixel grid and what one frame's pixels saw.

Pixel grid
----------
Equiangular in the radar frame (boresight local :math:`+x`, azimuth :math:`\varphi` from
:math:`+x` towards :math:`+y`, elevation :math:`\vartheta` towards :math:`+z`): with fields of
view :math:`\Phi` (azimuth) and :math:`\Theta` (elevation) and :math:`N_{az}\times N_{el}` pixels,
:math:`\Delta\varphi = \Phi/N_{az}`, :math:`\Delta\vartheta = \Theta/N_{el}`, the pixel centres are

.. math::
    \varphi_j = -\tfrac{\Phi}{2} + (j + \tfrac12)\Delta\varphi,\qquad
    \vartheta_i = -\tfrac{\Theta}{2} + (i + \tfrac12)\Delta\vartheta,\qquad
    \hat{\mathbf u}_{ij} = [\cos\vartheta_i\cos\varphi_j,\ \cos\vartheta_i\sin\varphi_j,\ \sin\vartheta_i]

and the solid angle of a pixel is the exact integral of :math:`\cos\vartheta\,d\vartheta\,d\varphi`
over it,

.. math::
    \Delta\Omega_{ij} = \Delta\varphi\,[\sin(\vartheta_i + \tfrac{\Delta\vartheta}{2})
                        - \sin(\vartheta_i - \tfrac{\Delta\vartheta}{2})]
                      = 2\,\Delta\varphi\cos\vartheta_i\sin\tfrac{\Delta\vartheta}{2},
    \qquad \sum_{ij}\Delta\Omega_{ij} = 2\,\Phi\sin\tfrac{\Theta}{2}.

Rows are ordered by increasing elevation, columns by increasing azimuth; the flat pixel index is
``i * n_az + j``. :math:`\Phi, \Theta \in (0, \pi]`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import PixelEngineError


@dataclass(frozen=True)
class PixelGrid:
    """Equiangular azimuth/elevation grid of pixel centres in the radar frame (module docstring)."""

    n_az: int
    n_el: int
    fov_az: float
    fov_el: float

    def __post_init__(self):
        for name in ("n_az", "n_el"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise PixelEngineError(f"PixelEngine: {name} must be an integer >= 1, got {value!r}")
        for name in ("fov_az", "fov_el"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not np.isfinite(value) or not 0.0 < value <= np.pi:
                raise PixelEngineError(
                    f"PixelEngine: {name} must be an angle in (0, pi] rad, got {value!r} (angles are in radians)")

    @property
    def d_az(self) -> float:
        """Azimuth pixel width :math:`\\Delta\\varphi` (rad)."""
        return float(self.fov_az) / self.n_az

    @property
    def d_el(self) -> float:
        """Elevation pixel height :math:`\\Delta\\vartheta` (rad)."""
        return float(self.fov_el) / self.n_el

    @property
    def azimuths(self) -> np.ndarray:
        """Pixel-centre azimuths ``[n_az]`` (rad, increasing)."""
        return -self.fov_az / 2 + (np.arange(self.n_az) + 0.5) * self.d_az

    @property
    def elevations(self) -> np.ndarray:
        """Pixel-centre elevations ``[n_el]`` (rad, increasing)."""
        return -self.fov_el / 2 + (np.arange(self.n_el) + 0.5) * self.d_el

    @property
    def num_pixels(self) -> int:
        return self.n_az * self.n_el

    def angles(self) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth and elevation of every pixel, each ``[n_el, n_az]`` (rad)."""
        el, az = np.meshgrid(self.elevations, self.azimuths, indexing="ij")
        return az, el

    def directions(self) -> np.ndarray:
        """Unit vectors ``[n_el, n_az, 3]`` through the pixel centres (radar frame)."""
        az, el = self.angles()
        return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)

    def solid_angles(self) -> np.ndarray:
        r"""Pixel solid angles ``[n_el, n_az]`` (sr):
        :math:`\Delta\Omega_{ij} = \Delta\varphi[\sin(\vartheta_i + \Delta\vartheta/2) - \sin(\vartheta_i - \Delta\vartheta/2)]`."""
        el = self.elevations
        band = np.sin(el + self.d_el / 2) - np.sin(el - self.d_el / 2)
        return np.broadcast_to((self.d_az * band)[:, None], (self.n_el, self.n_az)).copy()

    @property
    def field_of_view_solid_angle(self) -> float:
        """:math:`2\\Phi\\sin(\\Theta/2)` (sr), the sum of :meth:`solid_angles`."""
        return 2.0 * float(self.fov_az) * np.sin(float(self.fov_el) / 2)


# ---------------------------------------------------------------------------------------- results
@dataclass
class PixelRender:
    """What the radar "sees" in one frame: the hit pixels, in the order of the echoes' contributions.

    All arrays are ``[P]`` (``[P, 3]`` for vectors, world frame) over the pixels that hit a
    surface; :meth:`image` puts one of them back on the ``[n_el, n_az]`` grid. ``rcs`` is the
    monostatic pixel RCS at the phase centre :math:`\\sigma_p = 4\\pi A\\cos\\theta_i S^2\\Gamma^2\\chi f_s`
    (m^2); ``contributes`` marks the pixels with a non-zero echo (the contributions of the
    :class:`Echoes`, in this order).
    """

    frame: int
    grid: PixelGrid
    pixel: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray
    solid_angle: np.ndarray
    range: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    velocity: np.ndarray
    radial_velocity: np.ndarray
    cos_incidence: np.ndarray
    rcs: np.ndarray
    labels: np.ndarray
    contributes: np.ndarray

    @property
    def num_hits(self) -> int:
        return int(self.pixel.size)

    def image(self, values, fill=np.nan) -> np.ndarray:
        """``values [P]`` on the pixel grid ``[n_el, n_az]`` (rows: increasing elevation), ``fill`` elsewhere."""
        values = np.asarray(values)
        out = np.full(self.grid.num_pixels, fill, dtype=np.result_type(values.dtype, np.asarray(fill).dtype))
        out[self.pixel] = values
        return out.reshape(self.grid.n_el, self.grid.n_az)


__all__ = ["PixelGrid", "PixelRender"]
