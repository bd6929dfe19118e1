r"""Path engine: per-element echoes of an animation frame: PO direct echo, Sionna's multipath, random-phase diffuse.

The echo of a frame has three parts (each can be switched off for comparisons):

* **the coherent (specular) share of every reflection, by physical optics** (``physical_optics=True``):
  the lit surface is rendered from the array's phase centre (:mod:`sionnafmcw.engines.po_render`,
  the render shared with the pixel engine) and the PO integral of
  :mod:`sionnafmcw.physical_optics` is evaluated on its samples for every element pair, near-field
  exact (in Dr.Jit kernels over samples and pairs, :mod:`sionnafmcw.engines.po_kernel`, held to
  the numpy reference :func:`~sionnafmcw.engines.po_render.chain_po_gains` to rounding), with
  each material's complex reflection coefficient reduced to the coherent share
  :math:`\sqrt{1 - S^2}\,\Gamma` (power :math:`(1 - S^2)|\Gamma|^2`). A flat plate then returns
  :math:`4\pi A^2/\lambda^2` in the far field and the mirror image close in, a faceted sphere
  :math:`\pi r^2` (smoothed shading normals), whatever the tessellation. Sionna's first-order
  specular paths (exactly one interaction, specular) are dropped from the traced paths before
  the pair expansion, so nothing is counted twice. With ``multibounce="po"`` (default) the
  render's rays are also reflected and cast again up to ``max_depth`` bounces and every
  further surface carries the PO current of the image source's field (ray-tube PO on the exit
  aperture), which bounds a corner reflector by its aperture: a trihedral's triple bounce tends
  to :math:`4\pi a^4/(3\lambda^2)` in the far field and to the geometric-optics value close in
  (derivation in :mod:`~sionnafmcw.engines.po_render`); Sionna's purely specular chains are then
  dropped too. ``multibounce="sionna"`` keeps Sionna's specular chains of two or more
  interactions (image method, geometric optics). The PO contributions the radar cannot tell
  apart are merged per element pair (``po_merge``, :mod:`~sionnafmcw.engines.po_merge`: the channel
  at the carrier is kept exactly and the error stays within the merge's share of the noise budget);
* **Sionna's paths with a diffuse interaction** (and, with ``multibounce="sionna"``, its specular
  chains of two or more bounces), traced once for the whole array (below);
* **a random phase per diffuse scatterer** (``random_phase=True``): every path with a diffuse
  interaction is multiplied, once before the expansion to element pairs (so all pairs share it),
  by :math:`e^{j\phi}` with :math:`\phi` the sum over its diffuse interactions of
  :func:`sionnafmcw.diffuse.scatterer_phases` of (object, triangle, barycentric cell of
  :math:`\lambda/4`): fixed to the surface point, so it moves with the body and stays the same
  over chirps and frames, while neighbouring scatterers add in power -- the map power of a rough
  surface no longer grows with the ray count (6 dB per 4x rays before).

One :class:`~sionna.rt.Transmitter` and one :class:`~sionna.rt.Receiver` sit at the radar pose; with
``array_model="coherent"`` (default) Sionna traces once for the whole array and every element pair
gets the traced path with its own first and last segment (:mod:`~sionnafmcw.engines.element_pairs`,
which derives delay, gain and Doppler per pair and why the fixed interaction points are right);
``"per-element"`` traces every element for comparisons. Sionna's solver runs up to its path buffer
and the valid paths come out as numpy (:mod:`~sionnafmcw.engines.traced_paths`, which also removes
the specular copies Sionna returns twice).

Which surfaces each part sees, and the resolution each needs
------------------------------------------------------------
* **The direct echo and the PO multibounce** see every object's smooth surface
  (:mod:`~sionnafmcw.engines.surfaces`, built once in its own frame): the mesh's vertex normals
  rebuilt as curved PN triangles and tessellated until no sub-facet departs from it by more than
  :math:`\lambda/25` (:func:`~sionnafmcw.smooth_surface.refinement_level`), every PO sample moved onto
  it. A coherent echo needs the surface to a fraction of a wavelength; the user's mesh needs only
  normals that say where the surface is (2-20k triangles do).
* **Sionna traces the meshes as stored** (the *proxy*; a rigid object is written into its scene per
  frame): with ``multibounce="po"`` it contributes only the paths with a diffuse interaction, whose
  phase is random (``random_phase``), so they need the surface to a fraction of a *range bin*, not a
  wavelength. Rule: every facet lies within :data:`PROXY_SAGITTA_FRACTION` :math:`\Delta R`
  (:math:`\Delta R = c/2B`) of the smooth surface, i.e. :math:`e^2/8\rho \le \Delta R/8`: a diffuse
  scatterer then sits at most 1/8 of a range bin inside the skin. Its power follows the facet normal,
  which is off the surface's by at most half the normal's turn over an edge (0.3 rad with the body's
  :data:`~sionnafmcw.scenes.body.MAX_NORMAL_TURN`), a Lambertian lobe error that averages out over the
  facets to second order. A mesh coarser than the rule is traced as it is and reported
  (:class:`~.errors.ProxyResolutionWarning`, naming the edge length that would meet it); a finer one
  is traced as it is too (no decimation: Sionna's cost grows with the rays, hardly with the
  triangles, and the per-frame vertex update is what the rigid contract saves). The walker's 32 mm
  segments depart by at most 2.3 mm (foot and forearm): within the rule for bandwidths up to
  8 GHz (:math:`\Delta R/8` = 2.3 mm).

Conventions and choices
-----------------------
* **Orientation**: the radar pose is Sionna's ``(yaw, pitch, roll)`` (rad) applied to the radar
  frame (boresight local +x, azimuth along local y, elevation along local z). The element
  positions of ``RadarConfig`` are in that frame; Sionna rotates them with the same orientation.
* **No direct coupling**: the Tx and Rx elements are millimetres apart and Sionna drops segments
  shorter than 1 cm, so the solver runs with ``los=False``; Tx-Rx leakage is *not* modelled by
  this engine (add it on its own if wanted).
* **Labels**: each contribution is labelled with the object name of its *first* interaction (the
  object the transmitted wave hits first) by default. ``label="last"`` takes the last interaction
  (the object the receiver sees), ``label="moving"`` the first interaction on an object that moves
  in that frame (manifest or vertex velocity), falling back to the first. For single-bounce paths
  all three agree. Padding entries have the label ``""``.
* **Doppler**: rigid objects use Sionna's per-object velocity (the manifest velocity of the frame).
  For a mesh whose PLY carries per-vertex velocities ``vx, vy, vz``, Sionna's velocity of that
  object is set to zero and the engine adds, for every interaction on it,
  :math:`\mathbf v(\mathbf p)\cdot(\hat{\mathbf k}_{out} - \hat{\mathbf k}_{in})/\lambda` with
  :math:`\mathbf v(\mathbf p)` interpolated barycentrically at the interaction point and
  :math:`\lambda = c/f_c` -- Sionna's own formula, so a rigid field reproduces Sionna's value, and
  the sign is Sionna's (positive approaching).
* **No recompilation**: the scene is loaded once per animation (``merge_shapes=False`` so moving
  meshes stay separate objects); each frame writes the vertex positions of the meshes whose PLY
  changed through the Mitsuba scene parameters and the object velocities as parameter updates,
  with a fixed seed. The engine takes the solver's path buffer directly instead of building
  Sionna's ``Paths`` tensors (whose kernels bake the per-frame path count in as a constant and
  would recompile whenever it changes) and turns it into per-element arrays with numpy. The
  kernels of a geometry update are run once while loading, so from the second frame on no new
  kernel is launched at all (:attr:`PathEngine.stats`, ``new_kernel_hashes``).
* **Determinism**: a fixed seed gives the same rays, but Sionna's default candidate generator
  may order paths differently between runs and, rarely, keep or drop a path that grazes a
  triangle edge. ``deterministic=True`` uses Sionna's deterministic generator (identical output,
  about 4x slower on CPU).

Defaults (indoor 77 GHz radar)
------------------------------
``max_depth=2``: the target echo (one bounce) and the target-floor/wall multipath (two bounces),
the multipath that matters for an indoor radar; a third bounce costs about 50 % more time
(measured: 0.55 -> 0.86 s per frame in a closed room) for echoes tens of dB weaker.
``samples_per_src=100_000`` rays per source (the one source of the coherent model; per Tx
element with ``"per-element"``): about 750 rays on a person at 3 m (0.5 x 1.7 m). Specular and
diffuse reflection on (diffuse paths only carry energy on materials with a
``scattering_coefficient``), refraction off (through-wall paths at 77 GHz are negligible, and a
closed body is not a thin slab), diffraction off (first order only in Sionna, and weak at
millimetre waves). ``seed=1`` fixed, so a static scene gives the same rays every frame.

``static_scene=True``: the objects that never move are traced and rendered once per radar pose
and only what the moving objects change is done per frame (:mod:`~sionnafmcw.engines.static_scene`,
which derives why that is the whole frame). Measured on the circle walk (``python
benchmarks/circle_walk.py``, 100 frames, 3 solver seeds, 2 cores): ``simulate`` 0.92 s per frame
against 2.37 s with ``static_scene=False`` (0.386x), peak memory 0.78x, the same e_velo.

Sionna finds a multi-bounce specular chain only when one of its rays follows it. The coherent
model shoots ``samples_per_src`` rays once, :math:`M` times fewer than ``"per-element"``, so a
small corner reflector is found about as often as by one Tx element of a per-element trace
(measured, three 0.1 m trihedrals at 3-7 m: 1e5 rays find one of them, 1e6 all three; the
per-element trace with 1e5 rays found the nearest from one Tx element of three, an echo in 4 of
12 channels). Raise ``samples_per_src`` for small multi-bounce targets.

With ``physical_optics=False`` a faceted smooth body returns few purely specular echoes: a flat
facet sends the echo back only if its normal points at the radar to within about facet size /
range (a milliradian), while the facet normals of a 10k-triangle body are some 60 mrad apart.
With PO (default) the render's shading normals make the body the smooth surface it stands for
and its direct echo does not depend on ``samples_per_src`` (only the diffuse share does); the
render's cost grows with the surfaces in view (measured, circle walk in its closed room: some
3e5 rays and 1.9e5 samples per frame, 1.5e5 of them on the walls, floor and ceiling; about 4 s
of PO per frame on two shared cores, a profile of one frame; ``benchmarks/circle_walk_physics.py``).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..animation import Animation, RadarPose
from ..constants import SPEED_OF_LIGHT
from ..echoes import Echoes
from ..geometry import rotation_matrix
from ..sionna_rt import AntennaArray, PathSolver, Receiver, Transmitter, aligned_float, dr, mi, sionna_antenna_pattern
from .base import Engine
from .cpi_motion import (
    broadcast_rates, check_cpi_motion, frame_motion, interaction_accelerations, path_ends, render_range_accelerations,
    traced_range_accelerations, with_ego_doppler,
)
from .element_pairs import (
    coherent_echoes, diffuse_phases, interaction_velocities, path_labels, per_element_echoes, vertex_doppler,
)
from .errors import PathEngineError
from .traced_paths import TracedPaths, specular_chains, specular_duplicates, trace_paths
from .po_render import radio_material
from .surfaces import SurfaceWorld

_STATIC_BLOCKS = itertools.count()   # numbers the static echo blocks built in this process (their static_key)

#: The traced proxy's rule (module docstring, *Which surfaces each part sees*): facets within this
#: share of a range bin :math:`c/2B` of the smooth surface.
PROXY_SAGITTA_FRACTION = 1 / 8


def check_proxy_resolution(surfaces, radar) -> list[str]:
    """The objects of ``surfaces`` (a :class:`~.surfaces.SurfaceWorld`) whose stored mesh departs from
    its smooth surface by more than :data:`PROXY_SAGITTA_FRACTION` of ``radar``'s range bin, each
    reported by a :class:`~.errors.ProxyResolutionWarning` (object, departure, limit and the edge
    length that meets it: the sagitta grows as the edge squared)."""
    import warnings

    from .errors import ProxyResolutionWarning

    limit = PROXY_SAGITTA_FRACTION * SPEED_OF_LIGHT / (2 * radar.bandwidth)
    coarse = []
    for surface in surfaces.surfaces:
        if surface.bulge > limit:
            edge = surface.mesh_edge * np.sqrt(limit / surface.bulge)
            warnings.warn(f"object {surface.name!r}: its mesh departs from its smooth surface by up to "
                          f"{surface.bulge * 1e3:.2f} mm, more than 1/{round(1 / PROXY_SAGITTA_FRACTION)} of "
                          f"{radar.name!r}'s range bin ({limit * 1e3:.2f} mm): Sionna's diffuse paths on it may "
                          f"sit that far inside its surface; export it with edges of about {edge * 1e3:.1f} mm "
                          f"(now up to {surface.mesh_edge * 1e3:.1f} mm) where it curves most",
                          ProxyResolutionWarning, stacklevel=3)
            coarse.append(surface.name)
    return coarse


@dataclass
class _State:
    """Per-scene state of the path engine: the radar's devices and what is set in Sionna."""

    tx: object
    rx: object
    names_by_id: dict
    velocities: dict = field(default_factory=dict)  # name -> velocity currently set in Sionna
    pose: tuple | None = None
    materials: dict = field(default_factory=dict)   # name -> po_render.Material (PO)
    surfaces: object = None                          # surfaces.SurfaceWorld: the PO render's surfaces (PO)
    static: _StaticBlock | None = None               # the static scene of the current pose (static_scene=True)


