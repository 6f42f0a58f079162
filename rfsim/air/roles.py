"""The parts devices play in the air step (:func:`rfsim.air.step.propagate`): the protocols
of an emitter, a reflector and its reflection, a receiver, a reflector group and the links,
and small adapters (:class:`FixedEmitter`, :class:`AntennaPort`, :func:`as_reflector`).
The model they take part in is in :mod:`rfsim.air.step`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.air.segment import Segment

__all__ = ["Emitter", "Reflection", "Reflector", "Receiver", "Links", "ReflectorGroup", "GroupReflection",
           "FixedEmitter", "AntennaPort", "as_reflector"]


@runtime_checkable
class Emitter(Protocol):
    """Anything that radiates: ``antenna`` and ``emit(*, t0_s, fs_hz, n_samples) -> Segment | None``
    (on that time base, on the emitter's own carrier; None = silent)."""

    antenna: Any

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> Segment | None: ...


class Reflection(Protocol):
    """What a reflector returns: its re-radiation factor r(t) (the field it scatters is
    r(t)·incident(t)). ``constant_reradiation`` is r as one complex number when it does not
    change during the segment (None otherwise); ``reradiation(n)`` gives (…, n) samples.
    Optionally ``reradiation_terms`` → ``(A_s, Γ)`` when r(t) = A_s − Γ(t) (a chip's reflection
    states behind the antenna's structural mode), which lets the step form r(t)·g·x and its
    backward link in one pass."""

    scatters: bool

    @property
    def constant_reradiation(self) -> complex | None: ...

    def reradiation(self, n_samples: int) -> np.ndarray: ...


@runtime_checkable
class Reflector(Protocol):
    """Anything that scatters what it receives: ``antenna`` and ``reflect(incident: Segment)``
    → a :class:`Reflection` (or None: nothing scattered). It may keep state (a Gen2 state
    machine) and decide on its own schedule."""

    antenna: Any

    def reflect(self, incident: Segment) -> Reflection | None: ...


@runtime_checkable
class Receiver(Protocol):
    """Anything that listens: ``antenna``, ``noise_power_w`` [W per complex sample],
    ``fc_hz`` (its carrier / LO; None = the step's reference carrier) and
    ``receive(input: Segment)`` → its decisions or measurements.

    Optional: ``coupling(emitter) -> complex | None``, a direct coupling that replaces the
    channel's link from ``emitter`` (a reader's own TX→RX leakage)."""

    antenna: Any
    noise_power_w: float
    fc_hz: float | None

    def receive(self, input: Segment) -> Any: ...


class Links(Protocol):
    """The channel as the step sees it: the paths of one antenna pair, or None (no link).

    The returned object (``rfsim.channels.PathSet``) offers ``method(bandwidth_hz, propagation)``
    ("narrowband"/"exact"), ``apply(x, *, fs_hz, fc_hz, t0_s, method)``, ``static`` (no Doppler)
    and ``constant_gain(fc_hz)`` (optionally ``narrowband_constant(fc_hz, bandwidth_hz,
    propagation)``: the constant of a narrowband static link or None, remembered).

    The step asks every link at its own start, ``t_s = t0_s``; the Doppler phases of the
    returned paths refer to that time (``rfsim.channels.Channel.link``: paths evaluated at t_s), so
    a moving link advances by 2π·f_D·(t − t0_s) over the step."""

    def paths(self, tx, rx, *, fc_hz: float, t_s: float): ...


@runtime_checkable
class ReflectorGroup(Protocol):
    """Many reflectors joined as one entry of the step (a tag population): its ``members``
    (reflectors, in order; every per-reflector list of the step holds them in their place),
    ``antennas`` (theirs, as a tuple) and two ways to reflect:

    * ``reflect_each(incident)`` — a list of segments, one per member → the members'
      reflections, in order (what each member's ``reflect`` returns);
    * ``reflect_scaled(base, gains, fc_hz)`` — member j sees ``gains[j]·base`` (one emitter,
      every link narrowband and static): a :class:`GroupReflection`, or None when the group
      cannot answer so (the step then calls ``reflect_each``).
    """

    members: Sequence
    antennas: tuple

    def reflect_each(self, incident: Sequence[Segment]) -> list: ...

    def reflect_scaled(self, base: Segment, gains: Sequence[complex], fc_hz: float) -> Any: ...


class GroupReflection(Protocol):
    """What a group returns from ``reflect_scaled``: ``reactions`` ({member index: its own
    :class:`Reflection`}, in member order: members that reflected on their own), the
    others quiet (constant re-radiation r_j), ``terms(backs)`` → ``(terms, use)``: (n,)
    complex b_j·(r_j·g_j) for the backward constants ``backs`` (formed as the step forms
    them for one reflector) and the (n,) bool mask of the quiet members that scatter;
    ``powered`` and ``incident_power_dbm`` per member; ``len`` and ``[j]`` (member j's
    reflection)."""

    reactions: dict

    def terms(self, backs: Sequence[complex]) -> tuple: ...

    def __len__(self) -> int: ...

    def __getitem__(self, j: int) -> Any: ...


# ----------------------------------------------------------------------------- adapters


class FixedEmitter:
    """An emitter whose segment is already made (a reader's command segment).

    Parameters
    ----------
    antenna : the antenna it radiates from
    segment : :class:`Segment` (or an object with ``t0_s``, ``fs_hz``, ``fc_hz``, ``samples`` and
        optionally ``memo``, a dict shared by every segment of these samples: the Segment's memo)
    device : the device behind it (lets a receiver recognise its own transmitter)
    """

    def __init__(self, antenna, segment, *, device=None):
        if not isinstance(segment, Segment):
            memo = getattr(segment, "memo", None)
            segment = Segment(segment.t0_s, segment.fs_hz, segment.fc_hz, segment.samples)
            if memo is not None:  # the made segment's shared memo (a reader's cached waveform)
                segment.memo = memo
        self.antenna, self.segment, self.device = antenna, segment, device

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> Segment:
        if not self.segment.same_time_base(t0_s, fs_hz, n_samples):
            raise ConfigError("air.emitters", self.segment,
                              f"a segment on the step's time base (t0 {t0_s} s, fs {fs_hz} Hz, {n_samples} samples)")
        return self.segment


class AntennaPort:
    """A receiver that only listens: an antenna, its noise power [W per sample] and its
    carrier (None: the step's reference); ``receive`` returns the input segment."""

    def __init__(self, antenna, noise_power_w: float = 0.0, fc_hz: float | None = None):
        self.antenna, self.noise_power_w, self.fc_hz = antenna, float(noise_power_w), fc_hz

    def receive(self, input: Segment) -> Segment:
        return input


class _Listening:
    """A device that offers only ``listen(samples, *, t0_s, fs_hz)`` as a reflector."""

    def __init__(self, device):
        self.device, self.antenna = device, device.antenna

    def reflect(self, incident: Segment):
        return self.device.listen(incident.samples, t0_s=incident.t0_s, fs_hz=incident.fs_hz)


def as_reflector(device):
    """``device`` itself when it has ``reflect`` (or is a :class:`ReflectorGroup`), else a
    wrapper calling its ``listen``."""
    return device if (hasattr(device, "reflect") or hasattr(device, "reflect_scaled")) else _Listening(device)
