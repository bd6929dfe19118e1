r"""The PO contributions of a render's samples for every element pair, in Dr.Jit kernels.

:func:`~sionnafmcw.engines.po_render.chain_po_gains` (with
:func:`~sionnafmcw.physical_optics.po_gains` for the first bounce) states the PO integral of a
bounce sample by sample and element pair by element pair, in numpy: about forty passes over
``[M, N, P]`` arrays, on one core. :func:`element_pair_po` evaluates the same expressions,
including the element gains of :func:`~sionnafmcw.antenna.antenna_gain` towards the first and
from the last hit, in two Dr.Jit kernels per chunk of samples, on every core of the Mitsuba
variant's backend (LLVM on the CPU, CUDA on a GPU). For triple :math:`(m, n, p)`, with
:math:`\mathbf t'_m` the image of Tx element :math:`m` through the mirror map of the sample's
previous bounces (:math:`\mathbf t_m` itself on bounce 1),
:math:`\hat{\mathbf s}_t = (\mathbf p - \mathbf t'_m)/r_t`, :math:`\hat{\mathbf s}_r = (\mathbf p - \mathbf r_n)/r_r`
and :math:`\hat{\mathbf n}` the normal turned to the incident side:

.. math::
    a_{mnp} = \frac{j\,\Gamma_p}{4\pi}\sqrt{G_t(\mathbf q_p - \mathbf t_m)\,G_r(\mathbf p - \mathbf r_n)}\;
              \max\Bigl(0, -\hat{\mathbf n}\cdot\frac{\hat{\mathbf s}_t + \hat{\mathbf s}_r}{2}\Bigr)\,
              \frac{\Delta A\,F_{mnp}}{r_t r_r},\qquad
    \tau_{mnp} = \frac{r_t + r_r}{c},

:math:`F` the in-sample factor of :func:`~sionnafmcw.physical_optics.footprint_factor` (the linear
phase :math:`k\,\mathbf g\cdot\mathbf e_i`, :math:`\mathbf g = \hat{\mathbf s}_t + \hat{\mathbf s}_r`,
and the quadratic :math:`h_{ij} = (\mathbf e_i\cdot\mathbf e_j - (\hat{\mathbf s}_t\cdot\mathbf e_i)
(\hat{\mathbf s}_t\cdot\mathbf e_j))/r_t + (\dots)/r_r
+ (\cos\theta_t + \cos\theta_r)\,\mathbf e_i^T\mathbf K\mathbf e_j` of the footprint edges
:math:`\mathbf e_i` and the shape operator :math:`\mathbf K`), :math:`\mathbf q_p` the first hit of
the sample's ray (:math:`\mathbf p` on bounce 1), :math:`\Gamma_p` the chain's coherent
reflection; Doppler :math:`-\mathbf v\cdot(\hat{\mathbf s}_t + \hat{\mathbf s}_r)/\lambda` on
bounce 1 and :math:`[\mathbf v_1\cdot(\hat{\mathbf k}_{out,1} - \hat{\mathbf k}^m_{in,1})
+ \mathbf v_d\cdot(-\hat{\mathbf s}_r - \hat{\mathbf k}_{in,d})]/\lambda + f_{inner}` from
bounce 2 on (the derivations are in :mod:`sionnafmcw.physical_optics` and
:mod:`sionnafmcw.engines.po_render`). The numpy functions stay the reference:
``tests/test_po_kernel.py`` holds the kernel to them within rounding (:math:`10^{-12}` of the
largest contribution) on renders of real scenes, bounces 1 to 3, both patterns.

Per-sample inputs (normals, reflection, areas, footprint edges with their Gram matrix and
:math:`\mathbf e_i^T\mathbf K\mathbf e_j`, velocities, mirror maps) are prepared in numpy as ``[P]``
columns; everything per element happens in the kernels. The first kernel computes, per Tx element
and per Rx element, what depends on that element only (distance, obliquity term, footprint
projections and range-curvature terms, Doppler share, amplitude gain: :math:`M + N` element sides
instead of :math:`MN` pairs for the transcendental functions); the second combines them per pair
with the footprint factor. Each lane handles one sample (no index arithmetic, no gathers). Every
scalar that changes between calls (the sizes, the pose, the wavelength) enters as an opaque
variable and every input array as a 64-byte aligned copy
(:func:`~sionnafmcw.sionna_rt.aligned_float64`), so the kernel is compiled once per
process (or read from Dr.Jit's disk cache) and not per frame. The kernel has no scatter or
reduction: each output element is computed by its own lane, so results do not depend on the
thread count (bit for bit from run to run).
"""

from __future__ import annotations

import threading

import numpy as np

