"""Per-reader large-scale RSS models: log-distance + walls (WAF) + quasi-static shadowing.

The statistical ("log-distance") mode of Özkaya's active-RFID RSSI campaigns
(rssi-localization.md §1.7–1.8, §7 P0; seeds/002 L872, L978–L986, L1141–L1144, L1309)::

    Pr_j(x) = α_j − 10·n_j·log10(d_j(x)/d0) − nW_j(x)·WAF + X_j(x) + P_j(t)      [dBm]

- α_j [dBm]: mean received power at d0 = 1 m for reader j (per reader: antenna gains differ,
  L984); n_j: path-loss exponent of reader j; d_j = |x − p_j| [m] (3-D).
- nW_j(x)·WAF: the loss of the walls the straight line tag → reader j crosses (eq. 6.3/5.10;
  one WAF per crossing, rfsim.channels.large_scale.Wall / wall_loss_db).
- X_j(x) ~ N(0, σ_j²) [dB]: **quasi-static** shadowing per position and reader (the noise of
  the thesis's fixed-target simulations is frozen while the target stands still, erratum
  R§5.16, and redrawn when it moves). ``decorrelation_m = 0`` draws it independently for every
  distinct position; ``> 0`` uses a Gudmundson-correlated field per reader
  (ρ(Δ) = exp(−Δ/d_corr), rfsim.channels.large_scale.ShadowingField), so nearby tags (a target next
  to a reference tag, §1.9) see similar shadowing. Readers are independent of each other: the
  thesis adds its noise "on the transmit power of the target" (L1309) but its Table 7.3 is
  reproduced with independent per-reader terms (1.36/1.92/2.20/2.48 m vs 1.38/1.95/2.29/2.57)
  and not with one shared term (1.24/1.61/1.82/2.01 m; wave2-specs.md §R).
- P_j(t) ~ N(0, σ_p²): a time-varying "people" term, independent per beacon and reader, or an
  AR(1) sequence over beacons with coefficient ρ_p (people moving around, L1455, L1836).

α absorbs P_t + G_t + G_r − PL(d0) (L980), so the mean needs no carrier frequency. The same
mean, evaluated with estimated (α̂_j, n̂_j), is the model map of the estimators. Distances below
``MIN_DISTANCE_M`` (1 cm) are clamped so that a point on a reader stays finite.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError

from .geometry import _as_points
from .large_scale import ShadowingField, Wall, wall_loss_db

#: Distances are clamped to this minimum [m] before the logarithm.
MIN_DISTANCE_M = 0.01


@dataclass(frozen=True)
class ReaderLink:
    """Large-scale parameters of one reader's link to a tag (Table 6.1 row).

    Parameters
    ----------
    position_m : (x, y, z) reader antenna position [m]
    alpha_dbm : mean RSS at d0 [dBm]
    exponent : path-loss exponent n (> 0)
    sigma_db : shadowing standard deviation σ [dB] (≥ 0)
    d0_m : reference distance [m]
    """

    position_m: tuple[float, float, float]
    alpha_dbm: float
    exponent: float
    sigma_db: float
    d0_m: float = 1.0

    def __post_init__(self):
        if not float(self.sigma_db) >= 0:
            raise ConfigError("reader.sigma_db", self.sigma_db, "a standard deviation ≥ 0 dB")
        if not float(self.exponent) > 0:
            raise ConfigError("reader.exponent", self.exponent, "a path-loss exponent > 0")
        if len(self.position_m) != 3:
            raise ConfigError("reader.position_m", self.position_m, "three coordinates (x, y, z) in m")


class RssChannel:
    """Mean RSS of every reader at tag positions: log-distance per reader + wall losses.

    Parameters
    ----------
    readers : sequence of :class:`ReaderLink` (at least one)
    walls : sequence of :class:`rfsim.channels.large_scale.Wall` (attenuation = WAF per crossing)
    """

    def __init__(self, readers: Sequence[ReaderLink], walls: Sequence[Wall] = ()):
        if len(readers) == 0:
            raise ConfigError("readers", [], "at least one reader")
        self.readers = tuple(readers)
        self.walls = tuple(walls)
        self.positions_m = np.array([r.position_m for r in self.readers], float)   # (J, 3)
        self.alpha_dbm = np.array([r.alpha_dbm for r in self.readers], float)
        self.exponent = np.array([r.exponent for r in self.readers], float)
        self.sigma_db = np.array([r.sigma_db for r in self.readers], float)
        self.d0_m = np.array([r.d0_m for r in self.readers], float)

    @property
    def n_readers(self) -> int:
        return len(self.readers)

    def distance_m(self, points_m) -> np.ndarray:
        """Tag–reader distances of points, clamped at :data:`MIN_DISTANCE_M` (1 cm).

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` tag positions [m].

        Returns
        -------
        numpy.ndarray
            ``(..., J)`` distances [m].
        """
        x = _as_points(points_m)
        d = np.linalg.norm(x[..., None, :] - self.positions_m, axis=-1)
        return np.maximum(d, MIN_DISTANCE_M)

    def wall_loss_db(self, points_m) -> np.ndarray:
        """Wall loss ``nW_j·WAF`` on the lines point → reader j.

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` tag positions [m].

        Returns
        -------
        numpy.ndarray
            ``(..., J)`` losses [dB].
        """
        x = _as_points(points_m)
        return wall_loss_db(x[..., None, :], self.positions_m, self.walls)

    def mean_rss_dbm(self, points_m, alpha_dbm=None, exponent=None) -> np.ndarray:
        """Mean RSS ``α_j − 10·n_j·log10(d_j/d0) − nW_j·WAF`` at points (module docstring).

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` tag positions [m].
        alpha_dbm : array_like or None
            α_j [dBm], broadcast against ``(..., J)`` (e.g. per-trial calibrated values); None:
            the readers' own.
        exponent : array_like or None
            n_j [1], broadcast likewise; None: the readers' own.

        Returns
        -------
        numpy.ndarray
            ``(..., J)`` mean RSS [dBm].
        """
        a = self.alpha_dbm if alpha_dbm is None else np.asarray(alpha_dbm, float)
        n = self.exponent if exponent is None else np.asarray(exponent, float)
        log_d = np.log10(self.distance_m(points_m) / self.d0_m)
        return a - 10.0 * n * log_d - self.wall_loss_db(points_m)


def quasi_static_shadowing_db(points_m, sigma_db, *, rng: np.random.Generator,
                              decorrelation_m: float = 0.0, shared: bool = False,
                              n_features: int = 256) -> np.ndarray:
    """One realisation of the quasi-static shadowing ``X_j(x)`` [dB] at ``points_m``.

    All points of one environment (a trial: target track, reference tags, fingerprint
    positions) must be passed in one call: equal positions get equal values, and with
    ``decorrelation_m > 0`` nearby positions correlated values.

    Parameters
    ----------
    points_m : (K, 3) positions [m]
    sigma_db : (J,) per-reader σ_j [dB]
    rng : generator (keyword-only)
    decorrelation_m : 0 → independent per distinct position; > 0 → Gudmundson field per reader
    shared : one standard term for all readers, scaled by σ_j (the thesis's "noise on the
        transmit power of the target", L1309, read literally) instead of independent readers
    n_features : random features of the correlated field (rfsim.channels.large_scale.ShadowingField)

    Returns
    -------
    (K, J) float64 [dB]
    """
    x = _as_points(points_m).reshape(-1, 3)
    sig = np.asarray(sigma_db, float)
    n_terms = 1 if shared else sig.size
    if decorrelation_m > 0:
        unit = np.empty((x.shape[0], n_terms))
        for j in range(n_terms):
            field = ShadowingField(1.0, decorrelation_m, rng=rng, n_features=n_features)
            unit[:, j] = field.value_db(x)
        return unit * sig
    first: dict[tuple, int] = {}
    inverse = np.array([first.setdefault(p, len(first)) for p in map(tuple, x.tolist())], dtype=np.intp)
    draws = rng.standard_normal((len(first), n_terms))
    return draws[inverse] * sig


def people_term_db(n_beacons: int, n_readers: int, sigma_db: float, *, rng: np.random.Generator,
                   correlation: float = 0.0) -> np.ndarray:
    """Time-varying people term ``P_j(t)`` over beacons.

    Stationary AR(1) per reader: ``P_0 ~ N(0, σ²)``, ``P_t = ρ·P_{t−1} + √(1 − ρ²)·σ·w_t``
    (``ρ = correlation``; 0 = independent per beacon).

    Parameters
    ----------
    n_beacons : int
        Beacons (time steps).
    n_readers : int
        Readers J.
    sigma_db : float
        σ_p [dB].
    rng : numpy.random.Generator
        The draws.
    correlation : float
        ρ_p in [0, 1).

    Returns
    -------
    numpy.ndarray
        ``(n_beacons, n_readers)`` [dB].

    Raises
    ------
    ConfigError
        If ``correlation`` is outside [0, 1).
    """
    if not 0.0 <= correlation < 1.0:
        raise ConfigError("people.correlation", correlation, "a number in [0, 1)")
    w = rng.standard_normal((n_beacons, n_readers)) * sigma_db
    if correlation == 0.0 or n_beacons == 0:
        return w
    out = np.empty_like(w)
    out[0] = w[0]
    g = np.sqrt(1.0 - correlation ** 2)
    for t in range(1, n_beacons):
        out[t] = correlation * out[t - 1] + g * w[t]
    return out


__all__ = [
    "MIN_DISTANCE_M",
    "ReaderLink",
    "RssChannel",
    "quasi_static_shadowing_db",
    "people_term_db",
]
