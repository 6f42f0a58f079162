"""Link assembly: a scene of surfaces, walls and propagation models → :class:`PathSet` per link.

A link tx → rx is the sum of (DESIGN.md "Channel"; auris-sense-a-tag.md §1.7 Appendix A;
pass-paris-simulator.md §2.4)

* **LoS**: amplitude ``A = g_ls(d, fc)·√(G_tx·G_rx)·√(PLF)·10^(−L_walls/20)·10^(−S/20)``
  with ``g_ls`` the large-scale amplitude gain (Friis λ/(4πd) by default, or a
  :class:`~rfsim.channels.large_scale.LogDistance`), G the antennas' power gains towards each
  other, PLF the polarization mismatch, L_walls the WAF wall loss on the straight line and S
  the shadowing field at the link midpoint (symmetric, so links stay reciprocal); delay d/c.
* **Image paths** up to ``image_order`` reflections (:func:`rfsim.channels.surfaces.image_paths`):
  amplitude ``g_ls(ℓ, fc)·Πr·√(G_tx(first leg)·G_rx(last leg))·√(PLF along the image
  direction)``; delay ℓ/c. Walls and shadowing are not applied to reflected paths.
* **Diffuse NLoS taps** (when an :class:`~rfsim.channels.small_scale.ApdpModel` is set): the APDP
  splits the LoS large-scale power into LoS K/(K+1) and NLoS 1/(K+1) (PASS: the unit-power
  profile is scaled by the LoS large-scale gain), so the LoS amplitude becomes A·√(K/(K+1))
  and tap i gets ``g_ls·walls·shadowing·h_i`` with ``h_i ~ CN(0, P_i)``, delay d/c + τ_i. The
  antenna patterns and polarization are not applied to the diffuse taps (PASS "room" type:
  diffuse power arrives from all directions; a lossless antenna's mean gain is 1).

Quasi-static draws: :class:`Channel` holds one draw of the diffuse taps per link (the pair of
antennas; with ``reciprocal=True`` the pair is unordered, so backward = forward). A call with
``rng`` draws anew and holds the new draw; a call without ``rng`` reuses the held draw.

Motion: each end may move with a constant velocity (``(3,)`` [m/s], position
``p0 + v·t``) or along a trajectory (callable ``t → (3,)`` position [m]; velocity by a central
difference). Every path gets the Doppler shift ``f_D = −(fc/c)·dℓ/dt`` of its length ℓ (image
sources move with the mirrored velocity; diffuse taps share the LoS Doppler), so that
:func:`rfsim.channels.paths.apply_paths` continues the carrier phase −2π·fc·ℓ(t)/c to first order
inside an exchange (gen2-and-validation-anchors.md §4.7: f_D = 2v/λ for a monostatic tag).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.units import C_M_S

from .antennas import Antenna
from .large_scale import friis_amplitude_gain, wall_loss_db
from .paths import DelayTerms, PathSet, _carrier_phasors
from .small_scale import ApdpModel, draw_nlos_taps, tap_terms
from .surfaces import image_paths

__all__ = ["Scene", "Channel", "HeldLinks", "los_links", "kinematics"]

#: Half-step [s] of the central difference giving a trajectory's velocity.
_TRAJ_DT_S = 1e-6


@dataclass(frozen=True, eq=False)
class Scene:
    """Static description of the propagation environment.

    Parameters
    ----------
    surfaces : sequence of rfsim.channels.surfaces.Surface
        Specular reflectors; default none.
    walls : sequence of rfsim.channels.large_scale.Wall
        Walls whose WAF loss applies on the LoS; default none.
    large_scale : object or None
        A model with ``amplitude_gain(distance_m, fc_hz)`` (e.g.
        :class:`~rfsim.channels.large_scale.LogDistance`), one for every link; or a
        :class:`~rfsim.channels.large_scale.LinkLargeScale` (a model per antenna pair or per
        antenna, e.g. per reader); default None, Friis free space.
    apdp : rfsim.channels.small_scale.ApdpModel or None
        Diffuse taps; default None, none.
    shadowing : rfsim.channels.large_scale.ShadowingField or None
        Shadowing field; default None.
    image_order : int
        Maximum reflection order of the image paths (0: none), default 1.
    reciprocal : bool
        The link a → b equals b → a (one held diffuse draw per unordered pair), default True.

    Raises
    ------
    ConfigError
        ``channel.image_order`` unless a non-negative integer; ``channel.large_scale`` for a
        model without ``amplitude_gain``.
    """

    surfaces: tuple = ()
    walls: tuple = ()
    large_scale: object | None = None
    apdp: ApdpModel | None = None
    shadowing: object | None = None
    image_order: int = 1
    reciprocal: bool = True

    def __post_init__(self):
        object.__setattr__(self, "surfaces", tuple(self.surfaces))
        object.__setattr__(self, "walls", tuple(self.walls))
        if int(self.image_order) != self.image_order or self.image_order < 0:
            raise ConfigError("channel.image_order", self.image_order, "an integer ≥ 0")
        if self.large_scale is not None and not callable(getattr(self.large_scale, "amplitude_gain", None)):
            raise ConfigError("channel.large_scale", self.large_scale, "a model with amplitude_gain(d, fc)")

    def amplitude_gain(self, distance_m, fc_hz):
        """Large-scale amplitude gain at ``distance_m`` (Friis when ``large_scale`` is None).

        Friis: :math:`\\lambda / (4 \\pi d)` (:func:`rfsim.channels.large_scale.friis_amplitude_gain`).

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
        if self.large_scale is None:
            return friis_amplitude_gain(distance_m, fc_hz)
        return self.large_scale.amplitude_gain(distance_m, fc_hz)

    def link_amplitude_gain(self, tx, rx, distance_m, fc_hz):
        """Large-scale amplitude gain of the link ``tx → rx`` at ``distance_m``.

        The link's own model when ``large_scale`` is per link (``link_amplitude_gain``), else
        :meth:`amplitude_gain`.

        Parameters
        ----------
        tx, rx : Antenna
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
        per_link = getattr(self.large_scale, "link_amplitude_gain", None)
        if per_link is None:
            return self.amplitude_gain(distance_m, fc_hz)
        return per_link(tx, rx, distance_m, fc_hz)


def kinematics(antenna: Antenna, motion, t_s: float):
    """Position and velocity of an antenna at time ``t_s``.

    A trajectory's velocity is its central difference over ±``_TRAJ_DT_S``.

    Parameters
    ----------
    antenna : Antenna
        The antenna (``position_m`` is its position at t = 0 for a velocity motion).
    motion : None, array_like or callable
        None (static at ``antenna.position_m``), a (3,) velocity [m/s] (position
        ``antenna.position_m + v·t_s``) or a trajectory ``t → (3,)`` position [m].
    t_s : float
        Time [s].

    Returns
    -------
    position_m : numpy.ndarray
        ``(3,)`` [m].
    velocity_mps : numpy.ndarray
        ``(3,)`` [m/s].
    """
    p0 = antenna.position_m
    if motion is None:
        return p0.copy(), np.zeros(3)
    if callable(motion):
        p = np.asarray(motion(t_s), dtype=float).reshape(3)
        h = _TRAJ_DT_S
        v = (np.asarray(motion(t_s + h), float).reshape(3) - np.asarray(motion(t_s - h), float).reshape(3)) / (2 * h)
        return p, v
    v = np.asarray(motion, dtype=float).reshape(3)
    return p0 + v * float(t_s), v


def _doppler_hz(fc_hz, unit_dir, v_src, v_dst):
    """f_D = −(fc/c)·dℓ/dt for a straight path along ``unit_dir`` (src → dst)."""
    return -float(fc_hz) / C_M_S * float(unit_dir @ (v_dst - v_src))


#: Most static links whose deterministic part a :class:`Channel` keeps (more than the
#: tags of a large inventory: a round draws every tag's link again, and a smaller cache
#: would recompute every geometry each round; a few kB per link).
GEOMETRY_CACHE_SIZE = 4096


def _remember(table: dict, key, entry) -> None:
    """``table[key] = entry``, the oldest entry dropped first beyond :data:`GEOMETRY_CACHE_SIZE`."""
    if len(table) >= GEOMETRY_CACHE_SIZE:
        table.pop(next(iter(table)))
    table[key] = entry


class _ImageGeometry(NamedTuple):
    """Image paths tx → rx and their carrier-independent factors (:meth:`Channel._image_geometry`)."""

    found: list            # the image paths (rfsim.channels.surfaces.image_paths), possibly empty
    length_m: object       # (P,) path lengths [m], or None when there are none
    coefficient: object    # (P,) reflection coefficients, or None
    antenna_gain: object   # (P,) G_tx·G_rx along the paths, or None
    plf: object            # (P,) polarization mismatch factors, or None


class _Placement(NamedTuple):
    """Carrier-independent geometry of a link (:meth:`Channel._placement`; the same fields in
    the same order as the tuples of :func:`rfsim.channels.bulk.static_placements`)."""

    d: float                # distance [m]
    u: np.ndarray           # (3,) unit vector tx → rx
    env: float              # wall amplitude factor
    ant: float              # √(G_tx·G_rx)
    plf: float              # √PLF
    p_tx: np.ndarray        # (3,) tx position [m]
    p_rx: np.ndarray        # (3,) rx position [m]
    v_tx: np.ndarray        # (3,) tx velocity [m/s]
    v_rx: np.ndarray        # (3,) rx velocity [m/s]
    images: object          # _ImageGeometry or None
    apdp_args: object       # (K, τ_rms [s]) of the APDP at d, or None


class _Geometry(NamedTuple):
    """Deterministic part of a link at one carrier (:meth:`Channel._geometry`)."""

    d: float                # distance [m]
    g_ls: float             # large-scale amplitude gain
    env: float              # wall amplitude factor
    ant: float              # √(G_tx·G_rx)
    plf: float              # √PLF
    tau_los_s: float        # LoS delay [s]
    f_los_hz: float         # LoS Doppler shift [Hz]
    p_tx: np.ndarray        # (3,) tx position [m]
    p_rx: np.ndarray        # (3,) rx position [m]
    images: object          # image PathSet or None
    apdp_args: object       # (K, τ_rms [s]) of the APDP at d, or None


class _DiffuseDraw(NamedTuple):
    """A held draw of a link's diffuse part (:func:`rfsim.channels.small_scale.draw_taps`)."""

    los_amplitude: float    # |h_0|, the LoS tap's amplitude
    taps: np.ndarray        # (K,) complex diffuse taps
    delays_s: np.ndarray    # (K,) their delays relative to the LoS [s]


