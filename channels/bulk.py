"""Many link draws at once: the physics of :meth:`rfsim.channels.scene.Channel.link`, vectorised.

:func:`draw_links` returns the paths of n links tx_i → rx_i in one call, as rectangular
arrays (:class:`BulkPaths`), for Monte Carlo over positions (RSS/phase maps, detection
probability). Every link gets, as in :mod:`rfsim.channels.scene` (DESIGN.md "Channel";
auris-sense-a-tag.md §1.7; pass-paris-simulator.md §2.4):

* **LoS** (column 0): ``A = g_ls(d, fc)·√(G_tx·G_rx)·√PLF·10^(−L_walls/20)·10^(−S/20)``,
  delay d/c, Doppler ``f_D = −(fc/c)·û·(v_rx − v_tx)``; times √(K/(K+1)) when the scene has
  an APDP.
* **Image paths** (columns 1 … S): one column per surface sequence of
  :func:`rfsim.channels.surfaces.image_paths` (orders 1 … ``scene.image_order``, by order then
  surface index, no surface twice in a row). The mirror geometry, the side test, the
  finite-extent test and the Fresnel coefficients ``w_s·r_TE + (1 − w_s)·r_TM`` are evaluated
  for all links of one sequence at once; amplitude ``g_ls(ℓ)·Πr·√(G_tx(first leg)·
  G_rx(last leg)·PLF(image direction))``, delay ℓ/c. A sequence that gives no path for a link
  leaves its slot padded: gain 0, delay 0, ``valid`` False.
* **Diffuse taps** (the last T columns, when ``scene.apdp`` is set): ``g_ls·walls·shadowing·h_i``
  with ``h_i ~ CN(0, P_i)``, delay ``d/c + τ_i``, the LoS Doppler.

Average profile — method and exactness against :func:`rfsim.channels.small_scale.average_profile`
(the profile :meth:`Channel.link` draws from). The NLoS tail ``γe^{−γτ}`` is cut, as there,
into T equal bins over ``[0, t_trunc]`` with ``t_trunc = ln((1 + ε)/ε)/γ``,
``ε = min(ε_K, (ε_τ/3)^√2)``, renormalised to the NLoS power, one tap per bin at the bin's
centre of gravity, T = ⌈2·B/f_res⌉ + 1 (capped at ``max_taps − 1``), which is the first
refinement pass of ``average_profile``. In units of 1/γ that profile does not depend on the
distance, so it is computed once per call (powers ``w_i``, delays ``x_i``) and scaled per
link: ``P_i = w_i/(K+1)`` and ``τ_i = x_i/γ'`` with ``γ' = √(p·m₂ − (p·m₁)²)/τrms``,
``p = 1/(K+1)``, ``m_k = Σ w_i x_i^k``, which makes the discrete profile's RMS delay spread
equal to τrms(d) (to rounding). Hence: **K exact** (both), **τrms exact** here (``average_profile``
is within ``eps_trms``, 1 % by default, and refines its bin count until it is), **total power
exact** (both); the tap delays differ from ``average_profile`` by the factor γ/γ' (≈ 1 %) and,
where ``average_profile`` stretches ``t_max`` to ``(n−1)/(n·f_res)`` (1/γ < 24 ns with the
default curves) or adds bins, by its different bin grid. ``fs_hz`` rounding (PASS mode) is not
offered. Held (quasi-static) draws are the caller's business: one call is one independent draw
per link.

Cost: a few dozen NumPy passes over (n,) and (n, S) arrays plus n·T complex normals; no loop
over links (``rfsim.bench.channels.bench_bulk_links`` measures it).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.units import C_M_S

from .antennas import Antenna, Isotropic, polarization_mismatch_factor
from .geometry import local_angles
from .large_scale import wall_loss_db
from .paths import NARROWBAND_TOLERANCE, PROPAGATION_METHODS, PathSet
from .small_scale import binned_tail

#: Links per block (bounds the temporaries of the image-path geometry).
_BLOCK = 8192

__all__ = ["BulkPaths", "BatchLink", "draw_links", "diffuse_profile", "diffuse_template", "surface_sequences",
           "static_placements"]


@dataclass(frozen=True, eq=False)
class BulkPaths:
    """Paths of n links as rectangular arrays (p = 1 + S + T columns).

    Columns: 0 LoS, 1 … S image-path slots (one per surface sequence, see
    :func:`surface_sequences`), S+1 … S+T diffuse taps.

    Attributes
    ----------
    gain : (n, p) complex128, amplitude gains [linear], carrier phase excluded (as in
        :class:`~rfsim.channels.paths.PathSet`); 0 in padded slots
    delay_s : (n, p) float64, delays [s]; 0 in padded slots
    doppler_hz : (n, p) float64 Doppler shifts [Hz], or None when both ends are static
    valid : (n, p) bool, False in the padded image slots
    n_image_slots : S
    n_diffuse : T
    """

    gain: np.ndarray
    delay_s: np.ndarray
    doppler_hz: np.ndarray | None
    valid: np.ndarray
    n_image_slots: int
    n_diffuse: int

    @property
    def n_links(self) -> int:
        """Number of links n."""
        return int(self.gain.shape[0])

    @property
    def n_paths(self) -> int:
        """Columns per link p (padded)."""
        return int(self.gain.shape[1])

    def coefficients(self, fc_hz: float) -> np.ndarray:
        """Complex path coefficients ``g·e^{−j2π·fc·τ}``, phase reduced modulo one cycle in float64.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            ``(n, p) complex128`` [1].
        """
        return self.gain * np.exp(-2j * np.pi * np.mod(float(fc_hz) * self.delay_s, 1.0))

    def narrowband_gain(self, fc_hz: float) -> np.ndarray:
        """Narrowband gain ``Σ_p g·e^{−j2π·fc·τ}`` per link (at t = 0; padding adds 0).

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            ``(n,) complex128`` [1].
        """
        return self.coefficients(fc_hz).sum(axis=1)

    def pathset(self, i: int) -> PathSet:
        """Link ``i`` as a :class:`PathSet` without padding (the path order of ``Channel.link``).

        Parameters
        ----------
        i : int
            Link index.

        Returns
        -------
        PathSet
            The link.
        """
        keep = self.valid[i]
        dop = None if self.doppler_hz is None else self.doppler_hz[i, keep]
        return PathSet(self.gain[i, keep], self.delay_s[i, keep], dop)

    def narrowband_rms_error(self, bandwidth_hz: float) -> np.ndarray:
        """:func:`rfsim.channels.paths.narrowband_rms_error` of every link, at once.

        √(Σ|g|²·(2π·B·(τ − τ0))²) / √(Σ|g|²) per link, τ0 its earliest valid delay, padded
        slots excluded (gain 0); 0 for a link without power.

        Parameters
        ----------
        bandwidth_hz : float
            One-sided signal bandwidth B [Hz].

        Returns
        -------
        numpy.ndarray
            ``(n,) float64`` [1].
        """
        p = np.abs(self.gain) ** 2
        tau0 = np.where(self.valid, self.delay_s, np.inf).min(axis=1, keepdims=True)
        rel = 2.0 * np.pi * float(bandwidth_hz) * np.where(self.valid, self.delay_s - tau0, 0.0)
        total = p.sum(axis=1)
        return np.sqrt((p * rel**2).sum(axis=1) / np.where(total > 0, total, 1.0))

    def batch_link(self, shape: tuple[int, ...]) -> "BatchLink":
        """The n links as one link of the air interface (:mod:`rfsim.air.step`) over a batch.

        Row-major: link i is batch element ``unravel(i, shape)``.

        Parameters
        ----------
        shape : tuple of int
            Batch shape, prod(shape) = n.

        Returns
        -------
        BatchLink
            The batched link.
        """
        return BatchLink(self, tuple(int(s) for s in shape))


class BatchLink:
    """n narrowband static links as one link of a batched air step (:func:`rfsim.air.step.propagate`).

    The step multiplies a segment (…, n_samples) by :meth:`constant_gain`, a (*shape, 1) array
    of the links' narrowband gains Σ_p g·e^{−j2π·fc·τ} (:meth:`BulkPaths.narrowband_gain`),
    which gives the (*shape, n_samples) batch of every link's output at once. The
    narrowband decision is the one rule of :func:`rfsim.channels.paths.propagation_method` applied to
    every link: "narrowband" iff the largest :meth:`BulkPaths.narrowband_rms_error` is at most
    :data:`rfsim.channels.paths.NARROWBAND_TOLERANCE` (:meth:`narrowband_error`). Only the
    narrowband method is offered (:meth:`apply` raises otherwise).
    """

    def __init__(self, paths: BulkPaths, shape: tuple[int, ...]):
        if int(np.prod(shape)) != paths.n_links:
            raise ValueError(f"batch shape {shape} does not hold {paths.n_links} links")
        self.paths, self.shape = paths, shape
        self._max_error: dict[float, float] = {}
        self._gain: dict[float, np.ndarray] = {}

    def narrowband_error(self, bandwidth_hz: float) -> float:
        """Largest :meth:`BulkPaths.narrowband_rms_error` over the links (0 without links).

        Parameters
        ----------
        bandwidth_hz : float
            One-sided signal bandwidth [Hz].

        Returns
        -------
        float
            Relative RMS error [1].
        """
        b = float(bandwidth_hz)
        if b not in self._max_error:
            err = self.paths.narrowband_rms_error(b)
            self._max_error[b] = float(err.max()) if err.size else 0.0
        return self._max_error[b]

    @property
    def static(self) -> bool:
        """No path has a Doppler shift."""
        return self.paths.doppler_hz is None or not np.any(self.paths.doppler_hz)

    def method(self, bandwidth_hz: float, propagation: str = "auto") -> str:
        """"narrowband" or "exact" for all links together (class docstring).

        Parameters
        ----------
        bandwidth_hz : float
            One-sided signal bandwidth [Hz].
        propagation : {"auto", "exact", "narrowband"}
            Policy.

        Returns
        -------
        str
            "narrowband" or "exact".
        """
        if propagation not in PROPAGATION_METHODS:
            raise ValueError(f"propagation must be one of {PROPAGATION_METHODS}, got {propagation!r}")
        if propagation != "auto":
            return propagation
        return "narrowband" if self.narrowband_error(bandwidth_hz) <= NARROWBAND_TOLERANCE else "exact"

    def constant_gain(self, fc_hz: float) -> np.ndarray:
        """Narrowband gains at ``fc_hz`` (computed once per carrier; read-only).

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            ``(*shape, 1) complex128`` [1].
        """
        f = float(fc_hz)
        g = self._gain.get(f)
        if g is None:
            g = self.paths.narrowband_gain(f).reshape(self.shape + (1,))
            g.setflags(write=False)
            self._gain[f] = g
        return g

    def apply(self, x, *, fs_hz: float, fc_hz: float, t0_s: float = 0.0, method: str = "exact"):
        """Refuse: a batch of bulk links is applied narrowband only (by :meth:`constant_gain`).

        Parameters
        ----------
        x, fs_hz, fc_hz, t0_s, method
            As :meth:`rfsim.channels.paths.PathSet.apply` (unused).

        Raises
        ------
        ValueError
            Always, stating the largest narrowband error.
        """
        raise ValueError(f"a batch of bulk links is applied narrowband only (asked for {method!r}): "
                         f"the largest narrowband error is {max(self._max_error.values(), default=float('nan')):.3g} "
                         f"> {NARROWBAND_TOLERANCE}")


def surface_sequences(n_surfaces: int, order: int) -> list[tuple]:
    """Surface index sequences of orders 1 … ``order`` in the order of ``image_paths``.

    Parameters
    ----------
    n_surfaces : int
        Number of surfaces.
    order : int
        Highest reflection order.

    Returns
    -------
    list of tuple of int
        Sequences without a surface repeated back to back.
    """
    out = []
    for k in range(1, int(order) + 1):
        for seq in itertools.product(range(int(n_surfaces)), repeat=k):
            if all(a != b for a, b in zip(seq, seq[1:])):
                out.append(seq)
    return out


def diffuse_template(apdp) -> tuple[np.ndarray, np.ndarray]:
    """Unit-γ NLoS profile ``(w, x)`` used by :func:`draw_links` (see the module docstring).

    Parameters
    ----------
    apdp : rfsim.channels.small_scale.ApdpModel
        Profile-sampling options (bandwidth, resolution, tolerances).

    Returns
    -------
    w : numpy.ndarray
        ``(T,) float64`` tap powers, Σw = 1.
    x : numpy.ndarray
        ``(T,) float64`` tap delays in units of 1/γ (bin centres of gravity on
        ``[0, ln((1+ε)/ε)]``).
    """
    eps = min(apdp.eps_k, (apdp.eps_trms / 3.0) ** math.sqrt(2.0))
    n = min(int(math.ceil(2.0 * apdp.bandwidth_hz / apdp.fres_hz)) + 1, apdp.max_taps - 1)
    return binned_tail(1.0, -math.log(eps / (1.0 + eps)), max(n, 1))


def diffuse_profile(apdp, distance_m, *, template=None):
    """Per-link average profile of :func:`draw_links` (unit total power; module docstring).

    ``P_i = w_i/(K+1)`` and ``τ_i = x_i/γ'`` with ``γ' = √(p·m₂ − (p·m₁)²)/τrms``,
    ``p = 1/(K+1)``, ``m_k = Σ w_i x_i^k``: K(d) and τrms(d) of ``apdp`` are met exactly.

    Parameters
    ----------
    apdp : :class:`~rfsim.channels.small_scale.ApdpModel`
    distance_m : (n,) float64 [m]
    template : ``(w, x)`` from :func:`diffuse_template` (computed when None)

    Returns
    -------
    p_los : (n,) float64, LoS power K/(K+1)
    powers : (n, T) float64, NLoS tap powers (Σ = 1/(K+1))
    delays_s : (n, T) float64, NLoS tap delays [s] relative to the LoS
    """
    w, x = diffuse_template(apdp) if template is None else template
    d = np.asarray(distance_m, dtype=float)
    k_lin = np.asarray(apdp.k_lin_at(d), dtype=float)
    inf = np.isinf(k_lin)
    k_fin = np.where(inf, 0.0, k_lin)
    p_nlos = np.where(inf, 0.0, 1.0 / (k_fin + 1.0))
    m1, m2 = float(w @ x), float(w @ (x * x))
    spread = np.sqrt(np.maximum(p_nlos * m2 - (p_nlos * m1) ** 2, 0.0))  # γ'·τrms
    tau_rms = np.asarray(apdp.tau_rms_s_at(d), dtype=float)
    inv_gamma = np.where(spread > 0, tau_rms / np.where(spread > 0, spread, 1.0), 0.0)
    return 1.0 - p_nlos, p_nlos[:, None] * w, inv_gamma[:, None] * x


def _points(x, name) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim not in (1, 2) or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (3,) or (n, 3), got {a.shape}")
    return a


def _velocity(v, name, n) -> np.ndarray:
    return np.broadcast_to(np.zeros(3) if v is None else _points(v, name), (n, 3))


def _cross_const(a, k):
    """``a × k`` for a constant (3,) vector a and directions k (..., 3)."""
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    return np.stack((a[1] * kz - a[2] * ky, a[2] * kx - a[0] * kz, a[0] * ky - a[1] * kx), axis=-1)


def _gain(antenna: Antenna, directions) -> np.ndarray:
    """Power gain of ``antenna`` in global ``directions`` (..., 3); an isotropic pattern is a constant."""
    if isinstance(antenna.pattern, Isotropic):
        return np.full(directions.shape[:-1], float(antenna.pattern.gain_lin))
    return antenna.gain_in_direction(directions)


def _plf(tx: Antenna, rx: Antenna, k) -> np.ndarray:
    """Polarization mismatch ``|ê_tx·ê_rx*|²`` along directions k (..., 3) (any length).

    Linear–linear in closed form: with ``c = axis × k`` the transverse axis has
    ``|a_⊥| = |c|/|k|`` and ``a_⊥·b_⊥ = c_a·c_b/|k|²``, so ``PLF = (c_a·c_b)²/(|c_a|²·|c_b|²)``,
    0 where an axis is parallel to k (``|a_⊥| ≤ 1e-12``, the rule of
    :meth:`~rfsim.channels.antennas.Antenna.polarization_vector`). Other pairs use the antennas' own
    polarization vectors.
    """
    if tx.polarization == "linear" and rx.polarization == "linear":
        ca = _cross_const(tx.polarization_axis, k)
        cb = _cross_const(rx.polarization_axis, k)
        na = np.einsum("...j,...j->...", ca, ca)
        nb = np.einsum("...j,...j->...", cb, cb)
        tiny = 1e-24 * np.einsum("...j,...j->...", k, k)
        ok = (na > tiny) & (nb > tiny)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ok, np.einsum("...j,...j->...", ca, cb) ** 2 / (na * nb), 0.0)
    return polarization_mismatch_factor(tx.polarization_vector(k), rx.polarization_vector(k))


def _te_weight(tx: Antenna, k, nrm) -> np.ndarray:
    """TE power fraction of the tx field on unit rays k (n, 3) hitting a plane of normal ``nrm``.

    As :func:`rfsim.channels.surfaces._s_weight` with ``e = tx.polarization_vector(k)``: with
    ``s = k × n`` (1 where ``|s| < 1e-12``: normal incidence), ``w = |ŝ·e_⊥|²/|e_⊥|²``. For a
    linear antenna ``ŝ ⊥ k`` gives ``ŝ·a_⊥ = ŝ·a``, so ``w = (s·a)²/(|s|²·|a × k|²)`` (1 where
    ``a ∥ k``: no transverse field).
    """
    s = np.cross(k, nrm)
    ns2 = np.einsum("ij,ij->i", s, s)
    with np.errstate(divide="ignore", invalid="ignore"):
        if tx.polarization == "linear":
            a = tx.polarization_axis
            c = _cross_const(a, k)
            na2 = np.einsum("ij,ij->i", c, c)
            w = (s @ a) ** 2 / (ns2 * na2)
            return np.where((ns2 < 1e-24) | (na2 <= 1e-24), 1.0, w)
        e = np.asarray(tx.polarization_vector(k), dtype=complex)
        e_t = e - np.einsum("ij,ij->i", e, k)[:, None] * k
        pe = np.einsum("ij,ij->i", e_t.real, e_t.real) + np.einsum("ij,ij->i", e_t.imag, e_t.imag)
        w = np.abs(np.einsum("ij,ij->i", s, e_t)) ** 2 / (ns2 * pe)
        return np.where((ns2 < 1e-24) | (pe < 1e-24), 1.0, w)


def _norm(v):
    return np.sqrt(np.einsum("...j,...j->...", v, v))


def _trace_sequence(p_tx, p_rx, surfaces, seq, tx):
    """One surface sequence for all links → (valid, coef, image, first point, last point)."""
    n = p_tx.shape[0]
    images = [p_tx]
    for i in seq:
        s = surfaces[i]
        v = images[-1]
        images.append(v - 2.0 * ((v - s.point_m) @ s.normal)[:, None] * s.normal)
    valid = np.ones(n, dtype=bool)
    target = p_rx
    points = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for level in range(len(seq), 0, -1):
            s = surfaces[seq[level - 1]]
            v = images[level]
            dv = (v - s.point_m) @ s.normal
            dt = (target - s.point_m) @ s.normal
            valid &= dv * dt < 0.0
            t = np.where(valid, dv / np.where(valid, dv - dt, 1.0), 0.0)
            p = v + t[:, None] * (target - v)
            valid &= s.contains(p)
            points.append(p)
            target = p
        points = points[::-1]
        coef = np.ones(n, dtype=complex)
        prev = p_tx
        for idx, p in zip(seq, points):
            s = surfaces[idx]
            dvec = p - prev
            ln = _norm(dvec)
            k = dvec / np.where(ln > 0, ln, 1.0)[:, None]
            aoi = np.arccos(np.minimum(np.abs(k @ s.normal), 1.0))
            coef = coef * s.reflection(aoi, _te_weight(tx, k, s.normal))
            prev = p
    return valid, coef, images[-1], points[0], points[-1]


def _mirror_velocity(v, surfaces, seq):
    for i in seq:
        nrm = surfaces[i].normal
        v = v - 2.0 * (v @ nrm)[..., None] * nrm
    return v


def draw_links(scene, tx_positions_m, rx_positions_m, *, fc_hz: float, rng: np.random.Generator,
               tx_antenna: Antenna | None = None, rx_antenna: Antenna | None = None,
               tx_velocity_m_s=None, rx_velocity_m_s=None) -> BulkPaths:
    """Draw the paths of n links at once (LoS, image paths, diffuse APDP taps).

    Parameters
    ----------
    scene : :class:`~rfsim.channels.scene.Scene` (surfaces, walls, large scale, APDP, shadowing,
        image order)
    tx_positions_m, rx_positions_m : (n, 3) or (3,) float64 [m], broadcast against each other
    fc_hz : carrier frequency [Hz]
    rng : numpy Generator (keyword-only); one call draws ``n·T`` complex normals
    tx_antenna, rx_antenna : :class:`~rfsim.channels.antennas.Antenna` templates whose orientation,
        pattern and polarization apply at every position (their position is ignored); None is
        ``Antenna(...)``'s default (isotropic, linear, vertical)
    tx_velocity_m_s, rx_velocity_m_s : (n, 3) or (3,) velocities [m/s], or None (static)

    Returns
    -------
    :class:`BulkPaths` with p = 1 + S + T columns; ``pathset(i)`` equals
    ``Channel(scene).link(tx_i, rx_i, ...)`` in its deterministic paths (LoS, images) and in
    the law of its diffuse taps (module docstring). A per-link large-scale model
    (``rfsim.channels.large_scale.LinkLargeScale``) contributes its default model: the links are
    named by positions here, not by antennas.

    Raises
    ------
    ValueError
        if shapes do not broadcast or a tx coincides with its rx.
    """
    tx_in = _points(tx_positions_m, "tx_positions_m")
    rx_in = _points(rx_positions_m, "rx_positions_m")
    shape = np.broadcast_shapes(tx_in.shape, rx_in.shape)
    n = shape[0] if len(shape) == 2 else 1
    p_tx = np.ascontiguousarray(np.broadcast_to(tx_in, (n, 3)))
    p_rx = np.ascontiguousarray(np.broadcast_to(rx_in, (n, 3)))
    tx = Antenna(np.zeros(3)) if tx_antenna is None else tx_antenna
    rx = Antenna(np.zeros(3)) if rx_antenna is None else rx_antenna
    moving = tx_velocity_m_s is not None or rx_velocity_m_s is not None
    v_tx = _velocity(tx_velocity_m_s, "tx_velocity_m_s", n)
    v_rx = _velocity(rx_velocity_m_s, "rx_velocity_m_s", n)
    fc = float(fc_hz)
    seqs = surface_sequences(len(scene.surfaces), scene.image_order) if scene.surfaces else []
    w, x = diffuse_template(scene.apdp) if scene.apdp is not None else (np.zeros(0), np.zeros(0))
    n_img, n_dif = len(seqs), w.size
    p = 1 + n_img + n_dif
    gain = np.empty((n, p), dtype=np.complex128)
    delay = np.empty((n, p))
    dop = np.empty((n, p)) if moving else None
    valid = np.ones((n, p), dtype=bool)
    # blocks keep the (block, S, 3) temporaries in cache; the normals are drawn block after
    # block in row order, so the result does not depend on the block size
    for i0 in range(0, n, _BLOCK):
        b = slice(i0, min(i0 + _BLOCK, n))
        _fill_block(scene, seqs, w, x, p_tx[b], p_rx[b], v_tx[b], v_rx[b], tx, rx, fc, rng,
                    gain[b], delay[b], None if dop is None else dop[b], valid[b])
    return BulkPaths(gain, delay, dop, valid, n_img, n_dif)


def _fill_block(scene, seqs, w, x, p_tx, p_rx, v_tx, v_rx, tx, rx, fc, rng, gain, delay, dop, valid):
    """All columns of one block of links (views into the output arrays)."""
    n = p_tx.shape[0]
    n_img, n_dif = len(seqs), w.size
    moving = dop is not None
    diff = p_rx - p_tx
    d = _norm(diff)
    if not np.all(d > 0):
        raise ValueError("a tx and its rx are at the same position")
    g_ls = np.asarray(scene.amplitude_gain(d, fc), dtype=float)
    env = np.ones(n)
    if scene.walls:
        env *= np.power(10.0, -wall_loss_db(p_tx, p_rx, list(scene.walls)) / 20.0)
    if scene.shadowing is not None:
        env *= np.asarray(scene.shadowing.amplitude_gain(0.5 * (p_tx + p_rx)), dtype=float)
    a_los = g_ls * env * np.sqrt(_gain(tx, diff) * _gain(rx, -diff) * _plf(tx, rx, diff))
    tau_los = d / C_M_S
    if n_dif:
        p_los, p_tap, rel = diffuse_profile(scene.apdp, d, template=(w, x))
        a_los = a_los * np.sqrt(p_los)
    gain[:, 0] = a_los
    delay[:, 0] = tau_los
    if moving:
        f_los = -fc / C_M_S * np.einsum("ij,ij->i", diff / d[:, None], v_rx - v_tx)
        dop[:, 0] = f_los
    if n_img:
        sl = slice(1, 1 + n_img)
        _image_columns(scene, seqs, p_tx, p_rx, v_tx, v_rx, tx, rx, fc, moving,
                       gain[:, sl], delay[:, sl], None if dop is None else dop[:, sl], valid[:, sl])
    if n_dif:
        sl = slice(1 + n_img, 1 + n_img + n_dif)
        np.add(tau_los[:, None], rel, out=delay[:, sl])
        z = rng.standard_normal((n, 2 * n_dif)).view(np.complex128)
        np.multiply(z, (g_ls * env)[:, None] * np.sqrt(0.5 * p_tap), out=gain[:, sl])
        if moving:
            dop[:, sl] = f_los[:, None]


def _image_columns(scene, seqs, p_tx, p_rx, v_tx, v_rx, tx, rx, fc, moving, gain, delay, dop, valid):
    """Fill the image-path slots (views into the output arrays) for every surface sequence."""
    n, n_img = gain.shape
    surfaces = scene.surfaces
    ok = np.empty((n, n_img), dtype=bool)
    coef = np.empty((n, n_img), dtype=complex)
    v_src = np.empty((n, n_img, 3))
    first = np.empty((n, n_img, 3))
    last = np.empty((n, n_img, 3))
    for j, seq in enumerate(seqs):
        ok[:, j], coef[:, j], v_src[:, j], first[:, j], last[:, j] = _trace_sequence(
            p_tx, p_rx, surfaces, seq, tx)
    to_rx = p_rx[:, None, :] - v_src
    ell = np.where(ok, _norm(to_rx), 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):  # only padded slots can be degenerate
        g_ant = _gain(tx, first - p_tx[:, None, :]) * _gain(rx, last - p_rx[:, None, :])
        plf = _plf(tx, rx, to_rx)
        g = np.asarray(scene.amplitude_gain(ell, fc), dtype=float) * coef * np.sqrt(g_ant * plf)
    gain[...] = np.where(ok, g, 0.0)
    delay[...] = np.where(ok, ell / C_M_S, 0.0)
    valid[...] = ok
    if moving:
        for j, seq in enumerate(seqs):
            v_img = _mirror_velocity(v_tx, surfaces, seq)
            f = -fc / C_M_S * np.einsum("ij,ij->i", to_rx[:, j] / ell[:, j, None], v_rx - v_img)
            dop[:, j] = np.where(ok[:, j], f, 0.0)


def _linear_polarization(antennas, k) -> np.ndarray:
    """(n, 3) complex: :meth:`~rfsim.channels.antennas.Antenna.polarization_vector` of linearly
    polarized ``antennas[i]`` along ``k[i]`` (the same operations on (n, 3) arrays)."""
    k = k / np.linalg.norm(k, axis=-1, keepdims=True)
    axes = np.array([a.polarization_axis for a in antennas])
    e = axes - np.sum(axes * k, axis=-1, keepdims=True) * k
    ne = np.linalg.norm(e, axis=-1, keepdims=True)
    return np.where(ne > 1e-12, e / np.where(ne > 1e-12, ne, 1.0), 0.0).astype(complex)


def _shared_linear_pattern(antennas, name):
    pattern = antennas[0].pattern
    if any(a.pattern != pattern or a.polarization != "linear" for a in antennas):
        raise ValueError(f"static_placements needs linearly polarized {name} sharing one pattern")
    return pattern


def static_placements(scene, tx, rx_antennas) -> list[tuple]:
    """The carrier-independent geometry of the static links ``tx → rx_i`` of many receivers at
    once, each in the form of ``Channel._placement`` (for :meth:`rfsim.channels.scene.Channel.hold_placement`).

    The same operations as :meth:`rfsim.channels.scene.Channel._placement` on (n, 3) arrays instead of
    one (3,) vector at a time: ``d = √(Σ diff²)``, ``u = diff/d``, antenna gain
    ``√(G_tx(diff)·G_rx(−diff))``, ``√PLF`` from the two polarization vectors along ``diff``,
    the APDP's K(d) and τrms(d). Element by element these are the scalar path's IEEE
    operations; the tests compare the tuples bit for bit with ``Channel._placement``.

    Parameters
    ----------
    scene : :class:`~rfsim.channels.scene.Scene` without surfaces (or ``image_order`` 0) and walls
    tx : the common transmitting :class:`~rfsim.channels.antennas.Antenna`, or a sequence of n
        linearly polarized antennas sharing one pattern (one transmitter per link)
    rx_antennas : sequence of n linearly polarized antennas sharing one pattern (the
        receivers; their rotations and polarization axes are their own)

    Returns
    -------
    list of n tuples ``(d, u, 1.0, ant, √PLF, p_tx, p_rx, v_tx, v_rx, None, (K, τrms) or None)``

    Raises
    ------
    ValueError
        for a scene with reflecting surfaces or walls, antennas of mixed patterns or not
        linearly polarized, or a receiver at its transmitter's position.
    """
    rx_antennas = list(rx_antennas)
    if (scene.surfaces and scene.image_order > 0) or scene.walls:
        raise ValueError("static_placements covers scenes without reflecting surfaces and walls")
    if not rx_antennas:
        return []
    pattern = _shared_linear_pattern(rx_antennas, "receivers")
    one_tx = isinstance(tx, Antenna)
    txs = [tx] * len(rx_antennas) if one_tx else list(tx)
    if len(txs) != len(rx_antennas):
        raise ValueError(f"{len(txs)} transmitters for {len(rx_antennas)} receivers")
    p_tx = np.array([a.position_m for a in txs], dtype=float)
    p_rx = np.array([a.position_m for a in rx_antennas], dtype=float)
    diff = p_rx - p_tx
    # d as the channel's own link forms it (np.linalg.norm of the (3,) vector): its BLAS dot may
    # fuse or reorder the products on some CPUs, so a reduction over axis 1 can differ in the last bit
    d = np.array([np.linalg.norm(v) for v in diff], dtype=float)
    if not np.all(d > 0):
        raise ValueError("tx and rx are at the same position")
    u = diff / d[:, None]
    az, el = local_angles(-diff, np.array([a.rotation for a in rx_antennas]))
    g_rx = np.asarray(pattern.gain(az, el), dtype=float)
    if one_tx:
        g_tx = np.asarray(tx.gain_in_direction(diff), dtype=float)
        e_tx = tx.polarization_vector(diff)
    else:
        tx_pattern = _shared_linear_pattern(txs, "transmitters")
        az, el = local_angles(diff, np.array([a.rotation for a in txs]))
        g_tx = np.asarray(tx_pattern.gain(az, el), dtype=float)
        e_tx = _linear_polarization(txs, diff)
    ant = np.sqrt(g_tx * g_rx)
    plf = np.sqrt(polarization_mismatch_factor(e_tx, _linear_polarization(rx_antennas, diff)))
    apdp = None
    if scene.apdp is not None:
        apdp = (np.asarray(scene.apdp.k_lin_at(d), dtype=float), np.asarray(scene.apdp.tau_rms_s_at(d), dtype=float))
    zero = np.zeros(3)
    zero.setflags(write=False)
    out = []
    for i in range(len(rx_antennas)):
        ui, pt, pr = u[i].copy(), p_tx[i].copy(), p_rx[i].copy()
        for a in (ui, pt, pr):
            a.setflags(write=False)
        out.append((float(d[i]), ui, 1.0, ant[i], plf[i], pt, pr, zero, zero, None,
                    None if apdp is None else (float(apdp[0][i]), float(apdp[1][i]))))
    return out
