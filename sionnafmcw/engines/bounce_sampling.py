r"""The ray density of the PO multi-bounce chains, from an error bound on every exit aperture.

The first bounce of the PO render (:func:`~sionnafmcw.engines.po_render.render`) samples each
object with the step of :func:`~sionnafmcw.physical_optics.render_resolution`: the in-sample phase
bounded and the object's outline resolved by ``samples_across`` samples. A chain of :math:`d \ge 2`
bounces (:func:`~sionnafmcw.engines.po_render.reflect`) radiates from its *exit aperture*: the part
of the last surface that the rays of the chain reach. Its samples are the first bounce's ray tubes
that went through the whole chain, so the first bounce's density decides how well the aperture is
sampled, and an aperture much smaller than the object it starts on (a corner reflector seen off
its axis, whose triple-bounce aperture shrinks to a sliver) gets a handful of tubes: too few to
resolve its outline. This module sets the density of the chains by a rule instead.

The error of a sampled aperture
-------------------------------
Inside the aperture, the tubes' footprints tile the last surface without gaps or overlaps (their
edges are the mirrored angular steps) and each footprint's integral is exact for the linear
in-sample phase and second order in the quadratic (:func:`~sionnafmcw.physical_optics.footprint_factor`),
so the interior's only error is the in-sample phase, which the first bounce's rule bounds: the
ray tube's footprint on the last surface of a chain of plane mirrors is the first bounce's step at
the unfolded length :math:`L`, and its quadratic phase :math:`k s^2/(8L)` at :math:`s = L\Delta\theta`
is :math:`k L\Delta\theta^2/8`, while the bound wants it below :math:`Q_{max}` at the first
surface's range :math:`R \le L` -- it grows with :math:`L/R`, which for the corner reflectors and
the room's multipath stays below 2-3, within the second-order factor's accuracy.

The outline is different: a tube that the outline cuts counts whole or not at all. Let
:math:`h_i = a_i e^{-j2\pi c\tau_i/\lambda}` be tube :math:`i`'s share of the channel of an isotropic
element at the render origin (:func:`monostatic_channels`: the PO of the chain, in-sample factor
included). Where the outline cuts a tube, only a fraction :math:`f_i \in [0, 1]` of its footprint
belongs to the aperture, but the render counts the whole tube when its centre ray went through the
chain (:math:`c_i = 1`) and nothing otherwise, so the aperture's echo :math:`H_g = \sum_{i\in g} h_i`
is off by :math:`\sum_{i\in\partial g}(c_i - f_i)h_i` (the phase across a tube being what the
footprint factor already integrates), :math:`\partial g` the *boundary tubes*: the tubes of aperture
:math:`g` with a neighbour in the first bounce's grid whose chain differs (another sequence of
surfaces, or none). Split :math:`c_i - f_i` into its mean over the band and the scatter about it.
For an outline that is straight across a few tubes the centre rule makes :math:`|c_i - f_i| \le 1/2`;
where the outline runs along the grid the offsets repeat and the error is the band's coherent sum
times one offset; where it crosses the grid the offsets are spread uniformly over a tube, their
scatter has variance :math:`1/12`, and the errors add in power. So

.. math::
    |\delta H_g| \lesssim E_g = \tfrac12\Bigl|\sum_{i\in\partial g} h_i\Bigr|
        + \Bigl(\tfrac1{12}\sum_{i\in\partial g}|h_i|^2\Bigr)^{1/2}.

Against :math:`\sum_{\partial g}|h_i|`, the worst case, this keeps the cancellation the echo itself
has: a room's wall-to-wall aperture spans many Fresnel zones, its boundary band's coherent sum is
small, while :math:`\sum|h_i|` over it is many times the wall's echo. What :math:`E_g` must be
measured against is the echo the user reads: the object the chain ends on (the echo's label), all
its bounces, :math:`H_o = \sum_{\text{bounces}}\sum_{i \in o} h_i`. The rule asks, for every aperture,

.. math:: E_g \le \eta\,|H_o|,\qquad \eta = \eta_{16}\,\frac{16}{N},

:math:`N` = ``samples_across``, :data:`ERROR_SHARE` :math:`\eta_{16} = 0.1` (0.83 dB at worst for one
aperture at the default :math:`N = 16`), tightening as the user raises ``samples_across`` exactly as
the first bounce's outline does (its samples :math:`\propto 1/N`), so that the "density raised until
nothing moves" converges every bounce.

Where a bound is not met, the rule splits the aperture's boundary tubes and their neighbours across
the outline into four (:func:`quartered`: the rays through the quarters' centres, cast from the
origin, visibility as the render's; where the neighbour's grid cell holds no tube because its centre
ray missed the object, that cell too, so an outline is approached from both sides; a cell that a tube
or another new cell already covers is not cast again) and follows the new tubes' chains (the other
tubes' chains stay as they are). Each split halves the band of boundary tubes, and with it both terms
of :math:`E_g` (the band's width halves, and the number of its tubes doubles at a quarter of the
power each), so the cost goes to the outlines that need it. At most :data:`MAX_SPLITS` rounds (tubes
16 times finer); the first bounce's own PO is the same integral on the finer tubes.

Apertures are told apart by the sequence of surfaces of their chains: the object of every bounce
and, on a plane face (a corner reflector's, a wall: :func:`plane_samples`), the plane of the face
(its normal to 1e-3).

The rule samples the chains over plane faces only. Its premise, an interior that the tubes tile exactly
with the footprints of the mirrored steps, holds for plane mirrors; a chain that reflects off a curved
(smooth-shaded) surface is followed as if that surface were its tangent plane at each tube
(:mod:`~sionnafmcw.engines.po_render`), the divergence the curvature gives the reflected tube is not in
its footprint, and quartering the outline does not reduce that error. Such chains (a walker's body and
the floor, each other) keep the first bounce's density, which the curvature of their first surface
already sets fine (:func:`~sionnafmcw.physical_optics.render_resolution`).

What it finds (``benchmarks/po_bounces.py``, the converged echo being the same engine at
``samples_across`` 128): trihedrals (three bounces) and dihedrals (two) of 0.05-0.3 m at 1-10 m and
0-30 degrees off their axis within 1 dB of it at the defaults (0.99 dB at worst; before the rule up to
3.0 dB, a 0.1 m trihedral at 1 m, 30 degrees, whose triple bounce had 9 tubes). A closed room's floor
and ceiling are dihedral corners with the walls: their echo is the wall-to-floor double bounce along
the corner line, which the rule resolves (an empty room's floor and ceiling read 2.5 and 4.5 dB low
before; the walls, whose echo is their own specular spot, do not move), and so are a furnished room's
metal cabinet and door against the floor (7.8 and 6.6 dB low before).
"""

