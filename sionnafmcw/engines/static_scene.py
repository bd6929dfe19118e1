r"""The static scene once per radar pose: what the moving objects change, per frame, and nothing else.

In an indoor animation most of the echo comes from surfaces that do not move (walls, floor,
ceiling, furniture): on the circle walk most of the PO render's samples and of Sionna's diffuse
paths are on the room (the engine's figures ``static_po_samples`` and ``static_paths`` against
``po_samples`` and ``num_traced_paths``). With the radar at a fixed pose these are the same in
every frame, except where a moving object is in their way. The path engine
(``static_scene=True``) therefore splits every frame's echo into

* a **static block**: every path and PO chain that touches only static objects, traced and
  rendered once per radar pose with the moving objects taken out of the scene (:func:`hidden`),
  turned into echoes once; bit for bit the same :class:`~sionnafmcw.echoes.Echoes` block in every
  frame (``static_key``), so the synthesizer computes its beat cube once
  (:func:`sionnafmcw.synthesis.synthesize`, ``static_cache``);
* per frame, **what the moving objects change**: the paths and PO chains that touch a moving
  object (traced and rendered as before), and the static ones that a moving object now blocks,
  entered with the opposite sign.

Why this is the whole frame, exactly
------------------------------------
Every ray (Sionna's shot rays, the PO render's grid rays and their reflections) depends only on
its origin, direction and seed, never on the other rays. A ray's first hit in the scene with the
moving objects is its first hit in the static scene unless a moving object lies on the ray before
it; then the ray ends on the moving object. So, ray by ray and segment by segment, a static chain
(path or PO chain made of static interactions only) of the full scene is a static chain of the
static scene whose segments no moving object blocks, and every chain of the full scene that is not
such a chain touches a moving object. Per frame:

.. math::
    E_{frame} = E_{static} - \sum_{c\ \in\ \text{static, blocked}} E_c + \sum_{c\ \in\ \text{touching a moving object}} E_c .

*Blocked* is decided on the chains' segments: source → first interaction → … → last interaction
(→ receiver for Sionna's paths, whose last segment Sionna tests for visibility; the PO return
retraces the first segment on the first bounce and is not tested from the second on, as without
the cache, :mod:`~sionnafmcw.engines.po_render`). A segment can only be blocked where it passes
through the bounding sphere of a moving object (:class:`Spheres`, centre the box centre, radius the
farthest vertex), so only those segments are cast again, in the full scene
(:func:`blocked_segments`); a hit on a moving object before the segment's end blocks it. A
static PO chain whose reflected ray now hits a moving object first ends there instead: its next
bounce is rendered per frame on the moving object and the cached one is removed (the same test,
on the reflected ray, to its cached next hit or to infinity).

The PO echoes of the static block are merged into cells as without the cache
(:func:`~sionnafmcw.engines.po_merge.merge_contributions`); a blocked sample is taken out of its
cell at the cell's delay (:func:`~sionnafmcw.engines.po_merge.take_out_of_cells`), which is the
merge of the samples left in the cell. So the frame's echoes equal
those of the uncached engine up to the merge error (test: ``tests/test_static_scene.py``) and
depend on the frame only (the cache depends on the pose and the static geometry, not on the frames
before).

Which objects are static: those whose PLY does not change in any frame of the animation
(:attr:`~sionnafmcw.engines.loaded_scene.LoadedScene.changing`), with no rigid velocity in this
frame and no non-zero per-vertex velocity. The cache is rebuilt when the radar pose or the static
set changes.

Taking objects out of the scene: :func:`hidden` collapses every vertex of their meshes onto one
point, so their triangles have no area and no ray hits them (Mitsuba's ray-triangle test rejects
degenerate triangles), through the same scene-parameter update as a frame's geometry (no new
kernels), and writes the frame's vertices back afterwards.

Cost
----
The multi-bounce rule (:mod:`~sionnafmcw.engines.bounce_sampling`) makes the static block large
(the circle walk's room 288k -> 740k PO samples, a furnished room 225k -> 930k), and a frame pays
for its size in two places: the blocking test and the memory the block is held in.

* *The blocking test*: every frame asks which static segments pass through a moving object's
  bounding sphere. Tested segment by segment it costs (segments x spheres) numpy work a frame (the
  furnished room with three walkers of 13 parts: 1.1 s of a 2.3 CPU-s engine frame). The segments are
  fixed per pose, so they are indexed once (:class:`RayIndex`: grouped by the point their lines come
  from, the origin or its image in a plane, and by direction in a k-d tree) and the spheres in groups
  of touching ones (:meth:`Spheres.groups`, one per person): a frame tests the segments in the cones
  of the spheres alone, with the same closed form, so it finds the same segments.
* *Memory*: the block is held once (the joined echo block, the PO echoes and the merge's cells
  views of it: :meth:`StaticPO.share`), and what is the same for every sample of a render once
  (:func:`shared_rows`: a third of a first bounce). The static samples stay in float64: in float32
  a position 5 m from the world's origin rounds by :math:`5 \cdot 2^{-24} \approx 3\times10^{-7}` m,
  a delay of 33 ns by :math:`2\times10^{-15}` s, each :math:`4\pi\,\delta x/\lambda \approx
  2\pi f_c\,\delta\tau \approx 10^{-3}` rad at 77 GHz (an error -60 dB under the sample's echo):
  small, but a blocked sample must leave the block with bit for bit the gain it brought (the frame
  computes it again from the held render), so the block would have to be computed from the rounded
  render and would no longer equal the uncached engine's up to the synthesis's rounding, for the
  positions, directions and steps (a third of a render after the shared rows).

Measured (``benchmarks/static_block.py``, against the block held twice and tested segment by segment;
2-core AMD EPYC shared with other work, interleaved runs; every cube bit for bit the same): the
run's peak memory 0.86x on the circle walk and the furnished room with three walkers, the room's
steady frames 0.84-0.85x CPU (its blocking test 1.13 -> 0.17 s a frame); the walk's frames, whose
one walker blocks few segments, 0.95-1.01x.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

#: A segment counts as blocked when a moving object is hit more than this far (m) before its end
#: (Mitsuba's float32 hits at a few metres are good to about 1e-6 m; a blocker is a body part).
SEGMENT_TOLERANCE = 1e-4


def moving_objects(loaded, rigid_velocities: dict, vertex_doppler: bool = True) -> frozenset:
    """Names of the objects that move in this frame or change their mesh in any frame (module docstring)."""
    names = set(loaded.changing)
    for name, v in rigid_velocities.items():
        if np.any(np.asarray(v) != 0):
            names.add(name)
    for name, field_v in loaded.vertex_velocity.items():
        if vertex_doppler and field_v is not None and np.any(field_v != 0):
            names.add(name)
    return frozenset(names & set(loaded.shape_ids))


@contextmanager
def hidden(loaded, names):
    """The scene of ``loaded`` without the objects ``names`` (their meshes collapsed onto one point)
    for the duration of the block; the frame's vertices are written back on exit."""
    names = sorted(names)

    def write(vertices_of):
        for name in names:
            loaded._write_vertices(name, vertices_of(name))
        if names:
            loaded.params.update()
            loaded.scene.scene_geometry_updated()

    write(lambda name: np.repeat(loaded.vertices[name][:1], len(loaded.vertices[name]), axis=0))
    try:
        yield
    finally:
        write(lambda name: loaded.vertices[name])


