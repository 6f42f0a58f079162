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
    """Anything that radiates: an antenna and an ``emit`` method.

    Attributes
    ----------
    antenna : object
        The antenna it radiates from.
    """

    antenna: Any

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> Segment | None:
        """Produce the emitter's segment on the step's time base.

        Parameters
        ----------
        t0_s : float
            Start time of the step [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Samples of the step.

        Returns
        -------
        Segment or None
            The samples on that time base, on the emitter's own carrier [√W]; None: silent.
        """
        ...


class Reflection(Protocol):
    """What a reflector returns: its re-radiation factor r(t).

    The field it scatters is r(t)·incident(t). Optionally ``reradiation_terms`` → ``(A_s, Γ)``
    when r(t) = A_s − Γ(t) (a chip's reflection states behind the antenna's structural mode),
    which lets the step form r(t)·g·x and its backward link in one pass.

    Attributes
    ----------
    scatters : bool
        False when the reflector scatters nothing.
    constant_reradiation : complex or None
        r as one complex number when it does not change during the segment, else None.
    """

    scatters: bool

    @property
    def constant_reradiation(self) -> complex | None:
        """r as one complex number when it does not change during the segment, else None."""
        ...

    def reradiation(self, n_samples: int) -> np.ndarray:
        """Return the re-radiation factor per sample.

        Parameters
        ----------
        n_samples : int
            Samples of the segment.

        Returns
        -------
        ndarray, shape (..., n_samples), complex
            r(t) per sample (dimensionless), broadcastable to the incident samples.
        """
        ...


@runtime_checkable
class Reflector(Protocol):
    """Anything that scatters what it receives: an antenna and a ``reflect`` method.

    It may keep state (a Gen2 state machine) and decide on its own schedule.

    Attributes
    ----------
    antenna : object
        The reflector's antenna.
    """

    antenna: Any

    def reflect(self, incident: Segment) -> Reflection | None:
        """React to the incident field.

        Parameters
        ----------
        incident : Segment
            The incident field on the step's time base, in the baseband of the reference carrier [√W].

        Returns
        -------
        Reflection or None
            What it scatters; None: nothing.
        """
        ...


@runtime_checkable
class Receiver(Protocol):
    """Anything that listens: antenna, noise power, carrier and a ``receive`` method.

    Optional: ``coupling(emitter) -> complex | None``, a direct coupling that replaces the
    channel's link from ``emitter`` (a reader's own TX→RX leakage).

    Attributes
    ----------
    antenna : object
        The receiver's antenna.
    noise_power_w : float
        Noise power at its input [W per complex sample].
    fc_hz : float or None
        Its carrier / LO [Hz]; None: the step's reference carrier.
    """

    antenna: Any
    noise_power_w: float
    fc_hz: float | None

    def receive(self, input: Segment) -> Any:
        """Decide on or measure the receiver's input.

        Parameters
        ----------
        input : Segment
            The superposition of everything plus the receiver's noise, in the baseband of its
            carrier [√W].

        Returns
        -------
        object
            The receiver's decisions or measurements.
        """
        ...


class Links(Protocol):
    """The channel as the step sees it: the paths of one antenna pair, or None (no link).

    The returned object (``rfsim.channels.PathSet``) offers ``method(bandwidth_hz, propagation)``
    ("narrowband"/"exact"), ``apply(x, *, fs_hz, fc_hz, t0_s, method)``, ``static`` (no Doppler)
    and ``constant_gain(fc_hz)`` (optionally ``narrowband_constant(fc_hz, bandwidth_hz,
    propagation)``: the constant of a narrowband static link or None, remembered).

    The step asks every link at its own start, ``t_s = t0_s``; the Doppler phases of the
    returned paths refer to that time (``rfsim.channels.Channel.link``: paths evaluated at t_s), so
    a moving link advances by 2π·f_D·(t − t0_s) over the step.
    """

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        """Return the propagation paths of one antenna pair.

        Parameters
        ----------
        tx, rx : object
            Transmitting and receiving antennas.
        fc_hz : float
            Carrier [Hz].
        t_s : float
            Time the paths are evaluated at [s] (the step's start).

        Returns
        -------
        PathSet-like or None
            The pair's paths, or None when the scene has no such link.
        """
        ...


@runtime_checkable
class ReflectorGroup(Protocol):
    """Many reflectors joined as one entry of the step (a tag population).

    Two ways to reflect: ``reflect_each`` (one segment per member) and ``reflect_scaled`` (one
    emitter, every link narrowband and static).

    Attributes
    ----------
    members : sequence
        The reflectors, in order; every per-reflector list of the step holds them in their place.
    antennas : tuple
        Their antennas.
    """

    members: Sequence
    antennas: tuple

    def reflect_each(self, incident: Sequence[Segment]) -> list:
        """Reflect member by member.

        Parameters
        ----------
        incident : sequence of Segment
            One incident segment per member.

        Returns
        -------
        list
            The members' reflections, in order (what each member's ``reflect`` returns).
        """
        ...

    def reflect_scaled(self, base: Segment, gains: Sequence[complex], fc_hz: float) -> Any:
        """Reflect all members at once when member j sees ``gains[j]·base``.

        Parameters
        ----------
        base : Segment
            The one emitter's segment.
        gains : sequence of complex
            Per member the forward link constant g_j.
        fc_hz : float
            Carrier of the incident field [Hz].

        Returns
        -------
        GroupReflection or None
            The group's reflection, or None when the group cannot answer so (the step then calls
            ``reflect_each``).
        """
        ...


