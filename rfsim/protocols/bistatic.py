"""Waveforms at listener antennas during one reader exchange (bistatic reception).

A listener (a sense-a-tag antenna, a second reader's receive antenna) hears the reader's
segment directly and the backscatter of every tag (DESIGN.md "Simulation flow" step 5;
auris-sense-a-tag.md §6 "Signal flow": the reader→ST downlink and the tag→ST backscatter
channel, Fig. A.1). For a reader segment ``x_tx(t)`` (``reader.transmit``), the field at
tag i is ``inc_i = fwd_i{x_tx}`` and the tag re-radiates ``r_i(t)·inc_i(t)`` with
``r_i = A_s − Γ_i(t)`` (``tag.listen`` → ``TagResponse.reradiation``: structural mode A_s and
the chip's Γ, rfsim.devices.tag); listener antenna k receives

    ``y_k(t) = D_k{x_tx}(t) + Σ_i B_ik{r_i·inc_i}(t) (+ n_k(t))``

with ``D_k`` the reader→listener link and ``B_ik`` the tag→listener link, each applied with
the link's own narrowband/exact choice (``PathSet.method`` on the reply bandwidth 2·BLF,
:func:`rfsim.channels.paths.propagation_method`). Every tag scatters: A_s − Γ_A outside its reply.
All waveforms are complex baseband [√W] on the segment's time base. The step is one call
of the air interface (:func:`rfsim.air.step.propagate`) with the listeners as receivers and the
components kept.

The reader side (its own decode) is :func:`rfsim.protocols.engine.run_exchange`; this module only
adds the listeners, and returns the tag responses and the per-link components so that a
caller can measure the quantities of the closed forms (A_R, A_T1, A_T2, θ).

The channel is used through ``channel.link(tx, rx, *, fc_hz, rng, t_s)`` (one draw per link
when ``rng`` is given, the held draw otherwise; :class:`rfsim.air.step.LinkTable`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from rfsim.air.step import AntennaPort, FixedEmitter, LinkTable, as_reflector, propagate


@dataclasses.dataclass(frozen=True, eq=False)
class BistaticExchange:
    """One reader segment as heard by the tags and by the listener antennas.

    Attributes
    ----------
    tx : object
        The reader's ``TxSegment`` (``samples`` (n,) complex128 [√W], ``t0_s``, ``fs_hz``, ``fc_hz``).
    responses : tuple
        One ``TagResponse`` per tag (``gamma`` on the segment's time base).
    incident : ndarray, shape (n_tags, n), complex128
        Field at each tag's antenna port [√W].
    direct : ndarray, shape (n_listeners, n), complex128
        Reader → listener component [√W].
    backscatter : ndarray, shape (n_tags, n_listeners, n), complex128
        Tag i → listener k component [√W].
    noise : ndarray, shape (n_listeners, n), complex128, or None
        The added noise [√W] (None without noise).
    direct_links, forward_links, backward_links : tuple
        The PathSets used (``direct_links[k]``, ``forward_links[i]``, ``backward_links[i][k]``).
    """

    tx: Any
    responses: tuple
    incident: np.ndarray
    direct: np.ndarray
    backscatter: np.ndarray
    noise: np.ndarray | None
    direct_links: tuple
    forward_links: tuple
    backward_links: tuple

    @property
    def inputs(self) -> np.ndarray:
        """(n_listeners, n) complex128: total input at each listener antenna [√W]."""
        y = self.direct + self.backscatter.sum(axis=0)
        return y if self.noise is None else y + self.noise


def listen_exchange(reader, tags: Sequence, channel, cmd, listeners: Sequence, *, t_s: float,
                    rng: np.random.Generator | None, cw_after_s: float, round_index: int = 0,
                    propagation: str = "auto", noise_power_w: float = 0.0) -> BistaticExchange:
    r"""Simulate one reader segment at the tags and at listener antennas.

    One air step (:func:`rfsim.air.step.propagate`) with the listeners as receivers and the
    components kept: :math:`y_k = D_k\{x_{tx}\} + \sum_i B_{ik}\{r_i\,\mathrm{inc}_i\} + n_k`
    (module docstring; auris-sense-a-tag.md §6).

    Parameters
    ----------
    reader : object
        Reader device (``transmit``, ``antennas``, ``antenna_index``, ``link``).
    tags : sequence
        Tag devices (``listen``, ``antenna``).
    channel : object
        Link model with ``link(tx, rx, *, fc_hz, rng, t_s)`` → PathSet.
    cmd : object
        The Gen2 command the reader sends.
    listeners : sequence
        Receiving antennas (``rfsim.channels.Antenna``).
    t_s : float
        Start of the segment [s].
    rng : numpy.random.Generator or None
        Draws the links (forward, then per listener direct and backward) and the noise; None
        reuses the channel's held draws (noise then needs ``noise_power_w == 0``).
    cw_after_s : float
        CW after the command [s] (the reply window).
    round_index : int, default 0
        Inventory round (selects the reader antenna).
    propagation : {"auto", "exact", "narrowband"}, default "auto"
        Propagation policy (as :func:`rfsim.protocols.engine.run_exchange`).
    noise_power_w : float, default 0.0
        Complex AWGN power per sample added at every listener [W].

    Returns
    -------
    BistaticExchange
        The reader's segment, the tags' responses and incident fields, and the per-link
        components at the listeners.

    Raises
    ------
    ValueError
        ``noise_power_w > 0`` without ``rng``.
    """
    antenna = reader.antennas[reader.antenna_index(round_index)]
    tx = reader.transmit(cmd, t0_s=t_s, cw_after_s=cw_after_s, round_index=round_index)
    fs, x = tx.fs_hz, tx.samples
    if noise_power_w > 0 and rng is None:
        raise ValueError("noise needs an rng")
    ports = [AntennaPort(lis, noise_power_w) for lis in listeners]
    reflectors = [as_reflector(t) for t in tags]
    links = LinkTable(channel, rng=rng, reciprocal=False)
    air = propagate([FixedEmitter(antenna, tx, device=reader)], reflectors, ports, links, t0_s=t_s, fs_hz=fs,
                    n_samples=x.size, rng=rng, bandwidth_hz=2.0 * reader.link.blf_hz, propagation=propagation,
                    decide=False, keep_components=True)
    n_l, n_t = len(listeners), len(tags)
    direct = np.array(air.direct) if n_l else np.zeros((0, x.size), dtype=np.complex128)
    back = np.zeros((n_t, n_l, x.size), dtype=np.complex128)
    for i in range(n_t):
        for k in range(n_l):
            back[i, k] = air.backscatter[i][k]
    noise = np.array(air.noise) if (noise_power_w > 0 and n_l) else None
    incident = [seg.samples for seg in air.incident]
    inc_arr = np.array(incident) if incident else np.zeros((0, x.size), dtype=np.complex128)
    lk = air.links
    return BistaticExchange(tx=tx, responses=tuple(air.reflections), incident=inc_arr, direct=direct,
                            backscatter=back, noise=noise,
                            direct_links=tuple(lk[("emitter", 0, "receiver", k)] for k in range(n_l)),
                            forward_links=tuple(lk[("emitter", 0, "reflector", i)] for i in range(n_t)),
                            backward_links=tuple(tuple(lk.get(("reflector", i, "receiver", k)) for k in range(n_l))
                                                 for i in range(n_t)))


__all__ = ["BistaticExchange", "listen_exchange"]
