"""Links of the air step drawn beforehand: many receiving antennas as one batched receiver
(:class:`BatchAntenna`), the n links to it as one static narrowband link (:class:`BatchLink`),
the table the step looks links up in (:class:`DrawnLinks`), and :func:`add_drawn_link`, which
draws one link of a scene (:func:`rfsim.channels.bulk.draw_links`) into that table.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.lazy import lazy_import

_bulk = lazy_import("rfsim.channels.bulk")
_paths = lazy_import("rfsim.channels.paths")
_air_links = lazy_import("rfsim.air.links")


class BatchAntenna:
    """The same antenna at n positions: one receiver of :func:`rfsim.air.step.propagate` whose
    input has a leading batch dimension of n (one row per position).

    ``position_m`` is None: the step's distance check does not apply;
    :func:`rfsim.channels.bulk.draw_links` rejects a receiver at its transmitter instead.

    Parameters
    ----------
    template : rfsim.channels.antennas.Antenna
        Gives pattern, orientation and polarization (its position is not used).
    positions_m : array_like, shape (n, 3)
        The n positions [m].

    Attributes
    ----------
    template : rfsim.channels.antennas.Antenna
        As given.
    positions_m : ndarray, shape (n, 3)
        The positions [m] as a float array.
    """

    position_m = None

    def __init__(self, template, positions_m):
        self.template = template
        self.positions_m = np.atleast_2d(np.asarray(positions_m, dtype=float))


class BatchLink:
    """n links drawn at once (:class:`rfsim.channels.bulk.BulkPaths`) as one narrowband, static link of
    the air step: its constant gain is the (n, 1) column of per-row gains Σ_p g_p·e^{−j2π·fc·τ_p}.

    Every row is judged by the one narrowband rule of :func:`rfsim.channels.paths.propagation_method`
    (relative RMS envelope error ≤ :data:`rfsim.channels.paths.NARROWBAND_TOLERANCE`); a batch with a
    row that needs exact delays is refused (the static ST links of the exciter scenes are
    narrowband with errors of ≈ 0.001–0.01 at B = 2·BLF = 96 kHz).

    Parameters
    ----------
    bulk : rfsim.channels.bulk.BulkPaths
        The n drawn links (one row each).
    """

    static = True

    def __init__(self, bulk):
        self.bulk = bulk
        self._method: dict = {}

    def method(self, bandwidth_hz: float, propagation: str = "auto") -> str:
        r"""Return the propagation method of the batch: always ``"narrowband"``.

        Every row's relative RMS envelope error
        :math:`\sqrt{\sum_p |g_p|^2 (2\pi B (\tau_p - \tau_0))^2 / \sum_p |g_p|^2}`
        (:func:`rfsim.channels.paths.narrowband_rms_error`) must not exceed
        :data:`rfsim.channels.paths.NARROWBAND_TOLERANCE`. The answer is cached per
        (bandwidth, propagation).

        Parameters
        ----------
        bandwidth_hz : float
            Signal bandwidth B [Hz].
        propagation : str, optional
            The step's propagation setting, default ``"auto"``; ``"exact"`` is refused.

        Returns
        -------
        str
            ``"narrowband"``.

        Raises
        ------
        ValueError
            ``propagation`` is ``"exact"`` or a row exceeds the tolerance.
        """
        key = (float(bandwidth_hz), propagation)
        if key not in self._method:
            b = self.bulk
            # rfsim.channels.paths.narrowband_rms_error of every row at once (padded slots have g = 0)
            tau0 = np.where(b.valid, b.delay_s, np.inf).min(axis=1, keepdims=True)
            p = np.abs(b.gain) ** 2
            rel2 = np.where(b.valid, (2.0 * np.pi * bandwidth_hz * (b.delay_s - tau0)) ** 2, 0.0)
            err = np.sqrt((p * rel2).sum(axis=1) / np.maximum(p.sum(axis=1), 1e-300))
            if propagation == "exact" or np.any(err > _paths.NARROWBAND_TOLERANCE):
                raise ValueError(f"batched links need narrowband propagation at B = {bandwidth_hz:g} Hz "
                                 f"(largest envelope error {err.max():.3g} > {_paths.NARROWBAND_TOLERANCE})")
            self._method[key] = "narrowband"
        return self._method[key]

    def constant_gain(self, fc_hz: float) -> np.ndarray:
        r"""Return the narrowband gain of every row, :math:`\sum_p g_p e^{-j 2\pi f_c \tau_p}`.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        ndarray of complex128, shape (n, 1)
            The rows' gains [linear, amplitude].
        """
        return self.bulk.narrowband_gain(fc_hz)[:, None]

    def apply(self, x, *, fs_hz, fc_hz, t0_s=0.0, method="narrowband"):
        """Return the rows' received signals: the constant gains times ``x``.

        Parameters
        ----------
        x : ndarray of complex, shape (n_samples,) or (n, n_samples)
            The transmitted signal [√W].
        fs_hz : float
            Sample rate [Hz] (unused: the link is static and narrowband).
        fc_hz : float
            Carrier frequency [Hz].
        t0_s : float, optional
            Start time [s] (unused), default 0.
        method : str, optional
            Propagation method (unused; :meth:`method` is narrowband), default ``"narrowband"``.

        Returns
        -------
        ndarray of complex128, shape (n, n_samples)
            The received signals [√W].
        """
        return self.constant_gain(fc_hz) * x


class DrawnLinks:
    """The ``Links`` of :mod:`rfsim.air.step` for links drawn beforehand: ``paths(tx, rx)`` looks the
    antenna pair up (either direction: the channel is reciprocal). The table belongs to one
    scene; it keys the pairs by the identity of the antenna objects it was given, each entry a
    :class:`rfsim.air.links.HeldLink` that keeps its antennas alive."""

    def __init__(self):
        self._table: dict = {}

    def add(self, tx, rx, paths) -> None:
        """Register ``paths`` as the link tx ↔ rx.

        Parameters
        ----------
        tx : object
            The transmitting antenna (keyed by identity).
        rx : object
            The receiving antenna or :class:`BatchAntenna` (keyed by identity).
        paths : rfsim.channels.paths.PathSet or BatchLink
            The link.
        """
        self._table[(id(tx), id(rx))] = _air_links.HeldLink(tx, rx, paths)

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        """Look up the link tx ↔ rx (either direction).

        Parameters
        ----------
        tx : object
            One antenna of the pair.
        rx : object
            The other antenna of the pair.
        fc_hz : float
            Carrier frequency [Hz] (unused: the links were drawn at theirs).
        t_s : float
            Time [s] (unused: the links are static).

        Returns
        -------
        rfsim.channels.paths.PathSet or BatchLink or None
            The link; None when it was not drawn.
        """
        hit = self._table.get((id(tx), id(rx)))
        if hit is None or hit.tx is not tx:
            hit = self._table.get((id(rx), id(tx)))
            if hit is None or hit.tx is not rx:
                return None
        return hit.paths


def add_drawn_link(links: DrawnLinks, scene, tx, rx, *, fc_hz: float, rng: np.random.Generator) -> None:
    """Draw the link from antenna ``tx`` to ``rx`` in ``scene`` and add it to ``links``.

    One call of :func:`rfsim.channels.bulk.draw_links` on ``rng``.

    Parameters
    ----------
    links : DrawnLinks
        The table to add the link to.
    scene : rfsim.channels.scene.Scene
        The channel scene.
    tx : rfsim.channels.antennas.Antenna
        The transmitting antenna.
    rx : rfsim.channels.antennas.Antenna or BatchAntenna
        An antenna (the link is one path set, :meth:`rfsim.channels.bulk.BulkPaths.pathset`)
        or a :class:`BatchAntenna` (a :class:`BatchLink` of one row per position).
    fc_hz : float
        Carrier frequency [Hz].
    rng : numpy.random.Generator
        The draws of the link.
    """
    batched = isinstance(rx, BatchAntenna)
    rx_pos, rx_ant = (rx.positions_m, rx.template) if batched else (rx.position_m, rx)
    bulk = _bulk.draw_links(scene, tx.position_m, rx_pos, fc_hz=fc_hz, rng=rng, tx_antenna=tx, rx_antenna=rx_ant)
    links.add(tx, rx, BatchLink(bulk) if batched else bulk.pathset(0))


__all__ = ["BatchAntenna", "BatchLink", "DrawnLinks", "add_drawn_link"]
