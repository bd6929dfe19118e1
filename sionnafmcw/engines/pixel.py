r"""Pixel engine: every pixel of a render from the radar is a point target (eq. (2) of the reference paper).

The reference paper is Y. Liu, M. Ahmadi, J. Fuchs, M. Alaee-Kerahroodi and M. R. Bhavani Shankar,
"A Blender-based channel simulator for FMCW radar", Interdisciplinary Centre for Security,
Reliability and Trust (SnT), University of Luxembourg (see ``docs/index.md``); its eq. (2) models the beat
signal as a sum over the pixels of a render, each pixel a point target with range, strength,
angle and velocity. "The paper" below is this one.

Each frame is "photographed" from the radar: one ray per pixel centre of its grid
(:mod:`~sionnafmcw.engines.pixel_grid`) is cast from the virtual array's phase centre with
Mitsuba's ``ray_intersect_preliminary`` (distance, shape, triangle and barycentrics;
deterministic) over the surfaces the path engine's PO render casts over
(:mod:`~sionnafmcw.engines.surfaces`: the same animation, radio materials and rigid motions).
Every pixel that hits a surface is one contribution of the :class:`~sionnafmcw.echoes.Echoes`
(shape ``[num_tx, num_rx, num_hit_pixels]``, labelled with the name of the object hit) with its
range, direction, strength and velocity -- the paper's matrices :math:`R, P_r, \Theta, V`.

Models: physical optics for the coherent echo (default) or the paper's Lambertian eq. (2)
-----------------------------------------------------------------------------------------
Sionna's material model splits the reflected power of a surface into a coherent (specular)
share :math:`(1 - S^2)|\Gamma|^2` and a diffuse share :math:`S^2|\Gamma|^2`.

``model="physical-optics"`` (default): the coherent share is the near-field physical-optics
integral over the lit surface, the diffuse share the random-phase Lambertian pixels
(:mod:`~sionnafmcw.engines.lambertian`); nothing is counted twice. The PO integral is the path
engine's first bounce, by the same code: the render of :mod:`~sionnafmcw.engines.po_render`
(each object with a coherent share on its own grid at the resolution rule of
:func:`~sionnafmcw.physical_optics.render_resolution`, kept within the field of view), the
element-pair kernel of :mod:`~sionnafmcw.engines.po_kernel` (every Tx/Rx pair's exact delay,
Doppler, element gains and obliquity, whatever ``array_model``) and the merge of
:mod:`~sionnafmcw.engines.po_merge` within its share of the noise budget. Measured through the
engine (``tests/test_pixel_po.py``): metal plates of 0.1 and 0.2 m facing the radar at 2-20 m
within 0.03 dB of the near-field Fresnel PO, a plate split in 2 or 128 triangles the same echo,
a faceted sphere :math:`\pi r^2` within 1 dB.

Why PO is the default (decision): the Lambertian pixels alone miss the coherent share,
which is the dominant echo of every smooth surface facing the radar -- a 0.1 m metal plate at
5 m is 18.7 dBsm by PO and invisible (:math:`S = 0`) or :math:`4AS^2` = -14 dBsm to them, a
torso facet normal to the line of sight likewise -- and PO, unlike the path engine's
geometric-optics mirror, is right for finite and curved surfaces. ``model="lambertian"`` keeps
the paper's eq. (2) (every pixel a Lambertian scatterer of the diffuse share only; with
``diffuse_phase="deterministic"`` exactly as published) to reproduce the paper. In that model:

* pixel-vs-path comparisons are fair against the path engine with ``max_depth=1`` and either
  ``specular=False`` or surfaces whose mirror echo misses the radar; the diffuse parts then
  agree in absolute power (0.01-0.02 dB measured, ``tests/test_pixel_engine.py``);
* a smooth surface facing the radar is a weak diffuse reflector (a 1 m metal plate at 2 / 5 m
  with ``scattering_coefficient=1``: 6 / 13 dB below the path engine's mirror, walk-77ghz);
* a material with :math:`S = 0` (Sionna's default, every ITU material) is invisible.

Neither model has multipath (target-floor-radar) or the triple bounce of a corner reflector:
the pixel engine is single-bounce.

Measured through the engine
(``tests/test_pixel_po.py``): metal plates of 0.1 and 0.2 m facing the radar at 2-20 m within
0.03 dB of the near-field Fresnel PO, a plate split in 2 or 128 triangles the same echo, a
faceted sphere :math:`\pi r^2` within 1 dB.

Why PO is the default (decision): the Lambertian pixels alone miss the coherent share,
which is the dominant echo of every smooth surface facing the radar -- a 0.1 m metal plate at
5 m is 18.7 dBsm by PO and invisible (:math:`S = 0`) or :math:`4AS^2` = -14 dBsm to them, a
torso facet normal to the line of sight likewise -- and PO, unlike the path engine's
geometric-optics mirror, is right for finite and curved surfaces. ``model="lambertian"`` keeps
the paper's eq. (2) (every pixel a Lambertian scatterer of the diffuse share only; with
``diffuse_phase="deterministic"`` exactly as published) to reproduce the paper. In that model:

* pixel-vs-path comparisons are fair against the path engine with ``max_depth=1`` and either
  ``specular=False`` or surfaces whose mirror echo misses the radar; the diffuse parts then
  agree in absolute power (0.01-0.02 dB measured, ``tests/test_pixel_engine.py``);
* a smooth surface facing the radar is a weak diffuse reflector (a 1 m metal plate at 2 / 5 m
  with ``scattering_coefficient=1``: 6 / 13 dB below the path engine's mirror, walk-77ghz);
* a material with :math:`S = 0` (Sionna's default, every ITU material) is invisible.

Neither model has multipath (target-floor-radar) or the triple bounce of a corner reflector:
the pixel engine is single-bounce.

No recompilation
----------------
The scene is loaded once per animation and radar; the surfaces are built once and placed per
frame (:mod:`~sionnafmcw.engines.surfaces`: every per-frame value is opaque to Dr.Jit), the rays
are built from numpy arrays (the pose is data, not a kernel constant), and everything after the
casts and the PO kernel is numpy; :attr:`PixelEngine.stats` records launches and new kernel
hashes per frame.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..animation import Animation, RadarPose
from ..antenna import check_pattern
from ..array import phase_centre
from ..constants import SPEED_OF_LIGHT
from ..diffuse import scatterer_phases
from ..echoes import Echoes
from ..geometry import rotation_matrix
from ..physical_optics import SurfaceSamples
from ..sionna_rt import dr
from ..kinematics import element_kinematics, range_acceleration
from .base import Engine
from .cpi_motion import broadcast_rates, check_cpi_motion, frame_motion, render_range_accelerations, with_ego_doppler
from .errors import PixelEngineError
from .lambertian import diffuse_cells, diffuse_material, pixel_echoes
from .pixel_grid import PixelGrid, PixelRender
from .po_render import Material, radio_material
from .surfaces import SurfaceWorld


@dataclass
class _State:
    """Per-scene state of the pixel engine: the objects, their diffuse and PO materials, their surfaces
    and the diffuse cells per surface triangle (filled on first use)."""

    names: list
    materials: list
    po_materials: dict
    world: SurfaceWorld
    cells: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------- engine
class PixelEngine(Engine):
    r"""The scene rendered from the radar; each hit pixel a point target (see the module docstring).

    Parameters
    ----------
    n_az, n_el : int
        Pixels in azimuth (columns, along the radar's local y) and elevation (rows, along z).
    fov_az, fov_el : float
        Fields of view (rad), each in (0, pi].
    array_model : str
        ``"plane-wave"`` (eq. (2) of the paper, far field) or ``"exact"`` (spherical wavefronts
        per element).
    scattering_coefficient : float or None
        None: each material's own :math:`S` (consistent with the path engine); a number in
        [0, 1]: that :math:`S` for every material.
    vertex_doppler : bool
        Use per-vertex velocities from the PLYs where present (else the manifest velocity).
    model : str
        ``"physical-optics"`` (default): near-field PO for the coherent share :math:`(1 - S^2)|\Gamma|^2`
        on a per-object render plus the random-phase Lambertian pixels for the diffuse share
        :math:`S^2|\Gamma|^2`; ``"lambertian"``: the pixels only (the paper's eq. (2)).
    diffuse_phase : str
        ``"random"`` (default): each pixel's diffuse contribution carries the phase of the surface
        cell it hit (:func:`~sionnafmcw.diffuse.scatterer_phases`); ``"deterministic"``: none (the
        paper's eq. (2); the map power then grows with the pixel count).
    diffuse_cell_size : float or None
        Size (m) of the surface cells of the diffuse phases; None: :math:`\lambda/4` of the radar.
    po_samples_across : int
        Least number of PO samples across an object (:func:`~sionnafmcw.physical_optics.render_resolution`).
    po_max_rays : int
        Most PO rays per object and frame; an object whose render needs more stops the frame with a
        :class:`~sionnafmcw.engines.po_render.RenderError` that names it.
    po_merge : bool
        Sum the PO samples the radar cannot tell apart into one contribution per cell and pair, within
        the merge's share of the noise budget (:mod:`~sionnafmcw.engines.po_merge`): the same channel
        at the carrier, fewer contributions to synthesize.
    cpi_motion : str
        ``"frozen"`` (default) or ``"quadratic"``: motion within the CPI, every pixel and PO sample with
        its Doppler rate (:mod:`~sionnafmcw.engines.cpi_motion`). A moving radar's ego-Doppler enters
        either way.
    track_kernels : bool
        Record Dr.Jit kernel launches per frame in :attr:`stats`.

    Notes
    -----
    :attr:`stats` figures: ``trace_seconds`` (the ray cast), ``num_hits`` (pixels that hit a
    surface), ``num_contributions`` (hit pixels with a non-zero echo, plus the PO samples),
    ``num_po_rays`` and ``num_po_samples`` (the PO render's rays and its hits on the objects it was
    cast for; 0 in the Lambertian model), ``num_po_contributions`` (the PO samples after the merge).
    """

    name = "pixel"
    FIXED_SETTINGS = {"max_depth": 1}
    ARRAY_MODELS = ("plane-wave", "exact")
    MODELS = ("physical-optics", "lambertian")
    DIFFUSE_PHASES = ("random", "deterministic")

    def __init__(self, n_az: int = 128, n_el: int = 64, fov_az: float = float(np.deg2rad(120.0)),
                 fov_el: float = float(np.deg2rad(60.0)), array_model: str = "plane-wave",
                 scattering_coefficient: float | None = None, vertex_doppler: bool = True,
                 model: str = "physical-optics", diffuse_phase: str = "random",
                 diffuse_cell_size: float | None = None, po_samples_across: int = 16, po_max_rays: int = 2_000_000,
                 po_merge: bool = True, cpi_motion: str = "frozen", track_kernels: bool = True):
        if model not in self.MODELS:
            raise PixelEngineError(f"PixelEngine: model={model!r} is unknown; choose one of {', '.join(self.MODELS)}")
        check_cpi_motion(cpi_motion, PixelEngineError, "PixelEngine")
        if diffuse_phase not in self.DIFFUSE_PHASES:
            raise PixelEngineError(f"PixelEngine: diffuse_phase={diffuse_phase!r} is unknown; choose one of "
                                   f"{', '.join(self.DIFFUSE_PHASES)}")
        if diffuse_cell_size is not None and (isinstance(diffuse_cell_size, bool) or not isinstance(
                diffuse_cell_size, (int, float, np.integer, np.floating)) or not np.isfinite(diffuse_cell_size)
                or diffuse_cell_size <= 0):
            raise PixelEngineError(f"PixelEngine: diffuse_cell_size must be None or a positive length in m, "
                                   f"got {diffuse_cell_size!r}")
        for name, value in (("po_samples_across", po_samples_across), ("po_max_rays", po_max_rays)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise PixelEngineError(f"PixelEngine: {name} must be an integer >= 1, got {value!r}")
        if array_model not in self.ARRAY_MODELS:
            raise PixelEngineError(
                f"PixelEngine: array_model={array_model!r} is unknown; choose one of {', '.join(self.ARRAY_MODELS)}")
        if scattering_coefficient is not None:
            if isinstance(scattering_coefficient, bool) or not isinstance(
                    scattering_coefficient, (int, float, np.integer, np.floating)) \
                    or not 0.0 <= float(scattering_coefficient) <= 1.0:
                raise PixelEngineError(
                    f"PixelEngine: scattering_coefficient must be None or a number in [0, 1], "
                    f"got {scattering_coefficient!r}")
            scattering_coefficient = float(scattering_coefficient)
        grid = PixelGrid(n_az, n_el, fov_az, fov_el)
        super().__init__(track_kernels=track_kernels)
        self.grid = grid
        self.array_model = array_model
        self.scattering_coefficient = scattering_coefficient
        self.vertex_doppler = bool(vertex_doppler)
        self.model = model
        self.diffuse_phase = diffuse_phase
        self.diffuse_cell_size = None if diffuse_cell_size is None else float(diffuse_cell_size)
        self.po_samples_across = int(po_samples_across)
        self.po_max_rays = int(po_max_rays)
        self.po_merge = bool(po_merge)
        self.cpi_motion = cpi_motion
        self.last_po_samples: SurfaceSamples | None = None
        self._directions = self.grid.directions().reshape(-1, 3)
        self.last_render: PixelRender | None = None

    def _settings(self) -> dict:
        return {"n_az": self.grid.n_az, "n_el": self.grid.n_el, "fov_az": float(self.grid.fov_az),
                "fov_el": float(self.grid.fov_el), "array_model": self.array_model,
                "scattering_coefficient": self.scattering_coefficient, "vertex_doppler": self.vertex_doppler,
                "model": self.model, "diffuse_phase": self.diffuse_phase,
                "diffuse_cell_size": self.diffuse_cell_size, "po_samples_across": self.po_samples_across,
                "po_max_rays": self.po_max_rays, "po_merge": self.po_merge, "cpi_motion": self.cpi_motion,
                # what the model computes (constants of the model, for pixel-vs-path comparisons)
                "scattering": "diffuse" if self.model == "lambertian" else "physical-optics+diffuse",
                "specular": self.model == "physical-optics"}

    # ------------------------------------------------------------------ set-up
    def _load(self, scene, animation: Animation, radar) -> _State:
        """The objects, their diffuse and PO materials and their surfaces; a first cast compiles the
        casts' kernel while loading."""
        names = list(scene.objects)
        materials, po_materials = [], {}
        for name, obj in scene.objects.items():
            materials.append(diffuse_material(name, obj.radio_material, self.scattering_coefficient))
            if self.model == "physical-optics":
                m = radio_material(obj.radio_material, name)
                s = m.scattering_coefficient if self.scattering_coefficient is None else self.scattering_coefficient
                po_materials[name] = Material(m.name, m.eta, m.thickness, s)
        if self.model == "lambertian" and materials and all(m.scattering_coefficient == 0 for m in materials):
            warnings.warn(
                f"PixelEngine: every material of {animation.frames[0].xml} has scattering_coefficient 0; the pixel "
                "engine's Lambertian model sees diffuse scattering only, so it sees nothing. Give the materials a "
                "scattering_coefficient, set PixelEngine(scattering_coefficient=...) or use "
                "model='physical-optics'.", stacklevel=3)
        world = SurfaceWorld.build(animation, names, wavelength=SPEED_OF_LIGHT / radar.fc)
        world.cast(np.zeros(3), np.tile([[1.0, 0.0, 0.0]], (self.grid.num_pixels, 1)))
        return _State(names, materials, po_materials, world)

    def _check_radar(self, radar) -> None:
        check_pattern(radar.antenna_pattern)

    def _geometry_changed(self) -> None:
        dr.eval()

    # ------------------------------------------------------------------ public
    def render(self, animation: Animation, radar, frame: int, radar_pose: RadarPose | None = None) -> PixelRender:
        """Cast the pixel rays of ``frame`` and return the :class:`PixelRender` (also kept as :attr:`last_render`)."""
        self.echoes(animation, radar, frame, radar_pose)
        return self.last_render

    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        """Echoes ``[num_tx, num_rx, num_hit_pixels (+ PO contributions)]`` of ``frame``; the render is
        kept as :attr:`last_render`.

        Pixels whose material gives no diffuse echo (S = 0) are left out of the echoes but kept in
        :attr:`last_render`.
        """
        from .po_render import scene_objects

        state = self._state
        world = state.world
        rotation = rotation_matrix(pose.orientation)
        centre = pose.position + rotation @ phase_centre(radar)
        motion = frame_motion(animation, frame, pose, radar, state.names, self.cpi_motion == "quadratic",
                              self.vertex_doppler)
        world.place(animation, frame, self._loaded, {n: animation.object_velocity(frame, n) for n in state.names},
                    motion)
        objects = scene_objects(self._loaded, world, state.po_materials or {n: None for n in state.names},
                                vertex_doppler=self.vertex_doppler)
        t_cast = time.perf_counter()
        valid, _, obj, prim, uv = world.cast(centre, self._directions @ rotation.T)
        trace_seconds = time.perf_counter() - t_cast
        wavelength = SPEED_OF_LIGHT / radar.fc
        phases = None if self.diffuse_phase == "deterministic" else \
            (lambda o, t, b: self._phases(o, t, b, wavelength))
        render, echoes = pixel_echoes(frame, self.grid, radar, pose, rotation, centre, (valid, obj, prim, uv), objects,
                                      state.materials, self.array_model, phases)
        self.last_render = render
        echoes = _pixel_motion(echoes, render, (obj, prim, uv), objects, motion, wavelength)
        figures = {"trace_seconds": trace_seconds, "num_hits": render.num_hits, "num_po_rays": 0, "num_po_samples": 0,
                   "num_po_contributions": 0}
        self.last_po_samples = None
        if self.model == "physical-optics":
            po, po_figures = self._po_echoes(radar, objects, centre, rotation, pose, wavelength, motion)
            figures.update(po_figures)
            figures["trace_seconds"] += po_figures.pop("po_trace_seconds")
            if po is not None:
                echoes = Echoes.concatenate([echoes, po])
        figures["num_contributions"] = echoes.num_contributions
        return echoes, figures

    def close(self) -> None:
        """Drop the loaded scene and the last render."""
        super().close()
        self.last_render = None
        self.last_po_samples = None

    # ------------------------------------------------------------------ diffuse phases
    def _phases(self, obj, triangle, bary, wavelength: float) -> np.ndarray:
        """Random phases of the diffuse scatterers hit (:func:`~sionnafmcw.diffuse.scatterer_phases`): the
        cells per edge of every surface from the geometry it was built with (frame 0), so a surface
        cell keeps its phase whatever frame the engine starts with."""
        state = self._state
        cell = self.diffuse_cell_size if self.diffuse_cell_size is not None else wavelength / 4
        cells = np.ones(obj.size, dtype=np.int64)
        for k in np.unique(obj):
            if k not in state.cells:
                surface = state.world.surfaces[k]
                state.cells[k] = diffuse_cells(surface.first_vertices, surface.faces, cell)
            sel = np.flatnonzero(obj == k)
            cells[sel] = state.cells[k][triangle[sel]]
        names = np.array(state.names, dtype=object)
        return scatterer_phases(names[obj].astype(str), triangle, bary, cells)

    # ------------------------------------------------------------------ physical optics
    def _po_echoes(self, radar, objects, centre, rotation, pose, wavelength: float, motion=None):
        """The coherent share by physical optics: the path engine's first-bounce render
        (:func:`~sionnafmcw.engines.po_render.render`, within the field of view), its element-pair
        contributions (:func:`~sionnafmcw.engines.po_kernel.element_pair_po`) and their merge
        (:func:`~sionnafmcw.engines.po_merge.merge_contributions`). Returns ``(echoes or None, figures)``."""
        from .po_kernel import element_pair_po
        from .po_merge import merge_budget, merge_contributions
        from .po_render import render

        state = self._state
        targets = [k for k, m in enumerate(state.materials) if state.po_materials[state.names[k]].scattering_coefficient
                   < 1.0]
        t0 = time.perf_counter()
        origin = element_kinematics(pose, phase_centre(radar)[None])
        bounce = render(state.world, objects, centre, rotation, wavelength, targets=targets,
                        samples_across=self.po_samples_across, max_rays_per_object=self.po_max_rays,
                        field_of_view=(self.grid.fov_az / 2, self.grid.fov_el / 2),
                        origin_velocity=origin.velocity[0], origin_acceleration=origin.acceleration[0])
        seconds = time.perf_counter() - t0
        kept = bounce.select(bounce.carries_po())
        self.last_po_samples = kept.samples
        figures = {"num_po_rays": bounce.num_rays, "num_po_samples": kept.num_samples, "num_po_contributions": 0,
                   "po_trace_seconds": seconds}
        if kept.num_samples == 0:
            return None, figures
        tx_w = pose.position + radar.tx_positions @ rotation.T
        rx_w = pose.position + radar.rx_positions @ rotation.T
        a, tau, doppler = element_pair_po(kept, tx_w, rx_w, rotation, wavelength, radar.antenna_pattern)
        labels = kept.samples.labels
        rate = None
        if motion is not None:
            doppler = with_ego_doppler(doppler, motion, kept.samples.position, kept.samples.position, wavelength)
            if motion.quadratic and kept.acceleration is not None:
                rate = broadcast_rates(-render_range_accelerations(kept, motion) / wavelength, a.shape)
        if self.po_merge:
            merged = merge_contributions(a, tau, doppler, labels, kept.directions(centre, rotation), radar,
                                         merge_budget(radar), doppler_rate=rate)
            a, tau, doppler, labels, rate = merged.a, merged.tau, merged.doppler, merged.labels, merged.doppler_rate
        figures["num_po_contributions"] = a.shape[-1]
        return Echoes(a, tau, doppler, labels, doppler_rate=rate), figures


def _pixel_motion(echoes, render, hits, objects, motion, wavelength: float):
    r"""The pixels' echoes with the radar's ego-Doppler (a moving radar) and, with ``cpi_motion="quadratic"``,
    their Doppler rates :math:`-\ddot L/\lambda` (:mod:`~sionnafmcw.engines.cpi_motion`: from the
    centre of the Tx elements to the pixel's point and on to the centre of the Rx elements)."""
    if echoes.num_contributions == 0:
        return echoes
    keep = render.contributes
    points = render.position[keep]
    echoes.doppler = with_ego_doppler(echoes.doppler, motion, points, points, wavelength)
    if motion.quadratic:
        obj, prim, uv = (x[render.pixel][keep] for x in hits)
        acceleration = np.zeros(points.shape)
        for k in np.unique(obj):
            sel = np.flatnonzero(obj == k)
            acc = objects[k].hit_acceleration(prim[sel], uv[sel])
            if acc is not None:
                acceleration[sel] = acc
        velocity = render.velocity[keep]
        tx, rx = motion.tx_centre, motion.rx_centre
        ldd = (range_acceleration(tx.position, tx.velocity, tx.acceleration, points, velocity, acceleration)
               + range_acceleration(points, velocity, acceleration, rx.position, rx.velocity, rx.acceleration))
        echoes.doppler_rate = broadcast_rates(-ldd / wavelength, echoes.shape)
    return echoes


__all__ = ["PixelEngine", "PixelEngineError", "PixelGrid", "PixelRender"]