class _Frame(NamedTuple):
    """The delays and Doppler shifts of a static link at one carrier, shared by the links of its
    successive diffuse draws (:meth:`Channel.link`): the held draw's relative tap delays they were
    formed with (read-only, the same array every draw of the profile) and their
    :class:`rfsim.channels.paths.DelayTerms`."""

    relative_s: object      # (K,) tap delays relative to the LoS [s], or None
    terms: DelayTerms       # the link's delays, Doppler shifts and what depends on them alone


class _HeldPair(NamedTuple):
    """A link of :class:`HeldLinks`, kept with the antennas whose identities key it."""

    tx: object
    rx: object
    paths: object


class Channel:
    """A :class:`Scene` plus the held (quasi-static) diffuse draws of its links.

    For links between static antennas (no motion) the channel also keeps the deterministic
    part of the link — large-scale gain, wall loss, antenna gains, polarization mismatch,
    delay and the image paths, a pure function of the two antennas (compared by value), the
    carrier and the immutable scene — keyed by ``(tx, rx, fc_hz)``, and its carrier-
    independent part keyed by ``(tx, rx)``, and the terms of each diffuse profile it draws
    (:func:`rfsim.channels.small_scale.tap_terms`, keyed by K, τrms and the profile options),
    each bounded by :data:`GEOMETRY_CACHE_SIZE` (oldest entry dropped first). Only the diffuse
    taps (and the shadowing field, which can be redrawn) are evaluated anew on every call; the result is bit-identical to assembling
    the whole link again.
    """

    def __init__(self, scene: Scene):
        self.scene = scene
        self._held: dict = {}
        self._static: dict = {}
        self._placements: dict = {}
        self._frames: dict = {}
        self._tap_terms: dict = {}

    def _key(self, tx: Antenna, rx: Antenna):
        return frozenset((tx, rx)) if self.scene.reciprocal else (tx, rx)

    @property
    def has_random_part(self) -> bool:
        """Whether a link can differ from one draw to the next: diffuse taps (``apdp``) or a
        shadowing field (which can be redrawn). Without them a static link is a pure function
        of the two antennas, the carrier and the immutable scene, and a call with ``rng``
        draws nothing from it."""
        return self.scene.apdp is not None or self.scene.shadowing is not None

    def forget(self) -> None:
        """Drop every held diffuse draw (the next links need an ``rng``)."""
        self._held.clear()

    def link(self, tx: Antenna, rx: Antenna, *, fc_hz: float, rng: np.random.Generator | None = None,
             t_s: float = 0.0, tx_motion=None, rx_motion=None) -> PathSet:
        """Paths of the link ``tx → rx`` at time ``t_s`` [s].

        Parameters
        ----------
        tx, rx : Antenna
            The link's ends (their ``position_m`` is the position at t = 0 for a velocity
            motion).
        fc_hz : float
            Keyword-only: carrier frequency [Hz].
        rng : numpy.random.Generator or None, optional
            Keyword-only: draw the diffuse taps anew (and hold them); default None reuses the
            held draw.
        t_s : float, optional
            Keyword-only: evaluation time [s], default 0.0; Doppler phases of the result refer
            to this time.
        tx_motion, rx_motion : None, array_like or callable, optional
            Keyword-only: None (static, default), a (3,) velocity [m/s] or a trajectory
            ``t → position``.

        Returns
        -------
        PathSet
            LoS first, then image paths, then diffuse taps.

        Raises
        ------
        ValueError
            When the scene has diffuse taps, no ``rng`` is given and no draw is held for the
            link.
        """
        sc = self.scene
        static = tx_motion is None and rx_motion is None
        key = self._key(tx, rx)  # the antennas as given (before motion) name the link
        geo = self._static.get((tx, rx, fc_hz)) if static else None
        if geo is None:
            geo = self._geometry(tx, rx, fc_hz, t_s, tx_motion, rx_motion)
            if static:
                _remember(self._static, (tx, rx, fc_hz), geo)
        g_ls, env, images = geo.g_ls, geo.env, geo.images
        if sc.shadowing is not None:
            env *= float(sc.shadowing.amplitude_gain(0.5 * (geo.p_tx + geo.p_rx)))
        a_los = g_ls * env * geo.ant * geo.plf

        # One PathSet of LoS, image paths, diffuse taps (as concatenate() of the parts would
        # give, the parts written into its arrays: finite by construction, not checked again).
        h = rel = None
        if sc.apdp is not None:
            held = self._held.get(key) if rng is None else None
            if held is None:
                if rng is None:
                    raise ValueError("no diffuse draw held for this link: pass rng to draw one")
                k_lin, tau_rms_s = geo.apdp_args
                items = sc.apdp.profile_items
                terms = self._tap_terms.get((k_lin, tau_rms_s, items))
                if terms is None:
                    terms = tap_terms(k_lin, tau_rms_s, items)
                    _remember(self._tap_terms, (k_lin, tau_rms_s, items), terms)
                # the numbers of draw_taps(k_lin, tau_rms_s, rng=rng, n_draws=1, **profile_options)
                held = _DiffuseDraw(terms.los_amplitude, draw_nlos_taps(terms, rng), terms.nlos_delays_s)
                self._held[key] = held
            h, rel = held.taps, held.delays_s
            a_los = a_los * held.los_amplitude
        n_img = 0 if images is None else images.gain.size
        n = 1 + n_img + (0 if h is None else h.size)
        gains = np.empty(n, np.complex128)
        gains[0] = a_los
        if n_img:
            gains[1:1 + n_img] = images.gain
        if h is not None:
            gains[1 + n_img:] = g_ls * env * h
        frame = self._frames.get((tx, rx, fc_hz)) if static else None
        if frame is None or frame.terms.delay_s.size != n or frame.relative_s is not rel:
            delays, dops = np.empty(n), np.empty(n)
            delays[0], dops[0] = geo.tau_los_s, geo.f_los_hz
            if n_img:
                delays[1:1 + n_img], dops[1:1 + n_img] = images.delay_s, images.doppler_hz
            if h is not None:
                delays[1 + n_img:] = geo.tau_los_s + rel
                dops[1 + n_img:] = geo.f_los_hz
            if not static:
                return PathSet._own(gains, delays, dops)
            delays.setflags(write=False)
            dops.setflags(write=False)
            frame = _Frame(rel, DelayTerms(delays, dops))
            _remember(self._frames, (tx, rx, fc_hz), frame)
        terms = frame.terms
        return PathSet._own(gains, terms.delay_s, terms.doppler_hz, delay_terms=terms)

    def _geometry(self, tx, rx, fc_hz, t_s, tx_motion, rx_motion) -> _Geometry:
        """Deterministic part of the link ``tx → rx`` at ``t_s`` (everything but the diffuse
        taps and the shadowing): a :class:`_Geometry` ``(d, g_ls, wall amplitude, antenna gain,
        √PLF, τ_LoS, f_D,LoS, p_tx, p_rx, image PathSet or None, (K, τ_rms) of the APDP or None)``.

        The carrier enters only through the large-scale gains and the Doppler shifts: for
        static antennas the rest (:meth:`_placement`) is kept per antenna pair, so that a
        frequency hop costs little."""
        sc = self.scene
        static = tx_motion is None and rx_motion is None
        place = self._placements.get((tx, rx)) if static else None
        if place is None:
            place = self._placement(tx, rx, t_s, tx_motion, rx_motion)
            if static:
                _remember(self._placements, (tx, rx), place)
        d = place.d
        g_ls = float(sc.link_amplitude_gain(tx, rx, d, fc_hz))
        images = None
        if place.images is not None:
            images = self._image_part(place.images, place.p_rx, place.v_tx, place.v_rx, fc_hz, tx, rx)
        return _Geometry(d, g_ls, place.env, place.ant, place.plf, d / C_M_S,
                         _doppler_hz(fc_hz, place.u, place.v_tx, place.v_rx), place.p_tx, place.p_rx, images,
                         place.apdp_args)

    def hold_placement(self, tx: Antenna, rx: Antenna, placement: tuple) -> None:
        """Keep ``placement`` as the carrier-independent geometry of the static link ``tx → rx``.

        The tuple :meth:`_placement` returns; :func:`rfsim.channels.bulk.static_placements` makes
        them for many links at once, bit-identical, so that :meth:`link` does not evaluate it.

        Parameters
        ----------
        tx, rx : Antenna
            The link's ends.
        placement : tuple
            The geometry (:meth:`_placement`).
        """
        _remember(self._placements, (tx, rx), _Placement(*placement))

    def hold_placements(self, tx: Antenna, rx_antennas) -> int:
        """Evaluate at once, and hold, the carrier-independent geometry of the static links ``tx → rx_i`` not held yet.

        :func:`rfsim.channels.bulk.static_placements`, bit-identical to :meth:`_placement`, then
        :meth:`hold_placement`, so that the first :meth:`link` of each does not evaluate it on its
        own. A scene with reflecting surfaces or walls, receivers that are not linearly polarized
        antennas sharing one pattern, or more links than :data:`GEOMETRY_CACHE_SIZE` are left to
        :meth:`link`.

        Parameters
        ----------
        tx : Antenna
            The transmitter.
        rx_antennas : iterable of Antenna
            The receivers.

        Returns
        -------
        int
            The number of placements held.
        """
        sc = self.scene
        if (sc.surfaces and sc.image_order > 0) or sc.walls or not isinstance(tx, Antenna):
            return 0
        todo = [rx for rx in dict.fromkeys(rx_antennas) if (tx, rx) not in self._placements]
        if not todo or len(todo) + len(self._placements) > GEOMETRY_CACHE_SIZE:
            return 0
        pattern = todo[0].pattern if isinstance(todo[0], Antenna) else None
        if not all(isinstance(a, Antenna) and a.polarization == "linear" and a.pattern == pattern for a in todo):
            return 0
        if any(np.array_equal(a.position_m, tx.position_m) for a in todo):
            return 0  # left to link(), which names the error
        from .bulk import static_placements

        for rx, place in zip(todo, static_placements(sc, tx, todo)):
            self.hold_placement(tx, rx, place)
        return len(todo)

    def static_constants(self, tx: Antenna, rx_antennas, *, fc_hz: float, bandwidth_hz: float,
                         propagation: str = "auto", inbound: bool = False) -> list | None:
        """The narrowband constants of the static links ``tx → rx_i`` at one carrier, all at once.

        For a scene whose static links are one LoS path each (Friis, no reflecting surfaces, no
        diffuse taps, no shadowing; walls allowed) the constant of link i is
        ``A_i·e^{−j2π·(fc·τ_i mod 1)}`` with ``A_i = g_ls(d_i, fc)·env_i·√(G_tx·G_rx)_i·√PLF_i``
        and ``τ_i = d_i/c`` (the LoS of :meth:`link`), evaluated here as arrays over the links
        from their held placements (:meth:`hold_placements`): the same operations, elementwise,
        as ``link(tx, rx_i, fc_hz=fc_hz).narrowband_constant(fc_hz, bandwidth_hz, propagation)``,
        so the same numbers to the bit (tested), without a PathSet per link. A frequency hop
        then costs a few array passes instead of a link assembly per tag.

        Parameters
        ----------
        tx : Antenna
            The transmitter (e.g. the reader's antenna).
        rx_antennas : sequence of Antenna
            The receivers (e.g. the tags' antennas), static.
        fc_hz : float
            Carrier frequency [Hz].
        bandwidth_hz : float
            One-sided signal bandwidth [Hz] (the narrowband decision of a one-path link).
        propagation : {"auto", "exact", "narrowband"}, default "auto"
            Propagation policy.
        inbound : bool, default False
            The links ``rx_i → tx`` instead (the backward links of :meth:`backscatter_links` for a
            monostatic ``tx``): the same constants in a reciprocal scene, else None.

        Returns
        -------
        list of complex or None
            Per receiver its constant [√W per √W], in order; None when the scene's links are not
            of that form, the policy is "exact", or a placement cannot be held (the caller then
            asks :meth:`link` link by link).
        """
        sc = self.scene
        if (inbound and not sc.reciprocal) or (sc.apdp is not None or sc.shadowing is not None or sc.large_scale is not None
                or (sc.surfaces and sc.image_order > 0) or propagation == "exact" or not math.isfinite(bandwidth_hz)):
            return None
        if not rx_antennas:
            return []
        self.hold_placements(tx, rx_antennas)
        places = [self._placements.get((tx, rx)) for rx in rx_antennas]
        if any(p is None or p.images is not None for p in places):
            return None
        if any(p.v_tx.any() or p.v_rx.any() for p in places):
            return None
        d = np.array([p.d for p in places], float)
        g_ls = friis_amplitude_gain(d, float(fc_hz))
        a_los = g_ls * np.array([p.env for p in places], float) * np.array([p.ant for p in places], float) \
            * np.array([p.plf for p in places], float)
        coef = a_los.astype(np.complex128) * _carrier_phasors(d / C_M_S, fc_hz)
        return (coef + 0j).tolist()  # constant_gain: 0j plus the one coefficient

    def _placement(self, tx, rx, t_s, tx_motion, rx_motion) -> _Placement:
        """Carrier-independent geometry of the link, a :class:`_Placement`: ``(d, unit vector, wall amplitude,
        antenna gain, √PLF, p_tx, p_rx, v_tx, v_rx, image paths or None, APDP (K, τ_rms) or
        None)``; the image paths as ``(paths, lengths, coefficients, antenna gains, PLF)``."""
        sc = self.scene
        p_tx, v_tx = kinematics(tx, tx_motion, t_s)
        p_rx, v_rx = kinematics(rx, rx_motion, t_s)
        if tx_motion is not None:
            tx = dataclasses.replace(tx, position_m=p_tx)
        if rx_motion is not None:
            rx = dataclasses.replace(rx, position_m=p_rx)
        diff = p_rx - p_tx
        d = float(np.linalg.norm(diff))
        if not d > 0:
            raise ValueError("tx and rx are at the same position")
        u = diff / d
        env = 1.0
        if sc.walls:
            env *= 10.0 ** (-float(wall_loss_db(p_tx, p_rx, list(sc.walls))) / 20.0)
        ant = np.sqrt(float(tx.gain_towards(p_rx)) * float(rx.gain_towards(p_tx)))
        plf = np.sqrt(float(tx.polarization_mismatch(rx)))
        found = None
        if sc.surfaces and sc.image_order > 0:
            found = self._image_geometry(tx, rx, p_tx, p_rx)
        apdp_args = None
        if sc.apdp is not None:  # K-factor and RMS delay spread of the APDP at this distance
            apdp_args = (float(sc.apdp.k_lin_at(d)), float(sc.apdp.tau_rms_s_at(d)))
        for a in (u, p_tx, p_rx, v_tx, v_rx):  # kept in the cache: read-only
            a.setflags(write=False)
        return _Placement(d, u, env, ant, plf, p_tx, p_rx, v_tx, v_rx, found, apdp_args)

    def _image_geometry(self, tx, rx, p_tx, p_rx) -> _ImageGeometry:
        """Image paths tx → rx and their carrier-independent factors (reflection coefficient,
        antenna gains, polarization mismatch)."""
        sc = self.scene
        found = image_paths(p_tx, p_rx, sc.surfaces, sc.image_order, polarization=tx.polarization_vector)
        if not found:
            return _ImageGeometry(found, None, None, None, None)
        ell = np.array([ip.length_m for ip in found])
        first = np.array([ip.points_m[0] for ip in found])
        last = np.array([ip.points_m[-1] for ip in found])
        v_src = np.array([ip.virtual_source_m for ip in found])
        coef = np.array([ip.coefficient for ip in found])
        g_ant = tx.gain_towards(first) * rx.gain_towards(last)
        plf = tx.polarization_mismatch(rx, direction=p_rx - v_src)
        return _ImageGeometry(found, ell, coef, g_ant, plf)

    def _image_part(self, image_geometry, p_rx, v_tx, v_rx, fc_hz, tx, rx) -> PathSet:
        sc = self.scene
        found, ell = image_geometry.found, image_geometry.length_m
        if not found:
            return PathSet(np.zeros(0, complex), np.zeros(0))
        gains = (np.asarray(sc.link_amplitude_gain(tx, rx, ell, fc_hz), float) * image_geometry.coefficient
                 * np.sqrt(image_geometry.antenna_gain * image_geometry.plf))
        dops = np.empty(len(found))
        for i, ip in enumerate(found):
            v_img = v_tx.copy()
            for s_idx in ip.surfaces:  # mirror the source velocity in every surface
                nrm = sc.surfaces[s_idx].normal
                v_img = v_img - 2.0 * (v_img @ nrm) * nrm
            dops[i] = _doppler_hz(fc_hz, (p_rx - ip.virtual_source_m) / ip.length_m, v_img, v_rx)
        return PathSet(gains, ell / C_M_S, dops)

    def backscatter_links(self, emitter: Antenna, tag: Antenna, receiver: Antenna | None = None, *,
                          fc_hz: float, rng: np.random.Generator | None = None, t_s: float = 0.0,
                          emitter_motion=None, tag_motion=None, receiver_motion=None):
        """(forward, backward) paths emitter → tag → receiver.

        Monostatic (``receiver`` None or equal to ``emitter``) with ``reciprocal=True``: the
        backward paths are the forward paths (one held draw). Otherwise the backward link is
        assembled on its own (its diffuse draw uses the same ``rng`` after the forward one).

        Parameters
        ----------
        emitter, tag : Antenna
            The emitter and the tag.
        receiver : Antenna or None
            The receiver (None: the emitter).
        fc_hz : float
            Carrier frequency [Hz].
        rng : numpy.random.Generator or None
            Draw the diffuse taps anew; None reuses the held draws.
        t_s : float
            Evaluation time [s].
        emitter_motion, tag_motion, receiver_motion : None, array_like or callable
            Motions as in :meth:`link`.

        Returns
        -------
        forward, backward : PathSet
            The two links.
        """
        fwd = self.link(emitter, tag, fc_hz=fc_hz, rng=rng, t_s=t_s, tx_motion=emitter_motion, rx_motion=tag_motion)
        if (receiver is None or receiver == emitter) and self.scene.reciprocal:
            return fwd, fwd
        rcv = emitter if receiver is None else receiver
        r_motion = emitter_motion if receiver is None else receiver_motion
        bwd = self.link(tag, rcv, fc_hz=fc_hz, rng=rng, t_s=t_s, tx_motion=tag_motion, rx_motion=r_motion)
        return fwd, bwd