from __future__ import annotations

import numpy as np

#: Most rounds of splitting (each halves the tubes of an outline: 2**MAX_SPLITS finer at most).
MAX_SPLITS = 4
#: :math:`\eta` at the default ``samples_across`` (16): the bound on an exit aperture's echo error as a share of
#: its object's echo amplitude (0.1: 0.83 dB at worst).
ERROR_SHARE = 0.1
#: A sample is on a plane face where its normal turns across its footprint by at most this (rad): the
#: rounding of a flat-shaded face's corner normals, far below any curvature the render resolves.
PLANE_TURN = 1e-6
#: Grid neighbour search: a probe ray belongs to the nearest tube whose centre lies within this share
#: of the larger of the two tubes' steps (1/sqrt(2) is the farthest a point of a square tube can be
#: from its centre; a little more for the tubes' curvature on the sphere).
NEIGHBOUR_REACH = 0.75


def error_share(samples_across: int) -> float:
    r""":math:`\eta = \eta_{16}\,16/N` (:data:`ERROR_SHARE` at the default ``samples_across`` N = 16): the largest
    bound on an aperture's echo error, as a share of the echo of the object it ends on (module docstring)."""
    return ERROR_SHARE * 16.0 / int(samples_across)


def follow(world, first, objects, rotation, wavelength: float, depth: int, group: str = "all") -> list:
    """The renders of bounces 1 to ``depth`` from the first bounce ``first`` (:func:`~.po_render.reflect`)."""
    from .po_render import reflect

    renders = [first]
    while renders[-1].depth < depth and renders[-1].num_samples:
        renders.append(reflect(world, renders[-1], objects, rotation, wavelength, group=group))
    return renders