@dataclass
class Spheres:
    """Bounding spheres ``centre [K, 3]``, ``radius [K]`` (m) of the moving objects."""

    centre: np.ndarray
    radius: np.ndarray

    @classmethod
    def around(cls, vertex_sets) -> Spheres:
        """One sphere per vertex set ``[V, 3]``: centre of the bounding box, radius to the farthest vertex."""
        centres, radii = [], []
        for v in vertex_sets:
            v = np.asarray(v, float)
            c = 0.5 * (v.min(axis=0) + v.max(axis=0))
            centres.append(c)
            radii.append(float(np.max(np.linalg.norm(v - c, axis=-1))) * (1 + 1e-6) + 1e-6)
        return cls(np.reshape(np.asarray(centres, float), (-1, 3)), np.asarray(radii, float))

    def clusters(self) -> list[np.ndarray]:
        r"""The spheres in groups that touch (indices per group): the connected components of the graph
        whose edges join two spheres that overlap, :math:`|\mathbf c_i - \mathbf c_j| \le r_i + r_j`.
        A body's parts overlap at its joints, so each person is one group and people apart are apart."""
        from scipy.sparse.csgraph import connected_components

        gap = np.linalg.norm(self.centre[:, None] - self.centre[None], axis=-1)
        count, label = connected_components(gap <= self.radius[:, None] + self.radius[None], directed=False)
        return [np.flatnonzero(label == g) for g in range(count)]

    def groups(self) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """``(members, centre [3], radius)`` per group of :meth:`clusters`: the group's sphere (centre of
        the members' bounding box, radius to the farthest member's surface) holds every member."""
        out = []
        for members in self.clusters():
            centre, radius = self.centre[members], self.radius[members]
            lo, hi = (centre - radius[:, None]).min(axis=0), (centre + radius[:, None]).max(axis=0)
            c_all = 0.5 * (lo + hi)
            r_all = float(np.max(np.linalg.norm(centre - c_all, axis=-1) + radius)) if len(members) > 1 \
                else float(radius[0])
            out.append((members, centre[0] if len(members) == 1 else c_all, r_all))
        return out

    def meet(self, origins, directions, lengths) -> np.ndarray:
        r"""``[P]`` bool: the segments :math:`\mathbf o + t\hat{\mathbf k}`, :math:`0 \le t \le \ell`
        (``lengths`` may be ``inf``; ``directions`` unit) that pass through a sphere: with
        :math:`t_c = (\mathbf c - \mathbf o)\cdot\hat{\mathbf k}` and :math:`d^2 = |\mathbf c - \mathbf o|^2 - t_c^2`,
        :math:`d \le r` and :math:`[t_c - h, t_c + h]` (:math:`h = \sqrt{r^2 - d^2}`) meets :math:`[0, \ell]`.

        A two-level hierarchy of bounding spheres: every segment is tested against the sphere around
        each group of touching spheres (:meth:`clusters`: one per person), and only the segments that
        meet a group's sphere against its members. A segment that passes through a member passes
        through the group's sphere, which holds the member, so the answer is the test of every sphere;
        the cost is (segments x groups) plus (the few segments near a person x its parts) instead of
        (segments x spheres)."""
        o = np.asarray(origins, float)
        k = np.asarray(directions, float)
        length = np.broadcast_to(np.asarray(lengths, float), (len(o),))
        out = np.zeros(len(o), dtype=bool)
        if len(o) == 0 or len(self.radius) == 0:
            return out
        for members, c_all, r_all in self.groups():
            centre, radius = self.centre[members], self.radius[members]
            if len(members) == 1:
                out |= _meet_one(o, k, length, centre[0], float(radius[0]))
                continue
            idx = np.flatnonzero(_meet_one(o, k, length, c_all, r_all) & ~out)
            if idx.size == 0:
                continue
            # every member at once on the segments that meet the group's sphere: t_c = c.k - o.k and
            # |c - o|^2 = |o|^2 - 2 c.o + |c|^2 as [P, K] products, about the group's centre (metres, not the room's)
            oi, ki, li = o[idx] - c_all, k[idx], length[idx]
            c = centre - c_all
            tc = ki @ c.T - np.einsum("pi,pi->p", oi, ki)[:, None]
            d2 = (np.einsum("pi,pi->p", oi, oi)[:, None] - 2.0 * (oi @ c.T)
                  + np.einsum("ki,ki->k", c, c)[None]) - tc ** 2
            r2 = (radius ** 2)[None]
            h = np.sqrt(np.clip(r2 - d2, 0.0, None))
            out[idx] = np.any((d2 <= r2) & (tc + h >= 0) & (tc - h <= li[:, None]), axis=1)
        return out