from ..constants import SPEED_OF_LIGHT
from ..sionna_rt import aligned_float64, array_backend, dr, drjit_element_gain

def _gain(pattern, x, y, z):
    r"""Power gain of one element towards the radar-frame direction ``(x, y, z)`` (Dr.Jit): the formula of
    :func:`~sionnafmcw.antenna.antenna_gain` for any ``RadarConfig.antenna_pattern``
    (:func:`~sionnafmcw.sionna_rt.drjit_element_gain`)."""
    return drjit_element_gain(pattern, x, y, z)


def _sinc_and_derivatives(y):
    """:math:`S(y) = \\sin y/y`, :math:`S'`, :math:`S''` in Dr.Jit, as
    :func:`~sionnafmcw.physical_optics.sinc_and_derivatives` (its series below :math:`|y| = 0.05`)."""
    small = dr.abs(y) < 0.05
    safe = dr.select(small, 1.0, y)
    sin, cos = dr.sincos(safe)
    s0 = sin / safe
    s1 = (cos - s0) / safe
    s2 = -s0 - 2.0 * s1 / safe
    y2 = y * y
    s0 = dr.select(small, 1.0 - y2 / 6.0 * (1.0 - y2 / 20.0 * (1.0 - y2 / 42.0 * (1.0 - y2 / 72.0))), s0)
    s1 = dr.select(small, -y / 3.0 * (1.0 - y2 / 10.0 * (1.0 - y2 / 28.0 * (1.0 - y2 / 54.0))), s1)
    s2 = dr.select(small, -1.0 / 3.0 + y2 / 10.0 * (1.0 - y2 * (5.0 / 84.0) * (1.0 - y2 * (14.0 / 540.0))), s2)
    return s0, s1, s2


#: Samples per kernel launch: the buffers of every launch then fall into the same few size classes,
#: which Dr.Jit's allocation cache reuses from call to call (a one-off measurement, not a repo
#: script: 20 circle-walk frames through ``simulate`` peaked at 1451 MiB with chunks of 65536,
#: 1405 MiB with 16384, 1361 MiB with the numpy reference; the kernel as fast either way:
#: ``benchmarks/po_kernel.py``).
CHUNK = 1 << 14