class HeldLinks:
    """Links already drawn, by antenna pair: the channel side (``Links``) of an air step
    (:func:`rfsim.air.step.propagate`) over a held channel state.

    :meth:`paths` returns the link of a pair (matched by antenna identity, whatever the carrier
    and time: the draw is held), or None for a pair it does not hold.

    Parameters
    ----------
    pairs : iterable of tuple, optional
        ``(tx_antenna, rx_antenna, paths)``; ``paths`` is a
        :class:`~rfsim.channels.paths.PathSet` or a batched link
        (:class:`rfsim.channels.bulk.BatchLink`). Default empty.
    """

    def __init__(self, pairs=()):
        self._pairs: dict = {}
        for tx, rx, p in pairs:
            self._pairs[(id(tx), id(rx))] = _HeldPair(tx, rx, p)  # the antennas are kept alive with their ids

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        """The held link of a pair (matched by antenna identity, whatever the carrier and time).

        Parameters
        ----------
        tx, rx : Antenna
            The pair.
        fc_hz : float
            Carrier frequency [Hz] (unused: the draw is held).
        t_s : float
            Time [s] (unused).

        Returns
        -------
        PathSet or BatchLink or None
            The link, or None for a pair it does not hold.
        """
        hit = self._pairs.get((id(tx), id(rx)))
        return None if hit is None else hit.paths