class RayIndex:
    r"""Static segments indexed by the point their lines come from, to find the few that may pass
    through a moving object's sphere without testing them all.

    Every static segment of the PO render lies on a ray from a fixed point, its *apparent source*
    :math:`\mathbf s`: the first bounce's rays leave the render's origin; a specular reflection at
    :math:`\mathbf p` (tangent plane normal :math:`\hat{\mathbf n}`) of a ray that came from
    :math:`\mathbf s_{in}` leaves the mirror image
    :math:`\mathbf s = \mathbf s_{in} - 2((\mathbf s_{in} - \mathbf p)\cdot\hat{\mathbf n})\hat{\mathbf n}`,
    the same point for every sample of one plane (a wall's reflections all come from the radar's
    image in the wall). So the segments fall in groups, one per apparent source, and within a group
    the rays from :math:`\mathbf s` are indexed by their unit directions (a k-d tree,
    :class:`scipy.spatial.cKDTree`).

    A ray from :math:`\mathbf s` meets the sphere :math:`(\mathbf c, r)`,
    :math:`D = |\mathbf c - \mathbf s| > r`, only if its direction lies within
    :math:`\alpha = \arcsin(r/D)` of :math:`(\mathbf c - \mathbf s)/D`, the cone tangent to the
    sphere; between unit vectors the angle :math:`\theta` and the chord :math:`2\sin(\theta/2)` grow
    together, so a ball query of chord :math:`2\sin(\alpha/2)` finds every such ray (from inside the
    sphere, :math:`D \le r`, every ray may meet it). The group's point is one member's :math:`\mathbf s`;
    a segment :math:`\mathbf p + t\hat{\mathbf k}` lies within
    :math:`\delta = |(\mathbf p - \mathbf s)\times\hat{\mathbf k}|` of the ray from :math:`\mathbf s` along
    :math:`\hat{\mathbf k}` (and ahead of :math:`\mathbf s`, :math:`(\mathbf p - \mathbf s)\cdot\hat{\mathbf k} \ge 0`,
    else it is tested on its own), so each group queries the sphere grown by its largest
    :math:`\delta` (rounding, :math:`10^{-15}` m, on a plane; a curved surface's samples make groups of
    one). Segments in groups smaller than :data:`MIN_GROUP` are tested directly. The cone holds every
    segment that meets its sphere; each sphere's exact test (:meth:`Spheres.meet`'s closed form) runs
    on the segments in its cone alone: a frame costs the segments near the moving objects.
    """

    #: Groups of fewer segments are tested directly (a tree is not worth it).
    MIN_GROUP = 64

    def __init__(self, sources, starts, directions):
        from scipy.spatial import cKDTree

        sources, starts, k = (np.asarray(x, float) for x in (sources, starts, directions))
        # one group per apparent source, its point the first member's (sources agree to rounding on a plane)
        _, first, label = np.unique(np.round(sources, 9), axis=0, return_index=True, return_inverse=True)
        label = label.reshape(-1)
        point = sources[first][label]
        ahead = np.einsum("pi,pi->p", starts - point, k) >= 0
        offset = np.linalg.norm(np.cross(starts - point, k), axis=-1)
        label = np.where(ahead, label, -1)
        counts = np.bincount(label[label >= 0], minlength=len(first))
        label = np.where((label >= 0) & (counts[np.maximum(label, 0)] >= self.MIN_GROUP), label, -1)
        self.loose = np.flatnonzero(label < 0)
        self.groups = []
        order = np.argsort(label, kind="stable")
        bounds = np.searchsorted(label[order], np.arange(len(first) + 1))
        for g in range(len(first)):
            members = order[bounds[g]:bounds[g + 1]]
            if members.size:
                self.groups.append((sources[first[g]], cKDTree(k[members]), members, float(offset[members].max())))
        self.size = len(sources)

    def _cones(self, tree, point, members, centres, radii) -> list:
        """Per sphere (``centres [S, 3]``, ``radii [S]``) the ``members`` of a group (rays from ``point``) whose
        direction lies in the sphere's cone: one ball query for all of them."""
        centres = np.asarray(centres, float).reshape(-1, 3)
        radii = np.asarray(radii, float).reshape(-1)
        d = np.linalg.norm(centres - point, axis=-1)
        out = [members] * len(d)                  # from inside a sphere every ray may meet it
        cone = np.flatnonzero(d > radii)
        if cone.size:
            chord = 2.0 * np.sin(0.5 * np.arcsin(radii[cone] / d[cone]))
            hits = tree.query_ball_point((centres[cone] - point) / d[cone, None], chord * (1 + 1e-9) + 1e-12,
                                         return_sorted=False)
            for i, hit in zip(cone, hits):
                out[i] = members[np.asarray(hit, dtype=np.int64)]
        return out

    def meet(self, spheres: Spheres, starts, directions, lengths) -> np.ndarray:
        """``[P]`` bool: :meth:`Spheres.meet` of the indexed segments (``starts``, unit ``directions``,
        ``lengths``, the segments the index was built on): each sphere's exact test on the segments in
        its cone alone, found per group of touching spheres (:meth:`Spheres.groups`) and then per member
        (the cones only choose which segments the exact test sees, so how they are queried does not change
        the answer)."""
        out = np.zeros(self.size, dtype=bool)
        if self.size == 0 or len(spheres.radius) == 0:
            return out
        starts, k = np.asarray(starts, float), np.asarray(directions, float)
        length = np.broadcast_to(np.asarray(lengths, float), (self.size,))
        if self.loose.size:
            out[self.loose] = spheres.meet(starts[self.loose], k[self.loose], length[self.loose])
        groups = spheres.groups()
        group_centres = np.array([centre for _, centre, _ in groups], float).reshape(-1, 3)
        group_radii = np.array([radius for _, _, radius in groups], float)
        for point, tree, members, margin in self.groups:
            grow = margin * (1 + 1e-9) + 1e-12
            for (parts, _, _), near in zip(groups, self._cones(tree, point, members, group_centres,
                                                                group_radii + grow)):
                if near.size == 0:
                    continue
                cones = [near] if len(parts) == 1 else \
                    self._cones(tree, point, members, spheres.centre[parts], spheres.radius[parts] + grow)
                for j, rows in zip(parts, cones):
                    rows = rows[~out[rows]]
                    if rows.size:
                        out[rows] = _meet_one(starts[rows], k[rows], length[rows], spheres.centre[j],
                                              float(spheres.radius[j]))
        return out