def resolved_bounces(world, first, objects, rotation, wavelength: float, depth: int, samples_across: int,
                     group: str = "all", max_splits: int | None = None, exact_ids=()) -> list:
    """The renders of bounces 1 to ``depth`` with every exit aperture resolved (module docstring): the
    chains of ``first`` followed, the boundary tubes of the apertures whose bound is not met split and
    their chains followed (the other tubes' chains are kept), until every bound holds or
    ``max_splits`` rounds (default :data:`MAX_SPLITS`; 0: the chains at the first bounce's density) are done;
    the own chains of the objects ``exact_ids`` (integrated over their exact apertures,
    :mod:`~sionnafmcw.engines.flat_faces`) are not split."""
    renders = follow(world, first, objects, rotation, wavelength, depth, group)
    if len(renders) < 2 or max_splits == 0 or not plane_chains(renders, objects):
        return renders
    channels = monostatic_channels(renders, wavelength)
    for _ in range(MAX_SPLITS if max_splits is None else max_splits):
        split, empty = under_resolved(renders, objects, samples_across, wavelength, channels, exact_ids)
        if split.size == 0 and empty.size == 0:
            break
        new = follow(world, quartered(world, renders[0], split, objects, rotation, wavelength, group, empty),
                     objects, rotation, wavelength, depth, group)
        renders, channels = _joined(renders, channels, split, new, monostatic_channels(new, wavelength,
                                                                                        renders[0].source[:1]))
    return renders


def plane_chains(renders, objects) -> bool:
    """True when some chain of two or more bounces in ``renders`` runs over plane faces only
    (:func:`plane_samples`): the chains the rule samples (module docstring)."""
    plane = plane_samples(renders[0])
    for bounce in renders[1:]:
        if bounce.num_samples == 0:
            return False
        plane = plane[bounce.parent] & plane_samples(bounce)
        if np.any(plane):
            return True
    return False


def _joined(renders, channels, split, new, new_channels):
    """The chains of the tubes of ``renders[0]`` not in ``split``, then the chains ``new`` of the quarters:
    the renders and their channels per bounce."""
    from dataclasses import replace

    from .po_render import join_first_bounces, join_renders

    keep = np.ones(renders[0].num_samples, dtype=bool)
    keep[split] = False
    out, out_channels = [], []
    previous = 0
    for d, bounce in enumerate(renders):
        if d:
            keep = keep[bounce.parent]
        kept = bounce.select(keep)
        if d:   # the parents' indices among the kept samples of the bounce before
            kept.parent = ranks[bounce.parent[keep]]
        ranks = np.cumsum(keep) - 1
        part = [channels[d][keep]]
        if d < len(new):
            kept = join_first_bounces(kept, new[0]) if d == 0 else join_renders(kept, new[d], previous)
            part.append(new_channels[d])
        previous = int(np.count_nonzero(keep))
        out.append(kept)
        out_channels.append(np.concatenate(part))
    for d in range(len(renders), len(new)):   # the quarters' chains went deeper than any before
        offset = previous if d == len(renders) else 0
        out.append(replace(new[d], parent=new[d].parent + offset))
        out_channels.append(new_channels[d])
    return out, out_channels


def plane_samples(bounce) -> np.ndarray:
    r"""``[P]`` bool: the samples on a plane face, whose normal turns across the tube's footprint by less
    than :data:`PLANE_TURN` (:math:`\|\mathbf K\|_F\sqrt{\Delta A}`, :math:`\mathbf K` the shape operator):
    a flat-shaded face up to the rounding of its corner normals."""
    s = bounce.samples
    if s.curvature is None:
        return np.ones(s.num_samples, dtype=bool)
    turn = np.sqrt(np.einsum("pij,pij->p", s.curvature, s.curvature) * s.area)
    return turn <= PLANE_TURN


def surface_codes(bounce, plane=None) -> np.ndarray:
    """One int64 per sample naming its surface: the object and, on a plane face (``plane [P]``,
    :func:`plane_samples` when None), the face's normal to 1e-3 (module docstring)."""
    s = bounce.samples
    plane = plane_samples(bounce) if plane is None else plane
    key = np.round(s.normal * 1000.0).astype(np.int64) + 1000
    code = (key[:, 0] * 2001 + key[:, 1]) * 2001 + key[:, 2] + 1
    return s.object_id.astype(np.int64) * (2001 ** 3 + 1) + np.where(plane, code, 0)


