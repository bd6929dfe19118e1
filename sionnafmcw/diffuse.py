r"""Diffuse scattering as random-phase Lambertian scatterers fixed to the surface.

A rough surface re-radiates the diffuse share :math:`S^2|\Gamma|^2` of the reflected power
(Sionna's material model; the coherent share :math:`(1 - S^2)|\Gamma|^2` is physical optics,
:mod:`sionnafmcw.physical_optics`). Within one render sample (centimetres) there are many
roughness cells of a wavelength (3.9 mm) or less with unrelated phases: their sum is a random
phasor whose *power* is the sample's Lambertian power. So every sample is a scatterer of power
:math:`|a|^2` (the pixel engine's, :func:`lambertian_gains`) and a random phase :math:`\phi_i`:

* **fixed to the surface point**: :math:`\phi_i` is a deterministic hash of (object, triangle,
  barycentric cell) (:func:`scatterer_phases`): the triangle index and barycentric coordinates
  are the hit's position in the object's own frame, so the phase moves with the body, is the same
  for every Tx/Rx element (one set of scatterers for the whole array), for every chirp of the CPI
  (the echo is fixed within a CPI), and for every frame in which the same surface cell is hit (a
  static wall keeps its phases, so static clutter removal removes it);
* **uniform in** :math:`[0, 2\pi)` **and independent between cells**: neighbours add in power,
  :math:`E|\sum_i a_i e^{j\phi_i}e^{-jk L_i}|^2 = \sum_i|a_i|^2` whatever the sample count, while
  deterministic phases add the neighbours coherently and the map power grows with the sampling
  density (6 dB per 4x samples on a plate facing the radar).

The barycentric position is quantised into ``cells_per_edge`` :math:`Q` steps per triangle edge
(:func:`cells_per_edge`: edge length / cell size, cell size :math:`\lambda/4` by default), cell
:math:`(\lfloor Qb_1\rfloor, \lfloor Qb_2\rfloor)`. The cell must be smaller than the sample
spacing (distinct samples, distinct phases); a hit that falls in the same cell in another frame
gets the same phase.

The hash is SplitMix64 (Steele, Lea & Flood 2014) over the 64-bit words (object key, triangle,
cell u, cell v), the object key being the first 8 bytes of BLAKE2b of the object's name (or its
integer id): stable across processes and platforms (Python's ``hash`` of a string is salted per
process and is not used). The top 53 bits give :math:`\phi = 2\pi\,u`, :math:`u\in[0, 1)`.
"""

from __future__ import annotations

import hashlib

import numpy as np

from .constants import SPEED_OF_LIGHT
from .physical_optics import ElementGeometry, SurfaceSamples, element_gains, element_positions, oriented_normals