def shared_rows(record) -> None:
    """Replace every array field ``[P, ...]`` of the dataclass ``record`` whose rows are all bit for bit
    the same by a read-only broadcast view of one row: the same values, one row of memory.

    A static render holds many such fields (on the first bounce the image source, the identity mirror
    map, the unit chain reflection; on every bounce the zero velocities and, on flat surfaces, the
    zero shape operator): about a third of the first bounce's bytes. Selecting samples
    (:meth:`~sionnafmcw.engines.po_render.Render.select`) gives ordinary arrays again."""
    for name in record.__dataclass_fields__:
        x = getattr(record, name)
        if not isinstance(x, np.ndarray) or x.ndim == 0 or len(x) < 2 or x.dtype.hasobject or x.strides[0] == 0:
            continue
        rows = np.ascontiguousarray(x).view(np.uint8).reshape(len(x), -1)
        if np.all(rows == rows[:1]):
            object.__setattr__(record, name, np.broadcast_to(x[0].copy(), x.shape))


def _meet_one(o, k, length, c, r) -> np.ndarray:
    """``[P]`` bool: the segments (:meth:`Spheres.meet`) through the one sphere ``(c, r)``."""
    oc = c - o
    tc = np.einsum("pi,pi->p", oc, k)
    d2 = np.einsum("pi,pi->p", oc, oc) - tc ** 2
    h = np.sqrt(np.clip(r * r - d2, 0.0, None))
    return (d2 <= r * r) & (tc + h >= 0) & (tc - h <= length)


