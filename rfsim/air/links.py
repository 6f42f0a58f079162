"""The links of the air step (:func:`rfsim.air.step.propagate`): a table of one draw per antenna
pair (:class:`LinkTable`), a link applied to a segment (:func:`through`: one held constant
for a narrowband static link, else the paths' ``apply``), the check that no two antennas
share a position (:func:`check_positions`) and the one-line error of a missing link.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.air.cache import AirCache, CheckedAntennas
from rfsim.air.segment import Segment

__all__ = ["PROPAGATION_METHODS", "LinkTable", "HeldLink", "AntennaMotion", "HeldConstant", "check_positions", "link_constant", "through",
           "require_link"]

#: Propagation policies a link understands (``"auto"``: narrowband where the link says so).
PROPAGATION_METHODS = ("auto", "exact", "narrowband")

_antenna_of = operator.attrgetter("antenna")


class HeldLink(NamedTuple):
    """One draw of a :class:`LinkTable`, kept with the antennas whose identities key it.

    Attributes
    ----------
    tx, rx : object
        The transmitting and receiving antennas (kept alive: their ids stay their own).
    paths : PathSet-like or None
        The pair's paths (None: the channel has no such link).
    """

    tx: object
    rx: object
    paths: object


class AntennaMotion(NamedTuple):
    """The motion of one antenna of a :class:`LinkTable`, kept with the antenna it is keyed by.

    Attributes
    ----------
    antenna : object
        The moving antenna (kept alive: its id stays its own).
    motion : object
        Its velocity (3,) [m/s] or trajectory ``t_s → position_m``, as ``channel.link`` takes it.
    """

    antenna: object
    motion: object


class HeldConstant(NamedTuple):
    """The narrowband constant of one link (:func:`link_constant`), kept with the link it is keyed by.

    Attributes
    ----------
    paths : PathSet-like
        The link (kept alive: its id stays its own).
    gain : complex or None
        The link's complex gain [√W per √W], or None when it is not one constant.
    """

    paths: object
    gain: object


class LinkTable:
    """Links of one step drawn from a channel, one draw per antenna pair.

    Pairs are drawn in the order the step asks for them: every emitter → reflector link in
    reflector order, then per receiver the direct links and the reflector links.

    Parameters
    ----------
    channel : object
        Has ``link(tx, rx, *, fc_hz, rng, t_s, tx_motion, rx_motion)`` (``rfsim.channels.Channel``).
    rng : numpy.random.Generator or None, default None
        Generator for new draws (None: the channel's held draws).
    reciprocal : bool, default True
        A pair's reverse link is the same draw (the same PathSet object), as for a reciprocal
        channel's monostatic round trip.
    motions : sequence of AntennaMotion or None, default None
        The moving antennas and their motions (velocity (3,) m/s or trajectory), passed on to
        the channel; the other antennas are static.
    """

    def __init__(self, channel, *, rng: np.random.Generator | None = None, reciprocal: bool = True,
                 motions: Sequence[AntennaMotion] | None = None):
        self.channel, self.rng, self.reciprocal = channel, rng, reciprocal
        self.motions = {id(m.antenna): AntennaMotion(m.antenna, m.motion) for m in (motions or ())}
        self._held: dict = {}

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        """Return the link of one antenna pair, drawn on first use and held for the step.

        Parameters
        ----------
        tx, rx : object
            Transmitting and receiving antennas.
        fc_hz : float
            Carrier of the link [Hz].
        t_s : float
            Time the link is evaluated at [s] (the step's start).

        Returns
        -------
        PathSet-like or None
            The pair's paths (the reverse pair's draw when ``reciprocal``), or None when the channel
            has no such link.
        """
        key = (id(tx), id(rx), float(fc_hz))
        hit = self._held.get(key)
        if hit is None and self.reciprocal:
            hit = self._held.get((id(rx), id(tx), float(fc_hz)))
        if hit is None:
            kw = {}
            tx_motion, rx_motion = self._motion(tx), self._motion(rx)
            if tx_motion is not None:
                kw["tx_motion"] = tx_motion
            if rx_motion is not None:
                kw["rx_motion"] = rx_motion
            hit = self.channel.link(tx, rx, fc_hz=fc_hz, rng=self.rng, t_s=t_s, **kw)
            self._held[key] = HeldLink(tx, rx, hit)  # the antennas are kept alive with their ids
            return hit
        return hit.paths

    def _motion(self, antenna):
        """The motion of ``antenna`` (None: static)."""
        m = self.motions.get(id(antenna))
        return m.motion if (m is not None and m.antenna is antenna) else None


def check_positions(emitters: Sequence, reflector_antennas: Sequence, receivers: Sequence,
                    cache: AirCache | None = None) -> None:
    """Check that no two distinct antennas of a step share a position.

    Distinct antennas at distance 0 have no far-field link. ``receivers`` sharing an emitter's
    antenna are not checked (a reader's own port). A set of antennas whose positions are
    read-only arrays (``rfsim.channels.Antenna``) is checked once per run and remembered in
    ``cache`` by the identities of its antennas (a tuple of reflector antennas also by its own
    identity: a population's antennas are one tuple object, not compared antenna by antenna).

    Parameters
    ----------
    emitters : sequence
        The step's emitters (each with ``antenna``).
    reflector_antennas : sequence
        The reflectors' antennas (a population's tuple or a list).
    receivers : sequence
        The step's receivers (each with ``antenna``).
    cache : AirCache or None, default None
        The run's cache (:class:`rfsim.air.cache.AirCache`); None checks every time.

    Raises
    ------
    ConfigError
        Two distinct antennas at the same ``position_m``.
    """
    emitter_ids = tuple(map(id, map(_antenna_of, emitters)))
    listening = []  # the receivers that do not share an emitter's antenna (a reader's own port does)
    for k, r in enumerate(receivers):
        a = r.antenna
        if id(a) not in emitter_ids:
            listening.append((k, a))
    ends = (emitter_ids, tuple([id(a) for _, a in listening]) if listening else ())
    if cache is not None:
        by_tuple = cache.checked_tuples.get(id(reflector_antennas)) if type(reflector_antennas) is tuple else None
        if (by_tuple is not None and by_tuple.reflectors is reflector_antennas
                and _ids(by_tuple.emitters) == ends[0] and _ids(by_tuple.receivers) == ends[1]):
            return
        key = (ends[0], tuple(map(id, reflector_antennas)), ends[1])
        if key in cache.checked:
            if len(reflector_antennas) > 1:  # a population's tuple: next time by its identity alone
                _remember_tuple(cache, reflector_antennas, emitters, listening)
            return
    named = ([(f"emitter[{i}]", e.antenna) for i, e in enumerate(emitters)]
             + [(f"reflector[{j}]", a) for j, a in enumerate(reflector_antennas)]
             + [(f"receiver[{k}]", a) for k, a in listening])
    seen: dict = {}
    frozen = True
    for name, ant in named:
        p = getattr(ant, "position_m", None)
        if p is None:
            continue
        if not (isinstance(p, np.ndarray) and not p.flags.writeable):
            frozen = False
        key_p = p.tobytes() if isinstance(p, np.ndarray) and p.dtype == np.float64 else np.asarray(p, float).tobytes()
        other = seen.get(key_p)
        if other is not None and other[1] is not ant:
            raise ConfigError(f"{name}.position_m", tuple(np.frombuffer(key_p).tolist()),
                              f"a position away from {other[0]}'s antenna (distance 0 m has no link)")
        seen.setdefault(key_p, (name, ant))
    if frozen and cache is not None:
        cache.remember(cache.checked, key, _entry(emitters, list(reflector_antennas), listening))
        _remember_tuple(cache, reflector_antennas, emitters, listening)


def _ids(objects) -> tuple:
    return tuple(map(id, objects))


def _entry(emitters, reflector_antennas, listening) -> CheckedAntennas:
    return CheckedAntennas(emitters=tuple(e.antenna for e in emitters), reflectors=reflector_antennas,
                           receivers=tuple(a for _, a in listening))


def _remember_tuple(cache: AirCache, reflector_antennas, emitters, listening) -> None:
    """Remember a checked tuple of reflector antennas by its identity, with the emitter and
    listening receiver antennas it was checked with."""
    if type(reflector_antennas) is tuple:
        cache.remember(cache.checked_tuples, id(reflector_antennas), _entry(emitters, reflector_antennas, listening))


def link_constant(paths, fc_hz: float, bandwidth_hz: float, propagation: str, memo: dict):
    """Return the complex constant of a narrowband static link, or None.

    The link's ``narrowband_constant`` when it has one; else ``constant_gain(fc_hz)`` when the
    link is ``static`` and its ``method(bandwidth_hz, propagation)`` is ``"narrowband"``,
    remembered in ``memo`` for the step.

    Parameters
    ----------
    paths : PathSet-like
        The link.
    fc_hz : float
        Carrier [Hz].
    bandwidth_hz : float
        Simulated bandwidth [Hz].
    propagation : str
        Propagation policy (:data:`PROPAGATION_METHODS`).
    memo : dict
        The step's memo, keyed by ``(id(paths), fc_hz)``, of :class:`HeldConstant` entries
        (the link kept alive with its id); updated in place.

    Returns
    -------
    complex or None
        The link's complex gain, or None when it is not one constant.
    """
    f = getattr(paths, "narrowband_constant", None)
    if f is not None:
        return f(fc_hz, bandwidth_hz, propagation)
    key = (id(paths), fc_hz)
    hit = memo.get(key)
    if hit is None or hit.paths is not paths:
        gain = None
        if paths.static and paths.method(bandwidth_hz, propagation) == "narrowband":
            gain = paths.constant_gain(fc_hz)
        hit = memo[key] = HeldConstant(paths, gain)
    return hit.gain


def through(paths, seg: Segment, x: np.ndarray | None, *, fc_hz: float, bandwidth_hz: float,
            propagation: str, memo: dict) -> tuple:
    """Apply a link to a segment's samples.

    Parameters
    ----------
    paths : PathSet-like
        The link.
    seg : Segment
        The segment (its sample rate; its samples when ``x`` is None).
    x : ndarray or None
        Samples to propagate, shape ``(..., n)`` [√W]; None: ``seg.samples``.
    fc_hz : float
        Carrier [Hz] (the exact carrier phase of the paths).
    bandwidth_hz : float
        Simulated bandwidth [Hz].
    propagation : str
        Propagation policy (:data:`PROPAGATION_METHODS`).
    memo : dict
        The step's memo of narrowband constants (:func:`link_constant`).

    Returns
    -------
    tuple
        ``(gain, None)`` for a narrowband static link (one complex constant), else
        ``(None, samples)`` with the propagated samples of the shape of ``x``, the link
        evaluated from t = 0 of the step.
    """
    g = link_constant(paths, fc_hz, bandwidth_hz, propagation, memo)
    if g is not None:
        return g, None
    method = paths.method(bandwidth_hz, propagation)
    src = seg.samples if x is None else x
    # The step asks its links at its own start (``Links.paths(..., t_s=t0_s)``), and a link's
    # Doppler phases refer to the time it was evaluated at, so every segment of the step (all
    # on the step's time base) starts at t = 0 of its links.
    if src.ndim == 1:
        return None, paths.apply(src, fs_hz=seg.fs_hz, fc_hz=fc_hz, t0_s=0.0, method=method)
    flat = src.reshape(-1, src.shape[-1])
    y = np.stack([paths.apply(r, fs_hz=seg.fs_hz, fc_hz=fc_hz, t0_s=0.0, method=method) for r in flat])
    return None, y.reshape(src.shape)


def require_link(links, tx, rx, *, fc_hz, t_s, what: str):
    """Return the link of an antenna pair, or a one-line error when the scene has none.

    Parameters
    ----------
    links : Links
        The step's links.
    tx, rx : object
        Transmitting and receiving antennas.
    fc_hz : float
        Carrier [Hz].
    t_s : float
        Time the link is evaluated at [s].
    what : str
        Description of the pair, shown in the error.

    Returns
    -------
    PathSet-like
        The pair's paths.

    Raises
    ------
    ConfigError
        ``links.paths`` gave None for the pair.
    """
    p = links.paths(tx, rx, fc_hz=fc_hz, t_s=t_s)
    if p is None:
        raise ConfigError("air.links", what, "a link for every emitter → reflector/receiver and "
                                             "reflector → receiver pair")
    return p
