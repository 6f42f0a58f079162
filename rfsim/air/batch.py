"""The batched air step: B prepared steps of :func:`rfsim.air.step.propagate` in one pass.

:func:`propagate_batch` runs the air of every step first (emit, links, reflections,
superposition: ``propagate`` with its receivers' noise off), then each step's receiver noise,
receiver by receiver, from the step's own generator (the numbers ``propagate`` draws there:
:func:`rfsim.air.noise.add_awgn` on the same sums), then the receivers' decisions. It equals
the steps run one after another by ``propagate`` whenever that leaves the draws of every
generator in their order: the air of a step draws nothing from a generator that an earlier
step drew noise from, nor from its own noise generator after a receiver with noise. That
holds when the links draw from generators of their own (:class:`rfsim.air.step.LinkTable`
with another ``rng``, held links), and for the engine's exchange, whose one generator per
trial draws the links before the noise of its one receiver (the reader's port); a link table
drawing from a noise generator otherwise is a one-line error. Steps may share a noise
generator (the queries of one trial): their noise is drawn in step order, as the sequence of
separate steps draws it.

With ``skip_unmodulated`` a step in which nothing modulates forms no receiver input (as
``propagate(skip_unmodulated=True)``): its receivers' noise draws are still made
(:func:`rfsim.air.noise.skip_awgn`, in receiver order), its ``inputs`` hold None.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rfsim.air.cache import AirCache
from rfsim.air.noise import add_receiver_noise, skip_receiver_noise
from rfsim.air.step import AirResult, first_read, propagate
from rfsim.core.errors import ConfigError

__all__ = ["AirStep", "propagate_batch"]


@dataclass
class AirStep:
    """One air step prepared for :func:`propagate_batch`.

    The fields are the arguments of :func:`rfsim.air.step.propagate`, with the same names and
    meanings (see there for units and defaults).

    Attributes
    ----------
    emitters, reflectors, receivers : sequence
        The step's devices in their air roles.
    links : object
        The link table (:class:`rfsim.air.links.LinkTable` or a held one).
    t0_s : float
        Start time of the step [s].
    fs_hz : float
        Sample rate [Hz].
    n_samples : int
        Samples per receiver input.
    rng : numpy.random.Generator or None
        Generator of the receivers' noise, default None.
    fc_ref_hz : float or None
        Reference carrier of the complex baseband [Hz], default None.
    bandwidth_hz : float or None
        Simulated bandwidth [Hz], default None.
    propagation : str
        Propagation mode, default ``"auto"``.
    decide : bool
        Whether the receivers decide on their inputs, default True.
    keep_components : bool
        Whether the per-term components and noise are kept, default False.
    cache : AirCache or None
        The run's cache; None gives the step one of its own.
    """

    emitters: Sequence
    reflectors: Sequence
    receivers: Sequence
    links: Any
    t0_s: float
    fs_hz: float
    n_samples: int
    rng: np.random.Generator | None = None
    fc_ref_hz: float | None = None
    bandwidth_hz: float | None = None
    propagation: str = "auto"
    decide: bool = True
    keep_components: bool = False
    cache: AirCache | None = None


class _Quiet:
    """A receiver as the noiseless air step sees it: its antenna, carrier and coupling,
    noise power 0 (the noise is added by :func:`propagate_batch` afterwards)."""

    noise_power_w = 0.0

    def __init__(self, receiver):
        self.antenna, self.fc_hz = receiver.antenna, getattr(receiver, "fc_hz", None)
        coupling = getattr(receiver, "coupling", None)
        if coupling is not None:
            self.coupling = coupling


def propagate_batch(steps: Sequence[AirStep], *, skip_unmodulated: bool = False) -> list[AirResult]:
    """Run B air steps as one batch.

    The air of every step first, then every step's receiver noise (receivers in order, from
    the step's ``rng``), then the decisions of the steps with ``decide`` (module docstring). A
    step whose cache's strategy is ``exchange="compiled"`` (:class:`rfsim.air.cache.Strategy`)
    draws its noise within its own air (:func:`rfsim.air.step.superpose_noise`): its links, then
    its receivers' noise, as ``propagate`` of that step alone draws them (the module
    docstring's condition keeps every generator's draws in that order).

    Parameters
    ----------
    steps : sequence of AirStep
        The prepared steps, in the order ``propagate`` would run them.
    skip_unmodulated : bool, default False
        A step in which nothing modulates forms no receiver input (its ``inputs`` hold None);
        its receivers' noise draws are still made.

    Returns
    -------
    list of rfsim.air.step.AirResult
        One per step, bit-identical to ``propagate`` of that step (with the same
        ``skip_unmodulated``) run after the steps before it (tests/test_batch.py).

    Raises
    ------
    ConfigError
        A step has a receiver with noise but no ``rng``.
    ValueError
        A step's link table draws from a generator that receiver noise is drawn from in an
        order the batch would change.
    """
    steps = list(steps)
    _check_noise_order(steps)
    steps = [s if s.cache is not None else _with_cache(s) for s in steps]
    # a step of the compiled exchange strategy forms its inputs with their noise in its own call:
    # its draws come in the order they would here (its links, then its receivers' noise)
    whole = [s.cache.strategy.exchange == "compiled" and not s.keep_components for s in steps]
    airs = [propagate(s.emitters, s.reflectors, s.receivers if w else [_Quiet(r) for r in s.receivers], s.links,
                      t0_s=s.t0_s, fs_hz=s.fs_hz, n_samples=s.n_samples, rng=s.rng if w else None,
                      fc_ref_hz=s.fc_ref_hz, bandwidth_hz=s.bandwidth_hz, propagation=s.propagation, decide=False,
                      keep_components=s.keep_components, skip_unmodulated=skip_unmodulated, cache=s.cache)
            for s, w in zip(steps, whole)]
    for s, air, w in zip(steps, airs, whole):
        if w:
            continue
        for k, rcv in enumerate(s.receivers):
            noise_w = float(rcv.noise_power_w)
            if noise_w > 0:
                if s.rng is None:
                    raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
                method = s.cache.strategy.noise
                if air.inputs[k] is None:  # nothing modulates: nobody reads this input, the draws are made
                    skip_receiver_noise(s.n_samples, s.rng, method=method)
                    continue
                noise = add_receiver_noise(air.inputs[k].samples, noise_w, s.rng, method=method,  # in place
                                           start=first_read(rcv, s.t0_s, s.fs_hz, s.n_samples),
                                           keep=s.keep_components)
                if s.keep_components:
                    air.noise[k] = noise
    for s, air in zip(steps, airs):
        if s.decide:
            air.outputs = [None if seg is None else rcv.receive(seg) for rcv, seg in zip(s.receivers, air.inputs)]
    return airs


def _with_cache(step: AirStep) -> AirStep:
    """``step`` with a cache of its own (as ``propagate`` makes one for a call without)."""
    return AirStep(**{**step.__dict__, "cache": AirCache()})


def _check_noise_order(steps: Sequence[AirStep]) -> None:
    """A one-line error where a step's link table draws from a noise generator in a way the
    batch would reorder (module docstring)."""
    noisy = [[k for k, r in enumerate(s.receivers) if float(r.noise_power_w) > 0] for s in steps]
    noisy_rngs = {}  # id(generator) -> index of the first step that draws noise from it
    users: dict = {}  # id(generator) -> number of steps whose ``rng`` it is
    for b, s in enumerate(steps):
        if s.rng is not None:
            users[id(s.rng)] = users.get(id(s.rng), 0) + 1
            if noisy[b]:
                noisy_rngs.setdefault(id(s.rng), b)
    for b, s in enumerate(steps):
        link_rng = getattr(s.links, "rng", None)
        if link_rng is None or id(link_rng) not in noisy_rngs:
            continue
        own_last = s.rng is link_rng and noisy[b] == [len(s.receivers) - 1] and noisy_rngs[id(link_rng)] == b
        shared = users[id(link_rng)] > 1
        if not own_last or shared:
            raise ValueError(f"steps[{b}].links: draws from a generator that receiver noise is drawn from; the batch "
                             "draws the noise after the links (give the links a generator of their own)")
