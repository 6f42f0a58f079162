"""Summary figures of a scenario's dataset with their Monte-Carlo standard errors, and the rule
that says whether two runs agree in distribution (regression of the distribution).

A run's dataset (HDF5) is reduced to its summary figures — per-cell probabilities, RMSEs, fitted
parameters, read rates — each a :class:`Figure` with its value, its Monte-Carlo standard error
and the number of independent trials (or clusters of trials) behind it. Two runs with different
seeds, or of different code, agree in distribution when every figure agrees within its interval
(:func:`compare`). The figures are computed here, from the dataset's raw columns where the
scenario stores them, not by the package under test.

Standard errors, by kind of figure:

``binomial``
    A proportion p̂ = k / n of n independent trials (a read rate, P(cancel) in a cell, a decode
    probability): se = sqrt(p̃ (1 − p̃) / n) with p̃ = (k + ½) / (n + 1), the binomial standard
    error at a shrunken estimate so that a cell with k = 0 or k = n still has a nonzero interval
    (at k = 0, n = 100: se = 0.007; the plain p̂ would give 0 and any later success would be
    judged a change).
``mean``
    A mean of n values: se = s / sqrt(n), s the sample standard deviation. Values that share a
    random draw (the reads of one trial, the time steps of one track) are grouped into clusters
    and the cluster-robust (ratio-estimator) variance is used,
    se² = G / (G − 1) · Σ_g (S_g − x̄ N_g)² / N², with S_g the sum and N_g the count of cluster g
    and G clusters (each value its own cluster when the values are independent).
``rmse``
    sqrt(m) of the mean m of squared errors, its se by the delta method from the se of m (a
    ``mean`` of the squares, clustered as above): se(√m) = se(m) / (2 √m).
``batch``
    A mean or RMSE of one time series (a single track: the HIMR scenarios, phase-tracking), whose
    values are correlated in time: the series is cut into :data:`N_BATCHES` contiguous batches and
    the batches are the clusters (the batch-means method); for a series much longer than its
    correlation time this is the se of the time average. Where the error also has a time profile
    that every seed shares (the HIMR tracks: the same trajectory, transients at the same times),
    batch means count the profile's variation too and the se is too large (conservative: seeds
    1 and 2 of the HIMR RMSEs differ by 0.01-0.4 se); a figure there is a weak check.
``fit``
    A fitted parameter with the standard error the scenario stores beside it (the inverse Fisher
    information of its maximum-likelihood fit, or the least-squares covariance); no bootstrap.
    A parameter at a bound of its fit (reader-detection's dead zone at 0) has a meaningless se;
    it is judged anyway, against the other run's se.
``binomial`` over clusters
    Rates whose trials share a draw (the 50 queries of a reader-detection trial, the beacons of
    one rss-localization trial): :func:`clustered_rate`.
``exact``
    A figure without randomness (a timing of the standard): se = 0, judged by equality up to a
    relative :data:`EXACT_RTOL` (the last bits of a float may move when a kernel is compiled
    differently).

The agreement rule and its z: :func:`bonferroni_z`, :func:`agree_one`, :func:`compare`.
Figures of one scenario are often correlated (the cells of a fit, trackers run on the same
trajectories): the Bonferroni bound holds for any correlation, but such figures move together
between two seeds (tag-to-tag-tracking's 21 figures all moved by 1-2.6 se from seed 1 to 2).

Figures with too few trials for a normal interval (``mean``/``rmse`` of fewer than
:data:`MIN_COUNT` values or clusters), with a non-finite value or se, are left out; a figure
present in one run only is reported and not judged (the count behind it is judged by its
probability figure).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from scipy.stats import norm

#: Contiguous batches of a time series for its batch-means standard error.
N_BATCHES = 20
#: Fewest values (or clusters) behind a ``mean``/``rmse`` figure; below it the sample se is too
#: uncertain for a normal interval at the Bonferroni z (a t with 19 degrees of freedom beyond
#: 4.5 has probability 2.4e-4 against 6.8e-6 for the normal).
MIN_COUNT = 20
#: Relative tolerance of an ``exact`` figure (last-bit moves of floats).
EXACT_RTOL = 1e-9
#: Family-wise false-alarm rate of one comparison (all figures of all scenarios compared).
FAMILY_ALPHA = 1e-3


@dataclass(frozen=True)
class Figure:
    """One summary figure of a run.

    Parameters
    ----------
    name : str
        Scenario-unique name, e.g. ``"cells/p_single[cell=3]"``.
    value : float
        The figure (its unit in the name's column, e.g. ``_m``).
    se : float
        Its Monte-Carlo standard error, same unit (module docstring); 0 for ``exact``.
    n : int
        Trials, values or clusters behind it.
    kind : str
        ``binomial``, ``mean``, ``rmse``, ``batch``, ``fit`` or ``exact``.
    """

    name: str
    value: float
    se: float
    n: int
    kind: str


def binomial(name: str, successes: int, trials: int) -> list[Figure]:
    """A proportion k / n with its binomial se at p̃ = (k + ½)/(n + 1) (module docstring).

    Parameters
    ----------
    name : str
        Figure name.
    successes, trials : int
        k and n; no figure when n = 0.

    Returns
    -------
    list of Figure
        One figure, or none.
    """
    k, n = int(round(successes)), int(trials)
    if n <= 0:
        return []
    p_shrunk = (k + 0.5) / (n + 1)
    return [Figure(name, k / n, math.sqrt(p_shrunk * (1.0 - p_shrunk) / n), n, "binomial")]


def proportion(name: str, rate: float, trials: int) -> list[Figure]:
    """A stored rate of ``trials`` trials as a :func:`binomial` figure (k = round(rate·n)).

    Parameters
    ----------
    name : str
        Figure name.
    rate : float
        The stored proportion; no figure when NaN.
    trials : int
        n.

    Returns
    -------
    list of Figure
        One figure, or none.
    """
    if not np.isfinite(rate):
        return []
    return binomial(name, round(float(rate) * int(trials)), trials)


def _cluster_mean(values: np.ndarray, clusters: np.ndarray | None) -> tuple[float, float, int]:
    """Mean of ``values`` and its cluster-robust se (module docstring); NaNs dropped."""
    values = np.asarray(values, dtype=float)
    keep = np.isfinite(values)
    values = values[keep]
    if clusters is None:
        clusters = np.arange(values.size)
    else:
        clusters = np.asarray(clusters)[keep]
    labels, index = np.unique(clusters, return_inverse=True)
    g = labels.size
    if g < 2:
        return float("nan"), float("nan"), g
    sums = np.bincount(index, weights=values, minlength=g)
    counts = np.bincount(index, minlength=g).astype(float)
    mean = values.mean()
    var = g / (g - 1) * np.sum((sums - mean * counts) ** 2) / values.size ** 2
    return float(mean), float(math.sqrt(var)), g


def mean(name: str, values: np.ndarray, clusters: np.ndarray | None = None, *, kind: str = "mean") -> list[Figure]:
    """A mean with its (cluster-robust) se; none with fewer than :data:`MIN_COUNT` clusters.

    Parameters
    ----------
    name : str
        Figure name.
    values : numpy.ndarray
        The values (NaNs dropped).
    clusters : numpy.ndarray, optional
        Cluster label of each value (values sharing a draw); default: independent values.
    kind : str, default "mean"
        Kind recorded in the figure.

    Returns
    -------
    list of Figure
        One figure, or none.
    """
    m, se, g = _cluster_mean(values, clusters)
    if g < MIN_COUNT or not (np.isfinite(m) and np.isfinite(se)):
        return []
    return [Figure(name, m, se, g, kind)]


def rmse(name: str, errors: np.ndarray, clusters: np.ndarray | None = None, *, kind: str = "rmse") -> list[Figure]:
    """sqrt(mean(e²)) with its delta-method se from the clustered se of mean(e²).

    Parameters
    ----------
    name : str
        Figure name.
    errors : numpy.ndarray
        Errors (NaNs dropped); a vector error gives its norm beforehand.
    clusters : numpy.ndarray, optional
        Cluster label of each error; default independent.
    kind : str, default "rmse"
        Kind recorded in the figure.

    Returns
    -------
    list of Figure
        One figure, or none.
    """
    m, se, g = _cluster_mean(np.asarray(errors, dtype=float) ** 2, clusters)
    if g < MIN_COUNT or not (np.isfinite(m) and np.isfinite(se)) or m <= 0.0:
        return []
    root = math.sqrt(m)
    return [Figure(name, root, se / (2.0 * root), g, kind)]


def clustered_rate(name: str, successes: np.ndarray, trials: np.ndarray) -> list[Figure]:
    """A proportion Σk / Σn over clusters (trials of several Bernoulli outcomes sharing a draw).

    se = max(cluster-robust se of the ratio, binomial se of Σk of Σn at p̃): the outcomes of a
    cluster are positively correlated (a shared channel draw), so the binomial se is a floor.
    When every cluster has the same rate (all 0 or all 1: the cluster-robust se is 0, the data
    show no spread), the se is that of fully correlated clusters, sqrt(p̃ (1 − p̃) / G) for G
    clusters, p̃ = (Σk + ½)/(Σn + 1): a run where one cluster of 16 reads a little is then not
    judged a change (0 of 800 queries has se 0.006, not the binomial 0.0009).

    Parameters
    ----------
    name : str
        Figure name.
    successes, trials : numpy.ndarray
        k and n of each cluster.

    Returns
    -------
    list of Figure
        One figure, or none with fewer than two clusters or Σn = 0.
    """
    k, n = np.asarray(successes, dtype=float), np.asarray(trials, dtype=float)
    total = n.sum()
    if k.size < 2 or total <= 0:
        return []
    p = k.sum() / total
    se_cluster = math.sqrt(k.size / (k.size - 1) * np.sum((k - p * n) ** 2)) / total
    (floor,) = binomial(name, k.sum(), int(total))
    if se_cluster == 0.0:
        p_shrunk = (k.sum() + 0.5) / (total + 1.0)
        return [Figure(name, float(p), math.sqrt(p_shrunk * (1.0 - p_shrunk) / k.size), int(k.size), "binomial")]
    return [Figure(name, float(p), float(max(se_cluster, floor.se)), int(k.size), "binomial")]


def batches(size: int) -> np.ndarray:
    """Batch labels of a time series of ``size`` values: :data:`N_BATCHES` contiguous runs.

    Parameters
    ----------
    size : int
        Length of the series (in time order).

    Returns
    -------
    numpy.ndarray
        Integer labels 0 … N_BATCHES − 1, non-decreasing.
    """
    return (np.arange(size) * N_BATCHES) // max(size, 1)


def batch_rmse(name: str, errors: np.ndarray, t_s: np.ndarray) -> list[Figure]:
    """RMSE of one time series with the batch-means se (module docstring).

    Parameters
    ----------
    name : str
        Figure name.
    errors : numpy.ndarray
        Errors of the series.
    t_s : numpy.ndarray
        Their times [s] (the series is sorted by time first).

    Returns
    -------
    list of Figure
        One figure (N_BATCHES clusters ≥ MIN_COUNT), or none.
    """
    order = np.argsort(t_s, kind="stable")
    return rmse(name, np.asarray(errors)[order], batches(order.size), kind="batch")


def fit(name: str, value: float, se: float, n: int) -> list[Figure]:
    """A fitted parameter with its stored se; none when either is not finite or se ≤ 0.

    Parameters
    ----------
    name : str
        Figure name.
    value, se : float
        Estimate and its stored standard error.
    n : int
        Trials behind the fit.

    Returns
    -------
    list of Figure
        One figure, or none.
    """
    if not (np.isfinite(value) and np.isfinite(se) and se > 0.0):
        return []
    return [Figure(name, float(value), float(se), int(n), "fit")]


def exact(name: str, value: float) -> list[Figure]:
    """A figure without randomness (se = 0, judged to :data:`EXACT_RTOL`).

    Parameters
    ----------
    name : str
        Figure name.
    value : float
        The figure.

    Returns
    -------
    list of Figure
        One figure.
    """
    return [Figure(name, float(value), 0.0, 1, "exact")]


def _groups(*keys: np.ndarray):
    """Unique rows of the key columns and a boolean mask of each (yields (key tuple, mask))."""
    stacked = np.rec.fromarrays(keys)
    for key in np.unique(stacked):
        yield tuple(_plain(k) for k in key), stacked == key


def _plain(x):
    if isinstance(x, bytes):
        return x.decode()
    if isinstance(x, (np.floating, float)):
        return float(x)
    if isinstance(x, (np.integer, int)):
        return int(x)
    return x


def _col(table: h5py.Group, name: str) -> np.ndarray:
    """A column; strings decoded."""
    out = table[name][()]
    if out.dtype == object:
        out = np.array([v.decode() if isinstance(v, bytes) else v for v in out])
    return out


# --- per scenario -------------------------------------------------------------------------


def _link(h: h5py.File) -> list[Figure]:
    """Per distance point: read rate (binomial over rounds). The mean RSSI and SNR of a point
    are not Monte-Carlo figures of its rounds: the rounds of a point share the reader's carrier
    (it dwells on one channel longer than a point's rounds), a draw the within-point spread
    does not see (seeds 1 and 2 differed by 2.4-2.8 within-point se at three points)."""
    r = h["reads"]
    point, success = _col(r, "point"), _col(r, "success").astype(bool)
    out = []
    for (p,), m in _groups(point):
        out += binomial(f"read_rate[point={p}]", success[m].sum(), m.sum())
    return out


def _cells_p(h: h5py.File, methods: tuple[str, ...], extra: tuple[str, ...]) -> list[Figure]:
    """Sense-a-tag cells: P(cancel) of each method and the ``extra`` fractions per cell, and the
    overall P of each method (binomial; n = the cell's samples)."""
    c = h["cells"]
    cell, n = _col(c, "cell"), _col(c, "n_samples")
    out = []
    for i in range(cell.size):
        for col in [f"p_{m}" for m in methods] + list(extra):
            out += proportion(f"{col}[cell={cell[i]}]", _col(c, col)[i], n[i])
    for m in methods:
        out += proportion(f"overall_p_{m}", h.attrs[f"overall_p_{m}"], int(n.sum()))
    return out


_ST_METHODS = ("single", "combination", "selection", "stamp")


def _phase_cancellation(h: h5py.File) -> list[Figure]:
    """Per cell: P(cancel) per method, detectable and tag-replied fractions; overall P."""
    return _cells_p(h, _ST_METHODS, ("detectable_fraction", "tag_replied_fraction"))


def _st_to_st(h: h5py.File) -> list[Figure]:
    """Per cell: P(cancel) per method and the detectable fraction; overall P."""
    return _cells_p(h, _ST_METHODS, ("detectable_fraction",))


def _himr_1d(h: h5py.File) -> list[Figure]:
    """CRC-ok fraction of the packets (binomial); RMSE of each estimator's error over the track
    (batch means)."""
    p = h["packets"]
    out = binomial("crc_ok_fraction", _col(p, "crc_ok").sum(), p["crc_ok"].size)
    e = h["estimates"]
    est, err, t = _col(e, "estimator"), _col(e, "error_m"), _col(e, "t_s")
    for (name,), m in _groups(est):
        out += batch_rmse(f"rmse_m[{name}]", err[m], t[m])
    return out


def _himr_2d(h: h5py.File) -> list[Figure]:
    """CRC-ok and aliased fractions of the packets (binomial); RMSE of each (case, variant,
    dealias) track over time (batch means), the ``literal`` observer excluded (it diverges: its
    error is not a Monte-Carlo quantity)."""
    p = h["packets"]
    out = binomial("crc_ok_fraction", _col(p, "crc_ok").sum(), p["crc_ok"].size)
    out += binomial("aliased_fraction", _col(p, "aliased").sum(), p["aliased"].size)
    e = h["estimates"]
    err, t = _col(e, "error_m"), _col(e, "t_s")
    for (case, variant, dealias), m in _groups(_col(e, "case"), _col(e, "variant"), _col(e, "dealias")):
        if variant != "literal":
            out += batch_rmse(f"rmse_m[case={case},{variant},{dealias}]", err[m], t[m])
    return out


def _gen2_waveforms(h: h5py.File) -> list[Figure]:
    """The timing of each profile as ``exact`` figures; the ACK's duration is left out (it
    carries the tag's random RN16, whose PIE symbols have unequal lengths)."""
    tm = h["timing"]
    prof = _col(tm, "profile")
    return [f for col in tm if col not in ("profile", "row", "ack_s")
            for i in range(prof.size) for f in exact(f"{col}[{prof[i]}]", _col(tm, col)[i])]


def _reader_detection(h: h5py.File) -> list[Figure]:
    """Read rate per (room, distance) pooled over angles and repetitions (a trial's 50 queries
    share its draw: clustered by trial); the fitted parameters of the moments and ML fits with
    their stored se."""
    t = h["trials"]
    reads, queries = _col(t, "n_reads"), _col(t, "n_queries")
    out = []
    for (room, d), m in _groups(_col(t, "room"), _col(t, "distance_m")):
        out += clustered_rate(f"read_rate[room={room},d={d:g}m]", reads[m], queries[m])
    f = h["fits"]
    method = _col(f, "method")
    n = int(queries.sum())
    for i, meth in enumerate(method):
        for col in f:
            if col.startswith("se_"):
                out += fit(f"{col[3:]}[{meth}]", _col(f, col[3:])[i], _col(f, col)[i], n)
    return out


def _detection_probability(h: h5py.File) -> list[Figure]:
    """P(reader detected), P(ST detected), P(tag replied) over all samples (binomial); the fitted
    parameters of each model with their stored se."""
    n = h["samples"]["row"].size
    out = []
    for key in ("p_reader_detected", "p_st_detected", "p_tag_replied"):
        out += proportion(key, h.attrs[key], n)
    f = h["fits"]
    model = _col(f, "model")
    for i in range(model.size):
        nt = int(_col(f, "n_train")[i])
        for a in ("a0", "a1", "a2", "a3", "a4"):
            out += fit(f"{a}[{model[i]},row={i}]", _col(f, a)[i], _col(f, f"se_{a}")[i], nt)
    return out


def _exciter_link(h: h5py.File) -> list[Figure]:
    """Decode probability and tag-replied fraction per (exciter, tag distance) point (binomial
    over draws); the Eq. (6.5) logistic fits per exciter distance and pooled, with stored se."""
    p = h["points"]
    draws, ex, tg = _col(p, "draws"), _col(p, "exciter_distance_m"), _col(p, "tag_distance_m")
    out = []
    for i in range(ex.size):
        for j in range(tg.size):
            at = f"[D={ex[i]:g}m,d={tg[j]:g}m]"
            out += binomial(f"p_decoded{at}", _col(p, "decoded_count")[i, j], draws[i, j])
            out += proportion(f"tag_replied_fraction{at}", _col(p, "tag_replied_fraction")[i, j], draws[i, j])
    rows = h["eq65_rows"]
    n_all = int(draws.sum())
    for i, d in enumerate(_col(rows, "exciter_distance_m")):
        for a in ("a1", "a2"):
            out += fit(f"eq65_{a}[D={d:g}m]", _col(rows, a)[i], _col(rows, f"{a}_stderr")[i], int(draws[i].sum()))
    for a in ("a1", "a2"):
        out += fit(f"eq65_pooled_{a}", h.attrs[f"eq65_pooled_{a}"], h.attrs[f"eq65_pooled_{a}_stderr"], n_all)
    for a in ("a1", "a2", "a3"):
        out += fit(f"eq65_extended_{a}", h.attrs[f"eq65_extended_{a}"], h.attrs[f"eq65_extended_{a}_stderr"], n_all)
    return out


def _inventory(h: h5py.File) -> list[Figure]:
    """Capture sweep: P(capture), P(detected), P(decoded), P(false ACK), P(capture of the weak
    tag) per point (binomial over trials); capture experiment per point; read rate per
    population size, pooled over its runs (exchangeable: new positions and draws per run) and
    clustered by run (:func:`clustered_rate`): the tags of one inventory share its hop table and
    Q dynamics (one run of 20 tags read 0.9 at seed 1 and 0.45 at seed 2, 3.4 binomial se)."""
    out = []
    c = h["capture_sweep"]
    trials = _col(c, "trials")
    keys = [_col(c, k) for k in ("profile", "spread", "threshold_db", "ratio_db")]
    for i in range(trials.size):
        at = f"[{keys[0][i]},spread={keys[1][i]},thr={keys[2][i]:g}dB,ratio={keys[3][i]:g}dB]"
        for col in ("p_capture", "p_detected", "p_decoded", "p_false_ack", "p_capture_weak"):
            out += proportion(f"{col}{at}", _col(c, col)[i], trials[i])
    cap = h["capture"]
    for (pt,), m in _groups(_col(cap, "point")):
        out += binomial(f"capture[point={pt}]", _col(cap, "captured")[m].sum(), m.sum())
    inv = h["inventories"]
    pop, read = _col(inv, "population"), _col(inv, "tags_read")
    for (n,), m in _groups(pop):
        out += clustered_rate(f"read_rate[N={n}]", read[m], pop[m])
    return out


def _rss_localization(h: h5py.File) -> list[Figure]:
    """RMSE of each (case, estimator) over its scored estimates, clustered by trial; beacon
    detection rate per case, clustered by trial."""
    e = h["estimates"]
    scored = _col(e, "scored").astype(bool)
    err, trial = _col(e, "error_m")[scored], _col(e, "trial")[scored]
    out = []
    for (case, est), m in _groups(_col(e, "case")[scored], _col(e, "estimator")[scored]):
        out += rmse(f"rmse_m[case={case},{est}]", err[m], trial[m])
    b = h["beacons"]
    det, btrial = _col(b, "detected").astype(float), _col(b, "trial")
    for (case,), m in _groups(_col(b, "case")):
        k = np.bincount(np.unique(btrial[m], return_inverse=True)[1], weights=det[m])
        n = np.bincount(np.unique(btrial[m], return_inverse=True)[1])
        out += clustered_rate(f"beacon_detected[case={case}]", k, n)
    return out


def _track_batches(realization: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Cluster labels of the periods of independent tracks: each realization's periods, in time
    order, cut into :data:`N_BATCHES` contiguous batches (batch means within a track, tracks
    independent): realization·N_BATCHES + batch."""
    labels = np.empty(realization.size, dtype=np.int64)
    for r in np.unique(realization):
        idx = np.flatnonzero(realization == r)
        idx = idx[np.argsort(period[idx], kind="stable")]
        labels[idx] = int(r) * N_BATCHES + batches(idx.size)
    return labels


def _st_localization(h: h5py.File) -> list[Figure]:
    """RMSE of each (case, tracker) over its estimates and the mean number of landmarks detected
    per period of each case; clustered by realization and time batch within it
    (:func:`_track_batches`: 10 realizations per case are too few clusters on their own)."""
    e = h["estimates"]
    err, real, period = _col(e, "error_m"), _col(e, "realization"), _col(e, "period")
    out = []
    for (case, tracker), m in _groups(_col(e, "case"), _col(e, "tracker")):
        out += rmse(f"rmse_m[case={case},{tracker}]", err[m], _track_batches(real[m], period[m]))
    p = h["periods"]
    real, period = _col(p, "realization"), _col(p, "period")
    for (case,), m in _groups(_col(p, "case")):
        out += mean(f"detected_landmarks[case={case}]", _col(p, "detected_landmarks")[m].astype(float),
                    _track_batches(real[m], period[m]))
    return out


_PT_ESTIMATORS = ("ekf1", "ekf2", "ekf3", "rts1", "rts2", "rts3", "rssi")


def _phase_tracking(h: h5py.File) -> list[Figure]:
    """Read success rate (batch means over the read sequence, :func:`clustered_rate`); RMSE of each estimator against the
    intended position (batch means over the track)."""
    r = h["reads"]
    t = _col(r, "t_s")
    success = _col(r, "success").astype(float)[np.argsort(t, kind="stable")]
    batch = batches(t.size)
    out = clustered_rate("read_success_rate", np.bincount(batch, weights=success), np.bincount(batch))
    e = h["estimates"]
    ix, iy, te = _col(e, "intended_x_m"), _col(e, "intended_y_m"), _col(e, "t_s")
    for k in _PT_ESTIMATORS:
        err = np.hypot(_col(e, f"{k}_x_m") - ix, _col(e, f"{k}_y_m") - iy)
        out += batch_rmse(f"rmse_m[{k}]", err, te)
    return out


def _tag_to_tag_tracking(h: h5py.File) -> list[Figure]:
    """Mean per-run RMSE of each (tracker, range) (runs of one trajectory share its broadcasts:
    clustered by trajectory); decode rate of the receptions per range, clustered by trajectory."""
    r = h["runs"]
    out = []
    for (tracker, rng_m), m in _groups(_col(r, "tracker"), _col(r, "range_m")):
        out += mean(f"mean_run_rmse_m[{tracker},r={rng_m:g}m]", _col(r, "rmse_m")[m], _col(r, "trajectory")[m])
    rc = h["receptions"]
    for (rng_m,), m in _groups(_col(rc, "range_m")):
        idx = np.unique(_col(rc, "trajectory")[m], return_inverse=True)[1]
        out += clustered_rate(f"decoded[r={rng_m:g}m]", np.bincount(idx, weights=_col(rc, "decoded")[m]),
                              np.bincount(idx))
    return out


def _access(h: h5py.File) -> list[Figure]:
    """Per distance: EPC read, TID read and Write success rates over the trials (binomial; the
    ``rates`` table's successes and trials); per distance, the fraction of trials whose Write was
    answered with error 0Bh (insufficient power)."""
    r = h["rates"]
    d, n = _col(r, "distance_m"), _col(r, "trials")
    out = []
    for i in range(d.size):
        for what in ("read", "tid", "write"):
            out += binomial(f"{what}_rate[d={d[i]:g}m]", _col(r, f"{what}_successes")[i], n[i])
        out += binomial(f"write_power_errors[d={d[i]:g}m]", _col(r, "write_power_errors")[i], n[i])
    return out


#: Figures extractor of each scenario (name as in ``rfsim list``).
EXTRACTORS = {
    "access": _access,
    "detection-probability": _detection_probability,
    "exciter-link": _exciter_link,
    "gen2-waveforms": _gen2_waveforms,
    "himr-1d": _himr_1d,
    "himr-2d": _himr_2d,
    "inventory": _inventory,
    "link": _link,
    "phase-cancellation": _phase_cancellation,
    "phase-tracking": _phase_tracking,
    "reader-detection": _reader_detection,
    "rss-localization": _rss_localization,
    "st-localization": _st_localization,
    "st-to-st": _st_to_st,
    "tag-to-tag-tracking": _tag_to_tag_tracking,
}


def summary_figures(path: str | Path, scenario: str | None = None) -> list[Figure]:
    """The summary figures of a dataset.

    Parameters
    ----------
    path : str or pathlib.Path
        The run's HDF5 file.
    scenario : str, optional
        Scenario name; default the file's ``scenario`` attribute.

    Returns
    -------
    list of Figure
        In a fixed order; names unique within the scenario.

    Raises
    ------
    KeyError
        For a scenario without an extractor in :data:`EXTRACTORS`.
    """
    with h5py.File(path, "r") as h:
        name = scenario or str(h.attrs["scenario"])
        figures = EXTRACTORS[name](h)
    names = [f.name for f in figures]
    assert len(set(names)) == len(names), f"{name}: duplicate figure names"
    return figures


# --- the agreement rule -------------------------------------------------------------------


def bonferroni_z(n_figures: int, family_alpha: float = FAMILY_ALPHA) -> float:
    """The two-sided z of a Bonferroni family of ``n_figures`` tests at ``family_alpha``.

    Under the null (same distribution, independent seeds) a figure's difference D = a − b has
    mean 0 and variance se_a² + se_b²; for a normal D, P(|D| > z·σ_D) = 2(1 − Φ(z)). By the union
    bound, P(any of m judged figures exceeds) ≤ m · 2(1 − Φ(z)), which equals α at
    z = Φ⁻¹(1 − α / (2m)) — conservative when the figures are correlated (cells of one run
    share nothing, but a fit and its cells do). m = 100: 4.06; 1,000: 4.56 (α = 1e-3).

    Parameters
    ----------
    n_figures : int
        m, the number of figures judged (≥ 1).
    family_alpha : float, default FAMILY_ALPHA
        α, the family-wise false-alarm rate.

    Returns
    -------
    float
        z.
    """
    return float(norm.isf(family_alpha / (2 * max(int(n_figures), 1))))


@dataclass(frozen=True)
class Row:
    """One figure of a comparison: before and after, the standardized difference and the verdict
    (``agree`` None when the figure is in one run only)."""

    scenario: str
    name: str
    before: Figure | None
    after: Figure | None
    z: float
    agree: bool | None


def agree_one(a: Figure, b: Figure, z_max: float) -> tuple[float, bool]:
    """The rule for one figure: |a − b| ≤ z_max·sqrt(se_a² + se_b²), or for two ``exact``
    figures |a − b| ≤ EXACT_RTOL·max(|a|, |b|).

    Parameters
    ----------
    a, b : Figure
        The same figure of two runs.
    z_max : float
        The Bonferroni z (:func:`bonferroni_z`).

    Returns
    -------
    z : float
        |a − b| / sqrt(se_a² + se_b²) (0 or inf for exact figures).
    agree : bool
        The verdict.
    """
    diff = abs(a.value - b.value)
    sigma = math.hypot(a.se, b.se)
    if sigma == 0.0:
        ok = diff <= EXACT_RTOL * max(abs(a.value), abs(b.value)) or a.value == b.value
        return (0.0 if ok else math.inf), ok
    z = diff / sigma
    return z, z <= z_max


def compare(before: dict[str, list[Figure]], after: dict[str, list[Figure]],
            family_alpha: float = FAMILY_ALPHA) -> tuple[list[Row], float]:
    """Judge every figure of every scenario of two runs with one Bonferroni family.

    Parameters
    ----------
    before, after : dict of str to list of Figure
        Figures per scenario.
    family_alpha : float, default FAMILY_ALPHA
        Family-wise false-alarm rate over all judged figures.

    Returns
    -------
    rows : list of Row
        One per figure name in either run.
    z_max : float
        The Bonferroni z used.
    """
    pairs = []
    for scenario in sorted(set(before) | set(after)):
        a = {f.name: f for f in before.get(scenario, [])}
        b = {f.name: f for f in after.get(scenario, [])}
        names = list(a) + [n for n in b if n not in a]
        pairs += [(scenario, n, a.get(n), b.get(n)) for n in names]
    judged = sum(1 for _, _, fa, fb in pairs if fa is not None and fb is not None and fa.kind != "exact")
    z_max = bonferroni_z(judged, family_alpha)
    rows = []
    for scenario, n, fa, fb in pairs:
        if fa is None or fb is None:
            rows.append(Row(scenario, n, fa, fb, math.nan, None))
        else:
            rows.append(Row(scenario, n, fa, fb, *agree_one(fa, fb, z_max)))
    return rows, z_max


# --- stored tables ------------------------------------------------------------------------


def save_table(path: str | Path, figures: dict[str, list[Figure]], meta: dict) -> None:
    """Write figures per scenario and ``meta`` (command, commit, seed, seconds) as JSON, one
    figure ``[name, value, se, n, kind]`` a line.

    Parameters
    ----------
    path : str or pathlib.Path
        Output file.
    figures : dict of str to list of Figure
        Figures per scenario.
    meta : dict
        Free-form provenance stored under ``"meta"``.
    """
    blocks = []
    for s, fs in sorted(figures.items()):
        rows = ",\n".join(json.dumps([f.name, f.value, f.se, f.n, f.kind]) for f in fs)
        blocks.append(f"{json.dumps(s)}: [\n{rows}\n]")
    text = '{"meta": ' + json.dumps(meta, indent=1) + ',\n"scenarios": {\n' + ",\n".join(blocks) + "\n}}\n"
    Path(path).write_text(text)


def load_table(path: str | Path) -> tuple[dict[str, list[Figure]], dict]:
    """Read a table written by :func:`save_table`.

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file.

    Returns
    -------
    figures : dict of str to list of Figure
        Figures per scenario.
    meta : dict
        Its provenance.
    """
    doc = json.loads(Path(path).read_text())
    figures = {s: [Figure(n, float(v), float(se), int(k), kind) for n, v, se, k, kind in fs]
               for s, fs in doc["scenarios"].items()}
    return figures, doc["meta"]


def markdown(rows: list[Row], z_max: float) -> str:
    """The comparison as a markdown table: scenario, figure, before ± se, after ± se, z, agree.

    Parameters
    ----------
    rows : list of Row
        From :func:`compare`.
    z_max : float
        Its Bonferroni z (stated above the table).

    Returns
    -------
    str
        The table.
    """
    def cell(f: Figure | None) -> str:
        return "—" if f is None else f"{f.value:.6g} ± {f.se:.2g}"

    judged = [r for r in rows if r.agree is not None]
    lines = [f"{sum(r.agree for r in judged)} of {len(judged)} figures agree; Bonferroni z = {z_max:.3f} "
             f"(family-wise false-alarm rate {FAMILY_ALPHA:g}); {len(rows) - len(judged)} in one run only.",
             "", "| scenario | figure | before ± se | after ± se | z | agree |", "|---|---|---|---|---|---|"]
    for r in rows:
        verdict = "n/a" if r.agree is None else ("yes" if r.agree else "**NO**")
        z = "" if not np.isfinite(r.z) else f"{r.z:.2f}"
        lines.append(f"| {r.scenario} | {r.name} | {cell(r.before)} | {cell(r.after)} | {z} | {verdict} |")
    return "\n".join(lines) + "\n"


__all__ = ["EXTRACTORS", "Figure", "Row", "agree_one", "batch_rmse", "batches", "binomial", "bonferroni_z",
           "compare", "exact", "fit", "load_table", "markdown", "mean", "proportion", "rmse", "save_table",
           "clustered_rate", "summary_figures"]
