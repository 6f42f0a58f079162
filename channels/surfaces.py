"""Flat reflecting surfaces: Fresnel coefficients and the image method (virtual transmitters).

Fresnel coefficients of a plane interface from free space (n1 = 1) into a medium of complex
refractive index n2 = √ε_r (pass-paris-simulator.md §2.4, ``channel_surface``), with the
angle of incidence θ measured from the surface normal and cos θ_t = √(1 − (sin θ / n2)²)::

    TE (s, E ⟂ plane of incidence):  r = (cos θ − n2·cos θ_t) / (cos θ + n2·cos θ_t)
    TM (p, E in plane of incidence): r = (cos θ_t − n2·cos θ) / (cos θ_t + n2·cos θ)

Both equal (1 − n2)/(1 + n2) at normal incidence. PASS calls TM the case "E-field along the
surface normal" (``dim == pol_dim``). For a lossy medium use ε_r = ε' − j·σ/(2π f ε0) (time
convention e^{+jωt}, consistent with the e^{−j2πfτ} carrier phase of a delay), see
:func:`relative_permittivity`; n2 = √ε_r takes the principal branch (Im n2 ≤ 0).

Transmission follows PASS: the amplitude factor ``1 − |r|²``. It is the power transmittance
of one lossless interface, which is also the amplitude factor of a path crossing a thin slab
(two interfaces, each with power transmittance 1 − |r|², no internal reflections, no
absorption) — the use PASS makes of it for blockage.

The image method: a source reflected in the plane of surface s₁, then s₂, … gives a virtual
source Vₖ; the path length is |rx − Vₖ| and the path exists if back-tracing from rx hits
every surface (inside its finite extent, if any) between the previous point and the image.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from rfsim.core.errors import ConfigError

__all__ = [
    "fresnel_reflection",
    "fresnel_transmission",
    "surface_coefficient",
    "relative_permittivity",
    "Surface",
    "ImagePath",
    "image_paths",
    "reflect_point",
]

_POLS = ("TE", "TM")


def relative_permittivity(eps_rel: float, sigma_s_m: float, fc_hz: float) -> complex:
    """Complex relative permittivity ε_r = ε' − j·σ/(2π·f·ε0) (e^{+jωt} convention, module docstring).

    Parameters
    ----------
    eps_rel : float
        Real part ε' [1].
    sigma_s_m : float
        Conductivity σ [S/m].
    fc_hz : float
        Frequency f [Hz].

    Returns
    -------
    complex
        ε_r [1].
    """
    from scipy.constants import epsilon_0  # CODATA value of the installed scipy

    return complex(eps_rel, -sigma_s_m / (2.0 * np.pi * fc_hz * epsilon_0))


def _check_pol(polarization: str) -> str:
    if polarization not in _POLS:
        raise ConfigError("surface.polarization", polarization, "'TE' or 'TM'")
    return polarization


def fresnel_reflection(aoi_rad, n2, polarization: str):
    """Fresnel amplitude reflection coefficient r (free space → medium n2).

    Parameters
    ----------
    aoi_rad : array-like, angle of incidence from the normal [rad], in [0, π/2]
    n2 : complex refractive index of the second medium (n2 = √ε_r), scalar or broadcastable
    polarization : ``"TE"`` (s, E ⟂ plane of incidence) or ``"TM"`` (p)

    Returns
    -------
    r : complex128 array of the broadcast shape
    """
    _check_pol(polarization)
    th = np.asarray(aoi_rad, dtype=float)
    n = np.asarray(n2, dtype=complex)
    ci = np.cos(th)
    ct = np.sqrt(1.0 - (np.sin(th) / n) ** 2)
    if polarization == "TE":
        return (ci - n * ct) / (ci + n * ct)
    return (ct - n * ci) / (ct + n * ci)


def fresnel_transmission(aoi_rad, n2, polarization: str):
    """PASS transmission amplitude factor ``1 − |r|²`` (slab crossing, see module docstring).

    Parameters
    ----------
    aoi_rad : array_like
        Angle of incidence from the normal [rad], in [0, π/2].
    n2 : complex or array_like
        Complex refractive index of the second medium.
    polarization : {"TE", "TM"}
        Polarisation.

    Returns
    -------
    numpy.ndarray
        Amplitude factor [1], broadcast shape.
    """
    r = fresnel_reflection(aoi_rad, n2, polarization)
    return 1.0 - np.abs(r) ** 2


def surface_coefficient(aoi_rad, n2, polarization: str, mode: str):
    """Surface gain for one of the PASS surface modes.

    Parameters
    ----------
    aoi_rad : array_like
        Angle of incidence from the normal [rad].
    n2 : complex or array_like
        Complex refractive index of the second medium.
    polarization : {"TE", "TM"}
        Polarisation.
    mode : {"off", "reflection", "transmission"}
        0, :func:`fresnel_reflection` or :func:`fresnel_transmission`.

    Returns
    -------
    numpy.ndarray
        complex128 gain [1], broadcast shape.

    Raises
    ------
    ConfigError
        For an unknown mode or polarisation.
    """
    if mode == "off":
        return np.zeros(np.broadcast(np.asarray(aoi_rad), np.asarray(n2)).shape, dtype=complex)
    if mode == "reflection":
        return fresnel_reflection(aoi_rad, n2, polarization)
    if mode == "transmission":
        return fresnel_transmission(aoi_rad, n2, polarization).astype(complex)
    raise ConfigError("surface.mode", mode, "'off', 'reflection' or 'transmission'")


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ValueError("zero-length vector")
    return v / n


@dataclass(frozen=True, eq=False)
class Surface:
    """A flat surface: the plane through ``point_m`` with normal ``normal``.

    Parameters
    ----------
    point_m : (3,) float [m], a point of the plane (the rectangle centre when finite)
    normal : (3,) float, plane normal (normalised on entry; its sign does not matter)
    eps_r : complex relative permittivity of the material (default 5.3: concrete-like)
    half_size_m : ``(a, b)`` half-widths [m] of a finite rectangle along ``u_axis`` and
        ``normal × u_axis``; ``None`` for an unbounded plane
    u_axis : (3,) float, in-plane direction of the rectangle's first side (default: any)
    """

    point_m: np.ndarray
    normal: np.ndarray
    eps_r: complex = 5.3
    half_size_m: tuple | None = None
    u_axis: np.ndarray | None = field(default=None)

    def __post_init__(self):
        object.__setattr__(self, "point_m", np.asarray(self.point_m, dtype=float).reshape(3).copy())
        n = _unit(self.normal)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "eps_r", complex(self.eps_r))
        if self.half_size_m is not None:
            hs = tuple(float(x) for x in self.half_size_m)
            if len(hs) != 2 or min(hs) <= 0:
                raise ConfigError("surface.half_size_m", self.half_size_m, "two positive half-widths [m]")
            object.__setattr__(self, "half_size_m", hs)
        if self.u_axis is None:
            ref = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            u = np.cross(ref, n)
        else:
            u = np.asarray(self.u_axis, dtype=float).reshape(3)
            u = u - (u @ n) * n
        object.__setattr__(self, "u_axis", _unit(u))

    @property
    def v_axis(self) -> np.ndarray:
        """(3,) second in-plane axis, ``normal × u_axis``."""
        return np.cross(self.normal, self.u_axis)

    @property
    def n2(self) -> complex:
        """Complex refractive index √ε_r (principal branch)."""
        return complex(np.sqrt(self.eps_r))

    def signed_distance(self, points_m) -> np.ndarray:
        """Signed distance of points from the plane along ``normal``.

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` points [m].

        Returns
        -------
        numpy.ndarray
            ``(...)`` distances [m].
        """
        return (np.asarray(points_m, dtype=float) - self.point_m) @ self.normal

    def contains(self, points_m, *, tol_m: float = 1e-9) -> np.ndarray:
        """Whether in-plane points lie inside the finite extent (always True if unbounded).

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` points in the plane [m].
        tol_m : float
            Tolerance on the half-widths [m].

        Returns
        -------
        numpy.ndarray
            ``(...)`` bool.
        """
        p = np.asarray(points_m, dtype=float)
        if self.half_size_m is None:
            return np.ones(p.shape[:-1], dtype=bool)
        rel = p - self.point_m
        a, b = self.half_size_m
        return (np.abs(rel @ self.u_axis) <= a + tol_m) & (np.abs(rel @ self.v_axis) <= b + tol_m)

    def reflection(self, aoi_rad, s_weight):
        """Co-polar reflection coefficient ``w_s·r_TE + (1 − w_s)·r_TM``.

        Exact for pure TE or pure TM incidence (vertical dipole over a floor: TM; over a vertical
        wall at horizontal incidence: TE); a co-polar approximation otherwise (depolarisation is
        neglected).

        Parameters
        ----------
        aoi_rad : array_like
            Angle of incidence from the normal [rad].
        s_weight : array_like
            Power fraction w_s of the incident field along the TE direction (⟂ plane of
            incidence) [1].

        Returns
        -------
        numpy.ndarray
            complex128 coefficient [1].
        """
        n2 = self.n2
        return s_weight * fresnel_reflection(aoi_rad, n2, "TE") + (1.0 - s_weight) * fresnel_reflection(
            aoi_rad, n2, "TM"
        )


def reflect_point(points_m, surface: Surface) -> np.ndarray:
    """Mirror image of points in the plane of ``surface``.

    Parameters
    ----------
    points_m : array_like
        ``(..., 3)`` points [m].
    surface : Surface
        The mirror plane.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` images [m].
    """
    p = np.asarray(points_m, dtype=float)
    return p - 2.0 * surface.signed_distance(p)[..., None] * surface.normal


@dataclass(frozen=True)
class ImagePath:
    """One specular path found by the image method.

    Attributes
    ----------
    virtual_source_m : (3,) float, image of the transmitter in all the surfaces [m]
    coefficient : complex, product of the reflection coefficients along the path
    length_m : float, unfolded path length |rx − virtual source| [m]
    surfaces : tuple of int, indices of the reflecting surfaces, in travel order
    points_m : (k, 3) float, the specular points [m], in travel order
    aoi_rad : (k,) float, angles of incidence at each point [rad]
    """

    virtual_source_m: np.ndarray
    coefficient: complex
    length_m: float
    surfaces: tuple
    points_m: np.ndarray
    aoi_rad: np.ndarray


def _s_weight(e, k, n) -> float:
    """Power fraction of field ``e`` (complex (3,)) along the TE direction for ray ``k``, normal ``n``."""
    s = np.cross(k, n)
    ns = np.linalg.norm(s)
    if ns < 1e-12:  # normal incidence: TE and TM coincide
        return 1.0
    s /= ns
    e_t = e - (e @ k) * k
    pe = float(np.real(np.vdot(e_t, e_t)))
    if pe < 1e-24:
        return 1.0
    return float(abs(np.vdot(s, e_t)) ** 2 / pe)


def _trace(tx, rx, surfaces, seq, polarization):
    """Back-trace one surface sequence; ImagePath or None if the path does not exist."""
    images = [tx]
    for i in seq:
        images.append(reflect_point(images[-1], surfaces[i]))
    target = rx
    points = []
    for level in range(len(seq), 0, -1):
        s = surfaces[seq[level - 1]]
        v = images[level]
        dv = s.signed_distance(v)
        dt = s.signed_distance(target)
        if not (dv * dt < 0.0):  # image and target must lie on opposite sides of the plane
            return None
        t = dv / (dv - dt)
        p = v + t * (target - v)
        if not s.contains(p):
            return None
        points.append(p)
        target = p
    points = points[::-1]
    # the real source must lie on the reflecting side of the first surface: checked above
    # through the first image (tx and its mirror are on opposite sides).
    coef = 1.0 + 0.0j
    aois = []
    prev = tx
    for idx, p in zip(seq, points):
        s = surfaces[idx]
        d = p - prev
        k = d / np.linalg.norm(d)
        cos_i = min(abs(float(k @ s.normal)), 1.0)
        aoi = float(np.arccos(cos_i))
        e = polarization(k) if callable(polarization) else polarization
        e = np.asarray(e, dtype=complex).reshape(3)
        coef *= complex(s.reflection(aoi, _s_weight(e, k, s.normal)))
        aois.append(aoi)
        prev = p
    return ImagePath(
        virtual_source_m=images[-1],
        coefficient=coef,
        length_m=float(np.linalg.norm(rx - images[-1])),
        surfaces=tuple(seq),
        points_m=np.array(points),
        aoi_rad=np.array(aois),
    )


def image_paths(tx_m, rx_m, surfaces, order: int = 1, *, polarization=None) -> list[ImagePath]:
    """Specular paths from ``tx_m`` to ``rx_m`` via up to ``order`` reflections.

    Parameters
    ----------
    tx_m, rx_m : (3,) float, end points [m]
    surfaces : sequence of :class:`Surface`
    order : maximum number of reflections (0 gives no paths)
    polarization : transmit E-field direction: ``None`` (vertical, ẑ), a (3,) vector, or a
        callable ``k -> (3,) complex`` such as :meth:`rfsim.channels.antennas.Antenna.polarization_vector`;
        it sets the TE/TM mix of each reflection (see :meth:`Surface.reflection`)

    Returns
    -------
    list of :class:`ImagePath`, by increasing order then surface index. The same surface is
    never used twice in a row; paths whose specular point falls outside a finite surface,
    or whose end points are not on the reflecting side, are dropped.
    """
    if order < 0:
        raise ConfigError("channel.image_order", order, "an integer ≥ 0")
    tx = np.asarray(tx_m, dtype=float).reshape(3)
    rx = np.asarray(rx_m, dtype=float).reshape(3)
    pol = np.array([0.0, 0.0, 1.0]) if polarization is None else polarization
    surfaces = list(surfaces)
    out = []
    for k in range(1, int(order) + 1):
        for seq in itertools.product(range(len(surfaces)), repeat=k):
            if any(a == b for a, b in zip(seq, seq[1:])):
                continue
            path = _trace(tx, rx, surfaces, seq, pol)
            if path is not None:
                out.append(path)
    return out