def blocked_segments(loaded, starts, ends, moving_ids, tolerance: float = SEGMENT_TOLERANCE) -> np.ndarray:
    """``[P]`` bool: the segments ``starts -> ends`` (world, m) on which a moving object (Mitsuba shape
    ids ``moving_ids``) is hit more than ``tolerance`` before the end, cast in the full scene."""
    from ..sionna_rt import cast_rays

    starts = np.asarray(starts, float)
    d = np.asarray(ends, float) - starts
    length = np.linalg.norm(d, axis=-1)
    if len(starts) == 0:
        return np.zeros(0, dtype=bool)
    k = d / np.maximum(length, 1e-300)[:, None]
    eps = 1e-5 * (1.0 + np.linalg.norm(starts, axis=-1))   # off the start surface, as po_render.reflect
    valid, t, shape, _, _ = cast_rays(loaded.scene, starts + eps[:, None] * k, k)
    return valid & np.isin(shape, list(moving_ids)) & (t + eps < length - tolerance)


def blocked_in_world(world, starts, ends, tolerance: float = SEGMENT_TOLERANCE) -> np.ndarray:
    """``[P]`` bool: the segments ``starts -> ends`` (world, m) on which a moving surface of the
    :class:`~sionnafmcw.engines.surfaces.SurfaceWorld` is hit more than ``tolerance`` before the end
    (the PO chains' test; :func:`blocked_segments` is Sionna's paths')."""
    starts = np.asarray(starts, float)
    d = np.asarray(ends, float) - starts
    length = np.linalg.norm(d, axis=-1)
    if len(starts) == 0:
        return np.zeros(0, dtype=bool)
    k = d / np.maximum(length, 1e-300)[:, None]
    eps = 1e-5 * (1.0 + np.linalg.norm(starts, axis=-1))   # off the start surface, as po_render.reflect
    valid, t, _, _, _ = world.cast(starts + eps[:, None] * k, k, "moving")
    return valid & (t + eps < length - tolerance)