class GroupReflection(Protocol):
    """What a group returns from ``reflect_scaled``.

    The members not in ``reactions`` are quiet (constant re-radiation r_j). It also offers
    ``powered`` and ``incident_power_dbm`` per member, ``len`` and ``[j]`` (member j's reflection).

    Attributes
    ----------
    reactions : dict
        {member index: its own :class:`Reflection`}, in member order: the members that
        reflected on their own.
    """

    reactions: dict

    def terms(self, backs: Sequence[complex]) -> tuple:
        """Form the quiet members' backscatter constants.

        Parameters
        ----------
        backs : sequence of complex
            Per member the backward link constant b_j.

        Returns
        -------
        tuple
            ``(terms, use)``: (n,) complex b_j·(r_j·g_j) (formed as the step forms them for one
            reflector) and the (n,) bool mask of the quiet members that scatter.
        """
        ...

    def __len__(self) -> int: ...

    def __getitem__(self, j: int) -> Any: ...


# ----------------------------------------------------------------------------- adapters


class FixedEmitter:
    """An emitter whose segment is already made (a reader's command segment).

    Parameters
    ----------
    antenna : object
        The antenna it radiates from.
    segment : Segment or object
        The segment, or an object with ``t0_s``, ``fs_hz``, ``fc_hz``, ``samples`` and optionally
        ``memo`` (a dict shared by every segment of these samples: it becomes the Segment's memo).
    device : object, optional
        The device behind it (lets a receiver recognise its own transmitter).
    """

    def __init__(self, antenna, segment, *, device=None):
        if not isinstance(segment, Segment):
            memo = getattr(segment, "memo", None)
            x = segment.samples
            if (type(x) is np.ndarray and x.dtype == np.complex128 and x.ndim >= 1 and x.shape[-1] >= 1
                    and segment.fs_hz > 0):  # valid as it is (a reader's read-only waveform): held, no checks
                segment = Segment.own(segment.t0_s, segment.fs_hz, segment.fc_hz, x)
            else:
                segment = Segment(segment.t0_s, segment.fs_hz, segment.fc_hz, x)
            if memo is not None:  # the made segment's shared memo (a reader's cached waveform)
                segment.memo = memo
        self.antenna, self.segment, self.device = antenna, segment, device

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> Segment:
        """Return the made segment, checked against the step's time base.

        Parameters
        ----------
        t0_s : float
            Start time of the step [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Samples of the step.

        Returns
        -------
        Segment
            The segment.

        Raises
        ------
        ConfigError
            The segment is not on that time base.
        """
        if not self.segment.same_time_base(t0_s, fs_hz, n_samples):
            raise ConfigError("air.emitters", self.segment,
                              f"a segment on the step's time base (t0 {t0_s} s, fs {fs_hz} Hz, {n_samples} samples)")
        return self.segment


class AntennaPort:
    """A receiver that only listens; ``receive`` returns its input segment.

    Parameters
    ----------
    antenna : object
        The antenna.
    noise_power_w : float, default 0.0
        Noise power [W per complex sample].
    fc_hz : float or None, default None
        Its carrier [Hz]; None: the step's reference carrier.
    """

    def __init__(self, antenna, noise_power_w: float = 0.0, fc_hz: float | None = None):
        self.antenna, self.noise_power_w, self.fc_hz = antenna, float(noise_power_w), fc_hz

    def receive(self, input: Segment) -> Segment:
        """Return the input segment unchanged.

        Parameters
        ----------
        input : Segment
            The receiver's input [√W].

        Returns
        -------
        Segment
            ``input``.
        """
        return input


class _Listening:
    """A device that offers only ``listen(samples, *, t0_s, fs_hz)`` as a reflector."""

    def __init__(self, device):
        self.device, self.antenna = device, device.antenna

    def reflect(self, incident: Segment):
        return self.device.listen(incident.samples, t0_s=incident.t0_s, fs_hz=incident.fs_hz)


def as_reflector(device):
    """Give a device the reflector role.

    Parameters
    ----------
    device : object
        A reflector (has ``reflect``), a :class:`ReflectorGroup`, or a device that only offers
        ``listen(samples, *, t0_s, fs_hz)``.

    Returns
    -------
    object
        ``device`` itself when it has ``reflect`` or ``reflect_scaled``, else a wrapper whose
        ``reflect`` calls its ``listen``.
    """
    return device if (hasattr(device, "reflect") or hasattr(device, "reflect_scaled")) else _Listening(device)