def grid_neighbours(first) -> np.ndarray:
    r"""``[P, 4]``: for every first-bounce tube the tube one step away along ``-step_az, +step_az, -step_el,
    +step_el`` (index, -1 where no tube is there: the ray missed or hit another object first).

    A probe :math:`\mathbf u_i \pm \mathbf s_i` belongs to its nearest tube centre :math:`j` when
    :math:`|\mathbf u_j - \mathbf u_i \mp \mathbf s_i| \le r_{ij}`, :math:`r_{ij} = \rho\max(s_i, s_j)`
    (:data:`NEIGHBOUR_REACH` :math:`\rho`). Every accepted distance is at most :math:`\rho\max_k s_k`, so the
    nearest-neighbour search is bounded there (a probe whose nearest centre lies farther would be
    refused anyway): the same neighbours as an unbounded search, without descending the k-d tree past
    the bound. The tree is built unbalanced on the centres (median splits cost a sort per node; the
    sliding-midpoint tree answers the same queries exactly)."""
    from scipy.spatial import cKDTree

    p = first.num_samples
    out = np.full((p, 4), -1, dtype=np.int64)
    if p == 0:
        return out
    u = first.direction
    size = np.maximum(np.linalg.norm(first.step_az, axis=1), np.linalg.norm(first.step_el, axis=1))
    probes = np.concatenate([u - first.step_az, u + first.step_az, u - first.step_el, u + first.step_el])
    bound = np.nextafter(NEIGHBOUR_REACH * float(size.max()), np.inf)
    distance, index = cKDTree(u, balanced_tree=False, compact_nodes=False).query(probes, distance_upper_bound=bound)
    near = index < p                                        # cKDTree answers p where nothing lies within the bound
    index = np.where(near, index, 0)
    reach = NEIGHBOUR_REACH * np.maximum(np.tile(size, 4), size[index])
    found = near & (distance <= reach) & (index != np.tile(np.arange(p), 4))
    return np.where(found, index, -1).reshape(4, p).T


def chain_ids(parent_chain: np.ndarray, codes: np.ndarray) -> np.ndarray:
    r"""``[P]``: dense ids of the pairs ``(parent_chain, codes)`` in lexicographic order (the inverse of
    ``np.unique`` over the stacked rows, ``axis=0``), by one 1-D unique of a single int64 key: ``codes``
    replaced by their ranks :math:`s\in[0, S)` (an order-preserving map), the key :math:`cS + s` orders the
    pairs as the rows do; ``parent_chain`` holds dense ids below :math:`P`, so :math:`PS < 2^{63}`."""
    ranks = np.unique(codes, return_inverse=True)[1].reshape(-1)
    width = int(ranks.max(initial=-1)) + 1
    key = parent_chain.astype(np.int64) * width + ranks
    return np.unique(key, return_inverse=True)[1].reshape(-1)


def monostatic_channels(renders, wavelength: float, origin=None) -> list:
    r"""Per render, every sample's share :math:`h_i = a_i e^{-j2\pi c\tau_i/\lambda}` ``[P]`` of the channel of
    an isotropic element at the render origin (transmitting and receiving), in-sample factor included
    (:func:`~.po_render.chain_po_gains`; for the cut pieces of :mod:`~sionnafmcw.engines.flat_faces`, their
    outline's, :func:`~.flat_faces.piece_factor`): the echo the error bound is measured against."""
    from ..constants import SPEED_OF_LIGHT
    from .flat_faces import piece_factor
    from .po_render import chain_po_gains

    origin = renders[0].source[:1] if origin is None else origin
    out = []
    for bounce in renders:
        if bounce.num_samples == 0:
            out.append(np.zeros(0, complex))
            continue
        a, tau, _ = chain_po_gains(bounce, origin, origin, wavelength, in_sample_phase=bounce.outline is None)
        if bounce.outline is not None:
            a = a * piece_factor(bounce, origin, origin, wavelength)
        out.append(a[0, 0] * np.exp(-2j * np.pi * SPEED_OF_LIGHT / wavelength * tau[0, 0]))
    return out