@dataclass
class _StaticBlock:
    """The static scene at one radar pose (:mod:`~sionnafmcw.engines.static_scene`): its key (pose,
    static objects and their meshes), Sionna's static paths, the static PO, the echo block handed to
    every frame (``static_key`` set) and the seconds it took."""

    key: tuple
    paths: TracedPaths | None
    traced: Echoes | None
    po: object
    block: Echoes
    seconds: float
    object_ids: dict = field(default_factory=dict)    # name -> Sionna object id of the scene it was built in

    def for_scene(self, object_ids: dict, key: tuple) -> _StaticBlock:
        """This block for another load of the same static scene (:func:`keep_static_blocks`): Sionna's object
        ids are given per load, so the ids its paths and PO samples hold are those of ``object_ids`` (name ->
        id) instead; the arrays that hold none are shared."""
        old = np.array([self.object_ids[n] for n in sorted(self.object_ids)], dtype=np.int64)
        new = np.array([object_ids[n] for n in sorted(self.object_ids)], dtype=np.int64)
        order = np.argsort(old)
        old, new = old[order], new[order]

        def moved(ids):
            if ids is None or old.size == 0:
                return ids
            ids = np.asarray(ids)
            at = np.minimum(np.searchsorted(old, ids), old.size - 1)
            return np.where(old[at] == ids, new[at], ids).astype(ids.dtype)

        paths = None if self.paths is None else replace(self.paths, shapes=moved(self.paths.shapes))
        po = self.po
        if po is not None:
            renders = [replace(r, samples=replace(r.samples, object_id=moved(r.samples.object_id)),
                               one_object=moved(r.one_object)) for r in po.renders]
            po = replace(po, renders=renders)   # its ray index and the block views hold no ids: shared
        return replace(self, key=key, paths=paths, po=po, seconds=0.0, object_ids=dict(object_ids))


