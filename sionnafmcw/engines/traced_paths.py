r"""Sionna's traced paths as numpy arrays, and the specular copies Sionna returns twice.

:func:`trace_paths` runs the solver's steps up to its path buffer and reads the valid paths out as
:class:`TracedPaths` (numpy, world frame, float64): the engine never builds Sionna's ``Paths`` tensors,
whose kernels bake the per-frame path count in as a constant and would recompile whenever it changes
(:mod:`~sionnafmcw.engines.path`, "No recompilation"). Importing this module sets the radar's minimum
segment length in Sionna (:data:`RADAR_MIN_SEGMENT_LENGTH`).

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import SPEED_OF_LIGHT
from ..sionna_rt import INVALID_SHAPE, InteractionType, dr, set_min_segment_length, solve_fields, trace_candidates
from .errors import PathEngineError

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


def trace_paths(solver, scene, *, samples_per_src: int, max_num_paths_per_src: int, max_depth: int,
                specular: bool, diffuse: bool, refraction: bool, diffraction: bool, seed: int) -> TracedPaths:
    """Sionna's path solver up to its path buffer, no ``Paths`` tensors (module docstring), as
    :class:`TracedPaths`; a full candidate buffer is a :class:`~.errors.PathEngineError`."""
    candidates = trace_candidates(
        solver, scene, samples_per_src=samples_per_src, max_num_paths_per_src=max_num_paths_per_src,
        max_depth=max_depth, specular_reflection=specular, diffuse_reflection=diffuse, refraction=refraction,
        diffraction=diffraction, seed=seed)
    found, capacity = candidates.found, candidates.capacity
    if found >= capacity:
        # Sionna keeps counting past the end of its candidate buffer and silently drops the
        # rest (measured: a closed room, diffuse only, 1e6 rays per source: 250k paths kept of
        # ~12M, 17 dB of power lost and the body gone), so a full buffer is an error here.
        raise PathEngineError(
            f"PathEngine: {found} candidate paths filled Sionna's path buffer ({capacity} = "
            f"max_num_paths_per_src={max_num_paths_per_src} x {capacity // max_num_paths_per_src} "
            f"sources) and the rest would be dropped silently; raise max_num_paths_per_src "
            f"(e.g. to {4 * max_num_paths_per_src}) or lower samples_per_src={samples_per_src}")
    buf = solve_fields(solver, scene, candidates, samples_per_src=samples_per_src, diffraction=diffraction)
    return buffer_arrays(buf, candidates.src_positions, candidates.tgt_positions)

def buffer_arrays(buf, src_positions, tgt_positions) -> TracedPaths:
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


__all__ = ["DUPLICATE_LENGTH_TOLERANCE", "DUPLICATE_POINT_TOLERANCE", "RADAR_MIN_SEGMENT_LENGTH", "TracedPaths",
           "buffer_arrays", "specular_chains", "specular_duplicates", "trace_paths"]
