"""The batched air step: B prepared steps of :func:`rfsim.air.step.propagate` in one pass.

The air of a step and its receiver noise are :func:`rfsim.air.step.propagate` of that step
(its links, then receiver by receiver its input and the noise from the step's own generator),
step after step; the receivers' decisions come after every step's air. A batch is thus the
steps run one after another, and it keeps the condition under which the steps' air could be
formed first and their noise afterwards (a batched noise kernel), the order it had drawn them
in: the air of a step draws nothing from a generator that an earlier step drew noise from,
nor from its own noise generator after a receiver with noise. That holds when the links draw
from generators of their own (:class:`rfsim.air.step.LinkTable` with another ``rng``, held
links), and for the engine's exchange, whose one generator per trial draws the links before
the noise of its one receiver (the reader's port); a link table drawing from a noise generator
otherwise is a one-line error. Steps may share a noise generator (the queries of one trial):
their noise is drawn in step order, as the sequence of separate steps draws it.

With ``skip_unmodulated`` a step in which nothing modulates forms no receiver input (as
``propagate(skip_unmodulated=True)``): its receivers' noise draws are still made
(:func:`rfsim.air.noise.skip_receiver_noise`, in receiver order), its ``inputs`` hold None.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rfsim.air.cache import AirCache
from rfsim.air.step import AirResult, propagate

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


def propagate_batch(steps: Sequence[AirStep], *, skip_unmodulated: bool = False) -> list[AirResult]:
    """Run B air steps as one batch.

    Every step's air with its receivers' noise (:func:`rfsim.air.step.propagate` of the step,
    ``decide`` off: its links, then receiver by receiver its input and that receiver's noise from
    the step's ``rng``), then the decisions of the steps with ``decide``. The module docstring's
    condition is checked first.

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
        order that forming every step's air before its noise would change (module docstring).
    """
    steps = list(steps)
    _check_noise_order(steps)
    airs = [propagate(s.emitters, s.reflectors, s.receivers, s.links, t0_s=s.t0_s, fs_hz=s.fs_hz,
                      n_samples=s.n_samples, rng=s.rng, fc_ref_hz=s.fc_ref_hz, bandwidth_hz=s.bandwidth_hz,
                      propagation=s.propagation, decide=False, keep_components=s.keep_components,
                      skip_unmodulated=skip_unmodulated, cache=s.cache)
            for s in steps]
    for s, air in zip(steps, airs):
        if s.decide:
            air.outputs = [None if seg is None else rcv.receive(seg) for rcv, seg in zip(s.receivers, air.inputs)]
    return airs


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
