"""Large-scale propagation: Friis / log-distance loss, walls (WAF) and correlated shadowing.

All gains here are **amplitude** factors (received field ∝ gain; received power ∝ gain²),
matching the complex path gains ``a`` of a link response. Loss values are in dB (power).

Sources: rssi-localization.md §1.7 (log-distance model eq. 5.3/5.4 with log-normal shadowing
X_σ, wall-attenuation factor eq. 5.10) and §1.9 (spatially correlated shadowing, e.g.
Gudmundson's exponential correlation), gen2-and-validation-anchors.md §4.7 (log-distance, PARIS
default n = 2), pass-paris-simulator.md §2.4 (PASS ``channel_large``:
g = min(1, (c/(4π·d·f))^{pl/2})), DESIGN.md "Channel".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.units import C_M_S

from .geometry import _as_points


def _positive_distance(distance_m) -> np.ndarray:
    d = np.asarray(distance_m, dtype=float)
    if not (d > 0).all():
        raise ValueError("distances must be positive and finite")
    return d


# --------------------------------------------------------------------------- path loss

def friis_amplitude_gain(distance_m, fc_hz) -> np.ndarray:
    """Free-space amplitude gain ``λ/(4π·d)`` between isotropic antennas (Friis).

    Received power ``P_rx = P_tx·G_tx·G_rx·(λ/(4πd))²``; valid in the far field (d ≫ λ).

    Parameters
    ----------
    distance_m : array_like, > 0 [m]
    fc_hz : array_like, broadcastable [Hz]

    Returns
    -------
    (...) float64, dimensionless amplitude factor
    """
    if type(distance_m) is float and type(fc_hz) is float:  # one link: the same operations on floats
        if not distance_m > 0:
            raise ValueError("distances must be positive and finite")
        return np.float64(C_M_S / (4.0 * math.pi * fc_hz * distance_m))
    d = _positive_distance(distance_m)
    return C_M_S / (4.0 * np.pi * np.asarray(fc_hz, dtype=float) * d)


@dataclass(frozen=True)
class LogDistance:
    """Log-distance path loss ``PL(d) = PL(d0) + 10·n·log10(d/d0)`` [dB].

    rssi-localization.md §1.7 eq. (5.3): ``n`` is the path-loss exponent (2 in free
    space, 1.6–1.8 in corridors, 2–4 indoors); ``PL(d0)`` is the loss at the reference
    distance ``d0``, by default the free-space value ``20·log10(4π·d0/λ)`` (``pl_d0_db=None``),
    which makes ``exponent=2`` identical to Friis. The amplitude gain is ``10^(−PL/20)``. The
    formula is applied at every distance > 0 (no saturation); it is meant for d ≥ d0.

    Parameters
    ----------
    exponent : path-loss exponent n (> 0)
    d0_m : reference distance [m] (> 0)
    pl_d0_db : loss at ``d0`` [dB], or None for free space at ``d0`` (frequency-dependent)
    """

    exponent: float = 2.0
    d0_m: float = 1.0
    pl_d0_db: float | None = None

    def __post_init__(self):
        if not float(self.exponent) > 0:
            raise ConfigError("channel.path_loss_exponent", self.exponent, "a number > 0")
        if not float(self.d0_m) > 0:
            raise ConfigError("channel.d0_m", self.d0_m, "a distance > 0 m")

    def path_loss_db(self, distance_m, fc_hz) -> np.ndarray:
        """Path loss ``PL(d) = PL(d0) + 10·n·log10(d/d0)`` (eq. 5.3).

        Parameters
        ----------
        distance_m : array_like
            Distance d > 0 [m].
        fc_hz : array_like
            Carrier frequency [Hz] (for the free-space PL(d0)).

        Returns
        -------
        numpy.ndarray
            Loss [dB] (positive = loss), shape of ``broadcast(distance_m, fc_hz)``.

        Raises
        ------
        ValueError
            If a distance is not positive and finite.
        """
        d = _positive_distance(distance_m)
        if self.pl_d0_db is None:
            pl0 = 20.0 * np.log10(4.0 * np.pi * self.d0_m * np.asarray(fc_hz, float) / C_M_S)
        else:
            pl0 = np.broadcast_to(float(self.pl_d0_db), np.shape(fc_hz))
        return pl0 + 10.0 * self.exponent * np.log10(d / self.d0_m)

    def amplitude_gain(self, distance_m, fc_hz) -> np.ndarray:
        """Amplitude gain ``10^(−PL(d)/20)``.

        Parameters
        ----------
        distance_m : array_like
            Distance d > 0 [m].
        fc_hz : array_like
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            Gain [1].
        """
        return np.power(10.0, -self.path_loss_db(distance_m, fc_hz) / 20.0)


class LinkLargeScale:
    """Per-link large-scale models: one model per antenna pair, per antenna, or a default.

    ``Scene.large_scale`` used to be one model for every link. Özkaya's readers each have
    their own α_j and n_j (Table 6.1, rssi-localization.md §1.8, seeds/002 L984, L1002–L1007:
    ``Pr_j = α_j − 10·n_j·log10 d − nW·WAF``), which a :class:`LogDistance` per reader
    expresses with ``pl_d0_db = P_t + G_t + G_r − α_j`` at d0 = 1 m. The model of a link
    a ↔ b is looked up, in this order:

    1. ``by_pair``: the unordered pair {a, b} (e.g. one tag–reader link with its own
       quasi-static shadowing folded into ``pl_d0_db``);
    2. ``by_antenna``: the model of a or of b (a reader's model for all its links); a link
       between two antennas that both have a model and no pair entry is ambiguous and raises;
    3. ``default`` (None = Friis free space).

    The lookup is symmetric, so links stay reciprocal. Antennas compare by value
    (``rfsim.channels.Antenna``). Callers that know only distances (``los_links``, the bulk links of
    ``rfsim.channels.bulk``) get the default model through :meth:`amplitude_gain`.

    Parameters
    ----------
    default : model with ``amplitude_gain(distance_m, fc_hz)`` or None (Friis)
    by_antenna : iterable of ``(antenna, model)``
    by_pair : iterable of ``(antenna_a, antenna_b, model)``
    """

    def __init__(self, default=None, *, by_antenna=(), by_pair=()):
        by_antenna, by_pair = list(by_antenna), list(by_pair)
        for m in [default] + [m for _, m in by_antenna] + [m for _, _, m in by_pair]:
            if m is not None and not callable(getattr(m, "amplitude_gain", None)):
                raise ConfigError("channel.large_scale", m, "a model with amplitude_gain(d, fc)")
        self.default = default
        self._antennas = {a: m for a, m in by_antenna}
        self._pairs = {frozenset((a, b)): m for a, b, m in by_pair}

    def model(self, tx, rx):
        """The model of the link ``tx ↔ rx`` by the lookup rules of the class.

        Parameters
        ----------
        tx, rx : rfsim.channels.Antenna
            The link's ends (unordered).

        Returns
        -------
        object or None
            The model (None = Friis).

        Raises
        ------
        ConfigError
            When both antennas have their own models and no pair entry settles the link.
        """
        m = self._pairs.get(frozenset((tx, rx)))
        if m is not None:
            return m
        mt, mr = self._antennas.get(tx), self._antennas.get(rx)
        if mt is not None and mr is not None and mt is not mr and tx != rx:
            raise ConfigError("channel.large_scale", (tuple(tx.position_m), tuple(rx.position_m)),
                              "a by_pair model for a link between two antennas with their own models")
        m = mt if mt is not None else mr
        return self.default if m is None else m

    def link_amplitude_gain(self, tx, rx, distance_m, fc_hz) -> np.ndarray:
        """Amplitude gain of the link ``tx ↔ rx`` at ``distance_m`` (its model, or Friis).

        Parameters
        ----------
        tx, rx : rfsim.channels.Antenna
            The link's ends.
        distance_m : array_like
            Distance [m].
        fc_hz : array_like
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            Gain [1].
        """
        m = self.model(tx, rx)
        return friis_amplitude_gain(distance_m, fc_hz) if m is None else m.amplitude_gain(distance_m, fc_hz)

    def amplitude_gain(self, distance_m, fc_hz) -> np.ndarray:
        """The default model's gain (Friis when None), for callers without antennas.

        Parameters
        ----------
        distance_m : array_like
            Distance [m].
        fc_hz : array_like
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            Gain [1].
        """
        if self.default is None:
            return friis_amplitude_gain(distance_m, fc_hz)
        return self.default.amplitude_gain(distance_m, fc_hz)


def pass_log_distance_gain(distance_m, fc_hz, exponent, c_m_s=C_M_S) -> np.ndarray:
    """PASS ``channel_large`` legacy gain (pass-paris-simulator.md §2.4), for golden tests.

    ``g = min(1, (c/(4π·d·f))^{pl/2})``: a log-distance **amplitude** factor with reference
    distance ``λ/(4π)`` (where it equals 1) and exponent ``pl``, saturated to 1 closer in.
    PASS uses ``c = 3e8`` by default; its selftest draws ``c`` at random, hence the argument.

    Parameters
    ----------
    distance_m : array_like
        Distance d [m].
    fc_hz : array_like
        Carrier frequency f [Hz].
    exponent : array_like
        Path-loss exponent pl [1].
    c_m_s : array_like
        Speed of light c [m/s].

    Returns
    -------
    numpy.ndarray
        Gain [1].
    """
    d = np.asarray(distance_m, dtype=float)
    g = np.power(np.asarray(c_m_s, float) / (4.0 * np.pi * d * np.asarray(fc_hz, float)),
                 np.asarray(exponent, float) / 2.0)
    return np.minimum(1.0, g)


# --------------------------------------------------------------------------- walls

@dataclass(frozen=True, eq=False)
class Wall:
    """A planar obstacle with an attenuation per crossing (wall-attenuation factor, WAF).

    rssi-localization.md §1.7 eq. (5.10): ``PL = PL_log-distance + Σ_walls WAF`` over the walls the
    straight line tx → rx crosses. The wall is the plane through ``origin_m`` spanned by the
    orthonormal in-plane axes ``e1``, ``e2``, limited to ``s1 ∈ [s1_min, s1_max]``,
    ``s2 ∈ [s2_min, s2_max]`` (``±inf`` for unbounded). Build it with :meth:`segment_2d`,
    :meth:`rectangle` or :meth:`plane`.

    A segment crosses the wall when its ends lie strictly on opposite sides of the plane and the
    intersection point lies inside the bounds (bounds inclusive); an end lying in the plane
    does not count as a crossing.
    """

    origin_m: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    attenuation_db: float
    s1_range: tuple = (-np.inf, np.inf)
    s2_range: tuple = (-np.inf, np.inf)

    def __post_init__(self):
        o = _as_points(self.origin_m).reshape(3)
        e1 = _as_points(self.e1).reshape(3)
        e2 = _as_points(self.e2).reshape(3)
        e1 = e1 / np.linalg.norm(e1)
        e2 = e2 - np.dot(e2, e1) * e1
        n2 = np.linalg.norm(e2)
        if not n2 > 1e-12:
            raise ValueError("wall axes e1 and e2 must not be parallel")
        for name, v in (("origin_m", o), ("e1", e1), ("e2", e2 / n2)):
            v = v.copy()
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        if not float(self.attenuation_db) >= 0:
            raise ConfigError("wall.attenuation_db", self.attenuation_db, "a loss ≥ 0 dB")
        object.__setattr__(self, "attenuation_db", float(self.attenuation_db))
        object.__setattr__(self, "s1_range", tuple(float(x) for x in self.s1_range))
        object.__setattr__(self, "s2_range", tuple(float(x) for x in self.s2_range))

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal ``e1 × e2``."""
        return np.cross(self.e1, self.e2)

    @classmethod
    def segment_2d(cls, p0_m, p1_m, attenuation_db, *, z_range_m=(-np.inf, np.inf)) -> "Wall":
        """Vertical wall over the floor-plan segment ``p0 → p1`` (xy [m]), height ``z_range_m``."""
        p0 = np.asarray(p0_m, float)[:2]
        p1 = np.asarray(p1_m, float)[:2]
        length = float(np.hypot(*(p1 - p0)))
        if not length > 0:
            raise ValueError("wall segment has zero length")
        return cls(np.r_[p0, 0.0], np.r_[p1 - p0, 0.0], (0.0, 0.0, 1.0), attenuation_db,
                   (0.0, length), tuple(z_range_m))

    @classmethod
    def rectangle(cls, corner_m, edge1_m, edge2_m, attenuation_db) -> "Wall":
        """Finite rectangle ``corner + a·edge1 + b·edge2``, ``a, b ∈ [0, 1]`` (edges ⊥)."""
        e1 = np.asarray(edge1_m, float)
        e2 = np.asarray(edge2_m, float)
        if abs(np.dot(e1, e2)) > 1e-9 * np.linalg.norm(e1) * np.linalg.norm(e2):
            raise ValueError("rectangle edges must be perpendicular")
        return cls(corner_m, e1, e2, attenuation_db,
                   (0.0, float(np.linalg.norm(e1))), (0.0, float(np.linalg.norm(e2))))

    @classmethod
    def plane(cls, point_m, normal_m, attenuation_db) -> "Wall":
        """Unbounded plane through ``point_m`` with normal ``normal_m``."""
        n = np.asarray(normal_m, float)
        n = n / np.linalg.norm(n)
        ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = np.cross(n, ref)
        return cls(point_m, e1, np.cross(n, e1), attenuation_db)

    def crossed(self, tx_m, rx_m) -> np.ndarray:
        """Whether the segments ``tx → rx`` cross this wall.

        Parameters
        ----------
        tx_m, rx_m : array_like
            ``(..., 3)`` segment ends [m], broadcast.

        Returns
        -------
        numpy.ndarray
            ``(...)`` bool.
        """
        tx = _as_points(tx_m)
        rx = _as_points(rx_m)
        n = self.normal
        dt = (tx - self.origin_m) @ n
        dr = (rx - self.origin_m) @ n
        opposite = dt * dr < 0
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(opposite, dt / (dt - dr), 0.0)
        hit = tx + t[..., None] * (rx - tx) - self.origin_m
        s1 = hit @ self.e1
        s2 = hit @ self.e2
        return (opposite & (s1 >= self.s1_range[0]) & (s1 <= self.s1_range[1])
                & (s2 >= self.s2_range[0]) & (s2 <= self.s2_range[1]))


def wall_crossings(tx_m, rx_m, walls) -> np.ndarray:
    """Crossing matrix of segments ``tx_m → rx_m`` with every wall.

    Parameters
    ----------
    tx_m, rx_m : array_like
        ``(..., 3)`` segment ends [m], broadcast.
    walls : sequence of Wall
        The walls.

    Returns
    -------
    numpy.ndarray
        ``(..., n_walls)`` bool.
    """
    shape = np.broadcast_shapes(_as_points(tx_m).shape, _as_points(rx_m).shape)[:-1]
    if len(walls) == 0:
        return np.zeros(shape + (0,), dtype=bool)
    return np.stack([w.crossed(tx_m, rx_m) for w in walls], axis=-1)


def wall_loss_db(tx_m, rx_m, walls) -> np.ndarray:
    """Total wall loss [dB] on the straight lines ``tx_m → rx_m`` (WAF model).

    ``L = Σ_w WAF_w·[segment crosses w]`` (rssi-localization.md §1.7 eq. 5.10, ``nW·WAF``);
    the amplitude factor is ``10^(−L/20)``.

    Parameters
    ----------
    tx_m, rx_m : (..., 3) float [m], broadcastable (e.g. tx (3,), rx (n, 3))
    walls : sequence of :class:`Wall`

    Returns
    -------
    (...) float64 [dB]
    """
    cross = wall_crossings(tx_m, rx_m, walls)
    att = np.array([w.attenuation_db for w in walls], dtype=float)
    return cross.astype(float) @ att if att.size else np.zeros(cross.shape[:-1])


# --------------------------------------------------------------------------- shadowing

#: Points per block in :meth:`ShadowingField.value_db` (bounds the (block, M) work array).
_BLOCK = 2048

class ShadowingField:
    """Quasi-static, spatially correlated log-normal shadowing ``S(x) ~ N(0, σ²)`` [dB].

    Correlation model (Gudmundson, Electron. Lett. 27(23), 1991; needed by
    rssi-localization.md §1.9): shadowing X_σ of eq. (5.4) with
    ``ρ(Δ) = exp(−Δ/d_corr)`` for positions ``Δ = |x − y|`` apart (isotropic in 3-D).

    Method — random Fourier features with Gaussian weights (Rahimi & Recht 2007):
    ``S(x) = σ·√(1/M)·Σ_m [a_m·cos(ω_m·x) + b_m·sin(ω_m·x)]`` with ``a_m, b_m ~ N(0, 1)``
    (evaluated as ``r_m·cos(ω_m·x − θ_m)``, ``r_m e^{jθ_m} = a_m + j·b_m``) and
    ``ω_m`` drawn from the spectral density of the exponential kernel, the multivariate Cauchy
    law ``ω = z/(d_corr·|g|)``, ``z ~ N(0, I₃)``, ``g ~ N(0, 1)`` (Matérn ν = 1/2).
    Exactness: for every realisation, ``S(x)`` at any single point is exactly ``N(0, σ²)``
    (``cos² + sin² = 1``); over realisations the covariance is exactly
    ``σ²·exp(−Δ/d_corr)`` (``E[cos(ω·Δ)]`` is the kernel); within one realisation the
    covariance is ``σ²·(1/M)·Σ cos(ω_m·Δ)``, i.e. the kernel up to a random error of order
    ``1/√M`` (M = ``n_features``, default 1024), and the joint law of several points is
    Gaussian given the ω's. The field is a deterministic function of position once drawn: the
    same position always gives the same value, and any set of positions can be requested in any
    order. :meth:`redraw` draws a new, independent realisation.

    Parameters
    ----------
    sigma_db : standard deviation σ [dB] (≥ 0)
    decorrelation_m : decorrelation distance d_corr [m] (> 0), ρ(d_corr) = 1/e
    rng : numpy Generator (keyword-only) for the first realisation
    n_features : number M of random features (cost ∝ M per point)
    """

    def __init__(self, sigma_db: float, decorrelation_m: float, *, rng: np.random.Generator,
                 n_features: int = 1024):
        if not float(sigma_db) >= 0:
            raise ConfigError("shadowing.sigma_db", sigma_db, "a number ≥ 0 dB")
        if not float(decorrelation_m) > 0:
            raise ConfigError("shadowing.decorrelation_m", decorrelation_m, "a distance > 0 m")
        if int(n_features) < 1:
            raise ConfigError("shadowing.n_features", n_features, "an integer ≥ 1")
        self.sigma_db = float(sigma_db)
        self.decorrelation_m = float(decorrelation_m)
        self.n_features = int(n_features)
        self.redraw(rng)

    def redraw(self, rng: np.random.Generator) -> None:
        """Replace the realisation by a new, independent one.

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of the new ω_m, a_m, b_m.
        """
        m = self.n_features
        z = rng.standard_normal((m, 3))
        g = np.abs(rng.standard_normal(m))
        self._omega = z / (self.decorrelation_m * g[:, None])           # (M, 3) [rad/m]
        a, b = rng.standard_normal((2, m))
        # a·cos φ + b·sin φ = r·cos(φ − θ): one cosine per feature instead of two
        self._amp = np.hypot(a, b) * (self.sigma_db / np.sqrt(m))
        self._theta = np.arctan2(b, a)

    def value_db(self, points_m) -> np.ndarray:
        """Shadowing S(x) at points.

        Bit-for-bit reproducible per point: every point's value is computed from its own
        coordinates in a fixed order (elementwise products, then a row sum), independent of the
        other points requested with it. Cost ≈ M cosines per point, in blocks of ``_BLOCK`` points
        to bound memory.

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` (or ``(..., 2)``, z = 0) positions [m].

        Returns
        -------
        numpy.ndarray
            ``(...) float64`` [dB].
        """
        x = _as_points(points_m)
        flat = x.reshape(-1, 3)
        out = np.empty(flat.shape[0])
        om = self._omega
        for i0 in range(0, flat.shape[0], _BLOCK):
            p = flat[i0:i0 + _BLOCK]
            phase = (p[:, 0:1] * om[:, 0] + p[:, 1:2] * om[:, 1] + p[:, 2:3] * om[:, 2]
                     - self._theta)
            np.cos(phase, out=phase)
            phase *= self._amp
            out[i0:i0 + _BLOCK] = phase.sum(axis=1)
        return out.reshape(x.shape[:-1])

    def amplitude_gain(self, points_m) -> np.ndarray:
        """Amplitude factor ``10^(−S/20)`` at points (a positive S is extra loss).

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` positions [m].

        Returns
        -------
        numpy.ndarray
            ``(...)`` gain [1].
        """
        return np.power(10.0, -self.value_db(points_m) / 20.0)


__all__ = [
    "friis_amplitude_gain",
    "LogDistance",
    "LinkLargeScale",
    "pass_log_distance_gain",
    "Wall",
    "wall_crossings",
    "wall_loss_db",
    "ShadowingField",
]
