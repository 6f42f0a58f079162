"""State-space models of HIMR tracking: dynamics, output maps h(x), Jacobians C(x) and
observability (himr-tag.md §1.5–1.13; seed 000 L479–L987, App. B L1734–L1819).

1-D (eqs. 6–9, L479–L496): x = [z ż z̈], ẋ = A₃x + b₃w, y = C₁x + v with
A₃ = [[0,1,0],[0,0,1],[0,0,0]], b₃ = [0,0,1]ᵀ, C₁ = I₃ (RSS range, phase velocity,
acceleration).

2-D (eqs. 24–28, L795–L835, with errata 1–3): x = [x ẋ ẍ y ẏ ÿ ψ ψ̇ ψ̈] (9 states),
A = blkdiag(A₃, A₃, A₃), outputs in the order of C and of the printed gains
[r₁ ṙ₁ … r_P ṙ_P, a₁, a₂, θ_z, ω_z] for P pylons (u = 1…P):

    r_u = √((x − x_u)² + (y − y_u)²)                                (L824)
    ṙ_u = ((x − x_u)·ẋ + (y − y_u)·ẏ) / r_u                         (L826)
    a₁ = ẍ·cos ψ + ÿ·sin ψ,   a₂ = −ẍ·sin ψ + ÿ·cos ψ              (L832, L834)
    θ_z = ψ,   ω_z = ψ̇                                              (L828, L830)

With ψ the heading of the body's y^B axis (erratum 13 default), a₁ is the accelerometer's
y^B reading and a₂ minus its x^B reading (:mod:`rfsim.devices.imu` conventions).
``accel = "prerotated"`` replaces a₁, a₂ by −ẍ, −ÿ — the body accelerations rotated into
the fixed frame with the measured θ_z and then by π (:func:`prerotate_accelerations`), so
that those two rows of C are constant and equal to the rows of (55) (himr-tag.md §6.3).

C(x) = ∂h/∂x is the analytic Jacobian of App. B (L1764–L1780, himr-tag.md §1.11), e.g.
C₂₁ = (y − y₁)((y − y₁)ẋ − (x − x₁)ẏ)/r₁³, C₇₇ = −ẍ sin ψ + ÿ cos ψ.

Observability (eq. 13, L521): O = [C; CA; …; CA^(n−1)], observable iff rank O = n.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

Accel = Literal["literal", "prerotated"]

#: 1-D triple integrator A₃ (eq. 9) and the 2-D block-diagonal A (erratum 2).
A3 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
A9 = np.kron(np.eye(3), A3)
#: 1-D output matrix C = I₃ (eq. 9).
C1 = np.eye(3)
#: Pylon positions of the 2-D experiment (Table 7, L1006–L1008) [m].
PYLONS_M = np.array([(-0.1, 1.5), (2.0, 3.05), (2.7, -0.03)])
#: Linearisation point of Table 8 (L1161–L1172): (x, y) = (2.1, 1.75) m, at rest, ψ = π.
TABLE8_STATE = np.array([2.1, 0.0, 0.0, 1.75, 0.0, 0.0, np.pi, 0.0, 0.0])
#: Initial conditions of Table 9 (L1196–L1206): (x [m], y [m], ψ [rad]), at rest.
INITIAL_CONDITIONS = {1: (2.0, 1.8048, np.pi), 2: (1.0, 1.0, np.pi / 2), 3: (2.5, 2.3, 3 * np.pi / 2)}
STATE_NAMES = ("x", "x_dot", "x_ddot", "y", "y_dot", "y_ddot", "psi", "psi_dot", "psi_ddot")


def initial_state(ic: int) -> np.ndarray:
    """The 9-state initial estimate of Table 9's initial condition ``ic``, at rest (L1196–L1206).

    Parameters
    ----------
    ic : int
        Initial condition 1, 2 or 3.

    Returns
    -------
    numpy.ndarray
        ``(9,)`` state ``[x ẋ ẍ y ẏ ÿ ψ ψ̇ ψ̈]`` [m, m/s, m/s², m, m/s, m/s², rad, rad/s, rad/s²].
    """
    x, y, psi = INITIAL_CONDITIONS[ic]
    return np.array([x, 0, 0, y, 0, 0, psi, 0, 0], float)


def output_names(n_pylons: int) -> tuple[str, ...]:
    """Names of the 2-D outputs in observer order (module docstring).

    Parameters
    ----------
    n_pylons : int
        Number of pylons P.

    Returns
    -------
    tuple of str
        ``("r1", "r1_dot", …, "a1", "a2", "theta_z", "omega_z")``, 2P + 4 names.
    """
    rf = [n for u in range(1, n_pylons + 1) for n in (f"r{u}", f"r{u}_dot")]
    return tuple(rf + ["a1", "a2", "theta_z", "omega_z"])


def _pylons(pylons_m) -> np.ndarray:
    p = np.asarray(pylons_m, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 1:
        raise ValueError(f"pylons must be (P, 2) positions [m], got shape {p.shape}")
    return p


def h_2d(x, pylons_m=PYLONS_M, accel: Accel = "literal") -> np.ndarray:
    """Outputs h(x) of the 2-D model (eq. 28, module docstring).

    Parameters
    ----------
    x : array_like
        ``(..., 9)`` states [m, m/s, m/s², m, m/s, m/s², rad, rad/s, rad/s²].
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    accel : {"literal", "prerotated"}
        Acceleration rows: body-frame a₁, a₂ or −ẍ, −ÿ.

    Returns
    -------
    numpy.ndarray
        ``(..., 2P + 4)``: per pylon r [m], ṙ [m/s]; a₁, a₂ [m/s²]; θ_z [rad]; ω_z [rad/s].

    Raises
    ------
    ValueError
        If ``pylons_m`` is not ``(P, 2)``.
    """
    x = np.asarray(x, dtype=float)
    p = _pylons(pylons_m)
    dx = x[..., 0, None] - p[:, 0]
    dy = x[..., 3, None] - p[:, 1]
    r = np.hypot(dx, dy)
    rdot = (dx * x[..., 1, None] + dy * x[..., 4, None]) / r
    rf = np.stack([r, rdot], axis=-1).reshape(*x.shape[:-1], 2 * p.shape[0])
    if accel == "prerotated":
        a1, a2 = -x[..., 2], -x[..., 5]
    else:
        c, s = np.cos(x[..., 6]), np.sin(x[..., 6])
        a1 = x[..., 2] * c + x[..., 5] * s
        a2 = -x[..., 2] * s + x[..., 5] * c
    return np.concatenate([rf, np.stack([a1, a2, x[..., 6], x[..., 7]], axis=-1)], axis=-1)


def jacobian_2d(x, pylons_m=PYLONS_M, accel: Accel = "literal") -> np.ndarray:
    """C(x) = ∂h/∂x of the 2-D model (App. B L1764–L1780, module docstring).

    Parameters
    ----------
    x : array_like
        ``(..., 9)`` states (units of :func:`h_2d`).
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    accel : {"literal", "prerotated"}
        Acceleration rows as in :func:`h_2d`.

    Returns
    -------
    numpy.ndarray
        ``(..., 2P + 4, 9)`` Jacobian (output units per state unit).

    Raises
    ------
    ValueError
        If ``pylons_m`` is not ``(P, 2)``.
    """
    x = np.asarray(x, dtype=float)
    p = _pylons(pylons_m)
    X, Xd, Xdd, Y, Yd, Ydd, psi = (x[..., i, None] for i in range(7))
    n_p = p.shape[0]
    C = np.zeros(x.shape[:-1] + (2 * n_p + 4, 9))
    dx, dy = X - p[:, 0], Y - p[:, 1]
    r = np.hypot(dx, dy)
    rows, rates = np.arange(0, 2 * n_p, 2), np.arange(1, 2 * n_p, 2)
    C[..., rows, 0], C[..., rows, 3] = dx / r, dy / r
    C[..., rates, 0] = dy * (dy * Xd - dx * Yd) / r ** 3
    C[..., rates, 1] = dx / r
    C[..., rates, 3] = dx * (dx * Yd - dy * Xd) / r ** 3
    C[..., rates, 4] = dy / r
    k = 2 * n_p
    if accel == "prerotated":
        C[..., k, 2] = C[..., k + 1, 5] = -1.0
    else:
        c, s = np.cos(psi[..., 0]), np.sin(psi[..., 0])
        xdd, ydd = Xdd[..., 0], Ydd[..., 0]
        C[..., k, 2], C[..., k, 5], C[..., k, 6] = c, s, -xdd * s + ydd * c
        C[..., k + 1, 2], C[..., k + 1, 5], C[..., k + 1, 6] = -s, c, -xdd * c - ydd * s
    C[..., k + 2, 6] = C[..., k + 3, 7] = 1.0
    return C


def prerotate_accelerations(y, n_pylons: int) -> np.ndarray:
    """Measured outputs with a₁, a₂ replaced by −ẍ, −ÿ (module docstring).

    With a₁ = a·y^B, a₂ = −a·x^B and y^B = (cos θ, sin θ), x^B = (sin θ, −cos θ):
    ẍ = a₁ cos θ − a₂ sin θ, ÿ = a₁ sin θ + a₂ cos θ, θ = the measured θ_z.

    Parameters
    ----------
    y : array_like
        ``(..., 2P + 4)`` measured outputs in observer order.
    n_pylons : int
        Number of pylons P.

    Returns
    -------
    numpy.ndarray
        A new ``(..., 2P + 4)`` array, accelerations [m/s²] in the fixed frame, negated.
    """
    y = np.array(y, dtype=float, copy=True)
    k = 2 * n_pylons
    a1, a2, th = y[..., k].copy(), y[..., k + 1].copy(), y[..., k + 2]
    c, s = np.cos(th), np.sin(th)
    y[..., k] = -(a1 * c - a2 * s)
    y[..., k + 1] = -(a1 * s + a2 * c)
    return y


def observability_matrix(A, C) -> np.ndarray:
    """Observability matrix O = [C; CA; …; CA^(n−1)] (eq. 13).

    Parameters
    ----------
    A : array_like
        ``(n, n)`` state matrix.
    C : array_like
        ``(p, n)`` output matrix.

    Returns
    -------
    numpy.ndarray
        ``(n·p, n)``.
    """
    A, C = np.asarray(A, float), np.asarray(C, float)
    blocks, M = [], C
    for _ in range(A.shape[0]):
        blocks.append(M)
        M = M @ A
    return np.vstack(blocks)


def observability_rank(A, C, tol: float | None = None) -> int:
    """rank O of :func:`observability_matrix` (numpy SVD rank); observable iff rank O = n.

    Parameters
    ----------
    A : array_like
        ``(n, n)`` state matrix.
    C : array_like
        ``(p, n)`` output matrix.
    tol : float or None
        Singular-value tolerance; None: numpy's default.

    Returns
    -------
    int
        The rank.
    """
    return int(np.linalg.matrix_rank(observability_matrix(A, C), tol=tol))


__all__ = ["A3", "A9", "C1", "PYLONS_M", "TABLE8_STATE", "INITIAL_CONDITIONS", "initial_state", "STATE_NAMES", "output_names", "h_2d",
           "jacobian_2d", "prerotate_accelerations", "observability_matrix", "observability_rank"]