def under_resolved(renders, objects, samples_across: int, wavelength: float, channels=None, exact_ids=()):
    r"""The first-bounce tubes to split (module docstring): ``(split, empty)``, the indices into
    ``renders[0]`` of the boundary tubes of every exit aperture (bounces 2 and on) whose bound
    :math:`E_g \le \eta|H_o|` fails and of their neighbours across the outline, and the ``[K, 2]``
    (tube, side) pairs of those boundary tubes whose neighbouring grid cell holds no tube.
    ``channels``: :func:`monostatic_channels` of ``renders`` (computed when None); the apertures of chains
    that stay on one of the objects ``exact_ids`` are left as they are (their echo is not the tubes')."""
    from .po_merge import label_codes

    first = renders[0]
    p = first.num_samples
    if len(renders) < 2 or p == 0 or renders[1].num_samples == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2), dtype=np.int64)
    eta = error_share(samples_across)
    channels = monostatic_channels(renders, wavelength) if channels is None else channels
    names, codes = label_codes(np.concatenate([b.samples.labels for b in renders]))   # np.unique's, run by run
    echo = np.abs(np.bincount(codes, np.concatenate(channels).real, names.size)
                  + 1j * np.bincount(codes, np.concatenate(channels).imag, names.size))
    label_of = np.split(codes.reshape(-1), np.cumsum([b.num_samples for b in renders])[:-1])
    neighbours = grid_neighbours(first)
    has = neighbours >= 0
    split = np.zeros(p, dtype=bool)
    empty = np.zeros((p, 4), dtype=bool)
    plane = plane_samples(first)                            # the chain so far over plane faces only
    chain = np.unique(surface_codes(first, plane), return_inverse=True)[1].reshape(-1)
    root = np.arange(p)
    for d, bounce in enumerate(renders[1:], start=1):
        if bounce.num_samples == 0:
            break
        root = root[bounce.parent]
        here = plane_samples(bounce)
        plane = plane[bounce.parent] & here
        chain = chain_ids(chain[bounce.parent], surface_codes(bounce, here))
        signature = np.full(p, -1, dtype=np.int64)
        signature[root] = chain
        own = signature[root]
        other = np.where(has[root], signature[np.where(has[root], neighbours[root], 0)], -2)
        differs = other != own[:, None]
        boundary = differs.any(axis=1)
        groups = int(chain.max()) + 1
        h = channels[d] * boundary
        band = np.abs(np.bincount(chain, h.real, groups) + 1j * np.bincount(chain, h.imag, groups))
        bound = 0.5 * band + np.sqrt(np.bincount(chain, np.abs(h) ** 2, groups) / 12.0)     # E_g
        label = np.zeros(groups, dtype=np.int64)
        label[chain] = label_of[d]
        take = boundary & plane & (bound > eta * echo[label])[chain]
        if len(exact_ids) and bounce.one_object is not None:
            take &= ~np.isin(bounce.one_object, np.fromiter(exact_ids, np.int64))
        if not np.any(take):
            continue
        split[root[take]] = True
        across = differs[take] & has[root[take]]
        split[neighbours[root[take]][across]] = True
        empty[root[take]] |= ~has[root[take]]
    return np.flatnonzero(split), np.argwhere(empty)


def _cell_offsets(points, centres, s_az, s_el):
    """``points [K, 3]`` in the cell coordinates of ``centres`` (the same rows): the offsets along the
    steps ``s_az``, ``s_el`` in units of the step (a point lies in the cell where both are below 1/2)."""
    diff = points - centres
    return (np.abs(np.einsum("ki,ki->k", diff, s_az)) / np.einsum("ki,ki->k", s_az, s_az),
            np.abs(np.einsum("ki,ki->k", diff, s_el)) / np.einsum("ki,ki->k", s_el, s_el))


def _inside(points, centres, s_az, s_el, neighbours: int = 8) -> np.ndarray:
    """``[K]`` bool: the directions ``points`` that lie in one of the tube cells (``centres`` and steps)."""
    from scipy.spatial import cKDTree

    out = np.zeros(len(points), dtype=bool)
    if len(points) == 0 or len(centres) == 0:
        return out
    reach = float(np.max(np.maximum(np.linalg.norm(s_az, axis=1), np.linalg.norm(s_el, axis=1))))
    k = min(neighbours, len(centres))
    _, index = cKDTree(centres).query(points, k=k, distance_upper_bound=reach)
    index = index.reshape(len(points), k)
    for j in range(k):
        found = index[:, j] < len(centres)
        c = index[found, j]
        a, e = _cell_offsets(points[found], centres[c], s_az[c], s_el[c])
        out[np.flatnonzero(found)[(a < 0.5) & (e < 0.5)]] = True
    return out


def _inside_earlier(centres, s_az, s_el, neighbours: int = 8) -> np.ndarray:
    """``[K]`` bool: the cells whose centre lies in a cell earlier in the list (the list coarsest first)."""
    from scipy.spatial import cKDTree

    out = np.zeros(len(centres), dtype=bool)
    if len(centres) < 2:
        return out
    reach = float(np.max(np.maximum(np.linalg.norm(s_az, axis=1), np.linalg.norm(s_el, axis=1))))
    k = min(neighbours, len(centres))
    _, index = cKDTree(centres).query(centres, k=k, distance_upper_bound=reach)
    for j in range(k):
        found = (index[:, j] < len(centres)) & (index[:, j] < np.arange(len(centres)))
        c = index[found, j]
        rows = np.flatnonzero(found)
        a, e = _cell_offsets(centres[rows], centres[c], s_az[c], s_el[c])
        out[rows[(a < 0.5) & (e < 0.5)]] = True
    return out