def first_hit_moving(world, starts, directions) -> np.ndarray:
    """``[P]`` bool: the rays ``starts + t directions`` (started off their surface as
    :func:`~sionnafmcw.engines.po_render.reflect` does) whose nearest hit in the
    :class:`~sionnafmcw.engines.surfaces.SurfaceWorld` is on a moving surface."""
    if len(starts) == 0:
        return np.zeros(0, dtype=bool)
    eps = 1e-5 * (1.0 + np.linalg.norm(starts, axis=-1))
    valid, _, obj, _, _ = world.cast(starts + eps[:, None] * directions, directions, "all")
    return valid & np.isin(obj, world.moving())


# ---------------------------------------------------------------------------------------- PO
@dataclass
class StaticPO:
    """The PO render of the static objects (cast over the static surfaces only), its echoes merged, and
    what a frame needs.

    ``renders``: :class:`~sionnafmcw.engines.po_render.Render` per bounce; ``keep``: per bounce the
    samples that carry PO (:meth:`~sionnafmcw.engines.po_render.Render.carries_po`); ``incident``:
    the first bounce's rays from the render origin, unit directions ``[P, 3]`` and lengths ``[P]``
    (m); ``outgoing``: per bounce but the last rendered, the reflected direction of every sample
    ``[P, 3]``, the index of its next-bounce sample (``-1``: none) and the length to it (``inf``:
    none); the segments a frame re-checks, fixed per pose; ``cells``: per bounce the merge cell of every
    kept sample and the merged cells ``(tau, doppler, labels)`` (None without merging);
    ``echoes``: the merged static PO echoes of all bounces (None when empty); ``unmerged``: per bounce
    without merging, views ``(a, tau, doppler, labels)`` of the static block's contributions of its kept
    samples (:meth:`share`), from which a frame takes those of the samples a moving object blocks
    instead of computing them again (the same kernel on the same samples: the same values).
    """

    renders: list
    keep: list
    incident: tuple
    outgoing: list
    cells: list
    echoes: object
    index: dict = field(default_factory=dict)
    unmerged: dict = field(default_factory=dict)

    @classmethod
    def build(cls, world, objects, centre, rotation, wavelength: float, depth: int, samples_across: int,
              contributions, merge, max_splits: int | None = None, exact_ids=frozenset()) -> StaticPO:
        """Render the static surfaces of ``world`` (``objects``: its :func:`~.po_render.scene_objects`)
        from ``centre`` up to ``depth`` bounces, over the static surfaces alone;
        ``contributions(render)`` gives ``(a, tau, doppler, labels)`` of a render's samples,
        ``merge(render, contributions)`` the :class:`~sionnafmcw.engines.po_merge.Merged` ones or None
        (no merging; a ``Merged`` that merged nothing, ``fraction`` None, counts as None, so that a frame
        takes the blocked samples' contributions from the block instead of computing them again);
        ``max_splits``: as :func:`~.bounce_sampling.resolved_bounces`; ``exact_ids``: the objects whose own
        chains carry no PO here (:meth:`~.po_render.Render.carries_po`: integrated per frame by
        :mod:`~sionnafmcw.engines.flat_faces`)."""
        from ..echoes import Echoes
        from .bounce_sampling import resolved_bounces
        from .po_render import render

        static = [k for k, surface in enumerate(world.surfaces) if surface.kind == "static"]
        first = render(world, objects, centre, rotation, wavelength, targets=static, group="static",
                       samples_across=samples_across)
        renders = resolved_bounces(world, first, objects, rotation, wavelength, depth, samples_across, "static",
                                   max_splits, exact_ids)
        d_first = renders[0].samples.position - renders[0].source
        length_first = np.linalg.norm(d_first, axis=-1)
        incident = (d_first / np.maximum(length_first, 1e-300)[:, None], length_first)
        outgoing = []
        for d in range(len(renders) - 1):
            k_out = renders[d].reflected()[1]
            child = np.full(renders[d].num_samples, -1, dtype=np.int64)
            child[renders[d + 1].parent] = np.arange(renders[d + 1].num_samples)
            length = np.full(renders[d].num_samples, np.inf)
            has = child >= 0
            length[has] = np.linalg.norm(renders[d + 1].samples.position[child[has]]
                                         - renders[d].samples.position[has], axis=-1)
            outgoing.append((k_out, child, length))
        keep, cells, parts = [], [], []
        for b in renders:
            kept = b.carries_po(exact_ids)
            keep.append(kept)
            if not np.any(kept):
                cells.append(None)
                continue
            chosen = b.select(kept)
            a, tau, doppler, labels = contributions(chosen)
            merged = merge(chosen, (a, tau, doppler, labels))
            if merged is None or merged.fraction is None:   # nothing merged: the samples' own contributions
                cells.append(None)
                parts.append(Echoes(a, tau, doppler, labels))
            else:
                cells.append((merged.cell, merged.tau, merged.doppler, merged.labels))
                parts.append(Echoes(merged.a, merged.tau, merged.doppler, merged.labels))
        echoes = None if not parts else (parts[0] if len(parts) == 1 else Echoes.concatenate(parts))
        for b in renders:   # held for every frame of the pose: what is the same for all samples, once
            shared_rows(b)
            shared_rows(b.samples)
        return cls(renders, keep, incident, outgoing, cells, echoes)

    @property
    def num_samples(self) -> int:
        return int(sum(int(k.sum()) for k in self.keep))

    def share(self, block, offset: int) -> None:
        """Hold :attr:`echoes` and the merge's cells as views of ``block`` (an :class:`~sionnafmcw.echoes.Echoes`
        whose contributions ``[..., offset:]`` are :attr:`echoes`, bounce after bounce), not as arrays of
        their own: the static echoes in memory once."""
        from ..echoes import Echoes

        n = self.echoes.num_contributions
        view = slice(offset, offset + n)
        labels = np.asarray(block.labels)
        self.echoes = Echoes(block.a[..., view], block.tau[..., view], block.doppler[..., view], labels[..., view])
        row = labels[0, 0]   # the labels per contribution (the same for every element pair in a PO block)
        start = offset
        for d, (kept, cells) in enumerate(zip(self.keep, self.cells)):
            if not np.any(kept):
                continue
            if cells is None:   # unmerged: the block holds every kept sample's own contributions, in order
                g = slice(start, start + int(kept.sum()))
                self.unmerged[d] = (block.a[..., g], block.tau[..., g], block.doppler[..., g], row[g])
                start = g.stop
                continue
            cell, tau, _, _ = cells
            g = slice(start, start + tau.shape[2])
            self.cells[d] = (cell, block.tau[..., g], block.doppler[..., g], row[g])
            start = g.stop

    def _index(self, d: int) -> RayIndex:
        """The :class:`RayIndex` (built on first use, then kept for the pose) of the segments a frame tests:
        ``d = 0`` the first bounce's incident rays (from the render's origin), ``d >= 1`` the rays reflected
        at bounce ``d`` (from the image of bounce ``d``'s source in each sample's tangent plane)."""
        if d not in self.index:
            if d == 0:
                b = self.renders[0]
                self.index[0] = RayIndex(b.source, b.source, self.incident[0])
            else:
                b = self.renders[d - 1]
                n, k_out = b.reflected()
                p, src = b.samples.position, np.asarray(b.source, float)
                image = src - 2 * np.einsum("pi,pi->p", src - p, n)[:, None] * n
                self.index[d] = RayIndex(image, p, k_out)
        return self.index[d]

    def frame(self, world, objects, centre, rotation, wavelength: float, depth: int, samples_across: int,
              contributions, frequency: float, max_splits: int | None = None, exact_ids=()):
        """What the moving objects change in this frame: ``(renders, removed, num_removed)``.

        ``renders``: the frame's own PO renders (the moving objects' render and its reflections,
        and the static chains that now end on a moving object), to be turned into echoes as
        without the cache; ``removed``: :class:`~sionnafmcw.echoes.Echoes` that take the blocked
        static samples out of the static block (None when nothing is blocked); ``num_removed``:
        how many static samples were taken out. ``exact_ids``: as :meth:`build`, for the moving objects' chains.
        """
        from ..echoes import Echoes
        from .bounce_sampling import resolved_bounces
        from .po_merge import take_out_of_cells
        from .po_render import reflect, render

        moving = world.moving()
        spheres = Spheres(*world.bounding_spheres(moving))
        first = self.renders[0]
        removed = [np.zeros(first.num_samples, dtype=bool)]
        if first.num_samples and moving:
            cand = np.flatnonzero(self._index(0).meet(spheres, first.source, *self.incident))
            removed[0][cand] = blocked_in_world(world, first.source[cand], first.samples.position[cand])
        # the moving objects' own chains, every exit aperture resolved (bounce_sampling); the static chains
        # that now end on a moving object are followed from the cached static tubes
        chain = resolved_bounces(world, render(world, objects, centre, rotation, wavelength, targets=moving,
                                               samples_across=samples_across),
                                 objects, rotation, wavelength, depth, samples_across,
                                 max_splits=max_splits, exact_ids=exact_ids) if moving else []
        own = chain[:1]
        frontier = []
        for d in range(1, depth):
            nxt = [reflect(world, b, objects, rotation, wavelength) for b in frontier if b.num_samples]
            if d < len(self.renders):
                prev, (k_out, child, length) = self.renders[d - 1], self.outgoing[d - 1]
                gone = removed[d - 1][self.renders[d].parent]
                if moving and prev.num_samples:
                    cand = np.flatnonzero(~removed[d - 1] & self._index(d).meet(spheres, prev.samples.position,
                                                                                   k_out, length))
                    # the reflected rays that now end on a moving object: their cached next bounce goes,
                    # and they are rendered again (only those) on the moving object
                    cand = cand[first_hit_moving(world, prev.samples.position[cand], k_out[cand])]
                    if cand.size:
                        ended = child[cand]
                        gone[ended[ended >= 0]] = True
                        nxt.append(reflect(world, prev.select(cand), objects, rotation, wavelength))
                removed.append(gone)
            own.extend(chain[d:d + 1] + nxt)
            frontier = nxt
        out = []
        for d, (b, gone, kept, cells) in enumerate(zip(self.renders, removed, self.keep, self.cells)):
            take = gone & kept
            if not np.any(take):
                continue
            if cells is None and d in self.unmerged:   # the blocked samples' own contributions, from the block
                rows = (np.cumsum(kept) - 1)[take]
                a, tau, doppler, labels = self.unmerged[d]
                out.append(Echoes(-a[..., rows], tau[..., rows], doppler[..., rows], labels[rows]))
                continue
            a, tau, doppler, labels = contributions(b.select(take))
            if cells is None:
                out.append(Echoes(-a, tau, doppler, labels))
                continue
            cell_of_kept, cell_tau, cell_dop, cell_lab = cells
            cell = cell_of_kept[(np.cumsum(kept) - 1)[take]]
            a_r, tau_r, dop_r, lab_r = take_out_of_cells(a, tau, cell, cell_tau, cell_dop, cell_lab, frequency)
            out.append(Echoes(a_r, tau_r, dop_r, lab_r))
        removed_echoes = None if not out else (out[0] if len(out) == 1 else Echoes.concatenate(out))
        return own, removed_echoes, int(sum(int((g & k).sum()) for g, k in zip(removed, self.keep)))


__all__ = ["SEGMENT_TOLERANCE", "RayIndex", "Spheres", "StaticPO", "blocked_in_world", "blocked_segments",
           "first_hit_moving", "hidden", "moving_objects", "shared_rows"]
