r"""The PO contributions of a render's samples for every element pair, in Dr.Jit kernels.

:func:`~sionnafmcw.engines.po_render.chain_po_gains` (with
:func:`~sionnafmcw.physical_optics.po_gains` for the first bounce) states the PO integral of a
bounce sample by sample and element pair by element pair, in numpy: about forty passes over
``[M, N, P]`` arrays, on one core. :func:`element_pair_po` evaluates the same expressions,
including the element gains of :func:`~sionnafmcw.antenna.antenna_gain` towards the first and
from the last hit, in two Dr.Jit kernels per chunk of samples, on every core of the Mitsuba
variant's backend (LLVM on the CPU, CUDA on a GPU). For triple
For triple
:math:`(m, n, p)`, with :math:`\mathbf t'_m` the image of Tx element :math:`m` through the
mirror map of the sample's previous bounces (:math:`\mathbf t_m` itself on bounce 1),
:math:`\hat{\mathbf s}_t = (\mathbf p - \mathbf t'_m)/r_t`, :math:`\hat{\mathbf s}_r = (\mathbf p - \mathbf r_n)/r_r`
and :math:`\hat{\mathbf n}` the normal turned to the incident side:

.. math::
    a_{mnp} = \frac{j\,\Gamma_p}{4\pi}\sqrt{G_t(\mathbf q_p - \mathbf t_m)\,G_r(\mathbf p - \mathbf r_n)}\;
              \max\Bigl(0, -\hat{\mathbf n}\cdot\frac{\hat{\mathbf s}_t + \hat{\mathbf s}_r}{2}\Bigr)\,
              \frac{\Delta A\,\operatorname{sinc}\frac{k\,\mathbf g\cdot\mathbf e_1}{2}\,
              \operatorname{sinc}\frac{k\,\mathbf g\cdot\mathbf e_2}{2}}{r_t r_r},\qquad
    \tau_{mnp} = \frac{r_t + r_r}{c},

:math:`\mathbf g = \hat{\mathbf s}_t + \hat{\mathbf s}_r`, :math:`\mathbf q_p` the first hit of
the sample's ray (:math:`\mathbf p` on bounce 1), :math:`\Gamma_p` the chain's coherent
reflection; Doppler :math:`-\mathbf v\cdot(\hat{\mathbf s}_t + \hat{\mathbf s}_r)/\lambda` on
bounce 1 and :math:`[\mathbf v_1\cdot(\hat{\mathbf k}_{out,1} - \hat{\mathbf k}^m_{in,1})
+ \mathbf v_d\cdot(-\hat{\mathbf s}_r - \hat{\mathbf k}_{in,d})]/\lambda + f_{inner}` from
bounce 2 on (the derivations are in :mod:`sionnafmcw.physical_optics` and
:mod:`sionnafmcw.engines.po_render`). The numpy functions stay the reference:
``tests/test_po_kernel.py`` holds the kernel to them within rounding (:math:`10^{-12}` of the
largest contribution) on renders of real scenes, bounces 1 to 3, both patterns.

Per-sample inputs (normals, reflection, areas, footprint edges, velocities, mirror maps) are
prepared in numpy as ``[P]`` columns; everything per element happens in the kernels. The first
kernel computes, per Tx element and per Rx element, what depends on that element only (distance,
obliquity term, footprint projections, Doppler share, amplitude gain: :math:`M + N` element
sides instead of :math:`MN` pairs for the transcendental functions); the second combines them per
pair with the two sincs. Each lane handles one sample (no index arithmetic, no gathers). Every
scalar that changes between calls (the sizes, the pose, the wavelength) enters as an opaque
variable and every input array as a 64-byte aligned copy
(:func:`~sionnafmcw.sionna_rt.aligned_float64`), so the kernel is compiled once per
process (or read from Dr.Jit's disk cache) and not per frame. The kernel has no scatter or
reduction: each output element is computed by its own lane, so results do not depend on the
thread count (bit for bit from run to run).
"""

from __future__ import annotations

import numpy as np

from ..constants import SPEED_OF_LIGHT
from ..sionna_rt import aligned_float64, array_backend, dr

#: Half-power beamwidth of the ``"tr38901"`` element (rad), as in :func:`~sionnafmcw.antenna.antenna_gain`.
_HALF_POWER = float(np.deg2rad(65.0))


def _gain(pattern: str, x, y, z):
    r"""Power gain of one element towards the radar-frame direction ``(x, y, z)`` (Dr.Jit), the formula of
    :func:`~sionnafmcw.antenna.antenna_gain` (``"iso"``: 1; ``"tr38901"``: 3GPP TR 38.901, 8 dBi)."""
    if pattern == "iso":
        return dr.full(type(x), 1.0, dr.width(x))
    theta = dr.acos(dr.clip(z / dr.sqrt(x * x + y * y + z * z), -1.0, 1.0))
    phi = dr.atan2(y, x)
    a_v = -dr.minimum(12.0 * dr.square((theta - np.pi / 2) / _HALF_POWER), 30.0)
    a_h = -dr.minimum(12.0 * dr.square(phi / _HALF_POWER), 30.0)
    a_db = -dr.minimum(-(a_v + a_h), 30.0) + 8.0
    return dr.exp2(a_db * float(np.log2(10.0) / 10.0))


