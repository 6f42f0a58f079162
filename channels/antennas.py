"""Antenna radiation patterns, oriented antennas and polarization mismatch.

Every pattern has one method, ``gain(az_rad, el_rad)``, returning the **linear power gain over
isotropic** (directivity × radiation efficiency; ``10·log10`` of it is in dBi) in the antenna's
*local* frame (:mod:`rfsim.channels.geometry` conventions: az about local ``+z`` from the boresight
``+x``, el up from the local ``xy``-plane). Links use amplitude factors ``√G`` per end.

An :class:`Antenna` places a pattern at a position with an orientation ``(az, el, roll)`` and a
polarization; :meth:`Antenna.gain_towards` evaluates its gain towards global points and
:meth:`Antenna.polarization_mismatch` the power factor ``|ê_a·ê_b*|²`` between two antennas.

Sources: DESIGN.md "Channel" (isotropic, dipole, patch/panel, measured tables 2D/3D);
pass-paris-simulator.md §2.4 and §5.1 (PASS directivity tables: az 0..360°, el 0..180° from
``+z``, **linear amplitude** factors normalized to max 1, except the ``l2-dipole`` table, the
full-wave dipole field pattern with peak 2).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
import math
from functools import cached_property
from pathlib import Path

import numpy as np

from rfsim.core.errors import ConfigError, UserError
from rfsim.core.units import db_to_lin

from .geometry import Pose, _as_points, local_angles, rotation_matrix

#: Peak directivity of the thin half-wave dipole, ``D₀ = 4/Cin(2π) = 1.64092`` (2.15 dBi),
#: with ``Cin(x) = γ + ln x − Ci(x)`` (Balanis, *Antenna Theory*, §4.6).
HALF_WAVE_DIPOLE_PEAK = 1.6409223769845853


# --------------------------------------------------------------------------- patterns

@dataclass(frozen=True)
class Isotropic:
    """Isotropic pattern, ``G(az, el) = gain`` (default 1 = 0 dBi)."""

    gain_lin: float = 1.0

    def gain(self, az_rad, el_rad) -> np.ndarray:
        """Linear power gain of the pattern (class docstring).

        Parameters
        ----------
        az_rad, el_rad : array_like
            Local azimuth and elevation [rad], broadcast.

        Returns
        -------
        numpy.ndarray
            Gain [1], shape of ``broadcast(az_rad, el_rad)``.
        """
        az, el = np.broadcast_arrays(np.asarray(az_rad, float), np.asarray(el_rad, float))
        return np.full(az.shape, float(self.gain_lin))


@dataclass(frozen=True)
class HalfWaveDipole:
    """Thin half-wave dipole along the local ``+z`` axis.

    ``G(θ) = η·D₀·[cos(π/2·cosθ)/sinθ]²`` with θ = π/2 − el the angle from the dipole axis
    and ``D₀ = 2/∫₀^π cos²(π/2·cosθ)/sinθ dθ = 1.6409`` (2.15 dBi) at broadside, the
    sinusoidal-current result (Balanis, *Antenna Theory*, §4.6), so that ``∮G dΩ = 4π·η``.
    Omnidirectional in azimuth; ``efficiency`` η (default 1) scales the gain.
    """

    efficiency: float = 1.0

    def __post_init__(self):
        if not 0.0 < float(self.efficiency) <= 1.0:
            raise ConfigError("dipole.efficiency", self.efficiency, "a number in (0, 1]")

    def gain(self, az_rad, el_rad) -> np.ndarray:
        """Linear power gain of the pattern (class docstring).

        Parameters
        ----------
        az_rad, el_rad : array_like
            Local azimuth and elevation [rad], broadcast.

        Returns
        -------
        numpy.ndarray
            Gain [1], shape of ``broadcast(az_rad, el_rad)``.
        """
        az, el = np.broadcast_arrays(np.asarray(az_rad, float), np.asarray(el_rad, float))
        cos_t = np.sin(el)            # cos θ, θ from +z
        sin_t = np.cos(el)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(np.abs(sin_t) > 1e-12,
                         np.cos(0.5 * np.pi * cos_t) / np.where(sin_t == 0, 1.0, sin_t), 0.0)
        return self.efficiency * HALF_WAVE_DIPOLE_PEAK * f * f


@dataclass(frozen=True)
class Patch:
    """Analytic directional (patch/panel) pattern, boresight along local ``+x``.

    ``G(ψ) = G₀·[(1 − b)·max(cosψ, 0)^q + b]`` with ψ the angle off boresight,
    ``G₀ = 10^(gain_dbi/10)`` the peak and ``b = 10^(−front_to_back_db/10)`` the back-lobe
    floor (continuous at ψ = 90°; ``G = G₀·b`` over the whole rear half-space). The exponent
    follows from the half-power full beamwidth ``bw``: ``G(bw/2) = G₀/2`` ⇒
    ``q = ln((1/2 − b)/(1 − b)) / ln cos(bw/2)``. The radiated fraction is
    ``η = (1/4π)∮G dΩ = G₀·[(1 − b)/(2(q + 1)) + b]``; parameters with ``η > 1`` (more gain than
    the beamwidth allows) are rejected. Rotationally symmetric about the boresight (one
    beamwidth for both planes): a first-order model of a panel antenna, not a cavity model.

    Parameters
    ----------
    gain_dbi : peak gain [dBi]
    beamwidth_deg : half-power (−3 dB) full beamwidth, in (0, 180) [deg]
    front_to_back_db : front-to-back ratio [dB], > 3.01 (default 20)
    """

    gain_dbi: float
    beamwidth_deg: float
    front_to_back_db: float = 20.0

    def __post_init__(self):
        if not 0.0 < float(self.beamwidth_deg) < 180.0:
            raise ConfigError("patch.beamwidth_deg", self.beamwidth_deg, "a number in (0, 180)")
        if not float(self.front_to_back_db) > 10 * np.log10(2.0):
            raise ConfigError("patch.front_to_back_db", self.front_to_back_db, "a ratio > 3.01 dB")
        if self.radiated_fraction > 1.0 + 1e-12:
            g_max = 1.0 / ((1 - self.back_level) / (2 * (self.exponent + 1)) + self.back_level)
            raise ConfigError(
                "patch.gain_dbi", self.gain_dbi,
                f"at most {10 * np.log10(g_max):.2f} dBi for a {self.beamwidth_deg}° beamwidth "
                "(more would radiate more power than it accepts)")

    @property
    def back_level(self) -> float:
        """Back-lobe floor relative to the peak, ``b = 10^(−FB/10)``."""
        return float(1.0 / db_to_lin(self.front_to_back_db))

    @property
    def exponent(self) -> float:
        """cos-exponent ``q = ln((1/2 − b)/(1 − b)) / ln cos(bw/2)``."""
        b = self.back_level
        half_bw_rad = np.radians(self.beamwidth_deg) / 2
        return float(np.log((0.5 - b) / (1 - b)) / np.log(np.cos(half_bw_rad)))

    @property
    def peak_gain_lin(self) -> float:
        """Peak gain ``G₀`` (linear)."""
        return float(db_to_lin(self.gain_dbi))

    @property
    def radiated_fraction(self) -> float:
        """``(1/4π)∮G dΩ = G₀·[(1 − b)/(2(q + 1)) + b]`` (≤ 1: radiation efficiency)."""
        b = self.back_level
        return self.peak_gain_lin * ((1 - b) / (2 * (self.exponent + 1)) + b)

    def gain(self, az_rad, el_rad) -> np.ndarray:
        """Linear power gain of the pattern (class docstring).

        Parameters
        ----------
        az_rad, el_rad : array_like
            Local azimuth and elevation [rad], broadcast.

        Returns
        -------
        numpy.ndarray
            Gain [1], shape of ``broadcast(az_rad, el_rad)``.
        """
        az, el = np.broadcast_arrays(np.asarray(az_rad, float), np.asarray(el_rad, float))
        cos_psi = np.clip(np.cos(el) * np.cos(az), 0.0, None)
        b = self.back_level
        return self.peak_gain_lin * ((1 - b) * np.power(cos_psi, self.exponent) + b)


def _interp_periodic_az(az_grid_rad, values, az_rad):
    """Linear interpolation over azimuth with period 2π (grid ascending within one period)."""
    return np.interp(np.mod(az_rad, 2 * np.pi), az_grid_rad, values, period=2 * np.pi)


@dataclass(frozen=True, eq=False)
class Tabulated:
    """Measured or tabulated pattern on an (az, el) grid, linear interpolation.

    Two layouts:

    * **separable 2-D cuts** (``table is None``): ``P(az, el) = az_cut(az)·el_cut(el)``;
    * **full 3-D grid** (``table`` of shape ``(n_az, n_el)``): bilinear interpolation.

    Grids are in the local frame in rad: ``az_rad`` ascending within one period (periodic
    wrap), ``el_rad`` ascending in ``[−π/2, π/2]`` (clamped at the ends). ``quantity`` says what
    the numbers are: ``"power"`` (linear power gain; interpolated as is) or ``"amplitude"``
    (field factor; interpolated linearly **in amplitude** and then squared, so
    ``gain = |interp(a)|²``). ``scale`` multiplies the resulting power gain (e.g. to turn a
    pattern normalized to 1 into dBi with a known peak).

    Loaders: :meth:`from_pass_mat`, :meth:`from_npz`, :meth:`from_csv`.
    """

    az_rad: np.ndarray
    el_rad: np.ndarray
    az_cut: np.ndarray | None = None
    el_cut: np.ndarray | None = None
    table: np.ndarray | None = None
    quantity: str = "power"
    scale: float = 1.0

    def __post_init__(self):
        if self.quantity not in ("power", "amplitude"):
            raise ConfigError("antenna.quantity", self.quantity, "'power' or 'amplitude'")
        az = np.asarray(self.az_rad, float).ravel()
        el = np.asarray(self.el_rad, float).ravel()
        if np.any(np.diff(az) <= 0) or np.any(np.diff(el) <= 0):
            raise ValueError("az_rad and el_rad grids must be strictly ascending")
        object.__setattr__(self, "az_rad", az)
        object.__setattr__(self, "el_rad", el)
        if self.table is not None:
            t = np.asarray(self.table, float)
            if t.shape != (az.size, el.size):
                raise ValueError(f"table shape {t.shape} != (n_az, n_el) = {(az.size, el.size)}")
            object.__setattr__(self, "table", t)
        else:
            if self.az_cut is None or self.el_cut is None:
                raise ValueError("give either table (3-D) or both az_cut and el_cut (2-D cuts)")
            a = np.asarray(self.az_cut, float).ravel()
            e = np.asarray(self.el_cut, float).ravel()
            if a.size != az.size or e.size != el.size:
                raise ValueError("cut lengths must match their grids")
            object.__setattr__(self, "az_cut", a)
            object.__setattr__(self, "el_cut", e)

    def _interp(self, az, el):
        if self.table is None:
            return (_interp_periodic_az(self.az_rad, self.az_cut, az)
                    * np.interp(el, self.el_rad, self.el_cut))
        # bilinear on the (az, el) grid, periodic in az, clamped in el
        azg, elg, t = self.az_rad, self.el_rad, self.table
        period = 2 * np.pi
        azx = np.concatenate([azg, [azg[0] + period]])
        tx = np.concatenate([t, t[:1]], axis=0)
        a = azg[0] + np.mod(az - azg[0], period)
        i = np.clip(np.searchsorted(azx, a, side="right") - 1, 0, azx.size - 2)
        wa = (a - azx[i]) / (azx[i + 1] - azx[i])
        e = np.clip(el, elg[0], elg[-1])
        j = np.clip(np.searchsorted(elg, e, side="right") - 1, 0, max(elg.size - 2, 0))
        if elg.size == 1:
            return (1 - wa) * tx[i, 0] + wa * tx[i + 1, 0]
        we = (e - elg[j]) / (elg[j + 1] - elg[j])
        return ((1 - wa) * (1 - we) * tx[i, j] + wa * (1 - we) * tx[i + 1, j]
                + (1 - wa) * we * tx[i, j + 1] + wa * we * tx[i + 1, j + 1])

    def gain(self, az_rad, el_rad) -> np.ndarray:
        """Linear power gain of the pattern (class docstring).

        Parameters
        ----------
        az_rad, el_rad : array_like
            Local azimuth and elevation [rad], broadcast.

        Returns
        -------
        numpy.ndarray
            Gain [1], shape of ``broadcast(az_rad, el_rad)``.
        """
        az, el = np.broadcast_arrays(np.asarray(az_rad, float), np.asarray(el_rad, float))
        v = self._interp(az, el)
        if self.quantity == "amplitude":
            v = v * v
        return self.scale * v

    # ---------------------------------------------------------------- loaders
    @classmethod
    def from_pass_mat(cls, path) -> "Tabulated":
        """Load a PASS ``channelchar_directivity_*.mat`` table (pass-paris-simulator.md §5.1).

        PASS stores ``az`` 0..360° and ``el`` 0..180° **from +z**, and either separable
        ``az_gain``/``el_gain`` (``full3d = 0``) or ``gain`` (361×181, ``full3d = 1``), as linear
        **amplitude** factors. The loader converts el to elevation above the ``xy``-plane
        (``90° − el``, reordered ascending), drops the duplicated 360° azimuth column and keeps
        ``quantity="amplitude"``, so ``gain()`` returns the squared amplitude. The values are
        taken as they are: the ``l2-dipole`` file (peak 2) thus gives a power peak of 4 (+6.02
        dB), exactly what PASS applies.
        """
        from scipy.io import loadmat

        try:
            m = loadmat(str(path), squeeze_me=True, struct_as_record=False)
        except (OSError, ValueError) as exc:
            raise UserError(f"cannot read antenna pattern '{path}': {exc}") from exc
        az_deg = np.asarray(m["az"], float).ravel()
        el_z_deg = np.asarray(m["el"], float).ravel()
        keep = az_deg < 360.0
        az = np.radians(az_deg[keep])
        el = np.radians(90.0 - el_z_deg)[::-1]
        if int(np.asarray(m.get("full3d", 0))) == 1:
            table = np.asarray(m["gain"], float)[keep][:, ::-1]
            return cls(az, el, table=table, quantity="amplitude")
        az_cut = np.broadcast_to(np.asarray(m["az_gain"], float).ravel(), az_deg.shape)[keep]
        el_cut = np.broadcast_to(np.asarray(m["el_gain"], float).ravel(), el_z_deg.shape)[::-1]
        return cls(az, el, az_cut=az_cut, el_cut=el_cut, quantity="amplitude")

    @classmethod
    def from_npz(cls, path) -> "Tabulated":
        """Load ``az_rad``, ``el_rad`` and either ``table`` or ``az_cut`` + ``el_cut`` from an
        ``.npz`` file; optional ``quantity`` ("power"/"amplitude") and ``scale``."""
        try:
            with np.load(path, allow_pickle=False) as z:
                kw = {k: z[k] for k in z.files}
        except (OSError, ValueError) as exc:
            raise UserError(f"cannot read antenna pattern '{path}': {exc}") from exc
        if "quantity" in kw:
            kw["quantity"] = str(kw["quantity"])
        if "scale" in kw:
            kw["scale"] = float(kw["scale"])
        return cls(**kw)

    @classmethod
    def from_csv(cls, path, *, quantity: str = "power", degrees: bool = True) -> "Tabulated":
        """Load a 3-D grid from a CSV file with columns ``az, el, gain`` (header row required).

        ``az``/``el`` in degrees (``degrees=True``) or rad, el above the ``xy``-plane; every
        (az, el) grid point must appear once. ``gain`` is linear ``quantity``.
        """
        try:
            with open(Path(path), newline="") as fh:
                rows = list(csv.DictReader(fh))
        except OSError as exc:
            raise UserError(f"cannot read antenna pattern '{path}': {exc}") from exc
        try:
            a = np.array([float(r["az"]) for r in rows])
            e = np.array([float(r["el"]) for r in rows])
            g = np.array([float(r["gain"]) for r in rows])
        except (KeyError, ValueError) as exc:
            raise UserError(f"antenna pattern '{path}': need numeric columns az, el, gain") from exc
        if degrees:
            a, e = np.radians(a), np.radians(e)
        az_u, ia = np.unique(a, return_inverse=True)
        el_u, ie = np.unique(e, return_inverse=True)
        if az_u.size * el_u.size != g.size:
            raise UserError(f"antenna pattern '{path}': (az, el) points do not form a full grid")
        table = np.full((az_u.size, el_u.size), np.nan)
        table[ia, ie] = g
        if np.isnan(table).any():
            raise UserError(f"antenna pattern '{path}': (az, el) points do not form a full grid")
        if az_u[-1] - az_u[0] >= 2 * np.pi - 1e-9:     # duplicated 360° column
            az_u, table = az_u[:-1], table[:-1]
        return cls(az_u, el_u, table=table, quantity=quantity)


# --------------------------------------------------------------------------- polarization

def _transverse_basis(k):
    """Orthonormal ``(u, v)`` ⊥ unit ``k`` with ``(u, v, k)`` right-handed, shape (..., 3)."""
    ref = np.where(np.abs(k[..., 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    u = np.cross(ref, k)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    v = np.cross(k, u)
    return u, v


def polarization_mismatch_factor(e_a, e_b) -> np.ndarray:
    """Polarization mismatch ``|ê_a·ê_b*|²`` of complex unit polarization vectors.

    Both vectors must be expressed for the **same** propagation direction (from a to b); see
    :meth:`Antenna.polarization_vector`.

    Parameters
    ----------
    e_a, e_b : array_like
        ``(..., 3)`` complex unit vectors.

    Returns
    -------
    numpy.ndarray
        ``(...)`` power factor in [0, 1].
    """
    return np.abs(np.sum(np.asarray(e_a) * np.conj(np.asarray(e_b)), axis=-1)) ** 2


# --------------------------------------------------------------------------- antenna

_POLARIZATIONS = ("linear", "circular")
_HANDS = ("rhcp", "lhcp")


@dataclass(frozen=True, eq=False)
class Antenna:
    """An oriented antenna: position, orientation, pattern and polarization.

    Parameters
    ----------
    position_m : (3,) float [m] (stored read-only)
    orientation : ``(az, el, roll)`` [rad], :func:`rfsim.channels.geometry.rotation_matrix`
    pattern : any object with ``gain(az_rad, el_rad)`` (local frame, linear power)
    polarization : ``"linear"`` or ``"circular"``
    pol_tilt_rad : linear only: the local E-plane vector is ``cos(t)·ẑ + sin(t)·ŷ`` (local
        axes; ``t = 0`` is along the local ``+z``, i.e. a vertical dipole/patch when unrotated)
    handedness : circular only, ``"rhcp"`` or ``"lhcp"`` (IEEE: right-handed rotation about
        the propagation direction)

    Instances are immutable, hashable and compare by value (position, orientation, pattern,
    polarization); the engine can keep them in lists, sets and dict keys.
    """

    position_m: np.ndarray
    orientation: tuple = (0.0, 0.0, 0.0)
    pattern: object = field(default_factory=Isotropic)
    polarization: str = "linear"
    pol_tilt_rad: float = 0.0
    handedness: str = "rhcp"

    def __post_init__(self):
        p = _as_points(self.position_m).reshape(3).copy()
        p.setflags(write=False)
        object.__setattr__(self, "position_m", p)
        o = tuple(float(x) for x in self.orientation)
        if len(o) != 3:
            raise ConfigError("antenna.orientation", self.orientation, "(az, el, roll) in rad")
        object.__setattr__(self, "orientation", o)
        if self.polarization not in _POLARIZATIONS:
            raise ConfigError("antenna.polarization", self.polarization, "'linear' or 'circular'")
        if self.handedness not in _HANDS:
            raise ConfigError("antenna.handedness", self.handedness, "'rhcp' or 'lhcp'")
        if not callable(getattr(self.pattern, "gain", None)):
            raise ConfigError("antenna.pattern", self.pattern, "a pattern with gain(az, el)")
        object.__setattr__(self, "pol_tilt_rad", float(self.pol_tilt_rad))

    def _key(self):
        # the instance is immutable: its key (and its hash) are formed once; the hash is not
        # pickled with it (str hashes differ from one process to the next)
        d = self.__dict__
        k = d.get("_key_memo")
        if k is None:
            k = d["_key_memo"] = (tuple(self.position_m), self.orientation, self.pattern, self.polarization,
                                  self.pol_tilt_rad if self.polarization == "linear" else self.handedness)
        return k

    def __eq__(self, other):
        return self is other or (isinstance(other, Antenna) and self._key() == other._key())

    def __hash__(self):
        h = self.__dict__.get("_hash_memo")
        if h is None:
            h = self.__dict__["_hash_memo"] = hash(self._key())
        return h

    def __getstate__(self):
        return {k: v for k, v in self.__dict__.items() if k != "_hash_memo"}

    @cached_property
    def rotation(self) -> np.ndarray:
        """(3, 3) local → global rotation matrix."""
        return rotation_matrix(*self.orientation)

    @property
    def pose(self) -> Pose:
        """Position and orientation as a :class:`rfsim.channels.geometry.Pose`."""
        return Pose(self.position_m, *self.orientation)

    def gain_towards(self, points_m) -> np.ndarray:
        """Linear power gain towards global points.

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` points [m].

        Returns
        -------
        numpy.ndarray
            ``(...) float64`` gain [1].
        """
        d = _as_points(points_m) - self.position_m
        return self.gain_in_direction(d)

    def gain_in_direction(self, directions) -> np.ndarray:
        """Linear power gain in global directions.

        Parameters
        ----------
        directions : array_like
            ``(..., 3)`` direction vectors (any length).

        Returns
        -------
        numpy.ndarray
            ``(...) float64`` gain [1].
        """
        az, el = local_angles(directions, self.rotation)
        return np.asarray(self.pattern.gain(az, el), dtype=float)

    @property
    def polarization_axis(self) -> np.ndarray:
        """(3,) global unit vector of the linear polarization (local ``cos t·ẑ + sin t·ŷ``)."""
        t = self.pol_tilt_rad
        return self.rotation @ np.array([0.0, np.sin(t), np.cos(t)])

    def polarization_vector(self, k) -> np.ndarray:
        """Complex unit polarization vector for propagation along global ``k``.

        Linear: the polarization axis projected on the plane ⊥ ``k`` and normalized (zero
        where the axis is parallel to ``k`` — no transverse field). Circular:
        ``(u ∓ j·v)/√2`` for RHCP/LHCP with ``(u, v, k)`` right-handed; the same vector serves
        the transmitting and the receiving end when both use the same ``k`` (a → b), so equal
        hands match and opposite hands are orthogonal.

        Parameters
        ----------
        k : array_like
            ``(..., 3)`` propagation directions (any length).

        Returns
        -------
        numpy.ndarray
            ``(..., 3) complex``.
        """
        k = _as_points(k)
        k = k / np.linalg.norm(k, axis=-1, keepdims=True)
        if self.polarization == "linear":
            p = np.broadcast_to(self.polarization_axis, k.shape)
            e = p - np.sum(p * k, axis=-1, keepdims=True) * k
            n = np.linalg.norm(e, axis=-1, keepdims=True)
            return np.where(n > 1e-12, e / np.where(n > 1e-12, n, 1.0), 0.0).astype(complex)
        u, v = _transverse_basis(k)
        h = -1.0 if self.handedness == "rhcp" else 1.0
        return (u + 1j * h * v) / np.sqrt(2.0)

    def polarization_mismatch(self, other: "Antenna", *, direction=None) -> np.ndarray:
        """Polarization mismatch factor ``|ê_self·ê_other*|²``.

        Linear–linear gives ``cos²Δ`` of the angle between the projected axes, linear–circular
        1/2, circular same hand 1, opposite hand 0 (ideal axial ratio).

        Parameters
        ----------
        other : Antenna
            The other end.
        direction : array_like or None
            ``(..., 3)`` propagation direction from ``self`` to ``other`` (default: the straight
            line between their positions; give image directions for reflected paths).

        Returns
        -------
        numpy.ndarray
            Power factor in [0, 1].
        """
        k = (other.position_m - self.position_m) if direction is None else direction
        return polarization_mismatch_factor(self.polarization_vector(k),
                                            other.polarization_vector(k))


#: Front-to-back ratio [dB] of a 9 dBic UHF RFID reader patch panel (data-sheet class), the
#: back-lobe floor of the readers' panels in the AURIS scenes (detection-probability, st-localization).
PANEL_FRONT_TO_BACK_DB = 20.0


@dataclass(frozen=True, eq=False)
class EllipticalPanel(Antenna):
    """A circularly polarised panel whose axial ratio grows off boresight.

    ``AR(ψ) [dB] = AR0 + (AR1 − AR0)·(ψ/(BW/2))²`` for the angle ψ between the boresight axis
    and the propagation line (data-sheet class of patch panels: ≈ 1 dB on boresight, ≈ 3 dB at
    the beam edge). The polarisation vector for propagation along k is the ellipse
    ``(û − j·h·r·v̂)/sqrt(1 + r²)``, r = 1/AR (field ratio, linear), major axis û along the
    panel's vertical projected ⊥ k, ``v̂ = k × û``, h = +1 for RHCP (the hand convention of
    :meth:`Antenna.polarization_vector`: r = 1 gives its circular vector). Against a linear
    antenna whose axis makes the angle τ with û the mismatch is
    ``(cos²τ + r²·sin²τ)/(1 + r²)``: 1/2 for AR = 0 dB (the constant 3 dB), between
    ``1/(1 + r²)`` and ``r²/(1 + r²)`` otherwise (auris-sense-a-tag.md §3.3: the reader's
    circular panel; the axial-ratio law is the data-sheet class, not the source's).

    Parameters
    ----------
    axial_ratio_db : (AR0, AR1) [dB], on boresight and at ``half_beamwidth_rad`` off it
    half_beamwidth_rad : half the half-power beamwidth [rad]
    (other parameters: :class:`Antenna`; ``polarization`` is ``"circular"``)
    """

    axial_ratio_db: tuple = (1.0, 3.0)
    half_beamwidth_rad: float = math.radians(35.0)

    def _key(self):
        # two panels that differ only in their axial-ratio law are different antennas
        return (Antenna._key(self), tuple(self.axial_ratio_db), self.half_beamwidth_rad)

    @cached_property
    def _boresight_and_up(self) -> tuple[np.ndarray, np.ndarray]:
        """The panel's boresight axis and its vertical in the global frame (rotation of local x, z)."""
        return self.rotation @ np.array([1.0, 0.0, 0.0]), self.rotation @ np.array([0.0, 0.0, 1.0])

    def polarization_vector(self, k) -> np.ndarray:
        """Complex unit polarization vector of the ellipse for propagation along ``k`` (class docstring).

        Parameters
        ----------
        k : array_like
            ``(..., 3)`` propagation directions (any length).

        Returns
        -------
        numpy.ndarray
            ``(..., 3) complex``.
        """
        k = np.asarray(k, float)
        k = k / np.linalg.norm(k, axis=-1, keepdims=True)
        axis, up = self._boresight_and_up
        psi = np.arccos(np.clip(np.abs(k @ axis), 0.0, 1.0))
        ar0, ar1 = self.axial_ratio_db
        ar_db = ar0 + (ar1 - ar0) * (psi / self.half_beamwidth_rad) ** 2
        r = 10.0 ** (-ar_db / 20.0)[..., None]
        u = up - np.sum(up * k, axis=-1, keepdims=True) * k
        n = np.linalg.norm(u, axis=-1, keepdims=True)
        u = np.where(n > 1e-9, u / np.where(n > 1e-9, n, 1.0), np.array([0.0, 1.0, 0.0]))
        # v = k × u, written out (np.cross's own elementwise products and differences, without
        # its axis handling, which costs more than the products for one direction)
        v = np.stack([k[..., 1] * u[..., 2] - k[..., 2] * u[..., 1], k[..., 2] * u[..., 0] - k[..., 0] * u[..., 2],
                      k[..., 0] * u[..., 1] - k[..., 1] * u[..., 0]], axis=-1)
        h = 1.0 if self.handedness == "rhcp" else -1.0
        return (u - 1j * h * r * v) / np.sqrt(1.0 + r * r)


def vertical_dipole(position_m) -> Antenna:
    """A vertical half-wave dipole with linear polarization (auris-sense-a-tag.md L2878-2880).

    The sense-a-tag's antennas: omnidirectional in azimuth.

    Parameters
    ----------
    position_m : array_like
        ``(3,)`` position [m].

    Returns
    -------
    Antenna
        The antenna.
    """
    return Antenna(position_m=position_m, orientation=(0.0, 0.0, 0.0), pattern=HalfWaveDipole(),
                   polarization="linear")


__all__ = [
    "HALF_WAVE_DIPOLE_PEAK",
    "Isotropic",
    "HalfWaveDipole",
    "Patch",
    "Tabulated",
    "Antenna",
    "EllipticalPanel",
    "PANEL_FRONT_TO_BACK_DB",
    "polarization_mismatch_factor",
    "vertical_dipole",
]