def _labelled(part: Echoes) -> Echoes:
    """The static block's ``part`` with its labels (empty names where it has none) and without Doppler
    rates (a static scene seen from a radar at rest has none): the same arrays, not copies."""
    labels = part.labels if part.labels is not None else np.zeros(part.num_contributions, dtype=str)
    return Echoes(part.a, part.tau, part.doppler, labels)


def _per_element_rates(paths: TracedPaths, rates, shape) -> np.ndarray:
    """``"per-element"``: the Doppler rates ``[P]`` of traced paths placed as :func:`per_element_echoes` places
    their gains (each path is one element pair's contribution), ``[M, N, K]``."""
    link = paths.source * shape[1] + paths.target
    order = np.argsort(link, kind="stable")
    counts = np.bincount(link, minlength=shape[0] * shape[1])
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.empty(paths.num_paths, dtype=np.int64)
    rank[order] = np.arange(paths.num_paths) - starts[link[order]]
    out = np.zeros(shape)
    out[paths.source, paths.target, rank] = rates
    return out


def _pose_key(pose: RadarPose) -> tuple:
    return tuple(np.round(np.concatenate([pose.position, pose.orientation]), 12))


#: The static block last built in this process, by its content (:func:`keep_static_blocks`): at most one.
_KEPT_BLOCKS: dict = {}
_KEEP_BLOCKS = False


def keep_static_blocks(enabled: bool = True) -> None:
    """Keep the static block (:mod:`~sionnafmcw.engines.static_scene`) a path engine of this process built last,
    for the next engine whose static scene is the same: the same static meshes (their files' bytes and
    placements), materials, shape ids, moving objects, radar, pose and engine settings. The block is built
    by deterministic code from exactly these, so a kept block is the one that engine would build, and
    its first frame skips the build (the static objects' trace, PO render, bounce rule and PO integral).

    For a data set's worker (:func:`~sionnafmcw.dataset.generate.run_item` turns it on): items that share
    their room and radar, as a fixed room does, build it once per worker, and :func:`~sionnafmcw.simulate`
    keeps its beat cube too. One block is kept (its memory: the static render); ``enabled=False`` drops it."""
    global _KEEP_BLOCKS
    _KEEP_BLOCKS = bool(enabled)
    if not _KEEP_BLOCKS:
        _KEPT_BLOCKS.clear()


def static_blocks_kept() -> bool:
    """Whether this process keeps static blocks (:func:`keep_static_blocks`)."""
    return _KEEP_BLOCKS


def _material_key(material) -> tuple:
    """What a radio material is: its class, name, parameters and scattering pattern's (full precision)."""
    params = mi.traverse(material)
    values = tuple((k, tuple(np.ravel(np.asarray(params[k], dtype=float)))) for k in sorted(params.keys()))
    pattern = getattr(material, "scattering_pattern", None)
    pattern_key = (type(pattern).__name__,) + tuple(
        (a, float(np.ravel(np.asarray(getattr(pattern, a)))[0])) for a in ("alpha_r", "alpha_i", "lambda_")
        if pattern is not None and hasattr(pattern, a))
    return type(material).__name__, str(getattr(material, "name", "")), values, pattern_key


