"""Framed slotted ALOHA (FSA) analytics: exact slot-occupancy statistics of one frame.

N tags each pick one of L slots uniformly and independently (a Gen2 Query with L = 2^Q: every
tag draws its slot counter from [0, L − 1], gen2-and-validation-anchors.md §4.5). The number
of replies in one given slot is Binomial(N, 1/L) (anchors §4.6):

    P(k replies) = C(N, k)·(1/L)^k·(1 − 1/L)^(N−k),
    E[empty] = L·(1 − 1/L)^N,  E[single] = N·(1 − 1/L)^(N−1),
    E[collided] = L − E[empty] − E[single].

The slot counts of one frame are sums of L dependent slot indicators; their covariances
follow from the joint occupancy of two distinct slots i ≠ j (the remaining tags fall into the
other L − 2 slots):

    P(i empty, j empty)   = (1 − 2/L)^N
    P(i single, j single) = N(N − 1)/L²·(1 − 2/L)^(N−2)
    P(i empty, j single)  = N/L·(1 − 2/L)^(N−1)

so that, for indicator sums X = Σ_i x_i and Y = Σ_j y_j,
Cov(X, Y) = L·(E[x_i y_i] − p_x p_y) + L(L − 1)·(P(x_i, y_j) − p_x p_y). The collided count is
L − empty − single, so its moments are linear in the other two.

Efficiency η = E[single]/L is maximal at L = N, η = (1 − 1/N)^(N−1) → 1/e (anchors §4.6).
Population estimators from one frame's outcome: Schoute n̂ = S + 2.39·C (Schoute 1983, IEEE
TCOM 31(4)) and the lower bound n̂ = S + 2·C (Vogt 2002), S successes, C collided slots.
"""

from __future__ import annotations

import math

import numpy as np

#: Schoute's expected number of tags in a collided slot at L ≈ N (anchors §4.6).
SCHOUTE_TAGS_PER_COLLISION = 2.39


def _check(n_tags: int, n_slots: int) -> tuple[int, int]:
    n, L = int(n_tags), int(n_slots)
    if n < 0 or L < 1 or n != n_tags or L != n_slots:
        raise ValueError(f"need integers n_tags >= 0 and n_slots >= 1, got {n_tags}, {n_slots}")
    return n, L


def slot_occupancy_pmf(n_tags: int, n_slots: int) -> np.ndarray:
    r"""Probability that a given slot holds k replies, k = 0 … N.

    Binomial(N, 1/L) (gen2-and-validation-anchors.md §4.6):

    .. math:: P(k) = \binom{N}{k} \left(\frac{1}{L}\right)^k \left(1 - \frac{1}{L}\right)^{N-k}

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 0.
    n_slots : int
        Number of slots L ≥ 1 of the frame (a Gen2 Query: L = 2^Q).

    Returns
    -------
    ndarray, shape (N + 1,), float64
        P(k replies), k = 0 … N.

    Raises
    ------
    ValueError
        N or L not an integer, N < 0 or L < 1.
    """
    n, L = _check(n_tags, n_slots)
    p = 1.0 / L
    k = np.arange(n + 1)
    logc = np.array([math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1) for j in k])
    with np.errstate(divide="ignore"):
        log_q = math.log1p(-p) if p < 1 else -math.inf
    out = np.zeros(n + 1)
    for j in k:
        if p == 1.0:
            out[j] = 1.0 if j == n else 0.0
        else:
            out[j] = math.exp(logc[j] + j * math.log(p) + (n - j) * log_q)
    return out


def expected_counts(n_tags: int, n_slots: int) -> tuple[float, float, float]:
    r"""Expected numbers of empty, single and collided slots in one frame.

    :math:`E[\mathrm{empty}] = L (1 - 1/L)^N`, :math:`E[\mathrm{single}] = N (1 - 1/L)^{N-1}`,
    :math:`E[\mathrm{collided}] = L - E[\mathrm{empty}] - E[\mathrm{single}]`
    (gen2-and-validation-anchors.md §4.6).

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 0.
    n_slots : int
        Number of slots L ≥ 1 of the frame (a Gen2 Query: L = 2^Q).

    Returns
    -------
    tuple of float
        (E[empty], E[single], E[collided]) [slots].

    Raises
    ------
    ValueError
        N or L not an integer, N < 0 or L < 1.
    """
    n, L = _check(n_tags, n_slots)
    q = 1.0 - 1.0 / L
    e = L * q**n
    s = n * q ** (n - 1) if n >= 1 else 0.0
    return float(e), float(s), float(L - e - s)