def quartered(world, first, index, objects, rotation, wavelength: float, group: str = "all", empty=None):
    r"""The quarters of the first bounce ``first``'s tubes ``index`` as a first-bounce render: the rays
    through the centres of the quarters (:math:`\hat{\mathbf u} \pm \Delta_{az}/4 \pm \Delta_{el}/4`, normalised) cast from the
    render origin over ``group``, a hit kept where it is on the tube's own object (visibility as the
    render's), with half the steps and a quarter of the solid angle. ``empty`` ``[K, 2]``: (tube, side)
    pairs (:func:`grid_neighbours`' order) whose neighbouring grid cell holds no tube (its centre ray
    missed the object): that cell is cast in quarters too, for the object of the tube beside it, so that
    an outline is approached from both sides."""
    from .po_render import _samples, first_bounce

    index = np.asarray(index, dtype=np.int64)
    keep = np.ones(first.num_samples, dtype=bool)
    keep[index] = False
    origin = first.source[0]
    u, s_az, s_el = first.direction[index], first.step_az[index], first.step_el[index]
    owner = first.samples.object_id[index]
    if empty is not None and len(empty):
        tube, side = np.asarray(empty)[:, 0], np.asarray(empty)[:, 1]
        sign = np.where(side % 2 == 0, -1.0, 1.0)[:, None]
        e_az, e_el = first.step_az[tube], first.step_el[tube]
        e_u = first.direction[tube] + sign * np.where((side < 2)[:, None], e_az, e_el)
        e_u /= np.linalg.norm(e_u, axis=1, keepdims=True)
        u, s_az, s_el = np.concatenate([u, e_u]), np.concatenate([s_az, e_az]), np.concatenate([s_el, e_el])
        owner = np.concatenate([owner, first.samples.object_id[tube]])
    # every cell once, coarsest first: a cell whose centre lies in a cell cast before (two tubes bordering
    # the same empty cell, an empty cell seen from tubes of two sizes) is that cell
    order = np.argsort(-np.linalg.norm(s_az, axis=1), kind="stable")
    u, s_az, s_el, owner = u[order], s_az[order], s_el[order], owner[order]
    once = ~_inside_earlier(u, s_az, s_el)
    u, s_az, s_el, owner = u[once], s_az[once], s_el[once], owner[once]
    offsets = ((-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25))
    d = np.concatenate([u + a * s_az + e * s_el for a, e in offsets])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    s_az, s_el, owner_id = np.tile(s_az, (4, 1)), np.tile(s_el, (4, 1)), np.tile(owner, 4)
    # no ray into a cell a kept tube already covers (an empty cell next to finer tubes)
    free = ~_inside(d, first.direction[keep], first.step_az[keep], first.step_el[keep])
    d, s_az, s_el, owner_id = d[free], s_az[free], s_el[free], owner_id[free]
    solid = np.linalg.norm(np.cross(s_az, s_el), axis=1)
    valid, _, hit_obj, prim, uv = world.cast(np.ascontiguousarray(origin, dtype=float), d, group)
    ids = np.array([o.shape_id for o in objects], dtype=np.int64)
    hit = np.flatnonzero(valid & (hit_obj >= 0) & (ids[np.maximum(hit_obj, 0)] == owner_id))
    half_az, half_el = s_az[hit] / 2, s_el[hit] / 2
    samples, direction, acceleration = _samples(world, objects, hit_obj[hit], prim[hit], uv[hit], origin, half_az,
                                                half_el, solid[hit] / 4, rotation, wavelength)
    origin_motion = None if first.acceleration is None else (first.source_velocity[0], first.source_acceleration[0])
    if first.acceleration is not None and acceleration is None:
        acceleration = np.zeros((hit.size, 3))
    return first_bounce(samples, direction, half_az, half_el, origin, first.step, int(d.shape[0]), acceleration,
                        origin_motion)


__all__ = ["ERROR_SHARE", "MAX_SPLITS", "NEIGHBOUR_REACH", "PLANE_TURN", "chain_ids", "error_share", "follow",
           "grid_neighbours", "monostatic_channels", "plane_chains", "plane_samples", "quartered", "resolved_bounces",
           "surface_codes", "under_resolved"]
