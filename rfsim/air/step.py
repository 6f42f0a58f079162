"""The air interface: one propagation step for every emitter, reflector and receiver.

Every exchange in rfsim — a Gen2 command and its reply window, a sense-a-tag listening, an
exciter powering a tag-to-tag link — is one call of :func:`propagate` (DESIGN.md "The air
interface"). Devices join it through three small protocols, the channel through a fourth:

* an **emitter** (:class:`Emitter`: reader, exciter, SDR transceiver) produces a
  :class:`Segment` — start time, sample rate, its own carrier, complex baseband samples in
  √W at its antenna port — on the step's time base, or nothing (silent);
* a **reflector** (:class:`Reflector`: passive tag, sense-a-tag, autonomous tag) is given
  its incident segment and returns what it does with it (:class:`Reflection`): its
  re-radiation factor r(t) on the same time base (r = A_s − Γ(t): antenna structural mode
  and chip reflection states, rfsim.devices.tag), or None (it scatters nothing);
* a **receiver** (:class:`Receiver`: reader IQ, ST envelope chains, SDR IQ) is given its input
  segment (superposition of everything plus its noise) and returns its decisions or
  measurements;
* the **links** (:class:`Links`) give the propagation paths of one antenna pair
  (``paths(tx, rx, *, fc_hz, t_s)`` → a PathSet-like object, or None when the scene has no
  such link); :class:`LinkTable` builds them from a channel (``channel.link``) and holds one
  draw per pair for the step (reciprocal pairs share it: a monostatic round trip uses the
  same draw both ways).

Model (first-order backscatter). With emitter segments x_e(t) on carriers f_e, the field at
reflector j is (in the baseband of the step's reference carrier f_ref)

    inc_j(t) = Σ_e S_{f_e − f_ref}{ L_ej{x_e} }(t),

and receiver k (baseband of its own carrier f_k, default f_ref) gets

    y_k(t) = Σ_e S_{f_e − f_k}{ D_ek{x_e} }(t) + Σ_j Σ_e S_{f_e − f_k}{ L_jk{ r_j · L_ej{x_e} } }(t) + n_k(t),

with L{·} a link applied with the exact carrier phase of the emitter's carrier (the
PathSet's ``apply``: y = Σ_p g_p·e^{−j2π·f_e·τ_p}·e^{j2π·f_D,p·t}·x(t − τ_p), rfsim.channels.paths),
D_ek either the channel's link or, for a receiver sharing the emitter's antenna port, the
receiver's own ``coupling`` (a reader's TX→RX leakage), r_j the reflector's re-radiation
factor and n_k complex white Gaussian noise of power ``receiver.noise_power_w`` per sample
(kTB·F from :func:`rfsim.air.noise.thermal_noise_power_w`, which :mod:`rfsim.channels.noise` exports
with the other noise models; real part then imaginary part drawn from the step's ``rng``).

* **Carrier offsets.** S_Δ multiplies by e^{j2π·Δ·t} (t absolute time, phase reduced modulo
  one cycle): an emitter on another carrier appears shifted by the offset when |Δ| < fs/2,
  and is dropped otherwise — it lies outside the simulated band. Every drop is recorded in
  :attr:`AirResult.dropped` as ``(emitter index, "reflector"/"receiver", index, Δ [Hz])``.
* **Re-scattering neglected.** A reflector's re-radiation is not incident on other
  reflectors. Its size relative to the first-order field at reflector i is
  |r_j|·|h_ji| with h_ji the tag-to-tag amplitude gain, ≈ |r_j|·√(G_i·G_j)·λ/(4π·d_ij) in free
  space: with |r| ≤ 1 and dipoles (G = 1.64) at 915 MHz, −27 dB at d = 1 m, −21 dB at 0.5 m,
  −7 dB at 0.1 m (where the far-field estimate itself is no longer valid); the error it
  causes at a receiver is that fraction of tag i's own backscatter.
* **Narrowband, static links.** Where a link's envelope delays are negligible for the
  signal bandwidth (the link decides: ``paths.method(bandwidth_hz, propagation)``, the
  one rule of :func:`rfsim.channels.paths.propagation_method`) and none of its paths has a
  Doppler shift, it multiplies the segment by one complex constant a. The step keeps such
  incident fields as *scaled copies* (``Segment.scaled``: base segment and gain, samples
  formed only when asked), so a receiver's input becomes a·x(t) + Σ_i b_i·r_i(t)·x_i(t): a
  reflector that does not modulate (constant r) adds one complex constant to the factor of
  x, not a full-length pass; only modulating reflectors cost a pass each.
* **Groups.** A :class:`ReflectorGroup` (a tag population) joins as one entry for its
  members. When every member sees a scaled copy g_j·x of the one emitter's segment and
  every backward link has a held constant b_j, the group decides for all members at once
  (``reflect_scaled``): the quiet members add Σ_j b_j·(r_j·g_j) to the factor of x — the
  same products, added one after the other in member order, as member-by-member — and
  only the members that react go through their own ``reflect``. Otherwise the members
  reflect one by one (``reflect_each``).
* **Batch.** Segment samples may carry leading batch dimensions, ``(..., n)``: B
  independent trials on the same links (e.g. noise draws) run in one step. Reflectors then
  see batched incident segments and return factors broadcastable to them.

Bad input gives one-line :class:`rfsim.core.errors.ConfigError` messages naming the key: an empty
device list (``air.emitters``), a segment off the step's time base, two antennas at distance 0
(``<device>.position_m``), a pair without a link (``air.links``).
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.air.noise import add_awgn, skip_awgn

_ak = lazy_import("rfsim.air._step_kernels")

__all__ = ["Segment", "Emitter", "Reflector", "Reflection", "Receiver", "Links", "LinkTable",
           "ReflectorGroup", "GroupReflection", "members_of",
           "FixedEmitter", "AntennaPort", "AirResult", "as_reflector", "propagate", "carrier_shift",
           "PROPAGATION_METHODS"]

#: Propagation policies a link understands (``"auto"``: narrowband where the link says so).
PROPAGATION_METHODS = ("auto", "exact", "narrowband")


# ----------------------------------------------------------------------------- segment


class Segment:
    """A waveform segment: complex baseband samples in √W on a carrier.

    Parameters
    ----------
    t0_s : absolute time of sample 0 [s]
    fs_hz : sample rate [Hz]
    fc_hz : carrier frequency of the baseband [Hz]
    samples : (..., n) complex128 [√W] (leading batch dimensions allowed), or None together
        with ``base``/``gain``
    base, gain : a scaled copy ``gain · base.samples`` (``Segment.scaled``), formed only when
        :attr:`samples` is read

    ``memo`` is a dict for data derived from the samples that several devices share (a
    reflector's decoding of a segment it sees scaled copies of); it belongs to the segment.
    """

    __slots__ = ("t0_s", "fs_hz", "fc_hz", "_samples", "base", "gain", "memo", "n_samples")

    def __init__(self, t0_s: float, fs_hz: float, fc_hz: float, samples=None, *, base: "Segment | None" = None,
                 gain: complex = 1.0):
        self.t0_s, self.fs_hz, self.fc_hz = float(t0_s), float(fs_hz), float(fc_hz)
        if not self.fs_hz > 0:
            raise ConfigError("segment.fs_hz", fs_hz, "a sample rate > 0 Hz")
        self.memo: dict = {}
        if base is not None:
            if samples is not None:
                raise ValueError("give samples or base, not both")
            while base.base is not None:  # a scaled copy of a scaled copy
                gain = gain * base.gain
                base = base.base
            self.base, self.gain, self._samples = base, complex(gain), None
            self.n_samples = base.n_samples
            return
        x = np.asarray(samples)
        if x.ndim < 1 or x.shape[-1] < 1:
            raise ConfigError("segment.samples", x.shape, "an array (..., n) with n ≥ 1 samples")
        if x.dtype != np.complex128:
            x = x.astype(np.complex128)
        self.base, self.gain, self._samples = None, 1.0 + 0j, x
        self.n_samples = int(x.shape[-1])

    @classmethod
    def scaled(cls, base: "Segment", gain: complex, fc_hz: float | None = None) -> "Segment":
        """``gain · base`` on the time base of ``base`` (samples formed lazily)."""
        if base.base is not None:
            return cls(base.t0_s, base.fs_hz, base.fc_hz if fc_hz is None else fc_hz, base=base, gain=gain)
        out = cls.__new__(cls)  # the hot path of the air step: no re-validation of a valid base
        out.t0_s, out.fs_hz, out.fc_hz = base.t0_s, base.fs_hz, base.fc_hz if fc_hz is None else float(fc_hz)
        out.base, out.gain, out._samples, out.memo, out.n_samples = base, complex(gain), None, {}, base.n_samples
        return out

    @property
    def samples(self) -> np.ndarray:
        """(..., n) complex128 [√W]."""
        if self._samples is None:
            self._samples = self.gain * self.base.samples
        return self._samples

    @property
    def batch_shape(self) -> tuple:
        """Leading (batch) dimensions of the samples."""
        src = self.base if self.base is not None else self
        return tuple(src._samples.shape[:-1])

    @property
    def end_s(self) -> float:
        """Time just after the last sample [s]."""
        return self.t0_s + self.n_samples / self.fs_hz

    def same_time_base(self, t0_s: float, fs_hz: float, n_samples: int) -> bool:
        return self.t0_s == float(t0_s) and self.fs_hz == float(fs_hz) and self.n_samples == int(n_samples)

    def __repr__(self) -> str:
        kind = "scaled" if self.base is not None else "samples"
        return (f"Segment(t0_s={self.t0_s!r}, fs_hz={self.fs_hz!r}, fc_hz={self.fc_hz!r}, "
                f"n_samples={self.n_samples}, {kind})")


# ----------------------------------------------------------------------------- protocols


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


# ----------------------------------------------------------------------------- helpers


class FixedEmitter:
    """An emitter whose segment is already made (a reader's command segment).

    Parameters
    ----------
    antenna : the antenna it radiates from
    segment : :class:`Segment` (or an object with ``t0_s``, ``fs_hz``, ``fc_hz``, ``samples``)
    device : the device behind it (lets a receiver recognise its own transmitter)
    """

    def __init__(self, antenna, segment, *, device=None):
        if not isinstance(segment, Segment):
            segment = Segment(segment.t0_s, segment.fs_hz, segment.fc_hz, segment.samples)
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


class LinkTable:
    """Links of one step drawn from a channel, one draw per antenna pair.

    Parameters
    ----------
    channel : object with ``link(tx, rx, *, fc_hz, rng, t_s, tx_motion, rx_motion)``
        (``rfsim.channels.Channel``)
    rng : generator for new draws (None: the channel's held draws)
    reciprocal : a pair's reverse link is the same draw (the same PathSet object), as for a
        reciprocal channel's monostatic round trip
    motions : optional ``{antenna: motion}`` (velocity (3,) m/s or trajectory), passed on

    Pairs are drawn in the order the step asks for them: every emitter → reflector link in
    reflector order, then per receiver the direct links and the reflector links.
    """

    def __init__(self, channel, *, rng: np.random.Generator | None = None, reciprocal: bool = True,
                 motions: dict | None = None):
        self.channel, self.rng, self.reciprocal = channel, rng, reciprocal
        self.motions = motions or {}
        self._held: dict = {}

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        key = (id(tx), id(rx), float(fc_hz))
        hit = self._held.get(key)
        if hit is None and self.reciprocal:
            hit = self._held.get((id(rx), id(tx), float(fc_hz)))
        if hit is None:
            kw = {}
            if self.motions.get(id(tx)) is not None:
                kw["tx_motion"] = self.motions[id(tx)]
            if self.motions.get(id(rx)) is not None:
                kw["rx_motion"] = self.motions[id(rx)]
            hit = self.channel.link(tx, rx, fc_hz=fc_hz, rng=self.rng, t_s=t_s, **kw)
            self._held[key] = (tx, rx, hit)  # the antennas are kept alive with their ids
            return hit
        return hit[2]


def carrier_shift(x: np.ndarray, offset_hz: float, *, t0_s: float, fs_hz: float) -> np.ndarray:
    """``x·e^{j2π·Δ·t}`` with t = t0 + n/fs absolute time (phase reduced modulo one cycle)."""
    n = x.shape[-1]
    cycles = np.mod(offset_hz * t0_s, 1.0) + np.mod(offset_hz / fs_hz, 1.0) * np.arange(n)
    return x * np.exp(2j * np.pi * np.mod(cycles, 1.0))


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


_antenna_of = operator.attrgetter("antenna")


def _check_positions(emitters: Sequence, reflector_antennas: Sequence, receivers: Sequence) -> None:
    """Distinct antennas at distance 0 have no far-field link: a one-line error.

    ``receivers`` sharing an emitter's antenna are not checked (a reader's own port). A set
    of antennas whose positions are read-only arrays (``rfsim.channels.Antenna``) is checked once
    and remembered by identity (a tuple of reflector antennas also by its own identity: a
    population's antennas are one tuple object, not compared antenna by antenna)."""
    emitter_ids = {id(e.antenna) for e in emitters}
    listening = [(k, r.antenna) for k, r in enumerate(receivers) if id(r.antenna) not in emitter_ids]
    ends = (tuple(id(e.antenna) for e in emitters), tuple(id(a) for _, a in listening))
    by_tuple = _POSITIONS_CHECKED_TUPLES.get(id(reflector_antennas)) if type(reflector_antennas) is tuple else None
    if by_tuple is not None and by_tuple[0] is reflector_antennas and by_tuple[1] == ends:
        return
    key = (ends[0], tuple(map(id, reflector_antennas)), ends[1])
    if key in _POSITIONS_CHECKED:
        _remember_tuple(reflector_antennas, ends, emitters, listening)
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
    if frozen:
        if len(_POSITIONS_CHECKED) >= 64:
            _POSITIONS_CHECKED.pop(next(iter(_POSITIONS_CHECKED)))
        _POSITIONS_CHECKED[key] = [a for _, a in named]  # kept alive: their ids stay theirs
        _remember_tuple(reflector_antennas, ends, emitters, listening)


def _remember_tuple(reflector_antennas, ends: tuple, emitters, listening) -> None:
    """Remember a checked tuple of reflector antennas by its identity, with the ids of the
    emitter and listening receiver antennas it was checked with (the tuple and those antennas
    kept alive: their ids stay their own)."""
    if type(reflector_antennas) is not tuple:
        return
    if len(_POSITIONS_CHECKED_TUPLES) >= 64:
        _POSITIONS_CHECKED_TUPLES.pop(next(iter(_POSITIONS_CHECKED_TUPLES)))
    _POSITIONS_CHECKED_TUPLES[id(reflector_antennas)] = (reflector_antennas, ends, [e.antenna for e in emitters],
                                                         [a for _, a in listening])


#: antenna-identity keys of position sets already checked (:func:`_check_positions`)
_POSITIONS_CHECKED: dict = {}
#: id of a checked tuple of reflector antennas -> (the tuple, its emitter and receiver antenna ids, those antennas)
_POSITIONS_CHECKED_TUPLES: dict = {}


# ----------------------------------------------------------------------------- result


@dataclass(eq=False)
class AirResult:
    """What one step produced.

    Attributes
    ----------
    segments : per emitter its :class:`Segment` (None: silent)
    incident : per reflector its incident :class:`Segment` (reference carrier)
    reflections : per reflector what ``reflect`` returned
    inputs : per receiver its input :class:`Segment` (noise included)
    outputs : per receiver what ``receive`` returned (None when ``decide=False``)
    dropped : ``(emitter, "reflector"|"receiver", index, offset_hz)`` of every contribution
        outside ±fs/2 of the receiving carrier (module docstring)
    fc_ref_hz : the reference carrier of the reflectors' incident segments [Hz]
    direct, backscatter, noise : with ``keep_components``: per receiver the emitters'
        contribution (n,), per reflector and receiver the backscatter (n,), per receiver
        the noise (n,) or None; all [√W]
    links : with ``keep_components``: ``{(kind, i, kind, k): paths}`` of every link used
    groups : ``[(start, GroupReflection)]`` of the groups that took the shortcut (their
        members' entries in ``incident`` and ``reflections`` are formed when read)
    """

    segments: list
    incident: list
    reflections: list
    inputs: list
    outputs: list
    dropped: list
    fc_ref_hz: float
    direct: list | None = None
    backscatter: list | None = None
    noise: list | None = None
    links: dict = field(default_factory=dict)
    groups: list = field(default_factory=list)


# ----------------------------------------------------------------------------- groups


def members_of(reflectors: Sequence) -> list:
    """The reflectors of a step with every :class:`ReflectorGroup` replaced by its members
    (the indices every per-reflector list of the step uses)."""
    return _entries(reflectors)[0]


def _entries(reflectors: Sequence) -> tuple[list, list]:
    """(members, entries): the flat member list and per given reflector ``(start, stop,
    group or None)``."""
    if len(reflectors) == 1 and hasattr(reflectors[0], "reflect_scaled"):
        grp = reflectors[0]
        return grp.members, [(0, len(grp.members), grp)]
    members, entries = [], []
    for r in reflectors:
        if hasattr(r, "reflect_scaled"):
            entries.append((len(members), len(members) + len(r.members), r))
            members.extend(r.members)
        else:
            entries.append((len(members), len(members) + 1, None))
            members.append(r)
    return members, entries


_UNSET = object()


class _PerMember(Sequence):
    """A per-member list of the step whose entries for the members of a group that took
    the shortcut (:meth:`ReflectorGroup.reflect_scaled`) are formed when first read."""

    def __init__(self, items: list, fill):
        self._items, self._fill = items, fill

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, j):
        if isinstance(j, slice):
            return [self[k] for k in range(*j.indices(len(self._items)))]
        j = range(len(self._items))[j]
        v = self._items[j]
        if v is _UNSET:
            v = self._items[j] = self._fill(j)
        return v


def _accumulate(start: complex, values: np.ndarray) -> complex:
    """``start + values[0] + values[1] + …`` added left to right (``numpy.add.accumulate`` is
    sequential: the same sums, in the same order, as a Python loop)."""
    acc = np.empty(values.size + 1, dtype=np.complex128)
    acc[0] = start
    acc[1:] = values
    return complex(np.add.accumulate(acc)[-1])


# ----------------------------------------------------------------------------- the step


def _constant(paths, fc_hz: float, bandwidth_hz: float, propagation: str, memo: dict):
    """The complex constant of a narrowband static link at ``fc_hz``, or None (the link's
    ``narrowband_constant`` when it has one, else from ``static``/``method``/``constant_gain``,
    remembered in ``memo`` for the step)."""
    f = getattr(paths, "narrowband_constant", None)
    if f is not None:
        return f(fc_hz, bandwidth_hz, propagation)
    key = (id(paths), fc_hz)
    hit = memo.get(key, memo)
    if hit is memo:
        hit = None
        if paths.static and paths.method(bandwidth_hz, propagation) == "narrowband":
            hit = paths.constant_gain(fc_hz)
        memo[key] = hit
    return hit


def _through(paths, seg: Segment, x: np.ndarray | None, *, fc_hz: float, bandwidth_hz: float,
             propagation: str, memo: dict) -> tuple:
    """``paths`` applied to ``x`` (default the segment's samples): ``(gain, None)`` for a
    narrowband static link (one constant), else ``(None, samples)``."""
    g = _constant(paths, fc_hz, bandwidth_hz, propagation, memo)
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


class _Backscatter:
    """The contribution b·((A_s − Γ(t))·(g·x(t))) of one modulating reflector at a receiver on
    the emitter's carrier (narrowband, static links g and b; re-radiation r = A_s − Γ), kept
    as its factors until the receiver's sum is formed (:func:`_fused_sum`)."""

    __slots__ = ("x", "g", "a_s", "gamma", "b")

    def __init__(self, x, g, a_s, gamma, b):
        self.x, self.g, self.a_s, self.gamma, self.b = x, g, a_s, gamma, b

    def samples(self) -> np.ndarray:
        """The contribution as the step's array operations form it (n,)."""
        return self.b * ((self.a_s - self.gamma) * (self.g * self.x))


def _lazy_backscatter(r, pj, seg: Segment, g, y, rc, off: float, n_samples: int, bw: float, propagation: str,
                      memo: dict):
    """A :class:`_Backscatter` for reflection ``r`` through backward link ``pj`` when the
    contribution has that form (one-dimensional samples, forward constant ``g``, backward
    constant, no carrier offset, r(t) = A_s − Γ(t) given by ``r.reradiation_terms``), else None."""
    if y is not None or rc is not None or off != 0.0 or g is None or np.ndim(g) != 0:
        return None
    terms = getattr(r, "reradiation_terms", None)
    if terms is None or seg.samples.ndim != 1 or terms[1].shape != (n_samples,) or np.ndim(terms[0]) != 0:
        return None
    b = _constant(pj, seg.fc_hz, bw, propagation, memo)
    if b is None or np.ndim(b) != 0:
        return None
    return _Backscatter(seg.samples, g, terms[0], terms[1], b)


def _fused_sum(const: dict, parts: list, segs: list, n_samples: int):
    """A receiver's constant-factor terms Σ_e a_e·x_e (in ``const`` order) and, when they are
    one term a·x and ``parts`` is one :class:`_Backscatter` of the same x, that part too, in
    one kernel pass (:mod:`rfsim.air._step_kernels`: the same products and sums as the array
    operations; ``parts`` is then emptied). None when ``const`` is empty."""
    if len(const) == 1 and len(parts) == 1 and isinstance(parts[0], _Backscatter):
        (i, a), = const.items()
        bs = parts[0]
        x = segs[i].samples
        if (x is bs.x and np.ndim(a) == 0 and x.dtype == np.complex128 and bs.gamma.dtype == np.complex128
                and _air_kernels_ok()):
            out = np.empty(n_samples, dtype=np.complex128)
            _ak.backscatter_kernel(x, complex(a), complex(bs.g), complex(bs.a_s), bs.gamma, complex(bs.b), out)
            parts.clear()
            return out
    y = None
    for i, a in const.items():
        v = a * segs[i].samples
        y = v if y is None else y + v
    return y


def _air_kernels_ok() -> bool:
    """The fused kernel reproduces NumPy's complex products here (:func:`rfsim.air._step_kernels.fused_matches_numpy`)."""
    return _ak.fused_matches_numpy()


def _link(links, tx, rx, *, fc_hz, t_s, what: str):
    p = links.paths(tx, rx, fc_hz=fc_hz, t_s=t_s)
    if p is None:
        raise ConfigError("air.links", what, "a link for every emitter → reflector/receiver and "
                                             "reflector → receiver pair")
    return p


def propagate(emitters: Sequence, reflectors: Sequence, receivers: Sequence, links, *, t0_s: float,
              fs_hz: float, n_samples: int, rng: np.random.Generator | None = None,
              fc_ref_hz: float | None = None, bandwidth_hz: float | None = None, propagation: str = "auto",
              decide: bool = True, keep_components: bool = False, skip_unmodulated: bool = False) -> AirResult:
    """Run one exchange through the air (module docstring): emit, propagate, reflect,
    superpose, add noise, receive.

    Parameters
    ----------
    emitters, reflectors, receivers : devices implementing :class:`Emitter`,
        :class:`Reflector`, :class:`Receiver` (reflectors and receivers may be empty)
    links : :class:`Links` (e.g. a :class:`LinkTable` over a ``rfsim.channels.Channel``)
    t0_s, fs_hz, n_samples : the time base of the step [s], [Hz], [samples]
    rng : generator of the receiver noise (needed when a receiver has noise)
    fc_ref_hz : carrier of the reflectors' baseband [Hz]; default the first emitting
        emitter's carrier
    bandwidth_hz : one-sided bandwidth B of the signals that matter, for the links'
        narrowband decision (Gen2: 2·BLF); default fs/2
    propagation : ``"auto"``, ``"exact"`` or ``"narrowband"`` (``rfsim.channels.paths``)
    decide : call every receiver's ``receive`` (else ``outputs`` holds None)
    keep_components : keep the direct, backscatter and noise parts per receiver
    skip_unmodulated : when no reflector modulates (every re-radiation is a constant: no tag
        replies), form no receiver input: every noisy receiver's noise is still drawn from
        ``rng`` in receiver order (the generator is left as adding it leaves it), ``inputs``
        and ``outputs`` hold None and ``dropped`` lists the reflectors' side only. For a
        caller that reads the inputs only when something modulates, and whose links draw
        nothing for the receivers' side (the engine: its backward links are drawn with the
        forward ones). Ignored with ``keep_components``.

    Returns
    -------
    :class:`AirResult`
    """
    if propagation not in PROPAGATION_METHODS:
        raise ConfigError("air.propagation", propagation, f"one of {PROPAGATION_METHODS}")
    emitters, reflectors, receivers = list(emitters), list(reflectors), list(receivers)
    if not emitters:
        raise ConfigError("air.emitters", [], "at least one emitter (a reader, an exciter, a transceiver)")
    n_samples, fs_hz, t0_s = int(n_samples), float(fs_hz), float(t0_s)
    if n_samples < 1:
        raise ConfigError("air.n_samples", n_samples, "at least 1 sample")
    bw = 0.5 * fs_hz if bandwidth_hz is None else float(bandwidth_hz)
    members, entries = _entries(reflectors)
    n_mem = len(members)
    member_antennas = (entries[0][2].antennas if len(entries) == 1 and entries[0][2] is not None
                       else tuple(map(_antenna_of, members)))
    _check_positions(emitters, member_antennas, receivers)
    segs = []
    for i, e in enumerate(emitters):
        s = e.emit(t0_s=t0_s, fs_hz=fs_hz, n_samples=n_samples)
        if s is not None and not s.same_time_base(t0_s, fs_hz, n_samples):
            raise ConfigError(f"air.emitters[{i}]", s, f"a segment on the step's time base ({t0_s} s, "
                                                        f"{fs_hz} Hz, {n_samples} samples)")
        segs.append(s)
    live = [(i, s) for i, s in enumerate(segs) if s is not None]
    if fc_ref_hz is None:
        fc_ref_hz = live[0][1].fc_hz if live else float("nan")
    half = 0.5 * fs_hz
    dropped: list = []
    used: dict = {}
    memo: dict = {}  # narrowband constants of the links used in this step

    def shift(y, offset):
        return y if offset == 0.0 else carrier_shift(y, offset, t0_s=t0_s, fs_hz=fs_hz)

    # 1. incident field at every reflector, kept per emitter in the emitter's own baseband
    #    (for the backscatter), and what the reflector does with it
    incident, reflections, per_emitter = [_UNSET] * n_mem, [_UNSET] * n_mem, [None] * n_mem
    shortcut: dict = {}  # start of a group -> its GroupReflection (the group took the shortcut)
    # one emitter on the reference carrier (a reader's exchange): the loop below without the
    # carrier bookkeeping — the same links asked in the same order, the same arithmetic
    single = live[0] if (len(live) == 1 and live[0][1].fc_hz == fc_ref_hz) else None
    gains = None
    if single is not None:
        i0, seg0 = single
        e_ant, fc0 = emitters[i0].antenna, seg0.fc_hz
        held = getattr(links, "held_constants", None)
        if held is not None and not keep_components and members:
            gains = held(e_ant, member_antennas, fc_hz=fc0, bandwidth_hz=bw, propagation=propagation,
                         inbound=False)
    for start, stop, grp in entries:
        if grp is not None and gains is not None:
            g_part = gains if (start == 0 and stop == n_mem) else gains[start:stop]
            gr = grp.reflect_scaled(seg0, g_part, fc_ref_hz)
            if gr is not None:  # every member sees gains[j]·x: the group answers at once
                shortcut[start] = gr
                continue
        for j in range(start, stop):
            refl = members[j]
            if single is not None:
                if gains is not None:  # every link held, narrowband and static: its constant, remembered
                    g, y = gains[j], None
                else:
                    p = links.paths(e_ant, refl.antenna, fc_hz=fc0, t_s=t0_s)
                    if p is None:
                        _link(links, e_ant, refl.antenna, fc_hz=fc0, t_s=t0_s, what=f"emitter[{i0}] → reflector[{j}]")
                    if keep_components:
                        used[("emitter", i0, "reflector", j)] = p
                    g, y = _through(p, seg0, None, fc_hz=fc0, bandwidth_hz=bw, propagation=propagation, memo=memo)
                per_emitter[j] = ((i0, seg0, g, y),)
                inc = Segment.scaled(seg0, g, fc_ref_hz) if g is not None else Segment(t0_s, fs_hz, fc_ref_hz, y)
            else:
                ant = refl.antenna
                comps = []  # (emitter index, segment, constant gain or None, samples or None)
                total = None  # a Segment (scaled copy) or an array
                for i, seg in live:
                    fc_e = seg.fc_hz
                    p = links.paths(emitters[i].antenna, ant, fc_hz=fc_e, t_s=t0_s)
                    if p is None:
                        _link(links, emitters[i].antenna, ant, fc_hz=fc_e, t_s=t0_s,
                              what=f"emitter[{i}] → reflector[{j}]")
                    if keep_components:
                        used[("emitter", i, "reflector", j)] = p
                    g, y = _through(p, seg, None, fc_hz=fc_e, bandwidth_hz=bw, propagation=propagation, memo=memo)
                    comps.append((i, seg, g, y))
                    off = fc_e - fc_ref_hz
                    if off != 0.0 and abs(off) >= half:
                        dropped.append((i, "reflector", j, off))
                        continue
                    if total is None and off == 0.0 and g is not None:
                        total = Segment.scaled(seg, g, fc_ref_hz)
                        continue
                    v = shift(y if y is not None else g * seg.samples, off)
                    total = v if total is None else (total.samples if isinstance(total, Segment) else total) + v
                if total is None:
                    inc = Segment(t0_s, fs_hz, fc_ref_hz, np.zeros(n_samples, dtype=np.complex128))
                elif isinstance(total, Segment):
                    inc = total
                else:
                    inc = Segment(t0_s, fs_hz, fc_ref_hz, total)
                per_emitter[j] = comps
            incident[j] = inc
            if grp is None:
                reflections[j] = refl.reflect(inc)
        if grp is not None:
            reflections[start:stop] = grp.reflect_each(incident[start:stop])

    def shortcut_of(j):
        for start, gr in shortcut.items():
            if start <= j < start + len(gr):
                return gr[j - start]
        raise IndexError(j)

    def comps_of(j):
        comps = per_emitter[j]
        return comps if comps is not None else ((i0, seg0, gains[j], None),)

    incident = _PerMember(incident, lambda j: Segment.scaled(seg0, gains[j], fc_ref_hz))
    if skip_unmodulated and not keep_components and not _modulates(entries, reflections, shortcut):
        for rcv in receivers:  # silent air: nobody reads these inputs, the noise draws are made
            if float(rcv.noise_power_w) > 0:
                if rng is None:
                    raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
                skip_awgn(n_samples, rng)
        none = [None] * len(receivers)
        return AirResult(segments=segs, incident=incident, reflections=_PerMember(reflections, shortcut_of),
                         inputs=none, outputs=list(none), dropped=dropped, fc_ref_hz=float(fc_ref_hz),
                         groups=sorted(shortcut.items()))
    reflections = _PerMember(reflections, shortcut_of)

    # 2. every receiver: direct paths (or coupling), backscatter, noise
    inputs, outputs = [], []
    direct_l = [] if keep_components else None
    back_l = [[None] * len(receivers) for _ in members] if keep_components else None
    noise_l = [] if keep_components else None
    for k, rcv in enumerate(receivers):
        fc_k = rcv.fc_hz if getattr(rcv, "fc_hz", None) is not None else fc_ref_hz
        r_ant = rcv.antenna
        coupling = getattr(rcv, "coupling", None)
        const: dict = {}  # emitter index -> complex factor of x_e (narrowband, static contributions)
        parts: list = []  # full-length contributions, added after the constants in this order
        for i, seg in live:
            off = seg.fc_hz - fc_k
            if off != 0.0 and abs(off) >= half:
                dropped.append((i, "receiver", k, off))
                continue
            c = coupling(emitters[i]) if coupling is not None else None
            if c is not None:
                if off == 0.0:
                    const[i] = const.get(i, 0j) + c
                else:
                    parts.append(shift(c * seg.samples, off))
                continue
            p = _link(links, emitters[i].antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s,
                      what=f"emitter[{i}] → receiver[{k}]")
            if keep_components:
                used[("emitter", i, "receiver", k)] = p
            g, y = _through(p, seg, None, fc_hz=seg.fc_hz, bandwidth_hz=bw, propagation=propagation, memo=memo)
            if g is not None and off == 0.0:
                const[i] = const.get(i, 0j) + g
            else:
                parts.append(shift(y if y is not None else g * seg.samples, off))
        if keep_components:
            d = np.zeros(n_samples, dtype=np.complex128)
            for i, g in const.items():
                d = d + g * segs[i].samples
            for v in parts:
                d = d + v
            direct_l.append(d)
        backs = None  # the held constants of the reflector → receiver links (as ``gains`` above)
        if single is not None and gains is not None:
            backs = held(r_ant, member_antennas, fc_hz=fc0, bandwidth_hz=bw, propagation=propagation, inbound=True)
        for start, stop, grp in entries:
            gr = shortcut.get(start) if grp is not None else None
            if gr is not None and backs is not None and seg0.fc_hz == fc_k:
                _group_backscatter(gr, start, stop == n_mem and start == 0, gains, backs, members, r_ant, seg0,
                                   links, const, parts, i0=i0, t0_s=t0_s, n_samples=n_samples, bw=bw,
                                   propagation=propagation, memo=memo)
                continue
            for j in range(start, stop):
                refl = members[j]
                r = reflections[j]
                comps = comps_of(j)
                if single is not None and not keep_components:
                    # one emitter on the reference carrier: the general branch below, shortened
                    i, seg, g, y = comps[0]
                    if backs is not None:
                        pj = None
                    else:
                        pj = links.paths(refl.antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
                        if pj is None:
                            _link(links, refl.antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s,
                                  what=f"reflector[{j}] → receiver[{k}]")
                    if r is None or not r.scatters:
                        continue
                    off = seg.fc_hz - fc_k
                    if off != 0.0 and abs(off) >= half:
                        continue
                    rc = r.constant_reradiation
                    if rc is not None and g is not None and off == 0.0:
                        b = backs[j] if backs is not None else _constant(pj, seg.fc_hz, bw, propagation, memo)
                        if b is not None:  # a reflector that does not modulate: one constant, no pass
                            const[i] = const.get(i, 0j) + b * (rc * g)
                            continue
                    if pj is None:
                        pj = links.paths(refl.antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
                    lazy = _lazy_backscatter(r, pj, seg, g, y, rc, off, n_samples, bw, propagation, memo)
                    if lazy is not None:  # b·((A_s − Γ)·(g·x)): formed with the sum below
                        parts.append(lazy)
                        continue
                    inc_e = y if y is not None else g * seg.samples
                    scattered = (rc * inc_e) if rc is not None else r.reradiation(n_samples) * inc_e
                    gb, yb = _through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=bw, propagation=propagation,
                                      memo=memo)
                    parts.append(shift(yb if yb is not None else gb * scattered, off))
                    continue
                # the links are asked for whatever the reflector does (the draws do not depend on it)
                pj = fc_j = None
                for i, seg, g, y in comps:
                    if seg.fc_hz != fc_j:
                        fc_j = seg.fc_hz
                        pj = links.paths(refl.antenna, r_ant, fc_hz=fc_j, t_s=t0_s)
                        if pj is None:
                            _link(links, refl.antenna, r_ant, fc_hz=fc_j, t_s=t0_s,
                                  what=f"reflector[{j}] → receiver[{k}]")
                        if keep_components:
                            used[("reflector", j, "receiver", k)] = pj
                part = None
                if r is not None and r.scatters:
                    rc = r.constant_reradiation
                    r_t = None if rc is not None else r.reradiation(n_samples)
                    multi = len(comps) > 1
                    for i, seg, g, y in comps:
                        off = seg.fc_hz - fc_k
                        if off != 0.0 and abs(off) >= half:
                            continue
                        if multi:
                            pj = links.paths(refl.antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
                        if rc is not None and g is not None and off == 0.0 and not keep_components:
                            b = _constant(pj, seg.fc_hz, bw, propagation, memo)
                            if b is not None:  # a reflector that does not modulate: one constant, no pass
                                const[i] = const.get(i, 0j) + b * (rc * g)
                                continue
                        inc_e = y if y is not None else g * seg.samples
                        scattered = (rc * inc_e) if rc is not None else r_t * inc_e
                        gb, yb = _through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=bw,
                                          propagation=propagation, memo=memo)
                        v = shift(yb if yb is not None else gb * scattered, off)
                        parts.append(v)
                        if keep_components:
                            part = v if part is None else part + v
                if keep_components:
                    back_l[j][k] = np.zeros(n_samples, dtype=np.complex128) if part is None else part
        y = _fused_sum(const, parts, segs, n_samples)
        for v in parts:
            if isinstance(v, _Backscatter):
                v = v.samples()
            if y is None:
                y = np.array(v, dtype=np.complex128)
            elif y.shape == v.shape:
                y += v
            else:
                y = y + v
        if y is None:
            y = np.zeros(n_samples, dtype=np.complex128)
        noise_w = float(rcv.noise_power_w)
        n_k = None
        if noise_w > 0:
            if rng is None:
                raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
            # complex white noise √(N/2)·(a + j·b): every a then every b drawn from rng
            ab = add_awgn(y, noise_w, rng, keep=keep_components)
            if keep_components:
                n_k = ab[0] + 1j * ab[1]
        if keep_components:
            noise_l.append(n_k)
        seg_k = Segment(t0_s, fs_hz, fc_k, y)
        inputs.append(seg_k)
        outputs.append(rcv.receive(seg_k) if decide else None)
    return AirResult(segments=segs, incident=incident, reflections=reflections, inputs=inputs, outputs=outputs,
                     dropped=dropped, fc_ref_hz=float(fc_ref_hz), direct=direct_l, backscatter=back_l,
                     noise=noise_l, links=used, groups=sorted(shortcut.items()))


def _modulates(entries: list, reflections: list, shortcut: dict) -> bool:
    """Whether any reflection of the step (of a group that took the shortcut: its reactions,
    its quiet members being constant) scatters a field that is not a constant multiple of its
    incident one."""
    for start, stop, _ in entries:
        gr = shortcut.get(start)
        for r in (gr.reactions.values() if gr is not None else reflections[start:stop]):
            if r is not None and r.scatters and r.constant_reradiation is None:
                return True
    return False


def _group_backscatter(gr, start: int, whole: bool, gains, backs, members, r_ant, seg, links, const: dict,
                       parts: list, *, i0: int, t0_s: float, n_samples: int, bw: float, propagation: str,
                       memo: dict) -> None:
    """A group that took the shortcut, at a receiver on the emitter's carrier with held
    backward constants ``backs``: its quiet members' held constants b_j·(r_j·g_j) and its
    reacting members' contributions, in member order (the per-member branch of
    :func:`propagate`, members added to the factor of x one after the other)."""
    terms, use = gr.terms(backs if whole else backs[start:start + len(gr)])
    vals = None
    for jl, r in gr.reactions.items():
        j = start + jl
        if r is None or not r.scatters:
            continue
        rc = r.constant_reradiation
        g = gains[j]
        if rc is not None and backs[j] is not None:  # a reflector that does not modulate: one constant
            if vals is None:
                vals, use = terms.copy(), use.copy()
            vals[jl] = backs[j] * (rc * g)
            use[jl] = True
            continue
        pj = links.paths(members[j].antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
        inc_e = g * seg.samples
        scattered = (rc * inc_e) if rc is not None else r.reradiation(n_samples) * inc_e
        gb, yb = _through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=bw, propagation=propagation, memo=memo)
        parts.append(yb if yb is not None else gb * scattered)
    vals = terms if vals is None else vals
    if use.any():
        const[i0] = _accumulate(const.get(i0, 0j), vals[use])