def count_covariance(n_tags: int, n_slots: int) -> np.ndarray:
    r"""Covariance matrix of the (empty, single, collided) slot counts of one frame.

    Exact (module docstring): variances and covariances of the indicator sums from the one-slot
    and the two-distinct-slot occupancy probabilities,
    :math:`\mathrm{Cov}(X, Y) = L (E[x_i y_i] - p_x p_y) + L (L - 1) (P(x_i, y_j) - p_x p_y)`;
    collided = L − empty − single.

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 0.
    n_slots : int
        Number of slots L ≥ 1 of the frame (a Gen2 Query: L = 2^Q).

    Returns
    -------
    ndarray, shape (3, 3), float64
        Covariance of (empty, single, collided) [slots²].

    Raises
    ------
    ValueError
        N or L not an integer, N < 0 or L < 1.
    """
    n, L = _check(n_tags, n_slots)
    q1 = 1.0 - 1.0 / L
    q2 = 1.0 - 2.0 / L
    pe = q1**n
    ps = n / L * q1 ** (n - 1) if n >= 1 else 0.0
    pee = q2**n if L >= 2 else 0.0
    pss = n * (n - 1) / L**2 * q2 ** (n - 2) if (n >= 2 and L >= 2) else 0.0
    pes = n / L * q2 ** (n - 1) if (n >= 1 and L >= 2) else 0.0
    var_e = L * (pe - pe * pe) + L * (L - 1) * (pee - pe * pe)
    var_s = L * (ps - ps * ps) + L * (L - 1) * (pss - ps * ps)
    cov_es = L * (0.0 - pe * ps) + L * (L - 1) * (pes - pe * ps)
    # collided = L − E − S
    var_c = var_e + var_s + 2.0 * cov_es
    cov_ec = -var_e - cov_es
    cov_sc = -var_s - cov_es
    return np.array([[var_e, cov_es, cov_ec], [cov_es, var_s, cov_sc], [cov_ec, cov_sc, var_c]])


def efficiency(n_tags: int, n_slots: int) -> float:
    r"""Slot efficiency of one frame.

    :math:`\eta = E[\mathrm{single}]/L` (gen2-and-validation-anchors.md §4.6).

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 0.
    n_slots : int
        Number of slots L ≥ 1 of the frame (a Gen2 Query: L = 2^Q).

    Returns
    -------
    float
        η, the expected fraction of single (successful) slots.

    Raises
    ------
    ValueError
        N or L not an integer, N < 0 or L < 1.
    """
    return expected_counts(n_tags, n_slots)[1] / int(n_slots)


def optimal_efficiency(n_tags: int) -> float:
    r"""Slot efficiency at the optimal frame size L = N.

    :math:`\eta = (1 - 1/N)^{N-1}` (0.387 for N = 10, 0.370 for N = 100, → 1/e;
    gen2-and-validation-anchors.md §4.6).

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 1.

    Returns
    -------
    float
        η at L = N.

    Raises
    ------
    ValueError
        N < 1.
    """
    n = int(n_tags)
    if n < 1:
        raise ValueError(f"n_tags must be >= 1, got {n_tags}")
    return (1.0 - 1.0 / n) ** (n - 1)


def schoute_estimate(n_single: float, n_collided: float) -> float:
    """Schoute's population estimate from one frame's outcome.

    n̂ = S + 2.39·C (Schoute 1983, IEEE TCOM 31(4); gen2-and-validation-anchors.md §4.6).

    Parameters
    ----------
    n_single : float
        Number of single (successful) slots S.
    n_collided : float
        Number of collided slots C.

    Returns
    -------
    float
        Estimated number of tags n̂.
    """
    return float(n_single) + SCHOUTE_TAGS_PER_COLLISION * float(n_collided)


def lower_bound_estimate(n_single: float, n_collided: float) -> float:
    """Vogt's lower-bound population estimate from one frame's outcome.

    n̂ = S + 2·C (Vogt 2002; gen2-and-validation-anchors.md §4.6): every collided slot holds at
    least two tags.

    Parameters
    ----------
    n_single : float
        Number of single (successful) slots S.
    n_collided : float
        Number of collided slots C.

    Returns
    -------
    float
        Lower-bound estimate of the number of tags n̂.
    """
    return float(n_single) + 2.0 * float(n_collided)


def expected_frame_time_s(n_tags: int, n_slots: int, *, empty_s: float, single_s: float,
                          collided_s: float) -> float:
    r"""Mean air time of one frame.

    :math:`E[T] = E[\mathrm{empty}]\,T_e + E[\mathrm{single}]\,T_s + E[\mathrm{collided}]\,T_c`
    (gen2-and-validation-anchors.md §4.6, "time efficiency must weight slot types by duration").

    Parameters
    ----------
    n_tags : int
        Number of tags N ≥ 0.
    n_slots : int
        Number of slots L ≥ 1 of the frame (a Gen2 Query: L = 2^Q).
    empty_s : float
        Duration of an empty slot T_e [s].
    single_s : float
        Duration of a single (successful) slot T_s [s].
    collided_s : float
        Duration of a collided slot T_c [s].

    Returns
    -------
    float
        Expected frame time [s].

    Raises
    ------
    ValueError
        N or L not an integer, N < 0 or L < 1.
    """
    e, s, c = expected_counts(n_tags, n_slots)
    return e * float(empty_s) + s * float(single_s) + c * float(collided_s)


__all__ = ["SCHOUTE_TAGS_PER_COLLISION", "slot_occupancy_pmf", "expected_counts", "count_covariance",
           "efficiency", "optimal_efficiency", "schoute_estimate", "lower_bound_estimate",
           "expected_frame_time_s"]