def _sinc_half(x):
    """:math:`\\sin(x/2)/(x/2)` (1 at 0), Dr.Jit."""
    y = 0.5 * x
    return dr.select(y == 0, 1.0, dr.sin(y) / dr.select(y == 0, 1.0, y))


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
        normal = oriented_normals(s, np.concatenate([tx, rx]).mean(axis=0))
        gamma = coherent_reflection(s.reflection, s.scattering_coefficient)
    else:
        normal = s.normal * np.where(np.einsum("pi,pi->p", s.normal, bounce.direction) > 0, -1.0, 1.0)[:, None]
        gamma = bounce.chain_reflection * np.sqrt(np.clip(1 - s.scattering_coefficient ** 2, 0, 1)) * s.reflection
    weight = gamma * s.area / (4 * np.pi)
    columns = {"position": s.position, "normal": normal, "velocity": s.velocity,
               "weight": np.stack([weight.real, weight.imag], axis=-1)}
    if in_sample_phase and s.edges is not None:
        columns["edges"] = s.edges.reshape(p, 6)
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
    """The two kernels of :func:`element_pair_po` for one radar geometry; called per chunk of samples."""

    def __init__(self, tx, rx, rotation, wavelength, pattern, depth):
        self.b = array_backend()
        b = self.b
        self.tx, self.rx, self.pattern, self.depth = tx, rx, pattern, depth
        rot = np.asarray(rotation, float)
        self.k = dr.opaque(b.Float64, 2 * np.pi / wavelength)
        self.inv_lambda = dr.opaque(b.Float64, 1.0 / wavelength)
        self.rows = [[dr.opaque(b.Float64, float(rot[r, c])) for c in range(3)] for r in range(3)]
        self.tx_el = [[dr.opaque(b.Float64, float(x)) for x in t] for t in tx]
        self.rx_el = [[dr.opaque(b.Float64, float(x)) for x in r] for r in rx]

    def local(self, d):                     # world -> radar frame (R^T d)
        r = self.rows
        return [r[0][c] * d[0] + r[1][c] * d[1] + r[2][c] * d[2] for c in range(3)]

    def __call__(self, position, normal, velocity, weight, out, edges=None, image_linear=None, image_offset=None,
                 first_point=None, second_direction=None, first_velocity=None, direction=None, doppler_inner=None):
        b, depth = self.b, self.depth

        def cols(values):
            return [aligned_float64(values[:, c], b) for c in range(values.shape[1])]

        def sub(u, v):
            return [u[c] - v[c] for c in range(3)]

        def dot(u, v):
            return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]

        pos, nrm, vel = cols(position), cols(normal), cols(velocity)
        edge = None if edges is None else (cols(edges[:, :3]), cols(edges[:, 3:]))
        if depth > 1:
            lin, off, first = cols(image_linear), cols(image_offset), cols(first_point)
            k_out_1, v_1, k_in_d = cols(second_direction), cols(first_velocity), cols(direction)
            inner = cols(doppler_inner)[0]

        def side(el, transmit: bool):
            """Distance, -n.u, the two edge projections, Doppler share and sqrt(G) of one element."""
            if transmit and depth > 1:    # the image of the Tx element through the previous bounces
                src = [lin[3 * r] * el[0] + lin[3 * r + 1] * el[1] + lin[3 * r + 2] * el[2] + off[r]
                       for r in range(3)]
            else:
                src = el
            d = sub(pos, src)
            dist = dr.sqrt(dot(d, d))
            u = [c / dist for c in d]                                   # element (image) -> sample
            values = [dist, -dot(nrm, u)]
            values += [dot(u, e) for e in edge] if edge is not None else []
            towards = d
            if depth == 1:
                shift = -dot(vel, u) * self.inv_lambda
            elif transmit:
                towards = sub(first, el)                                # real element -> first hit
                length = dr.sqrt(dot(towards, towards))
                shift = dot(v_1, [k_out_1[c] - towards[c] / length for c in range(3)]) * self.inv_lambda + inner
            else:
                shift = dot(vel, [-u[c] - k_in_d[c] for c in range(3)]) * self.inv_lambda
            return values + [shift, dr.sqrt(_gain(self.pattern, *self.local(towards)))]

        tx_side = [side(t, True) for t in self.tx_el]
        rx_side = [side(r, False) for r in self.rx_el]
        dr.eval(*tx_side, *rx_side)
        w_re, w_im = cols(weight)
        outputs = []
        for t in tx_side:
            for r in rx_side:
                amp = dr.maximum((t[1] + r[1]) * 0.5, 0.0) * t[-1] * r[-1] / (t[0] * r[0])
                if edge is not None:
                    amp = amp * _sinc_half(self.k * (t[2] + r[2])) * _sinc_half(self.k * (t[3] + r[3]))
                outputs += [-w_im * amp, w_re * amp, (t[0] + r[0]) * (1.0 / SPEED_OF_LIGHT), t[-2] + r[-2]]
        dr.eval(*outputs)
        a, tau, doppler = out
        n = len(self.rx_el)
        for j, (a_re, a_im, tau_j, doppler_j) in enumerate(zip(*[iter(outputs)] * 4)):
            a.real[j // n, j % n] = a_re.numpy()                        # j * weight * amp
            a.imag[j // n, j % n] = a_im.numpy()
            tau[j // n, j % n] = tau_j.numpy()
            doppler[j // n, j % n] = doppler_j.numpy()


__all__ = ["element_pair_po"]