def los_links(tx_positions_m, rx_positions_m, fc_hz, *, large_scale=None, walls=(), tx_antenna=None,
              rx_antenna=None, tx_velocity_m_s=None, rx_velocity_m_s=None):
    """Vectorised LoS responses of many links at once.

    Amplitude gain :math:`g_{ls}(d) \\cdot 10^{-L_{walls}/20} \\sqrt{G_{tx} G_{rx} \\, p}`
    (p the polarization mismatch factor, when both antennas are given), delay d/c and Doppler
    :math:`f_D = -(f_c/c)\\, \\hat u \\cdot (v_{rx} - v_{tx})`.

    Parameters
    ----------
    tx_positions_m, rx_positions_m : array_like of float, shape (..., 3)
        Positions [m], broadcastable.
    fc_hz : float or array_like of float
        Carrier frequency [Hz] (scalar or broadcastable).
    large_scale : object or None, optional
        Keyword-only: model with ``amplitude_gain(d, fc)``; default None (Friis).
    walls : sequence of rfsim.channels.large_scale.Wall, optional
        Keyword-only: walls on the LoS; default none.
    tx_antenna, rx_antenna : rfsim.channels.antennas.Antenna or None, optional
        Keyword-only: templates whose orientation, pattern and polarization apply at every
        position (their own position is ignored); default None, isotropic, matched
        polarization.
    tx_velocity_m_s, rx_velocity_m_s : array_like of float, shape (..., 3), or None, optional
        Keyword-only: velocities [m/s]; default None, at rest.

    Returns
    -------
    gain : ndarray of complex128, shape (...)
        LoS amplitude gains (carrier phase excluded, as in :class:`PathSet`).
    delay_s : ndarray of float64, shape (...)
        Delays [s].
    doppler_hz : ndarray of float64, shape (...)
        Doppler shifts [Hz].
    """

    tx = np.asarray(tx_positions_m, dtype=float)
    rx = np.asarray(rx_positions_m, dtype=float)
    diff = rx - tx
    d = np.linalg.norm(diff, axis=-1)
    if large_scale is None:
        g = friis_amplitude_gain(d, fc_hz)
    else:
        g = large_scale.amplitude_gain(d, fc_hz)
    g = np.asarray(g, dtype=float)
    if walls:
        g = g * np.power(10.0, -wall_loss_db(tx, rx, list(walls)) / 20.0)
    if tx_antenna is not None:
        g = g * np.sqrt(tx_antenna.gain_in_direction(diff))
    if rx_antenna is not None:
        g = g * np.sqrt(rx_antenna.gain_in_direction(-diff))
    if tx_antenna is not None and rx_antenna is not None:
        from .antennas import polarization_mismatch_factor

        g = g * np.sqrt(polarization_mismatch_factor(tx_antenna.polarization_vector(diff),
                                                     rx_antenna.polarization_vector(diff)))
    u = diff / d[..., None]
    vt = np.zeros(3) if tx_velocity_m_s is None else np.asarray(tx_velocity_m_s, dtype=float)
    vr = np.zeros(3) if rx_velocity_m_s is None else np.asarray(rx_velocity_m_s, dtype=float)
    dop = -np.asarray(fc_hz, dtype=float) / C_M_S * np.sum(u * (vr - vt), axis=-1)
    return g.astype(np.complex128), d / C_M_S, dop
