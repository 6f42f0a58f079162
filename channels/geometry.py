"""Scene geometry: orientations, directions and antenna-local angles.

Conventions (used by every module of :mod:`channels`)
-----------------------------------------------------
* Global frame: right-handed Cartesian ``(x, y, z)`` in metres; ``z`` is "up".
* **Azimuth** ``az`` is measured about ``+z`` from ``+x`` towards ``+y`` (rad, ``(-π, π]`` on
  output). **Elevation** ``el`` is measured up from the ``xy``-plane (rad, ``[-π/2, π/2]``),
  so the unit vector of ``(az, el)`` is ``(cos el·cos az, cos el·sin az, sin el)``.
* An orientation ``(az, el, roll)`` turns the local frame of a device into the global one:
  ``R = Rz(az) · Ry(−el) · Rx(roll)`` (local → global). The local ``+x`` axis is the
  **boresight**: it points along ``(az, el)``; ``roll`` turns the device about its boresight
  (positive: right-handed about the boresight). With orientation ``(0, 0, 0)`` local and global
  axes coincide; a dipole's axis is its local ``+z`` (vertical when unrotated).
* A direction seen by an oriented device is expressed in its local frame by ``Rᵀ·d`` and then
  converted to local ``(az, el)`` with the same convention.

PASS/PARIS (pass-paris-simulator.md §2.4) uses degrees, an "elevation" measured from ``+z``
(90° = ``xy``-plane) and rotates patterns by subtracting ``[az, el]`` angles instead of a proper
3-D rotation; :func:`pass_rotate_angles_deg` reproduces that legacy rule for golden tests only.

All functions are vectorised: point arrays have shape ``(..., 3)`` and broadcast against each
other.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np


def _as_points(x) -> np.ndarray:
    """Float64 array with last axis 3 (a 2-D ``(..., 2)`` array gets ``z = 0``)."""
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] == (2,):
        a = np.concatenate([a, np.zeros(a.shape[:-1] + (1,))], axis=-1)
    if a.shape[-1:] != (3,):
        raise ValueError(f"points must have a last axis of length 3 (or 2), got shape {a.shape}")
    return a


def rotation_matrix(az_rad, el_rad, roll_rad=0.0) -> np.ndarray:
    """Rotation matrix local → global for orientation ``(az, el, roll)``.

    ``R = Rz(az)·Ry(−el)·Rx(roll)``: the local ``+x`` (boresight) maps to the unit vector of
    ``(az, el)``, and ``roll`` turns the device about its boresight.

    Parameters
    ----------
    az_rad, el_rad, roll_rad : array_like, broadcastable [rad]

    Returns
    -------
    R : (..., 3, 3) float64, with ``v_global = R @ v_local``.
    """
    az, el, roll = np.broadcast_arrays(
        np.asarray(az_rad, dtype=float), np.asarray(el_rad, dtype=float),
        np.asarray(roll_rad, dtype=float))
    ca, sa = np.cos(az), np.sin(az)
    ce, se = np.cos(el), np.sin(el)
    cr, sr = np.cos(roll), np.sin(roll)
    R = np.empty(az.shape + (3, 3))
    # Columns are the images of the local x, y, z axes.
    R[..., 0, 0] = ce * ca
    R[..., 1, 0] = ce * sa
    R[..., 2, 0] = se
    # local y: Rz·Ry(−el)·(0, cr, sr)
    R[..., 0, 1] = -sa * cr - ca * se * sr
    R[..., 1, 1] = ca * cr - sa * se * sr
    R[..., 2, 1] = ce * sr
    # local z: Rz·Ry(−el)·(0, −sr, cr)
    R[..., 0, 2] = sa * sr - ca * se * cr
    R[..., 1, 2] = -ca * sr - sa * se * cr
    R[..., 2, 2] = ce * cr
    return R


def unit_vector(az_rad, el_rad) -> np.ndarray:
    """Unit vector ``(cos el·cos az, cos el·sin az, sin el)`` (module conventions).

    Parameters
    ----------
    az_rad : array_like
        Azimuth [rad].
    el_rad : array_like
        Elevation [rad] (broadcast with ``az_rad``).

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` unit vectors [1].
    """
    az = np.asarray(az_rad, dtype=float)
    el = np.asarray(el_rad, dtype=float)
    ce = np.cos(el)
    return np.stack(np.broadcast_arrays(ce * np.cos(az), ce * np.sin(az), np.sin(el)), axis=-1)


def cartesian_to_spherical(v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Length, azimuth and elevation of vectors.

    Parameters
    ----------
    v : array_like
        ``(..., 3)`` vectors [m] (``(..., 2)`` means ``z = 0``).

    Returns
    -------
    r : numpy.ndarray
        Length [m].
    az : numpy.ndarray
        Azimuth in (−π, π] [rad] (0 for a zero vector).
    el : numpy.ndarray
        Elevation in [−π/2, π/2] [rad] (0 for a zero vector).
    """
    v = _as_points(v)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    rho = np.hypot(x, y)
    return np.hypot(rho, z), np.arctan2(y, x), np.arctan2(z, rho)


def direction_to(src_m, dst_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance and global direction from ``src_m`` to ``dst_m``.

    Parameters
    ----------
    src_m, dst_m : (..., 3) float [m], broadcastable (``(..., 2)`` means ``z = 0``)

    Returns
    -------
    distance_m : (...) float64 [m]
    az_rad : (...) float64, azimuth of ``dst − src`` about ``+z`` from ``+x`` [rad]
    el_rad : (...) float64, elevation of ``dst − src`` above the ``xy``-plane [rad]
    """
    return cartesian_to_spherical(_as_points(dst_m) - _as_points(src_m))


def local_angles(directions, rotation) -> tuple[np.ndarray, np.ndarray]:
    """Local ``(az, el)`` of global ``directions`` seen by a device with ``rotation``.

    v_local = Rᵀ·v, then the module's angle convention.

    Parameters
    ----------
    directions : array_like
        ``(..., 3)`` global direction vectors (need not be unit length).
    rotation : array_like
        ``(3, 3)`` or ``(..., 3, 3)`` local → global (:func:`rotation_matrix`).

    Returns
    -------
    az, el : numpy.ndarray
        Local azimuth and elevation [rad].
    """
    d = _as_points(directions)
    R = np.asarray(rotation, dtype=float)
    # v_local = Rᵀ v  ⇔  v_local_i = Σ_j R_ji v_j
    local = np.einsum("...ji,...j->...i", R, d)
    _, az, el = cartesian_to_spherical(local)
    return az, el


@dataclass(frozen=True, eq=False)
class Pose:
    """Position and orientation of a device.

    Parameters
    ----------
    position_m : (3,) float [m]
    az_rad, el_rad, roll_rad : float [rad], see the module conventions.
    """

    position_m: np.ndarray
    az_rad: float = 0.0
    el_rad: float = 0.0
    roll_rad: float = 0.0

    def __post_init__(self):
        p = _as_points(self.position_m).reshape(3).copy()
        p.setflags(write=False)
        object.__setattr__(self, "position_m", p)
        for name in ("az_rad", "el_rad", "roll_rad"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @cached_property
    def rotation(self) -> np.ndarray:
        """(3, 3) local → global rotation matrix."""
        return rotation_matrix(self.az_rad, self.el_rad, self.roll_rad)

    @property
    def boresight(self) -> np.ndarray:
        """(3,) global unit vector of the local ``+x`` axis."""
        return self.rotation[:, 0].copy()

    def local_angles_to(self, points_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance and local angles of points seen from this pose.

        Parameters
        ----------
        points_m : array_like
            ``(..., 3)`` points [m].

        Returns
        -------
        distance_m : numpy.ndarray
            [m].
        az_local_rad, el_local_rad : numpy.ndarray
            Local azimuth and elevation [rad].
        """
        d = _as_points(points_m) - self.position_m
        az, el = local_angles(d, self.rotation)
        return np.linalg.norm(d, axis=-1), az, el

    def _key(self):
        return (tuple(self.position_m), self.az_rad, self.el_rad, self.roll_rad)

    def __eq__(self, other):
        return isinstance(other, Pose) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())


# --------------------------------------------------------------------------- PASS legacy

def pass_spherical_deg(v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PASS ``get_distances`` angles (legacy, pass-paris-simulator.md §2.4 ``channel_newpos``).

    MATLAB ``cart2sph`` azimuth wrapped to ``[0, 360)`` and elevation ``90° − el``.

    Parameters
    ----------
    v : array_like
        ``(..., 3)`` vectors [m].

    Returns
    -------
    az_deg : numpy.ndarray
        Azimuth in [0, 360) [deg].
    el_deg : numpy.ndarray
        Elevation from +z in [0, 180] [deg].
    r_m : numpy.ndarray
        Length [m].
    """
    r, az, el = cartesian_to_spherical(v)
    return np.mod(np.degrees(az), 360.0), 90.0 - np.degrees(el), r


def pass_rotate_angles_deg(dir_deg, rot_deg, *, receiver: bool = False) -> np.ndarray:
    """PASS ``channel_directivity`` angle rotation (legacy, pass-paris-simulator.md §2.4).

    PASS subtracts the antenna rotation ``[az, el]`` from the direction ``[az, el]`` (degrees,
    el from ``+z``), adds ``[0, 180°]`` for the receiving end ("other side"), and wraps to the
    sphere: ``el ← el mod 360``; if ``el > 180`` then ``el ← 360 − el`` and ``az ← az + 180``;
    finally ``az ← az mod 360``. This is *not* a 3-D rotation (no roll, and elevation offsets
    are not rotations); it exists only to reproduce PASS golden data.

    Parameters
    ----------
    dir_deg : (..., 2) float, ``[az, el_from_z]`` [deg]
    rot_deg : (2,) or (..., 2) float, antenna rotation ``[az, el]`` [deg]
    receiver : add the ``+180°`` elevation of the receiving end

    Returns
    -------
    (..., 2) float64 ``[az in [0, 360), el_from_z in [0, 180]]`` [deg]
    """
    a = np.asarray(dir_deg, dtype=float) - np.asarray(rot_deg, dtype=float)
    az = a[..., 0]
    el = np.mod(a[..., 1] + (180.0 if receiver else 0.0), 360.0)
    flip = el > 180.0
    el = np.where(flip, 360.0 - el, el)
    az = np.mod(az + np.where(flip, 180.0, 0.0), 360.0)
    return np.stack([az, el], axis=-1)


__all__ = [
    "rotation_matrix",
    "unit_vector",
    "cartesian_to_spherical",
    "direction_to",
    "local_angles",
    "Pose",
    "pass_spherical_deg",
    "pass_rotate_angles_deg",
]
