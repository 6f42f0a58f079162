"""Tracks of a sense-a-tag (ST) through a room of landmark tags (:mod:`rfsim.scenes.landmark_room`)
and the tables of a tracking run (AURIS ch. 4; seeds/003 L4493-L4650).

A *track* is one realization's record, a dict of arrays over its T query periods:
``t_end_s`` (T,) period ends [s], ``truth`` (T, 2) the ST at the period ends [m], ``start`` (4,)
the known initial state [x, y, ẋ, ẏ] (PF-BIN's start: the position at t = 0 and the velocity
by the difference over the first millisecond), ``counts`` (T, L) detections per landmark,
``mean_detection_s`` (T,) t̂ [s] (NaN: none), ``active`` (T,) the reader antenna, ``slots`` and
``reads`` (T,) the Gen2 slots and EPC reads of the period (0 for the surrogate).

* :func:`surrogate_track`: the RTS surrogate (:mod:`rfsim.detection.landmark_rts`) on the fixed
  period grid t_end = (t + 1)·T_s, the rounds at τ_j = (t + (j + ½)/N)·T_s;
* :func:`listened_track`: the sample-level listening scene (:mod:`rfsim.scenes.landmark_listening`),
  periods as long as the rounds take;
* :func:`track_estimates`: the trackers of :mod:`rfsim.estimators.landmark_pf` on tracks.

:func:`period_rows`, :func:`detection_rows` and :func:`estimate_rows` turn a track (and the
trackers' estimates on it) into table rows; :data:`COLUMN_TEXT` and :data:`TABLE_TEXT` describe them.

What limits the trackers on surrogate tracks (``st-localization``, seed 1, trajectory 2 at
0.5 m/s, pfaa room): the detections of a period are spread over it, so the estimates lag the
period end by T_s/2 on average (0.075 m at 0.5 m/s, the false synchronous detection PF-AA
compensates only above 1.2 m/s), and the 45 binomial counts per period of the 9 × 5 grid
(landmarks at cell centres, ST and tags on the floor; the source's heights and grid offsets are
not given) carry ≈ 0.2 m of position information. In the RMS measure (20 realizations): against
the truth T_s/2 before the period end PF-BIN gives 0.156 m (0.190 m at the period end), PF-AA
0.209 m (0.215 m); PF-AA's AR noise q std 0.15 m gives 0.202 m, the variance reading of q (std
0.548 m) 0.229 m; a grid with landmarks on the room's edges (9 × 5 at 0.5 × 0.8 m) is worse
(PF-BIN 0.214 m, PF-AA 0.240 m).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rfsim.core.columns import concat
from rfsim.core.reads import reads_table
from rfsim.detection.landmark_rts import draw_landmark_detections, rts_fixed_logit, rts_likelihood_model
from rfsim.estimators.landmark_pf import LandmarkFilterConfig, run_tracker
from rfsim.scenes.landmark_listening import SampleLevelConfig, listen_track
from rfsim.protocols.inventory import READ_FIELDS
from rfsim.scenes.landmark_room import Room

#: Time step [s] of the finite difference that gives the initial velocity.
_START_DT_S = 1e-3


def _start(p0, p1) -> np.ndarray:
    return np.r_[p0, (p1 - p0) / _START_DT_S]


def surrogate_track(room: Room, position_at: Callable, *, duration_s: float, period_s: float, rounds: int,
                    rng: np.random.Generator) -> dict[str, np.ndarray]:
    r"""Draw a track of round(duration_s / period_s) periods of RTS surrogate detections.

    Periods end at :math:`t_{end} = (t + 1) T_s`; round j of period t is at
    :math:`\tau_j = (t + (j + 1/2)/N) T_s` (module docstring).

    Parameters
    ----------
    room : Room
        Landmarks and reader antennas.
    position_at : callable
        ``t_s (n,) → (n, 2)`` the ST's true position [m], called once on every time (0,
        1 ms, the round times, the period ends).
    duration_s : float
        Tracked time [s].
    period_s : float
        Query period T_s [s].
    rounds : int
        QT rounds N per period.
    rng : numpy.random.Generator
        The detections' draws.

    Returns
    -------
    dict of str to ndarray
        The track (module docstring): ``t_end_s``, ``truth``, ``start``, ``counts``,
        ``mean_detection_s``, ``active``, ``slots`` and ``reads`` (zeros).
    """
    landmarks = room.landmarks_xy()
    T = int(round(duration_s / period_s))
    t_end = (np.arange(T) + 1) * period_s
    tau = (np.arange(T)[:, None] + (np.arange(rounds)[None, :] + 0.5) / rounds) * period_s
    pos = position_at(np.concatenate([[0.0, _START_DT_S], tau.ravel(), t_end]))
    det = draw_landmark_detections(rts_fixed_logit(room.antennas_xyz_m, landmarks), landmarks, room.antennas_xyz_m,
                                   pos[2:2 + tau.size].reshape(T, rounds, 2), period_s=period_s, rng=rng)
    return {"t_end_s": t_end, "truth": pos[2 + tau.size:], "start": _start(pos[0], pos[1]),
            "slots": np.zeros(T, np.int64), "reads": np.zeros(T, np.int64), **det}


def listened_track(room: Room, position_at: Callable, *, height_m: float, rounds: int, sl: SampleLevelConfig,
                   st_config, seed: int, key: tuple[int, ...]) -> dict[str, np.ndarray]:
    """Return a track heard through sample-level Gen2 rounds.

    Parameters
    ----------
    room : Room
        Landmarks and reader antennas.
    position_at : callable
        ``t_s (n,) → (n, 2)`` the ST's true floor position [m].
    height_m : float
        Height of the ST's antennas above its floor position [m].
    rounds : int
        QT rounds per query period.
    sl : rfsim.scenes.landmark_listening.SampleLevelConfig
        The listening scene's settings.
    st_config : rfsim.devices.sense_a_tag_config.SenseATagConfig
        The ST's settings.
    seed : int
        Root seed.
    key : tuple of int
        Stream key (:func:`rfsim.scenes.landmark_listening.listen_track`:
        ``trial_rng(seed, *key, k)``).

    Returns
    -------
    dict of str to ndarray
        The track (module docstring), with the reader's ``read_log`` (a dict of columns);
        ``active`` is 0 (one reader antenna set).
    """
    res = listen_track(room, lambda t: np.r_[position_at(np.array([t]))[0], height_m], rounds=rounds, sl=sl,
                       st_config=st_config, seed=seed, key=key)
    pos = position_at(np.concatenate([[0.0, _START_DT_S], res.t_end_s]))
    return {"t_end_s": res.t_end_s, "truth": pos[2:], "start": _start(pos[0], pos[1]), "counts": res.counts,
            "mean_detection_s": res.mean_detection_s, "active": np.zeros(res.t_end_s.size, np.int64),
            "slots": res.slots_per_period, "reads": res.reads_per_period, "read_log": res.read_log}


def track_estimates(room: Room, chunk: list[dict], trackers, *, filters: LandmarkFilterConfig, rounds: int,
                    rngs: list) -> dict[str, np.ndarray]:
    """Run every tracker on B tracks with a common number T of periods.

    The filters' period Δt is the mean period of the tracks (T_s for the surrogate) and
    their likelihood the RTS model of each period's active antenna.

    Parameters
    ----------
    room : Room
        Landmarks and reader antennas.
    chunk : list of dict
        The B tracks (:func:`surrogate_track` or :func:`listened_track`).
    trackers : sequence of tuple of (str, str, float)
        (label, kind, v_threshold [m/s]) per tracker
        (:func:`rfsim.estimators.landmark_pf.run_tracker`).
    filters : rfsim.estimators.landmark_pf.LandmarkFilterConfig
        The particle filters' settings.
    rounds : int
        QT rounds per period.
    rngs : list of numpy.random.Generator
        One stream per tracker.

    Returns
    -------
    dict of str to ndarray
        Label → estimates, shape (B, T, 2) [m].
    """
    landmarks = room.landmarks_xy()
    col = {k: np.stack([d[k] for d in chunk]) for k in ("counts", "mean_detection_s", "active", "t_end_s", "start")}
    t_end = col["t_end_s"]
    probability = rts_likelihood_model(rts_fixed_logit(room.antennas_xyz_m, landmarks), col["active"], landmarks)
    return {label: run_tracker(kind, col["counts"], landmarks, config=filters, v_threshold_mps=vt,
                               period_s=float(np.mean(t_end[:, -1] / t_end.shape[1])), n_rounds=rounds,
                               probability=probability, initial_state=col["start"], period_end_s=t_end,
                               mean_detection_s=col["mean_detection_s"], rng=rng)
            for (label, kind, vt), rng in zip(trackers, rngs)}


def _keys(case: int, realization: int, n: int) -> dict[str, np.ndarray]:
    return {"case": np.full(n, case), "realization": np.full(n, realization), "period": np.arange(n)}


def period_rows(case: int, realization: int, track: dict) -> dict[str, np.ndarray]:
    """Return one row per query period: duration, truth, detection totals, active antenna, slots, reads.

    Parameters
    ----------
    case : int
        Index of the case.
    realization : int
        Index of the realization.
    track : dict
        The track (module docstring).

    Returns
    -------
    dict of str to ndarray
        Columns of the ``periods`` table (:data:`COLUMN_TEXT`), shape (T,) each.
    """
    c, truth, t_end = track["counts"], track["truth"], track["t_end_s"]
    return {**_keys(case, realization, t_end.size), "t_end_s": t_end, "period_duration_s": np.diff(np.r_[0.0, t_end]),
            "x_true_m": truth[:, 0], "y_true_m": truth[:, 1], "detected_landmarks": (c > 0).sum(axis=1),
            "detections": c.sum(axis=1), "mean_detection_s": track["mean_detection_s"],
            "active_antenna": track["active"], "slots": track["slots"], "reads": track["reads"]}


def read_rows(case: int, realization: int, track: dict, room: Room) -> dict[str, np.ndarray]:
    """Return one row per EPC read of a sample-level track.

    Parameters
    ----------
    case : int
        Index of the case.
    realization : int
        Index of the realization.
    track : dict
        The track; its ``read_log`` (absent or empty for a surrogate track) is used.
    room : Room
        Landmark and reader antenna positions (the ground truth).

    Returns
    -------
    dict of str to ndarray
        The reader's read log with the case and realization, and the ground truth of the
        read landmark (on the floor at its grid position): ``true_position_m`` (n, 3) [m]
        (NaN for a read of no landmark) and ``true_distance_m`` (n,) from the reading
        antenna [m]. Empty for a surrogate track.
    """
    log = track.get("read_log") or {}
    n = len(log.get("tag", ()))
    if n == 0:
        return {}
    tag = np.asarray(log["tag"], np.int64)
    position = np.full((n, 3), np.nan)
    position[tag >= 0, :2] = room.landmarks_xy()[tag[tag >= 0]]
    position[tag >= 0, 2] = 0.0
    antenna_m = np.asarray(room.antennas_xyz_m, float)[np.asarray(log["antenna"], np.int64) - 1]
    return {"case": np.full(n, case), "realization": np.full(n, realization),
            **{k: np.asarray(v) for k, v in log.items()}, "true_position_m": position,
            "true_distance_m": np.linalg.norm(position - antenna_m, axis=1)}


def reads_columns(rows: dict[str, np.ndarray]) -> dict:
    """Return the ``reads`` table in the per-read schema.

    Parameters
    ----------
    rows : dict of str to ndarray
        The rows of :func:`read_rows` (concatenated over realizations).

    Returns
    -------
    dict of str to rfsim.core.dataset.Column
        The table's columns (:func:`rfsim.core.reads.reads_table`): the per-read schema,
        then the case, realization, period, landmark and the slot's context.
    """
    fields = {"case": ("1", "index of the case (experiment, trajectory, speed) in the cases table"),
              "realization": ("1", COLUMN_TEXT["realization"]), "period": ("1", "query period of the read (0-based)"),
              "tag": ("1", "landmark read (grid order)"),
              **{k: READ_FIELDS[k] for k in ("time_s", "round", "slot", "n_replies", "snr_db")}}
    return reads_table(rows, fields, notes={"first_seen_timestamp_us": "start of the ACK segment; time restarts at 0 "
                                                                       "in each realization",
                                            "true_incident_power_dbm": "during the ACK"})


def chunk_tables(case: int, realizations: list[int], chunk: list[dict], estimates: list[list[dict]], room: Room,
                 n_trackers: int) -> dict[str, dict[str, np.ndarray]]:
    """Return the table rows of a chunk of realizations of a case.

    Parameters
    ----------
    case : int
        Index of the case.
    realizations : list of int
        The realizations' indices, one per track.
    chunk : list of dict
        The tracks.
    estimates : list of list of dict
        ``estimates[i]``: the :func:`estimate_rows` of realization i.
    room : Room
        Landmark and reader antenna positions.
    n_trackers : int
        Number of trackers (rows are ordered tracker by tracker).

    Returns
    -------
    dict of str to dict
        Table name (``periods``, ``detections``, ``estimates``, ``reads``; the last empty
        for surrogate tracks) → its columns.
    """
    pairs = list(zip(realizations, chunk))
    return {"periods": concat([period_rows(case, b, d) for b, d in pairs]),
            "detections": concat([detection_rows(case, b, d) for b, d in pairs]),
            "estimates": concat([r[k] for k in range(n_trackers) for r in estimates]),
            "reads": concat([read_rows(case, b, d, room) for b, d in pairs])}


def detection_rows(case: int, realization: int, track: dict) -> dict[str, np.ndarray]:
    """Return one row per (period, landmark) with at least one detection.

    Parameters
    ----------
    case : int
        Index of the case.
    realization : int
        Index of the realization.
    track : dict
        The track (its ``counts``, shape (T, L)).

    Returns
    -------
    dict of str to ndarray
        Columns ``case``, ``realization``, ``period``, ``landmark``, ``count``.
    """
    c = track["counts"]
    nz = np.nonzero(c)
    return {"case": np.full(nz[0].size, case), "realization": np.full(nz[0].size, realization), "period": nz[0],
            "landmark": nz[1], "count": c[nz]}


def estimate_rows(case: int, realization: int, track: dict, estimates: dict) -> list[dict[str, np.ndarray]]:
    """Return, per tracker, one row per period: the estimate and its error.

    Parameters
    ----------
    case : int
        Index of the case.
    realization : int
        Index of the realization.
    track : dict
        The track (its ``t_end_s`` and ``truth``).
    estimates : dict of str to ndarray
        Tracker label → estimates, shape (T, 2) [m].

    Returns
    -------
    list of dict of str to ndarray
        One dict of columns per tracker: keys, ``tracker``, ``x_est_m``, ``y_est_m`` and
        ``error_m`` (Euclidean distance to the truth) [m].
    """
    T = track["t_end_s"].size
    return [{**_keys(case, realization, T), "tracker": np.full(T, label), "x_est_m": x[:, 0], "y_est_m": x[:, 1],
             "error_m": np.linalg.norm(x - track["truth"], axis=-1)} for label, x in estimates.items()]


#: Descriptions of the columns of :func:`period_rows`, :func:`detection_rows`, :func:`estimate_rows`.
COLUMN_TEXT = {
    "realization": "realization (independent detections, and walk) of the case",
    "period": "query period index t (the period ends at (t + 1) T_s)", "landmark": "landmark index (grid order)",
    "count": "detections n_{t,k} of the landmark among the N rounds of the period (zeros not stored)",
    "t_end_s": "end of the period (the estimate's time)",
    "period_duration_s": "duration of the query period (T_s in the surrogate mode; sample level: N QT rounds)",
    "slots": "Gen2 slots of the period's N QT rounds (sample level; 0 in the surrogate mode)",
    "reads": "landmark EPCs the reader read in the period (sample level; 0 in the surrogate mode)",
    "x_true_m": "true x of the ST at the period end",
    "y_true_m": "true y of the ST at the period end", "detected_landmarks": "landmarks detected at least once",
    "detections": "detections summed over landmarks and rounds",
    "mean_detection_s": "mean detection time t-hat of the period (Eq. 4.23; NaN: nothing detected)",
    "active_antenna": "reader antenna active in the period (nearest to the previous WCL estimate)",
    "x_est_m": "estimated x (compensated where the tracker compensates)",
    "y_est_m": "estimated y of the tracker at the period end (compensated where the tracker compensates)",
    "error_m": "distance from the estimate to the true position",
}

#: Descriptions of the tables of a tracking run (``truth``: the period table's truth columns).
TABLE_TEXT = {
    "detections": "one row per (case, realization, period, landmark) with at least one detection",
    "periods": "one row per (case, realization, query period): duration, truth, detection totals, active antenna",
    "truth": "true ST position at the end of every query period of every realization",
    "estimates": "one row per (case, realization, period, tracker): estimate and error",
    "reads": "one row per EPC read of a landmark by the reader (sample level), in the per-read schema, with the "
             "case, realization and query period",
}

__all__ = ["surrogate_track", "listened_track", "track_estimates", "period_rows", "read_rows", "reads_columns",
           "chunk_tables", "detection_rows", "estimate_rows",
           "COLUMN_TEXT", "TABLE_TEXT"]
