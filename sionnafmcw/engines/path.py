r"""Path engine: per-element echoes of an animation frame: PO direct echo, Sionna's multipath, random-phase diffuse.

The echo of a frame has three parts (issue 11; each can be switched off for comparisons):

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
  interactions (image method, geometric optics). The PO contributions are merged per element
  pair into cells of 1/256 of the range and velocity resolution (``po_merge``,
  :data:`~sionnafmcw.engines.po_render.MERGE_FRACTION`,
  :func:`~sionnafmcw.engines.po_render.merge_contributions`: the channel at the carrier is kept
  exactly);
* **Sionna's paths with a diffuse interaction** (and, with ``multibounce="sionna"``, its specular
  chains of two or more bounces), traced once for the whole array (below);
* **a random phase per diffuse scatterer** (``random_phase=True``): every path with a diffuse
  interaction is multiplied, once before the expansion to element pairs (so all pairs share it),
  by :math:`e^{j\phi}` with :math:`\phi` the sum over its diffuse interactions of
  :func:`sionnafmcw.diffuse.scatterer_phases` of (object, triangle, barycentric cell of
  :math:`\lambda/4`): fixed to the surface point, so it moves with the body and stays the same
  over chirps and frames, while neighbouring scatterers add in power -- the map power of a rough
  surface no longer grows with the ray count (6 dB per 4x rays before).

One :class:`~sionna.rt.Transmitter` and one :class:`~sionna.rt.Receiver` sit at the radar pose
(pattern ``radar.antenna_pattern``, vertical polarisation). How the radar's elements see the
traced paths is the option ``array_model``:

* ``"coherent"`` (default): Sionna traces **once for the whole array**, from one source at the
  centre of the Tx elements :math:`\mathbf t_0` to one target at the centre of the Rx elements
  :math:`\mathbf r_0` (not both at the common phase centre: exactly co-located Tx and Rx make the
  retro-reflected paths degenerate, see :data:`RADAR_MIN_SEGMENT_LENGTH`). Every traced path
  :math:`\mathbf t_0 \to \mathbf v_1 \to \dots \to \mathbf v_d \to \mathbf r_0` keeps its
  interaction points, and every element pair :math:`(m, n)` gets it with its own first and last
  segment (below). The whole array sees one set of scatterers, as a real surface is one set of
  scatterers for a few-centimetre array, and the phase between the Tx blocks of a diffuse echo
  follows the array geometry (what MIMO angle processing relies on). It traces :math:`M` times
  fewer rays than ``"per-element"`` and leaves :math:`MN` times fewer paths to adapt.
* ``"per-element"``: Sionna's ``synthetic_array=False``: every Tx element is a source and every
  Rx element a target. Each Tx element then draws its **own** diffuse scatterers (two elements
  share 0-2.5 % of their body hits, measured in issue 11) and the Tx-block phases of diffuse
  echoes are scrambled: three speckle looks no radar gets. Kept only to compare with the coherent
  model (``benchmarks/path_engine.py``).

The coherent model, per element pair
------------------------------------
With :math:`\mathbf t_m`, :math:`\mathbf r_n` the element positions (world), the interaction
points :math:`\mathbf v_1 \dots \mathbf v_d` of a traced path and
:math:`\ell = \sum_{i=1}^{d-1}\|\mathbf v_{i+1} - \mathbf v_i\|` its inner length:

* **delay** (near-field exact, no plane-wave approximation across the array)

  .. math:: \tau_{mn} = \big(\|\mathbf v_1 - \mathbf t_m\| + \ell + \|\mathbf r_n - \mathbf v_d\|\big)/c ;

* **gain**: Sionna's :math:`a` of the traced path, rescaled for the changed first and last
  segments as Sionna's field calculator would spread them. Sionna applies one spreading factor
  :math:`1/s` at the end of the path, where :math:`s` is the *ray-tube length*: the whole path
  length for a chain of specular reflections (and refractions), but only the length after the
  last diffuse interaction for a path with one, since a diffuse reflection re-radiates a new
  ray tube with a Jones matrix :math:`\sqrt{f_s\,\Omega}\,\Gamma` that does not depend on the
  length before it (the incident tube's solid angle :math:`\Omega` carries the power that the
  tube cuts out of the surface, an area :math:`\Omega\,s_{pre}^2/\cos\theta_i`). Hence

  .. math::
      a_{mn} = a\,\frac{L_0}{L_{mn}}\,\rho_m\rho_n \quad\text{(specular chain)},\qquad
      a_{mn} = a\,\frac{s^{pre}_0}{s^{pre}_m}\,\frac{s^{post}_0}{s^{post}_n}\,\rho_m\rho_n
      \quad\text{(with a diffuse interaction)},

  with :math:`L` the path length, :math:`s^{post}` the length from the last diffuse point to
  the receiver (Sionna's ray-tube length) and :math:`s^{pre}` the length from the transmitter to
  the first diffuse point. The factor :math:`s^{pre}_0/s^{pre}_m` is the fixed-scatterer
  correction: the centre trace fixed the scatterer's area, and element :math:`m`'s incident field
  on it falls as :math:`1/s^{pre}_m` (Sionna, tracing per element, never needs it because each
  element's rays cut their own areas). :math:`\rho_m = \sqrt{G(\hat{\mathbf k}_m)/G(\hat{\mathbf k}_0)}`
  evaluates the element pattern (:func:`sionnafmcw.antenna.antenna_gain`, the same pattern Sionna
  uses) in element :math:`m`'s own departure direction instead of the centre's (likewise
  :math:`\rho_n` for arrival); 1 for ``"iso"``. The material's angle dependence (Fresnel
  :math:`\Gamma(\theta_i)`, Lambertian :math:`\cos\theta_s`, :math:`\cos\theta_i` of the cut
  area) is kept at the centre's angles: relative errors of order :math:`\delta/R\,\tan\theta`,
  below 1 % (0.1 dB) at 1 m for these arrays;
* **Doppler** :math:`f_{mn} = -\frac{1}{\lambda}\frac{d}{dt}L_{mn}` with the interaction points'
  velocities (Sionna's per-object velocity, or the per-vertex field below): the traced path's
  Doppler :math:`f_0 = \sum_i \mathbf u_i\cdot(\hat{\mathbf k}_{out,i} - \hat{\mathbf k}_{in,i})/\lambda`
  plus the change of the first incident and the last outgoing direction,

  .. math:: f_{mn} = f_0 + \big[\mathbf u_1\cdot(\hat{\mathbf k}^{0}_{in,1} - \hat{\mathbf k}^{m}_{in,1})
            + \mathbf u_d\cdot(\hat{\mathbf k}^{n}_{out,d} - \hat{\mathbf k}^{0}_{out,d})\big]/\lambda

  (:math:`\mathbf u_i` the velocity of the point :math:`\mathbf v_i`, :math:`\lambda = c/f_c`),
  Sionna's sign: positive approaching.

Why fixed interaction points are right
--------------------------------------
*Diffuse* paths: the scatterer is a point of the surface; the path from any element to it and on
to any element is exactly the segments above, so the delay and Doppler are exact and the array
sees one scatterer. *Specular* paths: the true reflection point of the pair :math:`(m, n)` is not
the centre's. By Fermat's principle the path length is stationary with respect to the reflection
point, so holding it fixed errs only to second order. For a flat facet (every Sionna reflection
is on a triangle) at range :math:`R`, element offsets :math:`\boldsymbol\delta_t, \boldsymbol\delta_r`
from the Tx and Rx centres (across the line of sight) move the reflection point by about
:math:`(\boldsymbol\delta_t + \boldsymbol\delta_r)/(2\cos\theta)` along the plane, where the
length's curvature is :math:`2\cos^2\theta/R`: the fixed point adds

.. math:: \Delta L \approx \frac{|\boldsymbol\delta_t + \boldsymbol\delta_r|^2}{4R}

whatever the incidence :math:`\theta`. The largest preset aperture is ``walk-77ghz``
(:math:`|\delta_t| \le 7.8` mm, :math:`|\delta_r| \le 2.9` mm): :math:`\Delta L \le 29\ \mu` m
at 1 m (:math:`\lambda/135`, 0.05 rad of round-trip phase, :math:`10^{-13}` s) and 2.9 µm at
10 m (0.005 rad); ``ti-awr1843boost`` 12 µm at 1 m. Multi-bounce specular chains obey the same
stationarity. The Doppler of the fixed point differs from the true one by about
:math:`|\mathbf u|\,|\boldsymbol\delta|/(R\lambda)`: 2.8 Hz for 1 m/s, 1.1 cm, 1 m (under a tenth of
a ``walk-77ghz`` Doppler bin, 37 Hz), 0.3 Hz at 10 m.

Coincident specular paths
-------------------------
Sionna keeps one copy of a specular chain per plane, hashing the planes by their normals
quantised to :math:`10^{-5}`; coplanar sub-triangles that are not axis-aligned have float32
normals that miss one another, and return the same path 2-5 times (measured: a plate turned
0.35 rad split into 8+ triangles, the default trihedral ``subdiv=2`` at 5-7 m), adding +3 to
+14 dB coherently. The engine keeps one of every group of specular chains (no diffuse
interaction) with the same source and target, the same objects and interaction types in the same
order, path lengths within :data:`DUPLICATE_LENGTH_TOLERANCE` wavelengths (:math:`\lambda/100`)
and every interaction point within :data:`DUPLICATE_POINT_TOLERANCE` wavelengths
(:math:`\lambda/2`) of the other's (:func:`specular_duplicates`). Measured: the copies' facet
normals disagree by about :math:`10^{-5}` (float32 vertices 5 m out, 6 cm triangles), which moves
the image-method reflection point by some 50 µm but, the length being stationary in the point
(Fermat), the path length by only 1 µm; the length tolerance is 40 times that, and the float32
delay itself is good to :math:`10^{-7}` of the length (3 µm at 30 m). Two genuinely different
specular points of one object sequence with the same length to :math:`\lambda/100` and less
than :math:`\lambda/2` apart are not separate scattering centres to the radar (one glint); a
faceted curve's neighbouring facets have their mirror points a facet width (centimetres) apart.
Diffuse paths are never merged (distinct rays, distinct surface samples).

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

import numpy as np

from ..animation import Animation, RadarPose
from ..antenna import antenna_gain, direction_angles
from ..constants import SPEED_OF_LIGHT
from ..echoes import Echoes
from ..geometry import rotation_matrix
from ..sionna_rt import (
    INVALID_SHAPE, AntennaArray, InteractionType, PathSolver, Receiver, Transmitter, dr, mi, set_min_segment_length,
    sionna_antenna_pattern, solve_fields, trace_candidates,
)
from .base import Engine, EngineError
from .loaded_scene import barycentric_weights, interpolate
from .po_render import radio_material

#: Minimum path segment length (m) for a radar. Sionna's 1 cm (``MIN_SEGMENT_LENGTH``, meant for
#: communication links) drops every retro-reflected path of a radar: a trihedral's or dihedral's
#: image-method path between Tx and Rx elements a distance d apart passes within ~d/2 of the
#: corner, so its segments between bounces are millimetres long (measured: the triple bounce of a
#: 0.3 m trihedral at 4 m vanishes for Tx-Rx offsets below ~1 cm and is found at 2 mm with
#: 0.1 mm). Set when this module is imported, before any path is solved; it applies to every
#: solver in the process (:func:`sionnafmcw.sionna_rt.set_min_segment_length`, which fails loudly
#: when Sionna no longer has the constant).
RADAR_MIN_SEGMENT_LENGTH = 1e-4
set_min_segment_length(RADAR_MIN_SEGMENT_LENGTH)

#: Two specular chains are one path when their lengths (c times the delay) agree within this many
#: wavelengths (1/100: 39 µm at 77 GHz; copies differ by about 1 µm, see the module docstring) ...
DUPLICATE_LENGTH_TOLERANCE = 0.01
#: ... and every interaction point agrees within this many wavelengths (1/2: 1.9 mm at 77 GHz;
#: copies' reflection points differ by about 50 µm at 5 m, growing with range).
DUPLICATE_POINT_TOLERANCE = 0.5

_SPECULAR_TYPES = (int(InteractionType.SPECULAR), int(InteractionType.REFRACTION))
_STATIC_BLOCKS = itertools.count()   # numbers the static echo blocks built in this process (their static_key)


class PathEngineError(EngineError):
    """The path engine cannot run this animation / radar combination; the message says why."""


@dataclass
class _State:
    """Per-scene state of the path engine: the radar's devices and what is set in Sionna."""

    tx: object
    rx: object
    names_by_id: dict
    velocities: dict = field(default_factory=dict)  # name -> velocity currently set in Sionna
    pose: tuple | None = None
    materials: dict = field(default_factory=dict)   # name -> po_render.Material (PO)
    normals: dict = field(default_factory=dict)     # po_render.scene_objects cache
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