def element_pair_po(bounce, tx_positions, rx_positions, rotation, wavelength: float, pattern: str,
                    in_sample_phase: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PO contributions ``(a, tau, doppler)`` ``[M, N, P]`` of a :class:`~sionnafmcw.engines.po_render.Render`
    for Tx elements ``tx_positions [M, 3]`` and Rx elements ``rx_positions [N, 3]`` (world, m)
    with the element ``pattern`` of a radar of ``rotation`` (radar frame -> world): what
    ``chain_po_gains(bounce, tx, rx, wavelength, G_t, G_r, in_sample_phase)`` gives with the gains
    :func:`~sionnafmcw.antenna.antenna_gain` towards the first hit and from the sample (module docstring)."""
    from ..antenna import check_pattern
    from ..physical_optics import PhysicalOpticsError, coherent_reflection, oriented_normals

    check_pattern(pattern)
    if not np.isfinite(wavelength) or wavelength <= 0:
        raise PhysicalOpticsError(f"element_pair_po: wavelength must be a positive length in m, got {wavelength!r}")
    s = bounce.samples
    tx = np.atleast_2d(np.asarray(tx_positions, float))
    rx = np.atleast_2d(np.asarray(rx_positions, float))
    m, n, p = tx.shape[0], rx.shape[0], s.num_samples
    a = np.empty((m, n, p), dtype=complex)
    tau = np.empty((m, n, p))
    doppler = np.empty((m, n, p))
    if p == 0:
        return a, tau, doppler
    # per sample, numpy: the normal turned to the incident side, the chain's reflection and area
    if bounce.depth == 1:
        normal, side = oriented_normals(s, np.concatenate([tx, rx]).mean(axis=0), return_side=True)
        gamma = coherent_reflection(s.reflection, s.scattering_coefficient)
    else:
        side = np.where(np.einsum("pi,pi->p", s.normal, bounce.direction) > 0, -1.0, 1.0)
        normal = s.normal * side[:, None]
        gamma = bounce.chain_reflection * np.sqrt(np.clip(1 - s.scattering_coefficient ** 2, 0, 1)) * s.reflection
    weight = gamma * s.area / (4 * np.pi)
    columns = {"position": s.position, "normal": normal, "velocity": s.velocity,
               "weight": np.stack([weight.real, weight.imag], axis=-1)}
    if in_sample_phase and s.edges is not None:
        e1, e2 = s.edges[:, 0], s.edges[:, 1]
        columns["edges"] = s.edges.reshape(p, 6)
        columns["gram"] = np.stack([np.einsum("pi,pi->p", e1, e1), np.einsum("pi,pi->p", e2, e2),
                                    np.einsum("pi,pi->p", e1, e2)], axis=-1)
        if s.curvature is not None:      # e_i^T K e_j of the normal on the incident side
            k_e1 = np.einsum("pij,pj->pi", s.curvature, e1)
            k_e2 = np.einsum("pij,pj->pi", s.curvature, e2)
            columns["curvature"] = side[:, None] * np.stack(
                [np.einsum("pi,pi->p", e1, k_e1), np.einsum("pi,pi->p", e2, k_e2),
                 0.5 * (np.einsum("pi,pi->p", e1, k_e2) + np.einsum("pi,pi->p", e2, k_e1))], axis=-1)
    if bounce.depth > 1:
        columns |= {"image_linear": bounce.image_linear.reshape(p, 9), "image_offset": bounce.image_offset,
                    "first_point": bounce.first_point, "second_direction": bounce.second_direction,
                    "first_velocity": bounce.first_velocity, "direction": bounce.direction,
                    "doppler_inner": bounce.doppler_inner[:, None]}
    kernel = _PairKernel(tx, rx, rotation, wavelength, pattern, bounce.depth)
    for start in range(0, p, CHUNK):
        part = slice(start, min(start + CHUNK, p))
        kernel(**{name: value[part] for name, value in columns.items()}, out=(a[..., part], tau[..., part],
                                                                          doppler[..., part]))
    return a, tau, doppler


class _PairKernel:
    """The two kernels of :func:`element_pair_po` for one radar geometry; called per chunk of samples.

    The kernels are built by :func:`_pair_outputs`, frozen (``dr.freeze``, one recording per named
    element pattern, bounce depth and set of columns): after a chunk of the same configuration has
    been traced once, a chunk of any size replays the recorded kernels without tracing the Python
    again (a frame's render of the static chains that end on the body, ~900 samples, takes 0.3 of
    numpy's time instead of 1.0-1.2: ``benchmarks/po_kernel.py``)."""

    def __init__(self, tx, rx, rotation, wavelength, pattern, depth):
        self.b = array_backend()
        b = self.b
        self.num_rx, self.pattern, self.depth = len(rx), pattern, depth
        rot = np.asarray(rotation, float)
        opaque = lambda x: dr.opaque(b.Float64, float(x))  # noqa: E731
        self.scalars = {"k": opaque(2 * np.pi / wavelength), "inv_lambda": opaque(1.0 / wavelength),
                        "rows": [[opaque(rot[r, c]) for c in range(3)] for r in range(3)],
                        "tx": [[opaque(x) for x in t] for t in tx], "rx": [[opaque(x) for x in r] for r in rx]}

    def __call__(self, out, **columns):
        b = self.b
        inputs = {name: [aligned_float64(values[:, c], b) for c in range(values.shape[1])]
                  for name, values in columns.items()}
        if isinstance(self.pattern, str) and dr.width(inputs["position"][0]) > 1:
            with _FROZEN_LOCK:   # a recording is one thread's at a time (threaded Dask workers share the process)
                outputs = _frozen_pair_outputs(self.pattern, self.depth)(inputs, self.scalars)
        else:   # one sample (the width of the scalars, which a frozen function keys on), or a measured
            # pattern (its gain table a Dr.Jit array of its own, which a recording must not outlive)
            outputs = _pair_outputs(self.pattern, self.depth, inputs, self.scalars)
            dr.eval(*outputs)
        a, tau, doppler = out
        n = self.num_rx
        for j, (a_re, a_im, tau_j, doppler_j) in enumerate(zip(*[iter(outputs)] * 4)):
            a.real[j // n, j % n] = a_re.numpy()                        # j * weight * amp
            a.imag[j // n, j % n] = a_im.numpy()
            tau[j // n, j % n] = tau_j.numpy()
            doppler[j // n, j % n] = doppler_j.numpy()


_FROZEN: dict = {}
_FROZEN_LOCK = threading.Lock()


def _frozen_pair_outputs(pattern: str, depth: int):
    """:func:`_pair_outputs` of ``pattern`` and ``depth`` as a frozen function of ``(inputs, scalars)``."""
    key = (pattern, depth)
    if key not in _FROZEN:
        _FROZEN[key] = dr.freeze(lambda inputs, scalars: _pair_outputs(pattern, depth, inputs, scalars))
    return _FROZEN[key]


def _pair_outputs(pattern: str, depth: int, inputs: dict, scalars: dict) -> list:
    """The Dr.Jit outputs ``[a_re, a_im, tau, doppler] * (M N)`` of one chunk (module docstring):
    ``inputs`` the per-sample columns (lists of ``Float64``) by name, as :func:`element_pair_po`
    prepares them; ``scalars`` the opaque wavenumber, 1/wavelength, radar rotation rows and element positions."""
    def sub(u, v):
        return [u[c] - v[c] for c in range(3)]

    def dot(u, v):
        return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]

    k, inv_lambda, rows = scalars["k"], scalars["inv_lambda"], scalars["rows"]

    def local(d):                     # world -> radar frame (R^T d)
        return [rows[0][c] * d[0] + rows[1][c] * d[1] + rows[2][c] * d[2] for c in range(3)]

    pos, nrm, vel = inputs["position"], inputs["normal"], inputs["velocity"]
    edge = (inputs["edges"][:3], inputs["edges"][3:]) if "edges" in inputs else None
    gram = inputs.get("gram")
    kappa = inputs.get("curvature")
    if depth > 1:
        lin, off, first = inputs["image_linear"], inputs["image_offset"], inputs["first_point"]
        k_out_1, v_1, k_in_d = inputs["second_direction"], inputs["first_velocity"], inputs["direction"]
        inner = inputs["doppler_inner"][0]

    def side(el, transmit: bool):
        """Distance, -n.u, the two edge projections and the three range-curvature terms
        (e_i.e_j - (u.e_i)(u.e_j))/r, Doppler share and sqrt(G) of one element."""
        if transmit and depth > 1:    # the image of the Tx element through the previous bounces
            src = [lin[3 * r] * el[0] + lin[3 * r + 1] * el[1] + lin[3 * r + 2] * el[2] + off[r]
                   for r in range(3)]
        else:
            src = el
        d = sub(pos, src)
        dist = dr.sqrt(dot(d, d))
        u = [c / dist for c in d]                                   # element (image) -> sample
        values = [dist, -dot(nrm, u)]
        if edge is not None:
            p1, p2 = dot(u, edge[0]), dot(u, edge[1])
            values += [p1, p2, (gram[0] - p1 * p1) / dist, (gram[1] - p2 * p2) / dist, (gram[2] - p1 * p2) / dist]
        towards = d
        if depth == 1:
            shift = -dot(vel, u) * inv_lambda
        elif transmit:
            towards = sub(first, el)                                # real element -> first hit
            length = dr.sqrt(dot(towards, towards))
            shift = dot(v_1, [k_out_1[c] - towards[c] / length for c in range(3)]) * inv_lambda + inner
        else:
            shift = dot(vel, [-u[c] - k_in_d[c] for c in range(3)]) * inv_lambda
        return values + [shift, dr.sqrt(_gain(pattern, *local(towards)))]

    tx_side = [side(t, True) for t in scalars["tx"]]
    rx_side = [side(r, False) for r in scalars["rx"]]
    dr.eval(*tx_side, *rx_side)
    w_re, w_im = inputs["weight"]
    outputs = []
    for t in tx_side:
        for r in rx_side:
            amp = dr.maximum((t[1] + r[1]) * 0.5, 0.0) * t[-1] * r[-1] / (t[0] * r[0])
            if edge is None:
                f_re, f_im = amp, 0.0
            else:       # the footprint factor of physical_optics.footprint_factor
                h = [t[4 + i] + r[4 + i] for i in range(3)]
                if kappa is not None:
                    h = [h[i] + (t[1] + r[1]) * kappa[i] for i in range(3)]
                sy, sy1, sy2 = _sinc_and_derivatives(0.5 * (k * (t[2] + r[2])))
                sz, sz1, sz2 = _sinc_and_derivatives(0.5 * (k * (t[3] + r[3])))
                mu = k * (h[0] + h[1]) / 24.0
                base = sy * sz
                im = mu * base + (k / 8.0) * (h[0] * sy2 * sz + h[1] * sy * sz2 + 2.0 * h[2] * sy1 * sz1)
                sin_mu, cos_mu = dr.sincos(mu)
                var = (k * k / 4.0) * ((h[0] * h[0] + h[1] * h[1]) / 180.0 + h[2] * h[2] / 36.0)
                second = var < 2.0                     # else the linear factor (|F| <= 1)
                f_re = amp * dr.select(second, cos_mu * base + sin_mu * im, base)
                f_im = amp * dr.select(second, cos_mu * im - sin_mu * base, 0.0)
            # a = j w amp F
            outputs += [-w_im * f_re - w_re * f_im, w_re * f_re - w_im * f_im,
                        (t[0] + r[0]) * (1.0 / SPEED_OF_LIGHT), t[-2] + r[-2]]
    return outputs


__all__ = ["element_pair_po"]