class PathEngine(Engine):
    """Sionna RT path solver turned into per-element radar echoes.

    Parameters
    ----------
    max_depth : int
        Maximum number of interactions per path.
    samples_per_src : int
        Rays shot per source: the one source of ``array_model="coherent"``, every Tx element with
        ``"per-element"``.
    max_num_paths_per_src : int
        Candidate buffer size per source (Sionna's default).
    diffuse, specular, refraction, diffraction : bool
        Interaction types (see the module docstring for the defaults).
    seed : int
        Solver seed, fixed across frames.
    vertex_doppler : bool
        Use per-vertex velocities from the PLYs where present (else Sionna's per-object velocity).
    label : str
        ``"first"``, ``"last"`` or ``"moving"`` (see the module docstring).
    track_kernels : bool
        Record Dr.Jit kernel launches per frame in :attr:`last_stats` / :attr:`stats`.
    deterministic : bool
        Sionna's deterministic candidate generator (default): the same seed gives the same paths
        in the same order on every run, so the same cube (``benchmarks/determinism.py``: no
        measurable cost per frame). With ``False`` a fixed seed gives the same rays, but the order
        of the paths, and rarely a path near a triangle edge, can differ between runs.
    array_model : str
        ``"coherent"`` (one trace from the Tx centre to the Rx centre, every element pair from the
        interaction points) or ``"per-element"`` (every element a source / target; for
        comparisons). See the module docstring.
    deduplicate : bool
        Keep one of every group of coincident specular paths (:func:`specular_duplicates`).
    physical_optics : bool
        PO direct echo from the render of :mod:`~sionnafmcw.engines.po_render` in place of
        Sionna's first-order specular paths (needs ``array_model="coherent"``).
    multibounce : str
        ``"po"``: ray-tube PO up to ``max_depth`` bounces replaces Sionna's specular chains;
        ``"sionna"``: Sionna's specular chains of two or more interactions are kept.
    random_phase : bool
        A random phase fixed to every diffuse scatterer (:mod:`sionnafmcw.diffuse`).
    po_samples_across : int
        Render samples across an object at least (:func:`~sionnafmcw.physical_optics.render_resolution`).
    po_merge : bool
        Merge the PO contributions per delay/Doppler cell of 1/256 of the resolutions
        (:data:`~sionnafmcw.engines.po_render.MERGE_FRACTION`).
    static_scene : bool
        Trace and render the objects that do not move once per radar pose, and per frame only what
        the moving objects change (:mod:`~sionnafmcw.engines.static_scene`): the same echoes up to
        the PO merge error, and a static echo block whose beat cube the synthesizer reuses. Used only
        in frames where the radar is at rest (a moving radar sees no static clutter: every frame is
        traced and rendered whole).
    cpi_motion : str
        ``"frozen"`` (default): every contribution keeps the frame's Doppler over the CPI;
        ``"quadratic"``: each also gets its Doppler rate from the accelerations of its interaction
        points and of the radar (motion within the CPI, :mod:`~sionnafmcw.engines.cpi_motion`).
        The radar's own velocity (a moving radar) enters the Doppler either way.
    po_bounce_rule : bool
        True (default): every multi-bounce exit aperture sampled by the error rule of
        :mod:`~sionnafmcw.engines.bounce_sampling` (the tubes along an outline split where its error
        may exceed a share of the object's echo); False: the chains at the first bounce's density (the
        engine before the rule, for comparisons: a corner reflector off its axis is then off by up to
        3 dB, a room's corners by up to 8 dB).
    po_flat_faces : bool
        True (default): the own chains of every object made of a few convex plane faces (corner
        reflectors, plates, small boxes: :mod:`~sionnafmcw.engines.flat_faces`) integrated over their
        exact apertures instead of sampled; False: sampled like every other surface (a corner reflector
        45 degrees off its axis is then off by up to 10 dB).

    Notes
    -----
    :attr:`last_paths` holds the :class:`TracedPaths` of the last frame (after de-duplication),
    with their interaction points. :attr:`stats` figures: ``num_paths`` (valid contributions of
    the frame over all element pairs, after de-duplication: :math:`MN` times the traced paths with
    ``"coherent"``), ``num_traced_paths`` (the paths Sionna traced and the engine kept: shared by
    all element pairs with ``"coherent"``, one element pair each with ``"per-element"``) and
    ``num_duplicates`` (specular copies removed), ``num_replaced_specular`` (Sionna's specular
    chains that PO replaced), ``po_rays``, ``po_samples``, ``po_contributions`` (after merging)
    and ``po_seconds``; ``trace_seconds`` (Sionna's trace) and ``adapt_seconds`` (paths to element
    pairs); with ``static_scene``: ``static_seconds`` (building the static scene in this frame, 0
    when it was reused), ``static_paths`` / ``static_blocked_paths`` (Sionna's static paths and those
    a moving object blocks in this frame), ``static_po_samples`` / ``static_po_removed`` (likewise for
    the PO samples); ``po_samples`` and ``po_contributions`` then count the frame's own renders.
    :attr:`last_renders` holds the PO :class:`~sionnafmcw.engines.po_render.Render` of every bounce
    (with ``static_scene``: the static scene's, cached, followed by the frame's own),
    :attr:`last_parts` the frame's ``"traced"`` and ``"po"`` echoes apart.
    """

    name = "path"
    FIXED_SETTINGS = {"los": False}
    LABELS = ("first", "last", "moving")
    ARRAY_MODELS = ("coherent", "per-element")
    MULTIBOUNCE = ("po", "sionna")

    def __init__(self, max_depth: int = 2, samples_per_src: int = 100_000, max_num_paths_per_src: int = 1_000_000,
                 diffuse: bool = True, specular: bool = True, refraction: bool = False, diffraction: bool = False,
                 seed: int = 1, vertex_doppler: bool = True, label: str = "first", track_kernels: bool = True,
                 deterministic: bool = True, array_model: str = "coherent", deduplicate: bool = True,
                 physical_optics: bool = True, multibounce: str = "po", random_phase: bool = True,
                 po_samples_across: int = 16, po_merge: bool = True, static_scene: bool = True,
                 cpi_motion: str = "frozen", po_bounce_rule: bool = True, po_flat_faces: bool = True):
        if label not in self.LABELS:
            raise PathEngineError(f"PathEngine: label={label!r} is unknown; choose one of {', '.join(self.LABELS)}")
        if array_model not in self.ARRAY_MODELS:
            raise PathEngineError(f"PathEngine: array_model={array_model!r} is unknown; choose one of "
                                  f"{', '.join(self.ARRAY_MODELS)}")
        if multibounce not in self.MULTIBOUNCE:
            raise PathEngineError(f"PathEngine: multibounce={multibounce!r} is unknown; choose one of "
                                  f"{', '.join(self.MULTIBOUNCE)}")
        check_cpi_motion(cpi_motion, PathEngineError, "PathEngine")
        if physical_optics and array_model != "coherent":
            raise PathEngineError("PathEngine: physical_optics=True needs array_model='coherent' (one set of "
                                  "scatterers for the whole array); pass physical_optics=False for 'per-element'")
        for name, value, low in (("max_depth", max_depth, 1), ("samples_per_src", samples_per_src, 1),
                                 ("max_num_paths_per_src", max_num_paths_per_src, 1), ("seed", seed, 0),
                                 ("po_samples_across", po_samples_across, 1)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise PathEngineError(
                    f"PathEngine: {name} must be an integer >= {low}, got {value!r}"
                    + (" (with los=False a depth-0 radar sees nothing)" if name == "max_depth" else "")
                )
        super().__init__(track_kernels=track_kernels)
        self.max_depth = int(max_depth)
        self.samples_per_src = int(samples_per_src)
        self.max_num_paths_per_src = int(max_num_paths_per_src)
        self.diffuse = bool(diffuse)
        self.specular = bool(specular)
        self.refraction = bool(refraction)
        self.diffraction = bool(diffraction)
        self.seed = int(seed)
        self.vertex_doppler = bool(vertex_doppler)
        self.label = label
        self.deterministic = bool(deterministic)
        self.array_model = array_model
        self.deduplicate = bool(deduplicate)
        self.physical_optics = bool(physical_optics)
        self.multibounce = multibounce
        self.random_phase = bool(random_phase)
        self.po_samples_across = int(po_samples_across)
        self.po_merge = bool(po_merge)
        self.static_scene = bool(static_scene)
        self.cpi_motion = cpi_motion
        self.po_bounce_rule = bool(po_bounce_rule)
        self.po_flat_faces = bool(po_flat_faces)
        self._motion = None
        self._solver = PathSolver(deterministic=self.deterministic)
        self.last_paths: TracedPaths | None = None
        self.last_renders: list = []
        self.last_exact_renders: list = []
        self.last_exact_ids: frozenset = frozenset()
        self._last_pieces: dict = {}

    def _settings(self) -> dict:
        return {"max_depth": self.max_depth, "samples_per_src": self.samples_per_src,
                "max_num_paths_per_src": self.max_num_paths_per_src, "diffuse": self.diffuse,
                "specular": self.specular, "refraction": self.refraction, "diffraction": self.diffraction,
                "seed": self.seed, "deterministic": self.deterministic, "vertex_doppler": self.vertex_doppler,
                "label": self.label, "array_model": self.array_model, "deduplicate": self.deduplicate,
                "physical_optics": self.physical_optics, "multibounce": self.multibounce,
                "random_phase": self.random_phase, "po_samples_across": self.po_samples_across,
                "po_merge": self.po_merge, "static_scene": self.static_scene, "cpi_motion": self.cpi_motion,
                "po_bounce_rule": self.po_bounce_rule, "po_flat_faces": self.po_flat_faces}

    @property
    def coherent(self) -> bool:
        return self.array_model == "coherent"

    # ------------------------------------------------------------------ hooks
    def _load(self, scene, animation: Animation, radar) -> _State:
        """The radar's Tx and Rx and a velocity parameter per object.

        ``"coherent"``: one element at the centre of the Tx elements and one at the centre of the
        Rx elements; ``"per-element"``: the radar's exact element layout.
        """
        wavelength = float(scene.wavelength[0]) if hasattr(scene.wavelength, "__len__") else float(scene.wavelength)
        pattern = sionna_antenna_pattern(radar.antenna_pattern, polarization="V")
        pattern_rx = sionna_antenna_pattern(radar.antenna_pattern, polarization="V")

        def array(positions, pat):
            p = np.asarray(positions, dtype=float) / wavelength
            return AntennaArray(pat, mi.Point3f(*[aligned_float(p[:, i]) for i in range(3)]))

        if self.coherent:
            tx_positions = radar.tx_positions.mean(axis=0, keepdims=True)
            rx_positions = radar.rx_positions.mean(axis=0, keepdims=True)
        else:
            tx_positions, rx_positions = radar.tx_positions, radar.rx_positions
        scene.tx_array = array(tx_positions, pattern)
        scene.rx_array = array(rx_positions, pattern_rx)
        tx = Transmitter("radar-tx", position=mi.Point3f(0, 0, 0), orientation=mi.Point3f(0, 0, 0))
        rx = Receiver("radar-rx", position=mi.Point3f(0, 0, 0), orientation=mi.Point3f(0, 0, 0))
        scene.add(tx)
        scene.add(rx)

        names_by_id = {}
        materials = {}
        for name, obj in scene.objects.items():
            names_by_id[int(obj.object_id)] = name
            obj.velocity = mi.Vector3f(0.0, 0.0, 0.0)  # create every velocity parameter up front
            if self.physical_optics:
                materials[name] = radio_material(obj.radio_material, name)
        surfaces = SurfaceWorld.build(animation, list(scene.objects), wavelength=wavelength) \
            if self.physical_optics or self.static_scene else None
        if surfaces is not None:
            check_proxy_resolution(surfaces, radar)
        return _State(tx, rx, names_by_id, materials=materials, surfaces=surfaces)

    def _geometry_changed(self) -> None:
        self._loaded.scene.scene_geometry_updated()

    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        self._set_pose(pose)
        velocities = self._update_velocities(animation, frame)
        wavelength = SPEED_OF_LIGHT / radar.fc
        loaded = self._loaded
        rigid = {name: np.asarray(animation.frame(frame).objects.get(name, np.zeros(3)), float)
                 for name in loaded.scene.objects}
        self._motion = motion = frame_motion(animation, frame, pose, radar, list(loaded.scene.objects),
                                             self.cpi_motion == "quadratic", self.vertex_doppler)
        static, spheres, moving_ids = None, None, frozenset()
        figures = {}
        world = self._state.surfaces
        if world is not None:
            world.place(animation, frame, loaded, rigid, motion)
        if self.static_scene and motion.radar_at_rest:
            from .static_scene import Spheres

            moving = frozenset(world.names[k] for k in world.moving())
            moving_ids = frozenset(int(loaded.scene.objects[n].object_id) for n in moving)
            static, built = self._static_block(animation, radar, pose, velocities, rigid, moving, wavelength)
            spheres = Spheres.around([loaded.vertices[n] for n in sorted(moving)])
            figures["static_seconds"] = built
        t0 = time.perf_counter()
        paths, filtered = self._traced_paths(wavelength)
        if static is not None and paths.num_paths:
            paths = paths.select(np.any(paths.valid_interactions & np.isin(paths.shapes, list(moving_ids)), axis=1))
        figures["trace_seconds"] = time.perf_counter() - t0
        figures.update(filtered)
        t0 = time.perf_counter()
        traced = self._traced_echoes(paths, velocities, radar, pose, wavelength)
        pieces = {"traced": [traced], "po": []}
        alive = paths
        if static is not None:
            pieces["traced"].insert(0, static.traced)
            num_blocked = 0
            if static.paths is not None and static.paths.num_paths:
                blocked = self._blocked_paths(static.paths, spheres, moving_ids)
                num_blocked = int(blocked.sum())
                if num_blocked:
                    removed = self._traced_echoes(static.paths.select(blocked), velocities, radar, pose, wavelength)
                    pieces["traced"].append(Echoes(-removed.a, removed.tau, removed.doppler, removed.labels))
                alive = TracedPaths.concatenate([static.paths.select(~blocked), paths])
            figures.update(static_paths=0 if static.paths is None else static.paths.num_paths,
                           static_blocked_paths=num_blocked)
        figures["adapt_seconds"] = time.perf_counter() - t0
        self.last_paths = alive
        figures["num_traced_paths"] = alive.num_paths
        figures["num_paths"] = (radar.num_tx * radar.num_rx if self.coherent else 1) * alive.num_paths
        if self.physical_optics:
            po, removed_po, po_figures = self._po_echoes(animation, radar, pose, rigid, wavelength, static)
            figures.update(po_figures)
            pieces["po"] = [None if static is None or static.po is None else static.po.echoes, removed_po, po]
        self._last_pieces = pieces
        first = 1 if static is not None else 0   # the static block comes first in each kind
        dynamic = [e for e in (*pieces["traced"][first:], *pieces["po"][first:]) if e is not None]
        if static is not None:
            return Echoes.concatenate([static.block, *dynamic]), figures
        if not dynamic:
            e = Echoes.empty(radar.num_tx, radar.num_rx)
            e.labels = np.zeros((radar.num_tx, radar.num_rx, 0), dtype=str)
            return e, figures
        return (dynamic[0] if len(dynamic) == 1 else Echoes.concatenate(dynamic)), figures

    @property
    def last_parts(self) -> dict:
        """The last frame's echoes by kind: ``"traced"`` (Sionna's paths) and ``"po"`` (the PO echo),
        each whole (static block, blocked static contributions with the opposite sign, the frame's
        own) or None when empty."""
        out = {}
        for kind, parts in getattr(self, "_last_pieces", {}).items():
            parts = [p for p in parts if p is not None and p.num_contributions]
            out[kind] = None if not parts else (parts[0] if len(parts) == 1 else Echoes.concatenate(parts))
        if not self.physical_optics:
            out.pop("po", None)
        return out

    # ------------------------------------------------------------------ Sionna's paths
    def _traced_paths(self, wavelength: float):
        """The frame's trace without the specular chains PO replaces and without specular copies, and its figures."""
        paths = trace_paths(self._solver, self._loaded.scene, samples_per_src=self.samples_per_src,
                            max_num_paths_per_src=self.max_num_paths_per_src, max_depth=self.max_depth,
                            specular=self.specular, diffuse=self.diffuse, refraction=self.refraction,
                            diffraction=self.diffraction, seed=self.seed)
        num_duplicates = num_replaced = 0
        if self.physical_optics and paths.num_paths:
            # PO replaces Sionna's specular chains: the first-order mirror paths always, the longer
            # chains with multibounce="po" (ray-tube PO on the exit aperture, po_render)
            replaced = specular_chains(paths, 1 if self.multibounce == "sionna" else None)
            num_replaced = int(replaced.sum())
            if num_replaced:
                paths = paths.select(~replaced)
        if self.deduplicate and paths.num_paths:
            duplicate = specular_duplicates(paths, wavelength)
            num_duplicates = int(duplicate.sum())
            if num_duplicates:
                paths = paths.select(~duplicate)
        return paths, {"num_duplicates": num_duplicates, "num_replaced_specular": num_replaced}

    def _traced_echoes(self, paths: TracedPaths, velocities: dict, radar, pose: RadarPose,
                       wavelength: float) -> Echoes | None:
        """Per element pair echoes of traced paths (None when there are none); ``paths`` is not changed.
        The radar's motion adds its ego-Doppler, ``cpi_motion="quadratic"`` the Doppler rates
        (:mod:`~sionnafmcw.engines.cpi_motion`)."""
        if not paths.num_paths:
            return None
        loaded, names_by_id, motion = self._loaded, self._state.names_by_id, self._motion
        vertex_velocity, velocity = interaction_velocities(paths, loaded, velocities, self.vertex_doppler)
        doppler = paths.doppler + vertex_doppler(paths, vertex_velocity, wavelength)
        labels = path_labels(paths, loaded, names_by_id, velocities, self.label, self.vertex_doppler)
        rates = None
        if motion.quadratic:
            acceleration = interaction_accelerations(paths, loaded, motion)
            if self.coherent:
                ends = (motion.tx_centre, motion.rx_centre)
            else:
                ends = (motion.tx[paths.source], motion.rx[paths.target])
            rates = -traced_range_accelerations(paths, velocity, acceleration, names_by_id, motion, *ends) / wavelength
        if self.random_phase:
            paths = replace(paths, a=paths.a * np.exp(1j * diffuse_phases(paths, loaded, names_by_id, wavelength)))
        first, last = path_ends(paths)
        if self.coherent:
            echoes = coherent_echoes(paths, doppler, velocity, labels, radar, pose, wavelength)
            echoes.doppler = with_ego_doppler(echoes.doppler, motion, first, last, wavelength)
        else:
            if motion.radar_moves:
                rows = np.arange(paths.num_paths)
                ego = with_ego_doppler(np.zeros((radar.num_tx, radar.num_rx, paths.num_paths)), motion, first, last,
                                       wavelength)
                doppler = doppler + ego[paths.source, paths.target, rows]
            echoes = per_element_echoes(paths, doppler, labels, radar)
            if rates is not None:
                rates = _per_element_rates(paths, rates, echoes.shape)
        if rates is not None:
            echoes.doppler_rate = rates if rates.ndim == 3 else broadcast_rates(rates, echoes.shape)
        return echoes

    def _blocked_paths(self, paths: TracedPaths, spheres, moving_ids) -> np.ndarray:
        """``[P]`` bool: the static paths with a segment that a moving object blocks in this frame."""
        from .static_scene import blocked_segments

        starts, ends, used = paths.segments()
        d = ends - starts
        length = np.linalg.norm(d, axis=-1)
        used &= length > 0
        p, j = np.nonzero(used)
        k = d[p, j] / length[p, j, None]
        near = spheres.meet(starts[p, j], k, length[p, j])
        p, j = p[near], j[near]
        blocked = np.zeros(paths.num_paths, dtype=bool)
        hit = blocked_segments(self._loaded, starts[p, j], ends[p, j], moving_ids)
        blocked[p[hit]] = True
        return blocked

    # ------------------------------------------------------------------ the static scene
    def _static_block(self, animation: Animation, radar, pose: RadarPose, velocities: dict, rigid: dict,
                      moving: frozenset, wavelength: float):
        """The static scene of this pose (built when the pose or the static objects changed) and the
        seconds spent building it in this frame (:mod:`~sionnafmcw.engines.static_scene`)."""
        from .static_scene import StaticPO, hidden

        loaded, state = self._loaded, self._state
        key = (_pose_key(pose), tuple(sorted((n, loaded.loaded_files.get(n)) for n in loaded.shape_ids
                                             if n not in moving)))
        if state.static is not None and state.static.key == key:
            return state.static, 0.0
        content = self._static_content(radar, pose, moving) if _KEEP_BLOCKS else None
        object_ids = {n: int(loaded.scene.objects[n].object_id) for n in loaded.shape_ids if n not in moving}
        if content is not None and content in _KEPT_BLOCKS:   # another engine of this process built it
            state.static = _KEPT_BLOCKS[content].for_scene(object_ids, key)
            return state.static, 0.0
        _KEPT_BLOCKS.clear()
        t0 = time.perf_counter()
        state.static = None
        with hidden(loaded, moving):   # Sionna's trace of the static objects alone
            paths, _ = self._traced_paths(wavelength)
            traced = self._traced_echoes(paths, velocities, radar, pose, wavelength)
        po = None
        if self.physical_optics:   # the PO render casts over the static surfaces alone
            objects, centre, rot, tx_w, rx_w = self._po_geometry(animation, radar, pose, rigid)
            po = StaticPO.build(state.surfaces, objects, centre, rot, wavelength, self._po_depth,
                                self.po_samples_across,
                                lambda b: self._po_contributions(b, radar, tx_w, rx_w, rot, wavelength),
                                lambda b, c: self._po_merge(radar, b, c, centre, rot, "static"), self._max_splits,
                                self._exact_ids(objects))
        parts = [e for e in (traced, None if po is None else po.echoes) if e is not None]
        # one copy of the static echoes: the block's arrays joined once, the PO echoes and the merge's cells
        # then views of them (the parts' own arrays freed), so the synthesis reads the block as views too
        joined = Echoes.concatenate(parts or [Echoes.empty(radar.num_tx, radar.num_rx)]).map_parts(_labelled)
        block = Echoes(joined.a, joined.tau, joined.doppler, joined.labels, static_count=joined.num_contributions,
                       static_key=("path-engine-static", next(_STATIC_BLOCKS)))
        del joined, parts
        if po is not None and po.echoes is not None:
            po.share(block, 0 if traced is None else traced.num_contributions)
        state.static = _StaticBlock(key, paths if paths.num_paths else None, traced, po, block,
                                    time.perf_counter() - t0, object_ids)
        if content is not None:
            _KEPT_BLOCKS[content] = state.static
        return state.static, state.static.seconds

    def _static_content(self, radar, pose: RadarPose, moving: frozenset) -> str:
        """A digest of everything the static block is built from (:func:`keep_static_blocks`): engine settings,
        radar, pose, and per object its name and Mitsuba id, whether it moves and, for a static one, its mesh
        file's bytes (or the geometry Mitsuba loaded), placement and radio material. Not Sionna's object ids,
        which each load gives anew (:meth:`_StaticBlock.for_scene` moves a kept block to the new ones)."""
        import hashlib
        import json

        loaded = self._loaded
        digest = hashlib.sha256()
        digest.update(json.dumps([self._settings(), radar.to_dict(), _pose_key(pose)], sort_keys=True,
                                 default=repr).encode())
        for name in sorted(loaded.shape_ids):
            obj = loaded.scene.objects[name]
            digest.update(repr((name, loaded.shape_ids[name], name in moving)).encode())
            if name in moving:
                continue
            source = loaded.loaded_files.get(name)
            if source is not None and source[0] != "not-ply":
                digest.update(Path(source[0]).read_bytes())
                digest.update(repr(source[2]).encode())
            else:
                digest.update(np.ascontiguousarray(loaded.vertices[name]).tobytes())
                digest.update(np.ascontiguousarray(loaded.faces[name]).tobytes())
                digest.update(repr(None if source is None else source[1]).encode())
            digest.update(repr(_material_key(obj.radio_material)).encode())
        return digest.hexdigest()

    # ------------------------------------------------------------------ physical optics
    @property
    def _max_splits(self) -> int | None:
        """Rounds of :func:`~.bounce_sampling.resolved_bounces`: its default with ``po_bounce_rule``, else none."""
        return None if self.po_bounce_rule else 0

    def _exact_ids(self, objects) -> frozenset:
        """Sionna ids of the objects whose own chains :mod:`~sionnafmcw.engines.flat_faces` integrates (none
        without ``po_flat_faces``)."""
        from .flat_faces import exact_objects

        return frozenset(objects[k].shape_id for k in exact_objects(objects)) if self.po_flat_faces else frozenset()

    @property
    def _po_depth(self) -> int:
        return self.max_depth if (self.multibounce == "po" and self.specular) else 1

    def _po_geometry(self, animation: Animation, radar, pose: RadarPose, rigid: dict):
        """The PO render's objects (the surfaces placed in the frame), its origin (the array's phase
        centre), the radar rotation and the Tx / Rx element positions (world)."""
        from .po_render import scene_objects

        rot = rotation_matrix(pose.orientation)
        centre = np.asarray(pose.position, float) + rot @ radar.phase_centre
        tx_w = np.asarray(pose.position, float) + radar.tx_positions @ rot.T
        rx_w = np.asarray(pose.position, float) + radar.rx_positions @ rot.T
        objects = scene_objects(self._loaded, self._state.surfaces, self._state.materials,
                                vertex_doppler=self.vertex_doppler)
        return objects, centre, rot, tx_w, rx_w

    def _po_contributions(self, bounce, radar, tx_w, rx_w, rot, wavelength: float):
        """``(a, tau, doppler, labels)`` of a render's samples for every element pair (element gains
        included): :func:`~sionnafmcw.engines.po_kernel.element_pair_po`, the Dr.Jit kernel of
        :func:`~sionnafmcw.engines.po_render.chain_po_gains`, and the radar's ego-Doppler when it moves."""
        from .po_kernel import element_pair_po

        if bounce.outline is None:
            a, tau, doppler = element_pair_po(bounce, tx_w, rx_w, rot, wavelength, radar.antenna_pattern)
        else:   # cut pieces of an exact aperture: point samples times their outline's factor
            from .flat_faces import piece_factor

            a, tau, doppler = element_pair_po(bounce, tx_w, rx_w, rot, wavelength, radar.antenna_pattern,
                                              in_sample_phase=False)
            a *= piece_factor(bounce, tx_w, rx_w, wavelength)
        doppler = with_ego_doppler(doppler, self._motion, bounce.first_point, bounce.samples.position, wavelength)
        return a, tau, doppler, bounce.samples.labels

    def _po_rates(self, bounce, wavelength: float):
        """Doppler rates ``[P]`` (Hz/s) of a render's samples with ``cpi_motion="quadratic"``, else None."""
        if not self._motion.quadratic or bounce.acceleration is None:
            return None
        return -render_range_accelerations(bounce, self._motion) / wavelength

    def _po_merge(self, radar, bounce, contributions, centre, rot, block: str, rates=None):
        """A render's PO contributions ``(a, tau, doppler, labels)`` merged within the ``block``'s share
        (``"static"`` or ``"frame"``, :data:`~sionnafmcw.synthesis.STATIC_BUDGET_SHARE`) of the merge
        budget (:func:`~sionnafmcw.engines.po_merge.merge_contributions`); None without ``po_merge``."""
        from ..synthesis import STATIC_BUDGET_SHARE
        from .po_merge import merge_budget, merge_contributions

        if not self.po_merge:
            return None
        share = STATIC_BUDGET_SHARE if block == "static" else 1.0 - STATIC_BUDGET_SHARE
        rate = None if rates is None else broadcast_rates(rates, np.shape(contributions[0]))
        return merge_contributions(*contributions, bounce.directions(centre, rot), radar, merge_budget(radar, share),
                                   doppler_rate=rate)

    def _po_echoes(self, animation: Animation, radar, pose: RadarPose, rigid: dict, wavelength: float, static=None):
        """PO echoes of the frame: the render from the phase centre and, with ``multibounce="po"``, its
        reflections up to ``max_depth`` bounces (:mod:`sionnafmcw.engines.po_render`), every element
        pair near-field exact, merged per delay/Doppler cell of :data:`~.po_render.MERGE_FRACTION` of
        the resolutions; ``rigid``: name -> the frame's rigid velocity (m/s). With the static scene
        cached (``static``), only the frame's own renders (what the moving objects change) and the
        blocked static samples (``removed``, opposite sign). Returns ``(echoes, removed, figures)``."""
        from .bounce_sampling import resolved_bounces
        from .flat_faces import exact_objects, exact_renders
        from .po_render import render

        t0 = time.perf_counter()
        world = self._state.surfaces
        objects, centre, rot, tx_w, rx_w = self._po_geometry(animation, radar, pose, rigid)
        depth = self._po_depth
        exact = exact_objects(objects) if self.po_flat_faces else {}
        exact_ids = self.last_exact_ids = frozenset(objects[k].shape_id for k in exact)
        removed, num_removed = None, 0
        origin_motion = {}
        if self._motion.quadratic or self._motion.radar_moves:
            from ..kinematics import element_kinematics

            origin = element_kinematics(pose, radar.phase_centre[None])
            origin_motion = {"origin_velocity": origin.velocity[0], "origin_acceleration": origin.acceleration[0]}
        if static is not None and static.po is not None:
            renders, removed, num_removed = static.po.frame(
                world, objects, centre, rot, wavelength, depth, self.po_samples_across,
                lambda b: self._po_contributions(b, radar, tx_w, rx_w, rot, wavelength), radar.fc, self._max_splits,
                exact_ids)
            self.last_renders = [*static.po.renders, *renders]
        else:
            first = render(world, objects, centre, rot, wavelength, samples_across=self.po_samples_across,
                           **origin_motion)
            renders = resolved_bounces(world, first, objects, rot, wavelength, depth, self.po_samples_across,
                                       max_splits=self._max_splits, exact_ids=exact_ids)
            self.last_renders = renders
        if exact:
            motion = (origin_motion["origin_velocity"], origin_motion["origin_acceleration"]) if origin_motion \
                else None
            self.last_exact_renders = exact_renders(world, objects, exact, centre, rot, wavelength, depth,
                                                    self.po_samples_across, origin_motion=motion)
        else:
            self.last_exact_renders = []
        echoes = []
        num_samples = 0
        # the tube renders without the exact objects' own chains, then those chains' exact pieces
        for b, keep in [*((b, b.carries_po(exact_ids)) for b in renders),
                        *((b, b.carries_po()) for b in self.last_exact_renders)]:
            if not np.any(keep):
                continue
            num_samples += int(keep.sum())
            kept = b.select(keep)
            contributions = self._po_contributions(kept, radar, tx_w, rx_w, rot, wavelength)
            rates = self._po_rates(kept, wavelength)
            merged = self._po_merge(radar, kept, contributions, centre, rot, "frame", rates)
            if merged is None:
                rate = None if rates is None else broadcast_rates(rates, np.shape(contributions[0]))
                echoes.append(Echoes(*contributions, doppler_rate=rate))
            else:
                echoes.append(Echoes(merged.a, merged.tau, merged.doppler, merged.labels,
                                     doppler_rate=merged.doppler_rate))
        figures = {"po_rays": int(sum(b.num_rays for b in renders)), "po_samples": num_samples,
                   "po_contributions": int(sum(e.num_contributions for e in echoes)),
                   "po_seconds": time.perf_counter() - t0}
        if static is not None and static.po is not None:
            figures.update(static_po_samples=static.po.num_samples, static_po_removed=num_removed)
        po = None if not echoes else (echoes[0] if len(echoes) == 1 else Echoes.concatenate(echoes))
        return po, removed, figures

    # ------------------------------------------------------------------ per frame
    def _update_velocities(self, animation: Animation, frame: int) -> dict:
        """Set Sionna's object velocities; returns the velocity used per object (m/s)."""
        state, loaded = self._state, self._loaded
        used = {}
        fr = animation.frame(frame)
        for name, obj in loaded.scene.objects.items():
            v = np.asarray(fr.objects.get(name, np.zeros(3)), dtype=float)
            if self.vertex_doppler and loaded.vertex_velocity.get(name) is not None:
                v = np.zeros(3)  # the per-vertex field replaces Sionna's rigid velocity
            used[name] = v
            if name not in state.velocities or not np.array_equal(state.velocities[name], v):
                obj.velocity = mi.Vector3f(float(v[0]), float(v[1]), float(v[2]))
                state.velocities[name] = v
        return used

    def _set_pose(self, pose: RadarPose) -> None:
        state = self._state
        key = _pose_key(pose)
        if state.pose == key:
            return
        p = [float(x) for x in pose.position]
        o = [float(x) for x in pose.orientation]
        for dev in (state.tx, state.rx):
            # opaque: a literal pose would be baked into the first frame's kernels
            position, orientation = mi.Point3f(*p), mi.Point3f(*o)
            dr.make_opaque(position, orientation)
            dev.position = position
            dev.orientation = orientation
        state.pose = key


__all__ = ["PROXY_SAGITTA_FRACTION", "PathEngine", "PathEngineError", "check_proxy_resolution", "keep_static_blocks",
           "static_blocks_kept"]