_MASK = np.uint64(0xFFFFFFFFFFFFFFFF)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on ``uint64`` arrays (wrapping arithmetic)."""
    with np.errstate(over="ignore"):
        x = (x + np.uint64(0x9E3779B97F4A7C15)) & _MASK
        x = ((x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _MASK
        x = ((x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _MASK
        return x ^ (x >> np.uint64(31))


def object_key(name) -> np.uint64:
    """Stable 64-bit key of an object name (str) or id (int): BLAKE2b, first 8 bytes, little endian."""
    digest = hashlib.blake2b(str(name).encode("utf-8"), digest_size=8).digest()
    return np.frombuffer(digest, dtype="<u8")[0]


def cells_per_edge(triangle_edge, cell_size: float) -> np.ndarray:
    """Barycentric quantisation steps per triangle: ``ceil(edge / cell_size)`` (>= 1), ``triangle_edge`` in m."""
    if not np.isfinite(cell_size) or cell_size <= 0:
        raise ValueError(f"cells_per_edge: cell_size must be a positive length in m, got {cell_size!r}")
    edge = np.asarray(triangle_edge, float)
    return np.maximum(1, np.ceil(edge / cell_size)).astype(np.int64)


def scatterer_phases(objects, triangle, barycentric, cells) -> np.ndarray:
    r"""Phase :math:`\phi\in[0, 2\pi)` ``[P]`` of the diffuse scatterer at each hit.

    ``objects [P]``: object names (str) or integer ids; ``triangle [P]``: triangle index in the
    object's mesh; ``barycentric [P, 2]``: :math:`(b_1, b_2)` of the hit; ``cells``: quantisation
    steps per edge (scalar or ``[P]``, :func:`cells_per_edge`).
    """
    objects = np.asarray(objects)
    triangle = np.asarray(triangle, dtype=np.int64)
    bary = np.asarray(barycentric, float)
    if bary.shape != triangle.shape + (2,) or objects.shape != triangle.shape:
        raise ValueError(f"scatterer_phases: objects {objects.shape}, triangle {triangle.shape} and barycentric "
                         f"{bary.shape} must be [P], [P] and [P, 2]")
    q = np.broadcast_to(np.asarray(cells, dtype=np.int64), triangle.shape)
    if np.any(q < 1):
        raise ValueError("scatterer_phases: cells must be >= 1")
    names, inverse = np.unique(objects, return_inverse=True)
    keys = np.array([object_key(n) for n in names], dtype=np.uint64)[inverse.reshape(-1)]
    cu = np.clip(np.floor(bary[:, 0] * q), 0, q - 1).astype(np.int64)
    cv = np.clip(np.floor(bary[:, 1] * q), 0, q - 1).astype(np.int64)
    h = _splitmix64(keys)
    for word in (triangle, cu, cv):
        h = _splitmix64(h ^ word.astype(np.uint64))
    return (h >> np.uint64(11)).astype(np.float64) * (2.0 * np.pi / 2.0 ** 53)


def shared_cells(samples: SurfaceSamples, cells) -> int:
    """How many samples share their (object, triangle, cell) with another sample.

    Such samples get the same phase and add coherently (growing with the sample count); it must be 0
    (``cells`` fine enough for the sample spacing). A cheap check for the engines (one ``np.unique``).
    """
    objects = samples.labels if samples.labels is not None else samples.object_id
    q = np.broadcast_to(np.asarray(cells, dtype=np.int64), samples.triangle.shape)
    cu = np.clip(np.floor(samples.barycentric[:, 0] * q), 0, q - 1).astype(np.int64)
    cv = np.clip(np.floor(samples.barycentric[:, 1] * q), 0, q - 1).astype(np.int64)
    _, obj = np.unique(np.asarray(objects), return_inverse=True)
    keys = np.stack([obj.reshape(-1), samples.triangle, cu, cv], axis=1)
    _, counts = np.unique(keys, axis=0, return_counts=True)
    return int(np.sum(counts[counts > 1]))


def sample_phases(samples: SurfaceSamples, cells) -> np.ndarray:
    """:func:`scatterer_phases` of :class:`SurfaceSamples` (object: ``labels`` if given, else ``object_id``)."""
    objects = samples.labels if samples.labels is not None else samples.object_id
    return scatterer_phases(objects, samples.triangle, samples.barycentric, cells)


def lambertian_gains(samples: SurfaceSamples, tx_positions, rx_positions, wavelength: float, tx_gain=None,
                     rx_gain=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Real Lambertian amplitudes ``|a| [M, N, P]``, delays and Dopplers of the diffuse share.

    The pixel engine's bistatic radar equation (without its polarisation factor :math:`\chi`,
    which the engine applies): :math:`\sigma_{mn} = 4\pi\,\Delta A\cos\theta_{i,m}\,S^2|\Gamma|^2
    \cos\theta_{s,n}/\pi`, :math:`|a_{mn}| = \lambda\sqrt{G_tG_r\sigma_{mn}}/((4\pi)^{3/2}r_tr_r)`.
    """
    geo = ElementGeometry.of(samples, tx_positions, rx_positions)
    m, n, p = geo.r_t.shape[0], geo.r_r.shape[0], samples.num_samples
    g_t = np.ones((m, p)) if tx_gain is None else np.asarray(tx_gain, float)
    g_r = np.ones((n, p)) if rx_gain is None else np.asarray(rx_gain, float)
    centre = np.concatenate([np.atleast_2d(tx_positions), np.atleast_2d(rx_positions)]).mean(axis=0)
    normal = oriented_normals(samples, centre)
    cos_i = np.clip(-np.einsum("mpi,pi->mp", geo.s_t, normal), 0.0, None)
    cos_s = np.clip(-np.einsum("npi,pi->np", geo.s_r, normal), 0.0, None)
    power = samples.scattering_coefficient ** 2 * np.abs(samples.reflection) ** 2
    sigma = 4 * np.pi * samples.area * power * cos_i[:, None] * cos_s[None] / np.pi
    amp = wavelength * np.sqrt(g_t[:, None] * g_r[None] * sigma) / ((4 * np.pi) ** 1.5 * geo.r_t[:, None] * geo.r_r[None])
    return amp, geo.delays(), geo.dopplers(samples.velocity, wavelength)


def diffuse_gains(samples: SurfaceSamples, tx_positions, rx_positions, wavelength: float, cells, tx_gain=None,
                  rx_gain=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Random-phase diffuse contributions ``(a, tau, doppler)`` ``[M, N, P]``:
    :math:`a = |a_{Lambert}|\,e^{j\phi_i}` with one :math:`\phi_i` per sample for every element pair."""
    amp, tau, doppler = lambertian_gains(samples, tx_positions, rx_positions, wavelength, tx_gain, rx_gain)
    return amp * np.exp(1j * sample_phases(samples, cells))[None, None], tau, doppler


def diffuse_echoes(samples: SurfaceSamples, radar, cells, position=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0),
                   label: str = "diffuse"):
    """:class:`~sionnafmcw.echoes.Echoes` of the random-phase diffuse scatterers for ``radar`` at its pose."""
    from .echoes import Echoes

    tx_w, rx_w, rotation = element_positions(radar, position, orientation)
    g_t, g_r = element_gains(radar, samples, tx_w, rx_w, rotation)
    a, tau, doppler = diffuse_gains(samples, tx_w, rx_w, SPEED_OF_LIGHT / radar.fc, cells, g_t, g_r)
    labels = samples.labels if samples.labels is not None else np.full(samples.num_samples, label)
    return Echoes(a, tau, doppler, labels)


__all__ = ["cells_per_edge", "diffuse_echoes", "diffuse_gains", "lambertian_gains", "object_key",
           "sample_phases", "scatterer_phases", "shared_cells"]
