r"""Echoes: what both engines hand to the beat synthesizer.

An :class:`Echoes` holds, for every transmit element :math:`m`, receive element :math:`n` and
contribution :math:`p` (a propagation path, or a pixel), at the start of the CPI:

* ``a[m, n, p]``: complex baseband gain, Sionna RT's convention (no carrier phase
  :math:`e^{-j2\pi f_c\tau}`), so that :math:`P_r = P_t |a|^2`;
* ``tau[m, n, p]``: delay (s);
* ``doppler[m, n, p]``: Doppler shift (Hz), positive for an approaching reflector, so that the
  delay evolves as :math:`\tau(t) = \tau_0 - (f_D/f_c)(t - t_n)`;
* ``doppler_rate[m, n, p]`` (optional, keyword): the Doppler shift's rate of change
  :math:`\dot f_D` (Hz/s) at the CPI start, for motion within the CPI: the delay then
  follows the second-order model

  .. math:: \tau(t) = \tau_0 - \frac{f_D}{f_c}(t - t_n) - \frac{\dot f_D}{f_c}\frac{(t - t_n)^2}{2},

  i.e. :math:`f_D = -\dot L/\lambda` and :math:`\dot f_D = -\ddot L/\lambda` for a contribution
  whose path length is :math:`L(t)` (:mod:`sionnafmcw.kinematics`). None (default): every rate
  zero, the CPI frozen at the frame's velocities (the model without motion within the CPI).

Tx is in physical element order. Zero-gain entries are padding (Sionna pads per-link path
lists to a common length).

Static block. An engine may put first the contributions that are the same every frame (the static
room seen from a fixed radar pose: zero Doppler) and mark them with ``static_count`` and
``static_key``: contributions ``[..., :static_count]`` are then bit for bit the same in every
:class:`Echoes` carrying the same ``static_key``, so their beat cube is too and the synthesizer
computes it once (:func:`~sionnafmcw.synthesis.synthesize`, ``static_cache``).

Ideal point targets (:meth:`Echoes.point_targets`) use spherical wavefronts per element and the
bistatic radar equation

.. math::
    a_{mnp} = \frac{\lambda \sqrt{G_t G_r \sigma_p}}{(4\pi)^{3/2} R^{t}_{mp} R^{r}_{np}},
    \qquad \tau_{mnp} = \frac{R^t_{mp} + R^r_{np}}{c},
    \qquad f_{D,mnp} = -\frac{\mathbf v_p\cdot(\hat{\mathbf u}^t_{mp} + \hat{\mathbf u}^r_{np})}{\lambda},

with :math:`\lambda = c/f_c`, :math:`R^t_{mp} = \|\mathbf p_p - \mathbf t_m\|`,
:math:`\hat{\mathbf u}^t_{mp}` the unit vector from Tx element :math:`m` to the target (likewise
for Rx) and :math:`G_t, G_r` the element pattern gains towards the target. The target moves
radially: :math:`\mathbf v_p = \dot R_p\,\hat{\mathbf u}_p` with :math:`\dot R_p` positive receding.
Monostatically this gives :math:`P_r = P_t G^2\lambda^2\sigma/((4\pi)^3R^4)` and
:math:`f_D = -2\dot R/\lambda`. With a radial acceleration :math:`\ddot R_p` as well
(``radial_accelerations``), :math:`\mathbf a_p = \ddot R_p\hat{\mathbf u}_p` and every element's
range acceleration is :math:`\ddot R^t_{mp} = \hat{\mathbf u}^t_{mp}\cdot\mathbf a_p
+ (|\mathbf v_p|^2 - (\hat{\mathbf u}^t_{mp}\cdot\mathbf v_p)^2)/R^t_{mp}`
(:func:`sionnafmcw.kinematics.range_acceleration`), so that
:math:`\dot f_{D,mnp} = -(\ddot R^t_{mp} + \ddot R^r_{np})/\lambda`, monostatically
:math:`-2\ddot R/\lambda`: over a CPI :math:`T` the Doppler sweeps :math:`2\ddot R T/\lambda`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .antenna import antenna_gain, direction_angles
from .constants import SPEED_OF_LIGHT


def _per_contribution(labels: np.ndarray) -> bool:
    """True when ``labels`` ``[M, N, P]`` is a broadcast ``[P]`` vector (stride 0 over the element pairs)."""
    return labels.ndim == 3 and labels.shape[0] * labels.shape[1] > 0 and labels.strides[:2] == (0, 0)


def _concatenate_rates(parts: list["Echoes"]) -> np.ndarray | None:
    """Doppler rates of :meth:`Echoes.concatenate`: None when no part has any, else every part's
    (zeros for a part without)."""
    if all(p.doppler_rate is None for p in parts):
        return None
    return np.concatenate([p.rates() for p in parts], axis=2)


def _concatenate_labels(parts: list[np.ndarray]) -> np.ndarray:
    """Labels of :meth:`Echoes.concatenate`: the ``[P]`` vectors joined and broadcast again when every
    part is one, else the full ``[M, N, P]`` arrays joined."""
    parts = [np.asarray(p) for p in parts]
    if all(_per_contribution(p) for p in parts):
        joined = np.concatenate([p[0, 0] for p in parts])
        return np.broadcast_to(joined, parts[0].shape[:2] + joined.shape)
    return np.concatenate(parts, axis=2)


#: The per-contribution arrays ``[num_tx, num_rx, num_contributions]`` of :class:`Echoes`.
CONTRIBUTION_FIELDS = ("a", "tau", "doppler")
#: What :meth:`Echoes.concatenate` joins on first use: the arrays, the optional Doppler rates and
#: the labels.
JOINED_FIELDS = (*CONTRIBUTION_FIELDS, "doppler_rate", "labels")


def target_direction(azimuth, elevation) -> np.ndarray:
    """Unit vectors ``[..., 3]`` in the radar frame; azimuth from +x towards +y, elevation towards +z (rad)."""
    az = np.asarray(azimuth, dtype=float)
    el = np.asarray(elevation, dtype=float)
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


@dataclass
class Echoes:
    r"""Per-element contributions ``[num_tx, num_rx, num_contributions]`` at the CPI start.

    Parameters
    ----------
    a, tau, doppler : array_like ``[num_tx, num_rx, num_contributions]``
        Complex gain, delay (s) and Doppler shift (Hz), see the module docstring.
    doppler_rate : array_like ``[num_tx, num_rx, num_contributions]``, keyword, optional
        :math:`\dot f_D` (Hz/s) at the CPI start (module docstring); None: zero (frozen CPI).
    labels : array_like, optional
        ``[num_contributions]`` (kept as a read-only broadcast view ``[num_tx, num_rx,
        num_contributions]``) or ``[num_tx, num_rx, num_contributions]``.
    static_count : int, keyword
        Length of the static block: contributions ``[..., :static_count]``.
    static_key : hashable, keyword
        Identity of the static block. Contract (the engine guarantees it): every :class:`Echoes`
        with the same ``static_key`` has the same ``static_count`` and bit-for-bit the same
        ``a``, ``tau`` and ``doppler`` in ``[..., :static_count]``. ``None`` (default): no static
        block, and then ``static_count`` must be 0. A key with ``static_count`` 0 is allowed (a
        static scene with nothing in it); its block is empty.
    """

    a: np.ndarray
    tau: np.ndarray
    doppler: np.ndarray
    labels: np.ndarray | None = None
    doppler_rate: np.ndarray | None = field(default=None, kw_only=True)
    static_count: int = field(default=0, kw_only=True)
    static_key: object = field(default=None, kw_only=True)

    def __post_init__(self):
        self.a = np.asarray(self.a, dtype=np.complex128)
        self.tau = np.asarray(self.tau, dtype=np.float64)
        self.doppler = np.asarray(self.doppler, dtype=np.float64)
        if self.a.ndim != 3:
            raise ValueError(f"Echoes.a must have shape [num_tx, num_rx, num_contributions], got {self.a.shape}")
        names = ("a", "tau", "doppler")
        if self.doppler_rate is not None:
            rate = np.asarray(self.doppler_rate, dtype=np.float64)
            if rate.shape == (self.a.shape[2],):
                rate = np.broadcast_to(rate, self.a.shape)
            self.doppler_rate = rate
            names += ("doppler_rate",)
        for name in names[1:]:
            if getattr(self, name).shape != self.a.shape:
                raise ValueError(
                    f"Echoes.{name} has shape {getattr(self, name).shape}, expected {self.a.shape} like Echoes.a"
                )
        for name in names:
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"Echoes.{name} contains non-finite values")
        if np.any((self.tau < 0) & (self.a != 0)):
            raise ValueError("Echoes.tau must be >= 0 for every contribution with non-zero gain")
        if self.labels is not None:
            labels = np.asarray(self.labels)
            if labels.shape == (self.a.shape[2],):
                labels = np.broadcast_to(labels, self.a.shape)
            if labels.shape != self.a.shape:
                raise ValueError(
                    f"Echoes.labels must have shape [num_contributions] or {self.a.shape}, got {labels.shape}"
                )
            self.labels = labels
        self._check_static_block()

    def _check_static_block(self) -> None:
        count = self.static_count
        if isinstance(count, (bool, np.bool_)) or not isinstance(count, (int, np.integer)):
            raise ValueError(f"Echoes.static_count must be an integer, got {count!r}")
        if not 0 <= count <= self.num_contributions:
            raise ValueError(f"Echoes.static_count={count} must lie in 0..num_contributions "
                             f"({self.num_contributions})")
        self.static_count = int(count)
        if self.static_key is None:
            if count:
                raise ValueError(f"Echoes.static_key is None but static_count={count}: a static block needs a key")
            return
        try:
            hash(self.static_key)
        except TypeError:
            raise ValueError(f"Echoes.static_key must be hashable, got {type(self.static_key).__name__}") from None

    def __getattr__(self, name):
        # only reached for attributes the instance lacks: the contribution arrays of a joined
        # Echoes (:meth:`concatenate`) before their first use
        parts = self.__dict__.get("_parts")
        if parts is None or name not in JOINED_FIELDS:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        if name == "labels":
            value = None
            if all(p.labels is not None for p in parts):
                value = _concatenate_labels([p.labels for p in parts])
        elif name == "doppler_rate":
            value = _concatenate_rates(parts)
        else:
            value = np.concatenate([getattr(p, name) for p in parts], axis=2)
        self.__dict__[name] = value
        if all(f in self.__dict__ for f in JOINED_FIELDS):
            del self._parts   # everything is joined: the parts are no longer needed
        return value

    def __setattr__(self, name, value):
        # a joined Echoes whose arrays are replaced (e.g. gains filtered) stops reading its parts: its
        # other arrays are joined first, so that no reader (:meth:`contributions`) sees the parts' old ones
        parts = self.__dict__.get("_parts")
        if parts is not None and name in JOINED_FIELDS:
            for other in JOINED_FIELDS:
                if other != name and other not in self.__dict__:
                    getattr(self, other)
            self.__dict__.pop("_parts", None)
        object.__setattr__(self, name, value)

    def map_parts(self, function) -> "Echoes":
        """``function(part)`` for every part of a joined :class:`Echoes` (:meth:`concatenate`), joined again
        the same lazy way with this one's static block; ``function(self)`` for one that is not joined.
        For what changes every contribution the same way (the IF chain's gain): the static block's
        part stays a part, nothing is copied."""
        parts = self.__dict__.get("_parts")
        if parts is None:
            return function(self)
        out = Echoes.concatenate([function(p) for p in parts])
        out.static_count, out.static_key = self.static_count, self.static_key
        return out

    @property
    def accelerating(self) -> bool:
        """True when some contribution has a non-zero :attr:`doppler_rate` (motion within the CPI)."""
        return self.doppler_rate is not None and bool(np.any(self.doppler_rate))

    def rates(self) -> np.ndarray:
        """:attr:`doppler_rate`, or zeros ``[num_tx, num_rx, num_contributions]`` (a read-only view) when None."""
        if self.doppler_rate is not None:
            return self.doppler_rate
        return np.broadcast_to(np.zeros(1), self.shape)

    @property
    def shape(self) -> tuple[int, int, int]:
        parts = self.__dict__.get("_parts")
        if parts is not None:
            return parts[0].shape[:2] + (sum(p.num_contributions for p in parts),)
        return self.a.shape

    @property
    def num_tx(self) -> int:
        return self.shape[0]

    @property
    def num_rx(self) -> int:
        return self.shape[1]

    @property
    def num_contributions(self) -> int:
        return self.shape[2]

    def contributions(self, start: int = 0, stop: int | None = None) -> "Echoes":
        """Contributions ``[..., start:stop]`` as an :class:`Echoes` without labels or static block:
        views where they lie in one part of a joined :class:`Echoes` (:meth:`concatenate`; the
        synthesizer takes the static block and the rest this way without joining them), else
        views of (or, across parts, a join of) the arrays."""
        total = self.num_contributions
        start, stop, _ = slice(start, stop).indices(total)
        parts = self.__dict__.get("_parts")
        if parts is not None:
            bounds = np.cumsum([0] + [p.num_contributions for p in parts])
            inside = [k for k in range(len(parts)) if bounds[k] < stop and bounds[k + 1] > start]
            if not inside:
                inside = [0]
            pieces = [parts[k].contributions(max(start - bounds[k], 0), min(stop, bounds[k + 1]) - bounds[k])
                      for k in inside]
            if len(pieces) == 1:
                return pieces[0]
            out = object.__new__(Echoes)
            for name in CONTRIBUTION_FIELDS:
                setattr(out, name, np.concatenate([getattr(p, name) for p in pieces], axis=2))
            out.doppler_rate = _concatenate_rates(pieces)
            out.labels, out.static_count, out.static_key = None, 0, None
            return out
        cut = slice(start, stop)
        out = object.__new__(Echoes)
        for name in CONTRIBUTION_FIELDS:
            setattr(out, name, getattr(self, name)[..., cut])
        out.doppler_rate = None if self.doppler_rate is None else self.doppler_rate[..., cut]
        out.labels, out.static_count, out.static_key = None, 0, None
        return out

    @classmethod
    def empty(cls, num_tx: int, num_rx: int) -> "Echoes":
        z = np.zeros((num_tx, num_rx, 0))
        return cls(z.astype(complex), z, z)

    @classmethod
    def concatenate(cls, parts: list["Echoes"]) -> "Echoes":
        """All contributions of ``parts`` side by side (labels kept where every part has them).

        The static block of ``parts[0]`` stays a prefix and is kept; those of the other parts are
        not (they are no longer a prefix). Labels that are the same for every element pair in
        every part (given as ``[num_contributions]``) stay a broadcast view. The contribution
        arrays and the labels (:data:`JOINED_FIELDS`) are joined when first read (a frame's labels
        are ~4e5 strings); :meth:`contributions` takes a range that lies in one part without joining.
        """
        if not parts:
            raise ValueError("Echoes.concatenate: no parts to concatenate")
        shapes = {p.shape[:2] for p in parts}
        if len(shapes) > 1:
            raise ValueError(f"Echoes.concatenate: the parts have different element pairs {sorted(shapes)}")
        # every part passed the checks of __post_init__ and so does their concatenation: not
        # checked again (a frame's echoes are ~1e5 contributions x element pairs). The arrays are
        # joined on first use (__getattr__): a frame's echoes share the static block's arrays
        # (~3e5 contributions x element pairs) instead of copying them every frame.
        out = object.__new__(cls)
        out._parts = [q for p in parts for q in (p.__dict__.get("_parts") or [p])]
        out.static_count, out.static_key = parts[0].static_count, parts[0].static_key
        return out

    def select(self, mask) -> "Echoes":
        """Keep the contributions where ``mask`` ([num_contributions] bool) is true; no static block."""
        mask = np.asarray(mask, dtype=bool)
        labels = None
        if self.labels is not None:
            labels = np.asarray(self.labels)
            labels = labels[0, 0, mask] if _per_contribution(labels) else labels[..., mask]
        rate = None if self.doppler_rate is None else self.doppler_rate[..., mask]
        return Echoes(self.a[..., mask], self.tau[..., mask], self.doppler[..., mask], labels, doppler_rate=rate)

    def frozen(self) -> "Echoes":
        """The same contributions without Doppler rates (the CPI frozen at the frame's velocities); the
        static block and labels are kept."""
        if self.doppler_rate is None:
            return self
        if "_parts" in self.__dict__:
            return self.map_parts(Echoes.frozen)
        import copy

        out = copy.copy(self)
        out.doppler_rate = None
        return out

    def received_power(self, tx_power: float) -> np.ndarray:
        """:math:`P_t |a|^2` per element pair and contribution (W)."""
        return tx_power * np.abs(self.a) ** 2

    @classmethod
    def leakage(cls, radar, coupling_db: float) -> "Echoes":
        r"""Direct Tx-to-Rx coupling (leakage) of every element pair, as explicit contributions.

        The path engine does not model it (Sionna drops segments shorter than 1 cm and the radar
        runs with ``los=False``). Each pair :math:`(m, n)` gets one contribution with
        :math:`|a| = 10^{C/20}` (``coupling_db`` = :math:`C`, the power coupling, e.g. -30 dB on
        TI boards), delay :math:`\|\mathbf t_m - \mathbf r_n\|/c` and zero Doppler: a static
        tone near range zero, removed by static clutter removal. Label ``"leakage"``.
        """
        if not np.isfinite(coupling_db):
            raise ValueError(f"Echoes.leakage: coupling_db must be finite, got {coupling_db!r}")
        d = np.linalg.norm(radar.tx_positions[:, None, :] - radar.rx_positions[None, :, :], axis=-1)
        shape = (radar.num_tx, radar.num_rx, 1)
        a = np.full(shape, 10 ** (coupling_db / 20), dtype=complex)
        return cls(a, (d / SPEED_OF_LIGHT)[..., None], np.zeros(shape), np.array(["leakage"]))

    @classmethod
    def point_targets(cls, radar, ranges, radial_velocities, azimuths, elevations=0.0, rcs=1.0,
                      labels=None, radial_accelerations=None) -> "Echoes":
        r"""Ideal point targets in the radar frame (see the module docstring for the model).

        Parameters
        ----------
        radar : RadarConfig
        ranges : array_like, m, from the radar frame origin at the CPI start
        radial_velocities : array_like, m/s, range rate (positive receding)
        azimuths, elevations : array_like, rad (azimuth positive towards +y)
        rcs : array_like, m^2
        radial_accelerations : array_like, optional
            :math:`\ddot R` (m/s^2, along the line of sight): the echoes get Doppler rates (module
            docstring); None: no Doppler rates (a frozen CPI).
        """
        accel = 0.0 if radial_accelerations is None else radial_accelerations
        ranges, velocities, az, el, rcs, accel = np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(x, dtype=float)) for x in (ranges, radial_velocities, azimuths, elevations, rcs,
                                                                   accel))
        )
        if np.any(ranges <= 0):
            raise ValueError("point_targets: ranges must be > 0 m")
        if np.any(rcs < 0):
            raise ValueError("point_targets: rcs must be >= 0 m^2")
        u = target_direction(az, el)  # [P,3]
        position = ranges[:, None] * u
        velocity = velocities[:, None] * u
        wavelength = SPEED_OF_LIGHT / radar.fc

        d_t = position[None, :, :] - radar.tx_positions[:, None, :]  # [M,P,3]
        d_r = position[None, :, :] - radar.rx_positions[:, None, :]  # [N,P,3]
        r_t = np.linalg.norm(d_t, axis=-1)
        r_r = np.linalg.norm(d_r, axis=-1)
        g_t = antenna_gain(radar.antenna_pattern, *direction_angles(d_t))
        g_r = antenna_gain(radar.antenna_pattern, *direction_angles(d_r))
        rate_t = np.einsum("mpi,pi->mp", d_t, velocity) / r_t  # dR_t/dt
        rate_r = np.einsum("npi,pi->np", d_r, velocity) / r_r

        amplitude = wavelength * np.sqrt(g_t[:, None, :] * g_r[None, :, :] * rcs) / (
            (4 * np.pi) ** 1.5 * r_t[:, None, :] * r_r[None, :, :]
        )
        tau = (r_t[:, None, :] + r_r[None, :, :]) / SPEED_OF_LIGHT
        doppler = -(rate_t[:, None, :] + rate_r[None, :, :]) / wavelength
        doppler_rate = None
        if radial_accelerations is not None:
            from .kinematics import range_acceleration

            acceleration = accel[:, None] * u
            zero = np.zeros(3)
            acc_t = range_acceleration(radar.tx_positions[:, None, :], zero, zero, position[None], velocity[None],
                                       acceleration[None])   # [M, P]
            acc_r = range_acceleration(radar.rx_positions[:, None, :], zero, zero, position[None], velocity[None],
                                       acceleration[None])   # [N, P]
            doppler_rate = -(acc_t[:, None, :] + acc_r[None, :, :]) / wavelength
        return cls(amplitude.astype(complex), tau, doppler, labels, doppler_rate=doppler_rate)


# A joined Echoes (Echoes.concatenate) reads its labels and Doppler rates through __getattr__, joined
# on first use: no class attribute may stand in for them (the dataclass defaults None stay the
# __init__ defaults).
del Echoes.labels
del Echoes.doppler_rate
