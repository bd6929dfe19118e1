r"""Every element pair's echo of a traced path: delay, gain and Doppler from its interaction points.

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
  share 0-2.5 % of their body hits, as measured) and the Tx-block phases of diffuse
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
"""

from __future__ import annotations

import numpy as np

from ..antenna import antenna_gain, direction_angles
from ..constants import SPEED_OF_LIGHT
from ..echoes import Echoes
from ..geometry import rotation_matrix
from ..sionna_rt import InteractionType
from .loaded_scene import barycentric_weights, interpolate
from .traced_paths import TracedPaths


def diffuse_phases(paths: TracedPaths, loaded, names_by_id: dict, wavelength: float) -> np.ndarray:
    r"""Random phase ``[P]`` of every path: the sum over its diffuse interactions of
    :func:`sionnafmcw.diffuse.scatterer_phases` of (object, triangle, barycentric cell of
    :math:`\lambda/4`), so a diffuse scatterer keeps its phase while it is on the same surface
    cell (:mod:`~sionnafmcw.engines.path`); 0 for specular chains. ``loaded``: the
    :class:`~.loaded_scene.LoadedScene` the paths were traced in, ``names_by_id``: object id -> name."""
    from ..diffuse import cells_per_edge, scatterer_phases

    phase = np.zeros(paths.num_paths)
    diffuse = paths.valid_interactions & (paths.types == int(InteractionType.DIFFUSE))
    if not np.any(diffuse):
        return phase
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



def interaction_velocities(paths: TracedPaths, loaded, velocities: dict, vertex_doppler: bool = True):
    """Velocities ``[P, D, 3]`` (m/s) of the interaction points: the per-vertex field alone, and in all.

    The first is the field interpolated on meshes with vertex velocities (zero elsewhere; what
    Sionna does not see); the second adds the per-object velocity Sionna uses (zero where the
    field replaces it).
    """
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
        field_v = loaded.vertex_velocity.get(name) if vertex_doppler else None
        if field_v is not None:
            faces = loaded.faces[name][paths.primitives[on]]
            vpos = loaded.vertices[name]
            w = barycentric_weights(paths.vertices[on], vpos[faces[:, 0]], vpos[faces[:, 1]], vpos[faces[:, 2]])
            vertex[on] = interpolate(field_v, faces, w)
    return vertex, rigid + vertex


def polyline_directions(paths: TracedPaths):
    """Unit directions ``[P, D+1, 3]`` of the segments source -> v_1 -> ... -> v_d -> target (0 after the last)."""
    starts, ends, _ = paths.segments()
    seg = ends - starts
    norm = np.linalg.norm(seg, axis=-1, keepdims=True)
    return np.divide(seg, norm, out=np.zeros_like(seg), where=norm > 0)


def vertex_doppler(paths: TracedPaths, vertex_velocity, wavelength: float) -> np.ndarray:
    """Sum over interactions on meshes with vertex velocities of v(p).(k_out - k_in)/lambda (Hz)."""
    if not np.any(vertex_velocity):
        return np.zeros(paths.num_paths)
    k = polyline_directions(paths)
    k_in, k_out = k[:, :-1], k[:, 1:]
    valid = paths.valid_interactions
    return np.einsum("pdi,pdi->p", np.where(valid[..., None], vertex_velocity, 0.0), k_out - k_in) / wavelength


def path_labels(paths: TracedPaths, loaded, names_by_id: dict, velocities: dict, label: str = "first",
                vertex_doppler: bool = True) -> np.ndarray:
    """Label ``[P]`` of every path: the object of its first interaction (``label="first"``), of its
    last (``"last"``), or of its first interaction on an object that moves in the frame
    (``"moving"``: ``velocities`` non-zero or, with ``vertex_doppler``, a non-zero vertex field),
    else the first (:mod:`~sionnafmcw.engines.path`, "Labels")."""
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
    if label == "first":
        return first.astype(str)
    if label == "last":
        return per_int[rows, np.maximum(paths.num_interactions - 1, 0)].astype(str)
    moving = {n for n, v in velocities.items() if np.any(v != 0)}
    if vertex_doppler:
        moving |= {n for n, v in loaded.vertex_velocity.items() if v is not None and np.any(v != 0)}
    is_moving = np.vectorize(lambda s: s in moving, otypes=[bool])(per_int) & found
    has = is_moving.any(axis=1)
    idx = np.argmax(is_moving, axis=1)
    return np.where(has, per_int[rows, idx], first).astype(str)


def per_element_echoes(paths: TracedPaths, doppler, labels, radar) -> Echoes:
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


def coherent_echoes(paths: TracedPaths, doppler, velocity, labels, radar, pose,
                    wavelength: float) -> Echoes:
    """``"coherent"``: every element pair from the traced path's interaction points (module docstring);
    ``velocity [P, D, 3]`` of the interaction points (:func:`interaction_velocities`)."""
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
        scale = scale * pattern_ratio(radar.antenna_pattern, d_tx, d_t0, rot)[:, None, :]
        scale = scale * pattern_ratio(radar.antenna_pattern, d_rx, d_r0, rot)[None, :, :]
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


def pattern_ratio(pattern: str, d_elements, d_centre, rot) -> np.ndarray:
    """Amplitude ratio ``[K, P]`` sqrt(G(element direction) / G(centre direction)), directions world -> radar frame."""
    g_el = antenna_gain(pattern, *direction_angles(d_elements @ rot))
    g_0 = antenna_gain(pattern, *direction_angles(d_centre @ rot))
    return np.sqrt(np.divide(g_el, g_0[None], out=np.ones_like(g_el), where=g_0[None] > 0))


__all__ = ["coherent_echoes", "diffuse_phases", "interaction_velocities", "path_labels", "pattern_ratio",
           "per_element_echoes", "polyline_directions", "vertex_doppler"]