@dataclass
class TracedPaths:
    """The valid paths of one trace, as numpy arrays (world frame, float64).

    ``a`` ``[P]`` complex gain, ``tau`` ``[P]`` (s), ``doppler`` ``[P]`` (Hz, Sionna's per-object
    velocities), ``source``/``target`` ``[P]`` the source/target index, ``types``/``shapes``/
    ``primitives`` ``[P, D]`` per interaction (``InteractionType.NONE`` / ``INVALID_SHAPE`` after
    the last), ``vertices`` ``[P, D, 3]``, ``num_interactions`` ``[P]``; ``sources``/``targets``
    the positions Sionna used ``[S, 3]`` / ``[T, 3]``.
    """

    a: np.ndarray
    tau: np.ndarray
    doppler: np.ndarray
    source: np.ndarray
    target: np.ndarray
    types: np.ndarray
    shapes: np.ndarray
    primitives: np.ndarray
    vertices: np.ndarray
    sources: np.ndarray
    targets: np.ndarray

    @property
    def num_paths(self) -> int:
        return len(self.a)

    @property
    def valid_interactions(self) -> np.ndarray:
        return (self.types != int(InteractionType.NONE)) & (self.shapes != int(INVALID_SHAPE))

    @property
    def num_interactions(self) -> np.ndarray:
        return self.valid_interactions.sum(axis=1)

    @staticmethod
    def concatenate(parts: list[TracedPaths]) -> TracedPaths:
        """The paths of ``parts`` (same sources, targets and depth) one after the other."""
        def cat(name):
            return np.concatenate([getattr(p, name) for p in parts])

        return TracedPaths(cat("a"), cat("tau"), cat("doppler"), cat("source"), cat("target"), cat("types"),
                           cat("shapes"), cat("primitives"), cat("vertices"), parts[0].sources, parts[0].targets)

    def segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The segments source -> v_1 -> ... -> v_d -> target: starts and ends ``[P, D+1, 3]`` (after the
        last interaction both at the target: zero length) and ``[P, D+1]`` bool, true for the
        ``d + 1`` segments of each path."""
        num, depth, _ = self.vertices.shape
        n_int = self.num_interactions
        pts = np.empty((num, depth + 2, 3))
        pts[:, 0] = self.sources[self.source]
        pts[:, 1:depth + 1] = self.vertices
        tgt = self.targets[self.target]
        for d in range(depth):
            pad = n_int <= d
            pts[pad, d + 1] = tgt[pad]
        pts[:, depth + 1] = tgt
        used = np.arange(depth + 1)[None, :] <= n_int[:, None]
        return pts[:, :-1], pts[:, 1:], used

    def select(self, keep) -> TracedPaths:
        """The paths where ``keep`` ([P] bool) is true."""
        return TracedPaths(self.a[keep], self.tau[keep], self.doppler[keep], self.source[keep], self.target[keep],
                           self.types[keep], self.shapes[keep], self.primitives[keep], self.vertices[keep],
                           self.sources, self.targets)


def specular_duplicates(paths: TracedPaths, wavelength: float, length_tolerance: float = DUPLICATE_LENGTH_TOLERANCE,
                        point_tolerance: float = DUPLICATE_POINT_TOLERANCE) -> np.ndarray:
    """Mask ``[P]`` of the specular paths that repeat another one (see "Coincident specular paths").

    Two paths are copies when both are specular chains (every interaction a specular reflection
    or a refraction) between the same source and target, with the same objects and interaction
    types in the same order, path lengths :math:`c\tau` within ``length_tolerance * wavelength``
    and every interaction point within ``point_tolerance * wavelength`` of the other's. Of every
    group the path with the shortest delay is kept (not marked).
    """
    valid = paths.valid_interactions
    chain = np.all(~valid | np.isin(paths.types, _SPECULAR_TYPES), axis=1) & valid.any(axis=1)
    duplicate = np.zeros(paths.num_paths, dtype=bool)
    idx = np.flatnonzero(chain)
    if len(idx) < 2:
        return duplicate
    length_tol, point_tol = length_tolerance * wavelength, point_tolerance * wavelength
    order = idx[np.argsort(paths.tau[idx], kind="stable")]
    length = paths.tau[order] * SPEED_OF_LIGHT
    for i, p in enumerate(order):
        if duplicate[p]:
            continue
        j = i + 1
        while j < len(order) and length[j] - length[i] <= length_tol:
            q = order[j]
            if (not duplicate[q] and paths.source[q] == paths.source[p] and paths.target[q] == paths.target[p]
                    and np.array_equal(paths.types[q], paths.types[p])
                    and np.array_equal(paths.shapes[q], paths.shapes[p])
                    and np.all(np.linalg.norm((paths.vertices[q] - paths.vertices[p])[valid[p]], axis=-1)
                               <= point_tol)):
                duplicate[q] = True
            j += 1
    return duplicate


def specular_chains(paths: TracedPaths, max_interactions: int | None = None) -> np.ndarray:
    """Mask ``[P]`` of the purely specular chains (every interaction a specular reflection or a
    refraction) with at most ``max_interactions`` interactions (None: any number): the paths that
    physical optics replaces (module docstring, "Physical optics")."""
    valid = paths.valid_interactions
    chain = np.all(~valid | np.isin(paths.types, _SPECULAR_TYPES), axis=1) & valid.any(axis=1)
    if max_interactions is not None:
        chain &= paths.num_interactions <= max_interactions
    return chain


def _pose_key(pose: RadarPose) -> tuple:
    return tuple(np.round(np.concatenate([pose.position, pose.orientation]), 12))


def _mesh_arrays(mesh):
    """``(vertices, faces)`` of an animation :class:`~sionnafmcw.animation.Mesh` (world frame)."""
    return mesh.vertices, mesh.faces


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
        the PO merge error, and a static echo block whose beat cube the synthesizer reuses.

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
                 po_samples_across: int = 16, po_merge: bool = True, static_scene: bool = True):
        if label not in self.LABELS:
            raise PathEngineError(f"PathEngine: label={label!r} is unknown; choose one of {', '.join(self.LABELS)}")
        if array_model not in self.ARRAY_MODELS:
            raise PathEngineError(f"PathEngine: array_model={array_model!r} is unknown; choose one of "
                                  f"{', '.join(self.ARRAY_MODELS)}")
        if multibounce not in self.MULTIBOUNCE:
            raise PathEngineError(f"PathEngine: multibounce={multibounce!r} is unknown; choose one of "
                                  f"{', '.join(self.MULTIBOUNCE)}")
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
        self._solver = PathSolver(deterministic=self.deterministic)
        self.last_paths: TracedPaths | None = None
        self.last_renders: list = []
        self._last_pieces: dict = {}

    def _settings(self) -> dict:
        return {"max_depth": self.max_depth, "samples_per_src": self.samples_per_src,
                "max_num_paths_per_src": self.max_num_paths_per_src, "diffuse": self.diffuse,
                "specular": self.specular, "refraction": self.refraction, "diffraction": self.diffraction,
                "seed": self.seed, "deterministic": self.deterministic, "vertex_doppler": self.vertex_doppler,
                "label": self.label, "array_model": self.array_model, "deduplicate": self.deduplicate,
                "physical_optics": self.physical_optics, "multibounce": self.multibounce,
                "random_phase": self.random_phase, "po_samples_across": self.po_samples_across,
                "po_merge": self.po_merge, "static_scene": self.static_scene}

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
            return AntennaArray(pat, mi.Point3f(mi.Float(p[:, 0]), mi.Float(p[:, 1]), mi.Float(p[:, 2])))

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
        return _State(tx, rx, names_by_id, materials=materials)

    def _geometry_changed(self) -> None:
        self._loaded.scene.scene_geometry_updated()

    def _frame_echoes(self, animation: Animation, radar, frame: int, pose: RadarPose):
        self._set_pose(pose)
        velocities = self._update_velocities(animation, frame)
        wavelength = SPEED_OF_LIGHT / radar.fc
        loaded = self._loaded
        rigid = {name: np.asarray(animation.frame(frame).objects.get(name, np.zeros(3)), float)
                 for name in loaded.scene.objects}
        static, spheres, moving_ids = None, None, frozenset()
        figures = {}
        if self.static_scene:
            from .static_scene import Spheres, moving_objects

            moving = moving_objects(loaded, rigid, self.vertex_doppler)
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
            po, removed_po, po_figures = self._po_echoes(animation, radar, pose, rigid, wavelength, static, spheres,
                                                         moving_ids)
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
        paths = self._trace(self._loaded.scene)
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
        """Per element pair echoes of traced paths (None when there are none); ``paths`` is not changed."""
        if not paths.num_paths:
            return None
        vertex_velocity, velocity = self._interaction_velocities(paths, velocities)
        doppler = paths.doppler + self._vertex_doppler(paths, vertex_velocity, wavelength)
        labels = self._labels(paths, velocities)
        if self.random_phase:
            paths = replace(paths, a=paths.a * np.exp(1j * self._diffuse_phases(paths, wavelength)))
        if self.coherent:
            return self._coherent_echoes(paths, doppler, velocity, labels, radar, pose, wavelength)
        return self._per_element_echoes(paths, doppler, labels, radar)

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
        t0 = time.perf_counter()
        state.static = None
        with hidden(loaded, moving):
            paths, _ = self._traced_paths(wavelength)
            traced = self._traced_echoes(paths, velocities, radar, pose, wavelength)
            po = None
            if self.physical_optics:
                objects, centre, rot, tx_w, rx_w = self._po_geometry(animation, radar, pose, rigid)
                po = StaticPO.build(loaded, objects, set(loaded.shape_ids) - set(moving), centre, rot, wavelength,
                                    self._po_depth, self.po_samples_across,
                                    lambda b: self._po_contributions(b, radar, tx_w, rx_w, rot, wavelength),
                                    lambda *c: self._po_merge(radar, *c, return_cells=True))
        parts = [e for e in (traced, None if po is None else po.echoes) if e is not None]
        block = Echoes.empty(radar.num_tx, radar.num_rx) if not parts else \
            (parts[0] if len(parts) == 1 else Echoes.concatenate(parts))
        labels = block.labels if block.labels is not None else np.zeros(block.num_contributions, dtype=str)
        block = Echoes(block.a, block.tau, block.doppler, labels, static_count=block.num_contributions,
                       static_key=("path-engine-static", next(_STATIC_BLOCKS)))
        state.static = _StaticBlock(key, paths if paths.num_paths else None, traced, po, block,
                                    time.perf_counter() - t0)
        return state.static, state.static.seconds

    # ------------------------------------------------------------------ physical optics
    @property
    def _po_depth(self) -> int:
        return self.max_depth if (self.multibounce == "po" and self.specular) else 1

    def _po_geometry(self, animation: Animation, radar, pose: RadarPose, rigid: dict):
        """The PO render's objects (shading normals cached), its origin (the array's phase centre),
        the radar rotation and the Tx / Rx element positions (world)."""
        from .po_render import scene_objects

        loaded, state = self._loaded, self._state
        rot = rotation_matrix(pose.orientation)
        centre = np.asarray(pose.position, float) + rot @ radar.phase_centre
        tx_w = np.asarray(pose.position, float) + radar.tx_positions @ rot.T
        rx_w = np.asarray(pose.position, float) + radar.rx_positions @ rot.T
        objects = scene_objects(loaded, rigid, state.materials, vertex_doppler=self.vertex_doppler,
                                cache=state.normals, reference=lambda name: _mesh_arrays(animation.mesh(0, name)))
        return objects, centre, rot, tx_w, rx_w

    @staticmethod
    def _po_contributions(bounce, radar, tx_w, rx_w, rot, wavelength: float):
        """``(a, tau, doppler, labels)`` of a render's samples for every element pair (element gains
        included): :func:`~sionnafmcw.engines.po_kernel.element_pair_po`, the Dr.Jit kernel of
        :func:`~sionnafmcw.engines.po_render.chain_po_gains`."""
        from .po_kernel import element_pair_po

        a, tau, doppler = element_pair_po(bounce, tx_w, rx_w, rot, wavelength, radar.antenna_pattern)
        return a, tau, doppler, bounce.samples.labels

    def _po_merge(self, radar, a, tau, doppler, labels, return_cells: bool = False):
        """The PO contributions merged per cell of :data:`~.po_render.MERGE_FRACTION` of the resolutions
        (``po_merge``; None without merging when ``return_cells``, else the contributions unchanged)."""
        from .po_render import MERGE_FRACTION, merge_contributions

        if not self.po_merge:
            return None if return_cells else (a, tau, doppler, labels)
        return merge_contributions(a, tau, doppler, labels, delay_cell=MERGE_FRACTION / radar.bandwidth,
                                   doppler_cell=MERGE_FRACTION / radar.cpi_duration, frequency=radar.fc,
                                   return_cells=return_cells)

    def _po_echoes(self, animation: Animation, radar, pose: RadarPose, rigid: dict, wavelength: float, static=None,
                   spheres=None, moving_ids=frozenset()):
        """PO echoes of the frame: the render from the phase centre and, with ``multibounce="po"``, its
        reflections up to ``max_depth`` bounces (:mod:`sionnafmcw.engines.po_render`), every element
        pair near-field exact, merged per delay/Doppler cell of :data:`~.po_render.MERGE_FRACTION` of
        the resolutions; ``rigid``: name -> the frame's rigid velocity (m/s). With the static scene
        cached (``static``), only the frame's own renders (what the moving objects change) and the
        blocked static samples (``removed``, opposite sign). Returns ``(echoes, removed, figures)``."""
        from .po_render import reflect, render

        t0 = time.perf_counter()
        loaded = self._loaded
        objects, centre, rot, tx_w, rx_w = self._po_geometry(animation, radar, pose, rigid)
        depth = self._po_depth
        removed, num_removed = None, 0
        if static is not None and static.po is not None:
            renders, removed, num_removed = static.po.frame(
                loaded, objects, moving_ids, spheres, centre, rot, wavelength, depth, self.po_samples_across,
                lambda b: self._po_contributions(b, radar, tx_w, rx_w, rot, wavelength), radar.fc)
            self.last_renders = [*static.po.renders, *renders]
        else:
            bounce = render(loaded, centre, rot, wavelength, rigid, self._state.materials, objects=objects,
                            samples_across=self.po_samples_across, vertex_doppler=self.vertex_doppler)
            renders = [bounce]
            while bounce.depth < depth and bounce.num_samples:
                bounce = reflect(loaded, bounce, objects, rot, wavelength)
                renders.append(bounce)
            self.last_renders = renders
        echoes = []
        num_samples = 0
        for b in renders:
            keep = b.carries_po()
            if not np.any(keep):
                continue
            num_samples += int(keep.sum())
            a, tau, doppler, labels = self._po_merge(
                radar, *self._po_contributions(b.select(keep), radar, tx_w, rx_w, rot, wavelength))
            echoes.append(Echoes(a, tau, doppler, labels))
        figures = {"po_rays": int(sum(b.num_rays for b in renders)), "po_samples": num_samples,
                   "po_contributions": int(sum(e.num_contributions for e in echoes)),
                   "po_seconds": time.perf_counter() - t0}
        if static is not None and static.po is not None:
            figures.update(static_po_samples=static.po.num_samples, static_po_removed=num_removed)
        po = None if not echoes else (echoes[0] if len(echoes) == 1 else Echoes.concatenate(echoes))
        return po, removed, figures

    def _diffuse_phases(self, paths: TracedPaths, wavelength: float) -> np.ndarray:
        r"""Random phase ``[P]`` of every path: the sum over its diffuse interactions of
        :func:`sionnafmcw.diffuse.scatterer_phases` of (object, triangle, barycentric cell of
        :math:`\lambda/4`), so a diffuse scatterer keeps its phase while it is on the same surface
        cell (module docstring, "Diffuse scattering"); 0 for specular chains."""
        from ..diffuse import cells_per_edge, scatterer_phases

        phase = np.zeros(paths.num_paths)
        diffuse = paths.valid_interactions & (paths.types == int(InteractionType.DIFFUSE))
        if not np.any(diffuse):
            return phase
        loaded, names_by_id = self._loaded, self._state.names_by_id
        rows, cols = np.nonzero(diffuse)
        for shape_id in np.unique(paths.shapes[rows, cols]):
            name = names_by_id.get(int(shape_id))
            if name is None:
                continue
            on = paths.shapes[rows, cols] == shape_id
            r, c = rows[on], cols[on]
            faces = loaded.faces[name][paths.primitives[r, c]]
            vpos = loaded.vertices[name]
            a, b, cc = vpos[faces[:, 0]], vpos[faces[:, 1]], vpos[faces[:, 2]]
            w = barycentric_weights(paths.vertices[r, c], a, b, cc)
            edge = np.max(np.stack([np.linalg.norm(b - a, axis=-1), np.linalg.norm(cc - b, axis=-1),
                                    np.linalg.norm(a - cc, axis=-1)]), axis=0)
            phi = scatterer_phases(np.full(r.size, name), paths.primitives[r, c], w[:, 1:],
                                   cells_per_edge(edge, wavelength / 4))
            np.add.at(phase, r, phi)
        return np.mod(phase, 2 * np.pi)

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

    def _trace(self, scene) -> TracedPaths:
        """The solver's steps up to the path buffer (no ``Paths`` tensors, see the module docstring), as numpy."""
        candidates = trace_candidates(
            self._solver, scene, samples_per_src=self.samples_per_src,
            max_num_paths_per_src=self.max_num_paths_per_src, max_depth=self.max_depth,
            specular_reflection=self.specular, diffuse_reflection=self.diffuse, refraction=self.refraction,
            diffraction=self.diffraction, seed=self.seed)
        found, capacity = candidates.found, candidates.capacity
        if found >= capacity:
            # Sionna keeps counting past the end of its candidate buffer and silently drops the
            # rest (measured: a closed room, diffuse only, 1e6 rays per source: 250k paths kept of
            # ~12M, 17 dB of power lost and the body gone), so a full buffer is an error here.
            raise PathEngineError(
                f"PathEngine: {found} candidate paths filled Sionna's path buffer ({capacity} = "
                f"max_num_paths_per_src={self.max_num_paths_per_src} x {capacity // self.max_num_paths_per_src} "
                f"sources) and the rest would be dropped silently; raise max_num_paths_per_src "
                f"(e.g. to {4 * self.max_num_paths_per_src}) or lower samples_per_src={self.samples_per_src}")
        buf = solve_fields(self._solver, scene, candidates, samples_per_src=self.samples_per_src,
                           diffraction=self.diffraction)
        return self._buffer_arrays(buf, candidates.src_positions, candidates.tgt_positions)

    @staticmethod
    def _buffer_arrays(buf, src_positions, tgt_positions) -> TracedPaths:
        """Sionna's ``PathsBuffer`` (valid paths only) as :class:`TracedPaths`."""
        num = int(buf.buffer_size)
        depth = buf.depth_dim_size
        sources = np.stack([src_positions.x.numpy(), src_positions.y.numpy(), src_positions.z.numpy()], -1)
        targets = np.stack([tgt_positions.x.numpy(), tgt_positions.y.numpy(), tgt_positions.z.numpy()], -1)
        if num == 0:
            z = np.zeros(0)
            zi = np.zeros((0, depth), dtype=np.int64)
            return TracedPaths(z.astype(complex), z, z, z.astype(np.int64), z.astype(np.int64), zi, zi, zi,
                               np.zeros((0, depth, 3)), sources.astype(float), targets.astype(float))
        a = buf.a[0][0]
        arrays = [buf.source_indices, buf.target_indices, dr.real(a), dr.imag(a), buf.tau, buf.doppler,
                  buf.shapes, buf.interaction_types, buf.primitives, buf.vertices_x, buf.vertices_y,
                  buf.vertices_z]
        dr.eval(*arrays)

        def per_interaction(x, dtype):
            return np.asarray(x.array.numpy(), dtype=dtype).reshape(num, depth)

        return TracedPaths(
            a=dr.real(a).numpy().astype(np.float64) + 1j * dr.imag(a).numpy().astype(np.float64),
            tau=buf.tau.numpy().astype(np.float64),
            doppler=buf.doppler.numpy().astype(np.float64),
            source=buf.source_indices.numpy().astype(np.int64),
            target=buf.target_indices.numpy().astype(np.int64),
            types=per_interaction(buf.interaction_types, np.int64),
            shapes=per_interaction(buf.shapes, np.int64),
            primitives=per_interaction(buf.primitives, np.int64),
            vertices=np.stack([per_interaction(buf.vertices_x, np.float64), per_interaction(buf.vertices_y, np.float64),
                               per_interaction(buf.vertices_z, np.float64)], axis=-1),
            sources=sources.astype(np.float64), targets=targets.astype(np.float64))

    # ------------------------------------------------------------------ paths -> Echoes
    def _interaction_velocities(self, paths: TracedPaths, velocities: dict):
        """Velocities ``[P, D, 3]`` (m/s) of the interaction points: the per-vertex field alone, and in all.

        The first is the field interpolated on meshes with vertex velocities (zero elsewhere; what
        Sionna does not see); the second adds the per-object velocity Sionna uses (zero where the
        field replaces it).
        """
        loaded = self._loaded
        valid = paths.valid_interactions
        vertex = np.zeros(paths.vertices.shape)
        rigid = np.zeros(paths.vertices.shape)
        for name, obj in loaded.scene.objects.items():
            on = valid & (paths.shapes == int(obj.object_id))
            if not np.any(on):
                continue
            v = velocities.get(name)
            if v is not None and np.any(v != 0):
                rigid[on] = v
            field_v = loaded.vertex_velocity.get(name) if self.vertex_doppler else None
            if field_v is not None:
                faces = loaded.faces[name][paths.primitives[on]]
                vpos = loaded.vertices[name]
                w = barycentric_weights(paths.vertices[on], vpos[faces[:, 0]], vpos[faces[:, 1]], vpos[faces[:, 2]])
                vertex[on] = interpolate(field_v, faces, w)
        return vertex, rigid + vertex

    @staticmethod
    def _polyline_directions(paths: TracedPaths):
        """Unit directions ``[P, D+1, 3]`` of the segments source -> v_1 -> ... -> v_d -> target (0 after the last)."""
        starts, ends, _ = paths.segments()
        seg = ends - starts
        norm = np.linalg.norm(seg, axis=-1, keepdims=True)
        return np.divide(seg, norm, out=np.zeros_like(seg), where=norm > 0)

    def _vertex_doppler(self, paths: TracedPaths, vertex_velocity, wavelength: float) -> np.ndarray:
        """Sum over interactions on meshes with vertex velocities of v(p).(k_out - k_in)/lambda (Hz)."""
        if not np.any(vertex_velocity):
            return np.zeros(paths.num_paths)
        k = self._polyline_directions(paths)
        k_in, k_out = k[:, :-1], k[:, 1:]
        valid = paths.valid_interactions
        return np.einsum("pdi,pdi->p", np.where(valid[..., None], vertex_velocity, 0.0), k_out - k_in) / wavelength

    def _labels(self, paths: TracedPaths, velocities: dict) -> np.ndarray:
        """Label ``[P]`` of every path (see the module docstring)."""
        loaded, names_by_id = self._loaded, self._state.names_by_id
        valid_int = paths.valid_interactions
        shapes = paths.shapes
        id_list = sorted(names_by_id)
        lut_ids = np.array(id_list, dtype=np.int64)
        lut_names = np.array([names_by_id[i] for i in id_list], dtype=object)
        pos = np.clip(np.searchsorted(lut_ids, shapes), 0, len(lut_ids) - 1)
        found = valid_int & (lut_ids[pos] == shapes)
        per_int = np.where(found, lut_names[pos], "")
        rows = np.arange(paths.num_paths)
        first = per_int[:, 0]
        if self.label == "first":
            return first.astype(str)
        if self.label == "last":
            return per_int[rows, np.maximum(paths.num_interactions - 1, 0)].astype(str)
        moving = {n for n, v in velocities.items() if np.any(v != 0)}
        if self.vertex_doppler:
            moving |= {n for n, v in loaded.vertex_velocity.items() if v is not None and np.any(v != 0)}
        is_moving = np.vectorize(lambda s: s in moving, otypes=[bool])(per_int) & found
        has = is_moving.any(axis=1)
        idx = np.argmax(is_moving, axis=1)
        return np.where(has, per_int[rows, idx], first).astype(str)

    def _per_element_echoes(self, paths: TracedPaths, doppler, labels, radar) -> Echoes:
        """``"per-element"``: every path belongs to one (source, target) = (Tx, Rx) element pair."""
        m_tx, n_rx = radar.num_tx, radar.num_rx
        src, tgt = paths.source, paths.target
        num = paths.num_paths
        link = src * n_rx + tgt
        order = np.argsort(link, kind="stable")
        link_sorted = link[order]
        counts = np.bincount(link, minlength=m_tx * n_rx)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        rank = np.empty(num, dtype=np.int64)
        rank[order] = np.arange(num) - starts[link_sorted]
        shape = (m_tx, n_rx, int(counts.max()))
        out_a = np.zeros(shape, dtype=np.complex128)
        out_tau = np.zeros(shape)
        out_dop = np.zeros(shape)
        out_lab = np.full(shape, "", dtype=object)
        out_a[src, tgt, rank] = paths.a
        out_tau[src, tgt, rank] = paths.tau
        out_dop[src, tgt, rank] = doppler
        out_lab[src, tgt, rank] = labels
        return Echoes(out_a, out_tau, out_dop, out_lab.astype(str))

    def _coherent_echoes(self, paths: TracedPaths, doppler, velocity, labels, radar, pose: RadarPose,
                         wavelength: float) -> Echoes:
        """``"coherent"``: every element pair from the traced path's interaction points (module docstring)."""
        rot = rotation_matrix(pose.orientation)
        t0, r0 = paths.sources[0], paths.targets[0]  # where Sionna traced from / to (world)
        tx = t0 + (radar.tx_positions - radar.tx_positions.mean(axis=0)) @ rot.T  # [M, 3]
        rx = r0 + (radar.rx_positions - radar.rx_positions.mean(axis=0)) @ rot.T  # [N, 3]
        num, depth, _ = paths.vertices.shape
        rows = np.arange(num)
        valid = paths.valid_interactions
        n_int = paths.num_interactions
        first = paths.vertices[:, 0]                               # [P, 3]
        last = paths.vertices[rows, n_int - 1]                     # [P, 3]
        # inner segments: cum[:, i] = |v_2 - v_1| + ... + |v_{i+1} - v_i| (only between interactions)
        seg = np.linalg.norm(np.diff(paths.vertices, axis=1), axis=-1) * valid[:, 1:]   # [P, D-1]
        cum = np.concatenate([np.zeros((num, 1)), np.cumsum(seg, axis=1)], axis=1)    # [P, D]
        inner = cum[rows, n_int - 1]

        d_tx = first[None] - tx[:, None]                           # [M, P, 3] element -> v_1
        d_rx = last[None] - rx[:, None]                            # [N, P, 3] element -> v_d
        l_tx = np.linalg.norm(d_tx, axis=-1)                       # [M, P]
        l_rx = np.linalg.norm(d_rx, axis=-1)                       # [N, P]
        d_t0, d_r0 = first - t0, last - r0
        l_t0, l_r0 = np.linalg.norm(d_t0, axis=-1), np.linalg.norm(d_r0, axis=-1)

        tau = (l_tx[:, None, :] + inner[None, None, :] + l_rx[None, :, :]) / SPEED_OF_LIGHT

        # spreading: the whole length for specular chains; before the first / after the last
        # diffuse interaction for the others (see the module docstring)
        is_diffuse = valid & (paths.types == int(InteractionType.DIFFUSE))
        has_diffuse = is_diffuse.any(axis=1)
        j_first = np.argmax(is_diffuse, axis=1)
        j_last = depth - 1 - np.argmax(is_diffuse[:, ::-1], axis=1)
        pre_inner = cum[rows, j_first]
        post_inner = inner - cum[rows, j_last]
        length0 = l_t0 + inner + l_r0
        chain_scale = length0[None, None, :] / (tau * SPEED_OF_LIGHT)
        diffuse_scale = (((l_t0 + pre_inner) / (l_tx + pre_inner))[:, None, :]
                         * ((l_r0 + post_inner) / (l_rx + post_inner))[None, :, :])
        scale = np.where(has_diffuse[None, None, :], diffuse_scale, chain_scale)
        if radar.antenna_pattern != "iso":
            scale = scale * self._pattern_ratio(radar.antenna_pattern, d_tx, d_t0, rot)[:, None, :]
            scale = scale * self._pattern_ratio(radar.antenna_pattern, d_rx, d_r0, rot)[None, :, :]
        a = paths.a[None, None, :] * scale

        # Doppler: the first incident and the last outgoing directions change per element
        k_in_m = d_tx / l_tx[..., None]                            # Tx element -> v_1
        k_in_0 = d_t0 / l_t0[:, None]
        k_out_n = -d_rx / l_rx[..., None]                          # v_d -> element
        k_out_0 = -d_r0 / l_r0[:, None]
        u_first = velocity[:, 0]
        u_last = velocity[rows, n_int - 1]
        shift_tx = np.einsum("pi,mpi->mp", u_first, k_in_0[None] - k_in_m) / wavelength
        shift_rx = np.einsum("pi,npi->np", u_last, k_out_n - k_out_0[None]) / wavelength
        f = doppler[None, None, :] + shift_tx[:, None, :] + shift_rx[None, :, :]
        return Echoes(a, tau, f, labels)

    @staticmethod
    def _pattern_ratio(pattern: str, d_elements, d_centre, rot) -> np.ndarray:
        """Amplitude ratio ``[K, P]`` sqrt(G(element direction) / G(centre direction)), directions world -> radar frame."""
        g_el = antenna_gain(pattern, *direction_angles(d_elements @ rot))
        g_0 = antenna_gain(pattern, *direction_angles(d_centre @ rot))
        return np.sqrt(np.divide(g_el, g_0[None], out=np.ones_like(g_el), where=g_0[None] > 0))


__all__ = ["DUPLICATE_LENGTH_TOLERANCE", "DUPLICATE_POINT_TOLERANCE", "PathEngine", "PathEngineError", "RADAR_MIN_SEGMENT_LENGTH",
           "TracedPaths", "specular_chains", "specular_duplicates"]
