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
with the other noise models; real part then imaginary part drawn from the step's ``rng``, or,
with the run's strategy ``noise="counter"``, from the counter-based stream of one key drawn
from ``rng`` and only from the receiver's ``first_read_sample`` on: :mod:`rfsim.air.noise`).

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

This module holds the step (:func:`propagate`) as six stages, each a function of its own
sharing one :class:`StepState`: :func:`emit` → :func:`draw_links` → :func:`reflect` → (per
receiver) :func:`superpose` → :func:`noise` → :func:`receive`; and its result
(:class:`AirResult`). Its parts live beside it and are importable from here:
:mod:`rfsim.air.segment` (:class:`Segment`, :func:`carrier_shift`), :mod:`rfsim.air.roles`
(the protocols and adapters), :mod:`rfsim.air.links` (:class:`LinkTable`, a link applied,
the position check), :mod:`rfsim.air.groups` (members of reflector groups),
:mod:`rfsim.air.fused` (the fused backscatter fast path) and :mod:`rfsim.air.cache` (the run's
:class:`AirCache`: its explicit fast-path :class:`Strategy` and what the step reuses between
calls). :mod:`rfsim.air.batch` runs B prepared steps as one batch.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.air.cache import AirCache, Strategy
from rfsim.air.noise import add_counter_awgn, add_receiver_noise, noise_key, skip_receiver_noise
from rfsim.air.segment import Segment, carrier_shift
from rfsim.air.roles import (AntennaPort, Emitter, FixedEmitter, GroupReflection, Links, Receiver, Reflection,
                             Reflector, ReflectorGroup, as_reflector)
from rfsim.air.links import PROPAGATION_METHODS, LinkTable, check_positions, link_constant, require_link, through
from rfsim.air.groups import UNSET, PerMember, entries_of, group_backscatter, members_of, modulates
from rfsim.air.fused import Backscatter, fused_noisy_sum, fused_sum, lazy_backscatter

__all__ = ["Segment", "Emitter", "Reflector", "Reflection", "Receiver", "Links", "LinkTable",
           "ReflectorGroup", "GroupReflection", "members_of",
           "FixedEmitter", "AntennaPort", "AirResult", "as_reflector", "propagate", "carrier_shift",
           "PROPAGATION_METHODS", "AirCache", "Strategy", "StepState", "Incoming", "emit", "draw_links", "reflect",
           "superpose", "noise", "receive", "superpose_noise"]

_antenna_of = operator.attrgetter("antenna")


# ----------------------------------------------------------------------------- result


@dataclass(eq=False, slots=True)
class AirResult:
    """What one step produced.

    Attributes
    ----------
    segments : list
        Per emitter its :class:`Segment` (None: silent).
    incident : sequence
        Per reflector its incident :class:`Segment` (reference carrier).
    reflections : sequence
        Per reflector what ``reflect`` returned.
    inputs : list
        Per receiver its input :class:`Segment` (noise included).
    outputs : list
        Per receiver what ``receive`` returned (None when ``decide=False``).
    dropped : list of tuple
        ``(emitter, "reflector"|"receiver", index, offset_hz)`` of every contribution outside
        ±fs/2 of the receiving carrier (module docstring).
    fc_ref_hz : float
        The reference carrier of the reflectors' incident segments [Hz].
    direct, backscatter, noise : list or None
        With ``keep_components``: per receiver the emitters' contribution (n,), per reflector and
        receiver the backscatter (n,), per receiver the noise (n,) or None; all [√W].
    links : dict
        With ``keep_components``: ``{(kind, i, kind, k): paths}`` of every link used.
    groups : list
        ``[(start, GroupReflection)]`` of the groups that took the shortcut (their members'
        entries in ``incident`` and ``reflections`` are formed when read).
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


# ----------------------------------------------------------------------------- the step


def propagate(emitters: Sequence, reflectors: Sequence, receivers: Sequence, links, *, t0_s: float,
              fs_hz: float, n_samples: int, rng: np.random.Generator | None = None,
              fc_ref_hz: float | None = None, bandwidth_hz: float | None = None, propagation: str = "auto",
              decide: bool = True, keep_components: bool = False, skip_unmodulated: bool = False,
              cache: AirCache | None = None) -> AirResult:
    """Run one exchange through the air: emit, links, reflect, superpose, noise, receive.

    The model (first-order backscatter, carrier offsets, narrowband static links, groups,
    batch dimensions) is in the module docstring.

    Parameters
    ----------
    emitters : sequence of Emitter
        The emitting devices (at least one).
    reflectors : sequence of Reflector or ReflectorGroup
        The reflecting devices (may be empty).
    receivers : sequence of Receiver
        The listening devices (may be empty).
    links : Links
        The links (e.g. a :class:`LinkTable` over a ``rfsim.channels.Channel``).
    t0_s : float
        Start time of the step [s].
    fs_hz : float
        Sample rate [Hz].
    n_samples : int
        Samples of the step.
    rng : numpy.random.Generator or None, default None
        Generator of the receiver noise (needed when a receiver has noise).
    fc_ref_hz : float or None, default None
        Carrier of the reflectors' baseband [Hz]; None: the first emitting emitter's carrier.
    bandwidth_hz : float or None, default None
        One-sided bandwidth B of the signals that matter, for the links' narrowband decision
        (Gen2: 2·BLF) [Hz]; None: fs/2.
    propagation : {"auto", "exact", "narrowband"}, default "auto"
        Propagation policy (``rfsim.channels.paths``).
    decide : bool, default True
        Call every receiver's ``receive`` (else ``outputs`` holds None).
    keep_components : bool, default False
        Keep the direct, backscatter and noise parts per receiver.
    skip_unmodulated : bool, default False
        When no reflector modulates (every re-radiation is a constant: no tag replies), form no
        receiver input: every noisy receiver's noise is still drawn from ``rng`` in receiver
        order (the generator is left as adding it leaves it), ``inputs`` and ``outputs`` hold
        None and ``dropped`` lists the reflectors' side only. For a caller that reads the inputs
        only when something modulates, and whose links draw nothing for the receivers' side
        (the engine: its backward links are drawn with the forward ones). Ignored with
        ``keep_components``.
    cache : AirCache or None, default None
        The run's :class:`rfsim.air.cache.AirCache` (its fast-path strategy and what the step
        reuses between calls); None: a new one for this call (the default strategy, nothing
        reused).

    Returns
    -------
    AirResult
        Segments, incident fields, reflections, receiver inputs and outputs of the step: every
        segment's samples (…, n) complex128 [√W] on the step's time base (n = ``n_samples``,
        leading batch dimensions as the emitters' segments have them).

    Raises
    ------
    ConfigError
        An unknown ``propagation``, an empty emitter list, ``n_samples`` < 1, a segment off the
        step's time base, two antennas at distance 0, a pair without a link, or a receiver with
        noise and no ``rng``.

    Notes
    -----
    The body is the six stages in order, each a function of this module sharing one
    :class:`StepState`: :func:`emit` (the emitters' segments), :func:`draw_links` (the links
    into the reflectors), :func:`reflect` (the incident fields and the reflectors' reactions),
    then per receiver :func:`superpose` (its links, direct paths and backscatter summed),
    :func:`noise` and :func:`receive`. The fast paths are branches chosen by data the step is
    given (one emitter with held link constants, a group that answers at once) or by the run's
    :class:`Strategy` (``cache.strategy``: the fused backscatter sum, the noise generator).
    """
    receivers = list(receivers)
    st = _begin(emitters, reflectors, receivers, links, t0_s=t0_s, fs_hz=fs_hz, n_samples=n_samples,
                bandwidth_hz=bandwidth_hz, propagation=propagation, keep=keep_components,
                cache=AirCache() if cache is None else cache)
    emit(st, fc_ref_hz)
    draw_links(st)
    reflect(st)
    if skip_unmodulated and not keep_components and not modulates(st.entries, st.reacted, st.shortcut):
        return _unheard(st, receivers, rng)
    compiled = st.cache.strategy.exchange == "compiled" and not keep_components
    for k, rcv in enumerate(receivers):
        if compiled:
            seg_k = superpose_noise(st, k, rcv, rng)
        else:
            seg_k = superpose(st, k, rcv)
            noise(st, seg_k, rcv, rng)
        receive(st, rcv, seg_k, decide=decide)
    return AirResult(segments=st.segs, incident=st.incident, reflections=st.reflections, inputs=st.inputs,
                     outputs=st.outputs, dropped=st.dropped, fc_ref_hz=float(st.fc_ref_hz), direct=st.direct_l,
                     backscatter=st.back_l, noise=st.noise_l, links=st.used,
                     groups=sorted(st.shortcut.items()) if st.shortcut else [])


class Incoming(NamedTuple):
    """A member's incident field from one emitter, in the emitter's own baseband.

    Attributes
    ----------
    emitter : int
        Index of the emitter.
    segment : Segment
        The emitter's segment x_e, samples (…, n) complex128 [√W].
    gain : complex or None
        The link's constant g (narrowband, static): the field is g·x_e; None: see ``samples``.
    samples : ndarray or None
        The field L{x_e}, (…, n) complex128 [√W], when the link is not one constant.
    """

    emitter: int
    segment: Segment
    gain: complex | None
    samples: np.ndarray | None


class StepState:
    """What the stages of one :func:`propagate` call share.

    Attributes
    ----------
    emitters, links, t0_s, fs_hz, n_samples, keep, cache
        The step's arguments (``keep``: ``keep_components``; ``cache``: the run's
        :class:`rfsim.air.cache.AirCache`).
    bw, propagation, half, memo
        The links' policy: bandwidth [Hz], propagation method, fs/2 [Hz] and the step's memo of
        narrowband link constants (keyed by ``(id(paths), fc_hz)``: every such paths object is
        held by the links for the step).
    members, entries, member_antennas
        The reflectors' flat member list, ``(start, stop, group or None)`` per given reflector,
        and the members' antennas.
    segs, live, fc_ref_hz, single, i0, seg0
        :func:`emit`: per emitter its segment (None: silent), the ``(index, segment)`` of the
        live ones, the reference carrier [Hz], and ``(i0, seg0)`` when one emitter emits on it.
    held, gains, per_emitter
        :func:`draw_links`: the links' ``held_constants`` (or None), the held forward constants
        (n_members,) complex (or None) and per member its :class:`Incoming` fields (None: the
        one emitter's scaled copy ``gains[j]·x``).
    incident, reacted, reflections, shortcut
        :func:`reflect`: per member its incident segment and its reflection (raw list, and the
        list itself or, when a group took the shortcut, the :class:`rfsim.air.groups.PerMember`
        view that forms a shortcut member's entry when read),
        and group start → the :class:`GroupReflection` of the groups that answered at once.
    inputs, outputs, direct_l, back_l, noise_l, dropped, used
        The result being formed (:class:`AirResult` fields; the components only with ``keep``).
    """

    __slots__ = ("emitters", "links", "t0_s", "fs_hz", "n_samples", "bw", "propagation", "keep", "half",
                 "members", "entries", "member_antennas", "segs", "live", "fc_ref_hz", "single", "i0", "seg0",
                 "held", "gains", "dropped", "used", "memo", "incident", "reacted", "reflections", "per_emitter",
                 "shortcut", "cache", "inputs", "outputs", "direct_l", "back_l", "noise_l")

    def shift(self, y, offset_hz: float):
        """Return ``y`` moved by a carrier offset.

        Parameters
        ----------
        y : ndarray
            Samples (…, n) complex128 [√W] on the step's time base.
        offset_hz : float
            The offset [Hz].

        Returns
        -------
        ndarray
            :func:`carrier_shift` of ``y`` (``y`` itself at offset 0).
        """
        return y if offset_hz == 0.0 else carrier_shift(y, offset_hz, t0_s=self.t0_s, fs_hz=self.fs_hz)

    def shortcut_of(self, j: int):
        """Return member j's reflection inside the group that answered at once.

        Parameters
        ----------
        j : int
            Member index.

        Returns
        -------
        Reflection or None
            The member's reflection from its group's :class:`GroupReflection`.
        """
        return _shortcut_member(self.shortcut, j)

    def comps_of(self, j: int):
        """Return member j's incident fields per emitter.

        Parameters
        ----------
        j : int
            Member index.

        Returns
        -------
        tuple of Incoming
            Its fields (a shortcut member: the one emitter's scaled copy ``gains[j]·x``).
        """
        comps = self.per_emitter[j]
        return comps if comps is not None else (Incoming(self.i0, self.seg0, self.gains[j], None),)


def _begin(emitters, reflectors, receivers: list, links, *, t0_s, fs_hz, n_samples, bandwidth_hz, propagation,
           keep: bool, cache: AirCache) -> StepState:
    """The arguments checked (one-line errors), the reflectors' members and entries, no two
    antennas at one position, the result's lists."""
    if propagation not in PROPAGATION_METHODS:
        raise ConfigError("air.propagation", propagation, f"one of {PROPAGATION_METHODS}")
    emitters, reflectors = list(emitters), list(reflectors)
    if not emitters:
        raise ConfigError("air.emitters", [], "at least one emitter (a reader, an exciter, a transceiver)")
    st = StepState()
    st.n_samples, st.fs_hz, st.t0_s = int(n_samples), float(fs_hz), float(t0_s)
    if st.n_samples < 1:
        raise ConfigError("air.n_samples", st.n_samples, "at least 1 sample")
    st.bw = 0.5 * st.fs_hz if bandwidth_hz is None else float(bandwidth_hz)
    st.members, st.entries = entries_of(reflectors)
    entries = st.entries
    st.member_antennas = (entries[0][2].antennas if len(entries) == 1 and entries[0][2] is not None
                          else tuple(map(_antenna_of, st.members)))
    check_positions(emitters, st.member_antennas, receivers, cache)
    st.cache = cache
    st.emitters, st.links, st.propagation, st.keep = emitters, links, propagation, keep
    st.half = 0.5 * st.fs_hz
    st.dropped, st.used, st.memo = [], {}, {}
    st.inputs, st.outputs = [], []
    st.direct_l = [] if keep else None
    st.back_l = [[None] * len(receivers) for _ in st.members] if keep else None
    st.noise_l = [] if keep else None
    return st


def emit(st: StepState, fc_ref_hz: float | None) -> list:
    """Stage 1, emit: every emitter's segment on the step's time base.

    Parameters
    ----------
    st : StepState
        The step (its ``emitters`` and time base ``t0_s``, ``fs_hz``, ``n_samples`` = n).
    fc_ref_hz : float or None
        The reflectors' reference carrier [Hz]; None: the first live emitter's.

    Returns
    -------
    list of Segment or None
        Per emitter its segment on its own carrier, samples (…, n) complex128 [√W] (None:
        silent); also ``st.segs``, with ``st.live``, ``st.fc_ref_hz`` and, for one emitter on the
        reference carrier (a reader's exchange), ``st.single = (i0, seg0)``.

    Raises
    ------
    ConfigError
        A segment off the step's time base.
    """
    segs, live = [], []
    for i, e in enumerate(st.emitters):
        s = e.emit(t0_s=st.t0_s, fs_hz=st.fs_hz, n_samples=st.n_samples)
        segs.append(s)
        if s is None:
            continue
        # (a FixedEmitter checks its made segment against the time base itself)
        if type(e) is not FixedEmitter and not s.same_time_base(st.t0_s, st.fs_hz, st.n_samples):
            raise ConfigError(f"air.emitters[{i}]", s, f"a segment on the step's time base ({st.t0_s} s, "
                                                        f"{st.fs_hz} Hz, {st.n_samples} samples)")
        live.append((i, s))
    st.segs, st.live = segs, live
    if fc_ref_hz is None:
        fc_ref_hz = live[0][1].fc_hz if live else float("nan")
    st.fc_ref_hz = fc_ref_hz
    st.single = single = live[0] if (len(live) == 1 and live[0][1].fc_hz == fc_ref_hz) else None
    st.i0, st.seg0 = single if single is not None else (None, None)
    return segs


def draw_links(st: StepState) -> list:
    """Stage 2, links: every emitter → reflector link, asked in member order, applied.

    For one emitter on the reference carrier whose links hold their constants
    (``links.held_constants``: narrowband and static, e.g. the engine's), the forward links are
    those constants, (n_members,) complex, and nothing is applied; otherwise every member's
    link from every live emitter is asked (drawn on first use) and applied in the emitter's
    own baseband (:func:`rfsim.air.links.through`: one constant for a narrowband static link).
    The receivers' links are asked by :func:`superpose`, receiver by receiver, before that
    receiver's noise: a generator shared by links and noise keeps that order.

    Parameters
    ----------
    st : StepState
        The step after :func:`emit`.

    Returns
    -------
    list
        Per member None (its field is ``st.gains[j]·x``, the held case) or a tuple of
        :class:`Incoming`, one per live emitter (gain, or samples (…, n) complex128 [√W]);
        also ``st.per_emitter``, with ``st.gains`` (the held constants or None). An emitter
        outside ±fs/2 of the reference carrier is recorded in ``st.dropped``.

    Raises
    ------
    ConfigError
        A pair without a link.
    """
    n_mem = len(st.members)
    st.per_emitter = [None] * n_mem
    st.held = st.gains = None
    if st.single is not None:
        st.held = getattr(st.links, "held_constants", None)
        if st.held is not None and not st.keep and st.members:
            st.gains = st.held(st.emitters[st.i0].antenna, st.member_antennas, fc_hz=st.seg0.fc_hz,
                               bandwidth_hz=st.bw, propagation=st.propagation, inbound=False)
    if st.gains is not None:  # every forward link a held constant: nothing to ask or apply
        return st.per_emitter
    sources = (st.single,) if st.single is not None else st.live
    for j, refl in enumerate(st.members):
        comps = []
        for i, seg in sources:
            fc_e, e_ant = seg.fc_hz, st.emitters[i].antenna
            p = st.links.paths(e_ant, refl.antenna, fc_hz=fc_e, t_s=st.t0_s)
            if p is None:
                require_link(st.links, e_ant, refl.antenna, fc_hz=fc_e, t_s=st.t0_s,
                             what=f"emitter[{i}] → reflector[{j}]")
            if st.keep:
                st.used[("emitter", i, "reflector", j)] = p
            g, y = through(p, seg, None, fc_hz=fc_e, bandwidth_hz=st.bw, propagation=st.propagation, memo=st.memo)
            comps.append(Incoming(i, seg, g, y))
            off = fc_e - st.fc_ref_hz
            if off != 0.0 and abs(off) >= st.half:
                st.dropped.append((i, "reflector", j, off))
        st.per_emitter[j] = tuple(comps)
    return st.per_emitter


def reflect(st: StepState) -> list:
    """Stage 3, reflect: every member's incident field and what the member does with it.

    A group whose members all see held scaled copies g_j·x of the one emitter answers at once
    (``reflect_scaled``: the shortcut); otherwise its members reflect together
    (``reflect_each``), a lone reflector on its own (``reflect``).

    Parameters
    ----------
    st : StepState
        The step after :func:`draw_links`.

    Returns
    -------
    sequence
        Per member its reflection (re-radiation factor r_j: a constant or (…, n) complex128; None:
        scatters nothing): a list, or, when a group took the shortcut, a
        :class:`rfsim.air.groups.PerMember` whose shortcut members' entries are formed when read;
        also ``st.reflections``, with ``st.incident`` (per member its incident segment on the
        reference carrier, samples (…, n) complex128 [√W], formed when read for a shortcut
        member) and ``st.shortcut`` (group start → GroupReflection).
    """
    n_mem = len(st.members)
    incident, reacted = [UNSET] * n_mem, [UNSET] * n_mem
    st.shortcut = {}
    members, gains, per_emitter = st.members, st.gains, st.per_emitter
    for start, stop, grp in st.entries:
        if grp is not None and gains is not None:
            g_part = gains if (start == 0 and stop == n_mem) else gains[start:stop]
            gr = grp.reflect_scaled(st.seg0, g_part, st.fc_ref_hz)
            if gr is not None:  # every member sees gains[j]·x: the group answers at once
                st.shortcut[start] = gr
                continue
        for j in range(start, stop):
            if gains is not None:  # the held constant: a scaled copy of the one emitter's segment
                # (on the reference carrier; its field for the later stages: StepState.comps_of)
                inc = incident[j] = Segment.scaled(st.seg0, gains[j], st.fc_ref_hz)
            else:
                inc = incident[j] = _incident(st, per_emitter[j])
            if grp is None:
                reacted[j] = members[j].reflect(inc)
        if grp is not None:
            reacted[start:stop] = grp.reflect_each(incident[start:stop])
    st.reacted = reacted
    if st.shortcut:  # a group answered at once: its members' entries are formed when read
        # (the fills hold what they read, not the step's state: no reference cycle through it)
        st.incident = PerMember(incident, functools.partial(_scaled_member, st.seg0, st.gains, st.fc_ref_hz))
        st.reflections = PerMember(reacted, functools.partial(_shortcut_member, st.shortcut))
    else:  # every entry is formed
        st.incident, st.reflections = incident, reacted
    return st.reflections


def _scaled_member(seg0: Segment, gains, fc_ref_hz: float, j: int) -> Segment:
    """Member j's incident field as the scaled copy ``gains[j]·seg0`` on the reference carrier."""
    return Segment.scaled(seg0, gains[j], fc_ref_hz)


def _shortcut_member(shortcut: dict, j: int):
    """Member j's reflection inside the group (start → GroupReflection in ``shortcut``) that
    answered at once."""
    for start, gr in shortcut.items():
        if start <= j < start + len(gr):
            return gr[j - start]
    raise IndexError(j)


def _incident(st: StepState, comps: tuple) -> Segment:
    """A member's incident segment on the reference carrier from its :class:`Incoming` fields:
    a lone constant on the reference carrier stays a scaled copy; otherwise each field (its
    samples, or g·x) shifted to the reference carrier (dropped outside ±fs/2) and summed."""
    total = None  # a Segment (scaled copy) or an array
    for i, seg, g, y in comps:
        off = seg.fc_hz - st.fc_ref_hz
        if off != 0.0 and abs(off) >= st.half:
            continue
        if total is None and off == 0.0 and g is not None:
            total = Segment.scaled(seg, g, st.fc_ref_hz)
            continue
        v = st.shift(y if y is not None else g * seg.samples, off)
        total = v if total is None else (total.samples if isinstance(total, Segment) else total) + v
    if total is None:
        return Segment(st.t0_s, st.fs_hz, st.fc_ref_hz, np.zeros(st.n_samples, dtype=np.complex128))
    if isinstance(total, Segment):
        return total
    return Segment(st.t0_s, st.fs_hz, st.fc_ref_hz, total)


def _unheard(st: StepState, receivers: list, rng) -> AirResult:
    """The result of a step in which nothing modulates (``skip_unmodulated``): no receiver
    input is formed, every noisy receiver's noise draws are still made, in receiver order."""
    for rcv in receivers:  # silent air: nobody reads these inputs, the noise draws are made
        if float(rcv.noise_power_w) > 0:
            if rng is None:
                raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
            skip_receiver_noise(st.n_samples, rng, method=st.cache.strategy.noise)
    none = [None] * len(receivers)
    return AirResult(segments=st.segs, incident=st.incident, reflections=st.reflections,
                     inputs=none, outputs=list(none), dropped=st.dropped, fc_ref_hz=float(st.fc_ref_hz),
                     groups=sorted(st.shortcut.items()))


def superpose(st: StepState, k: int, rcv) -> Segment:
    """Stage 4, superpose: receiver k's input without noise, y_k = Σ_e a_e·x_e + Σ parts.

    Receiver k's links are asked here, in order (the links from every live emitter, or the
    receiver's ``coupling`` when it shares the emitter's antenna; then the reflectors' links,
    :func:`_backscatter`); the narrowband static contributions on the receiver's carrier are
    summed as one complex factor a_e of x_e per emitter, the others as full-length parts,
    added after the constant terms in order (:func:`_sum_terms`, with the fused kernel where
    the run's strategy asks for it: ``Strategy.fused_backscatter``).

    Parameters
    ----------
    st : StepState
        The step after :func:`reflect`.
    k : int
        Index of the receiver.
    rcv : Receiver
        The receiver (its ``antenna``; optional ``fc_hz``, default the reference carrier, and
        ``coupling``).

    Returns
    -------
    Segment
        The receiver's input on its carrier, samples (…, n) complex128 [√W] (a new array, zeros
        when nothing arrives). With ``keep_components`` the direct and backscatter components
        (…, n) complex128 [√W] are appended to ``st.direct_l`` and ``st.back_l[j][k]``.
    """
    fc_k = rcv.fc_hz if getattr(rcv, "fc_hz", None) is not None else st.fc_ref_hz
    const, parts = _direct(st, k, rcv, fc_k)
    if st.keep:
        st.direct_l.append(_direct_component(st, const, parts))
    _backscatter(st, k, rcv.antenna, fc_k, const, parts, st.back_l)
    y = _sum_terms(const, parts, st.segs, st.n_samples, fused=st.cache.strategy.fused_backscatter)
    return Segment(st.t0_s, st.fs_hz, fc_k, y)


def superpose_noise(st: StepState, k: int, rcv, rng: np.random.Generator | None) -> Segment:
    """Stages 4 and 5 in one, the run's strategy ``exchange="compiled"``: receiver k's noisy input.

    The links are asked as in :func:`superpose`; then the noise key is drawn
    (:func:`rfsim.air.noise.noise_key`) and a static narrowband exchange — one constant term a·x
    and one modulating reflector with constant links — is formed with its noise on the samples
    the receiver reads (:func:`first_read` on) in one kernel call
    (:func:`rfsim.air.fused.fused_noisy_sum`). Any other sum is formed by :func:`superpose`'s
    terms and gets its noise from :func:`noise`. Either way the numbers are those of
    :func:`superpose` then :func:`noise` with ``Strategy(noise="counter")``.

    Parameters
    ----------
    st : StepState
        The step after :func:`reflect` (``keep_components`` off).
    k : int
        Index of the receiver.
    rcv : Receiver
        The receiver (``antenna``, ``noise_power_w`` [W]; optional ``fc_hz``, ``coupling``,
        ``first_read_sample``, ``input_array(n)``: an (n,) complex128 array to form the fused
        input in, or None).
    rng : numpy.random.Generator or None
        The step's generator (needed when the receiver has noise).

    Returns
    -------
    Segment
        The receiver's input with its noise, samples (…, n) complex128 [√W].

    Raises
    ------
    ConfigError
        A receiver with noise and no ``rng``.
    """
    fc_k = rcv.fc_hz if getattr(rcv, "fc_hz", None) is not None else st.fc_ref_hz
    const, parts = _direct(st, k, rcv, fc_k)
    _backscatter(st, k, rcv.antenna, fc_k, const, parts, None)
    noise_w = float(rcv.noise_power_w)
    if noise_w > 0:
        if rng is None:
            raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
        key, start = noise_key(rng), first_read(rcv, st.t0_s, st.fs_hz, st.n_samples)
        take = getattr(rcv, "input_array", None)  # where the receiver wants its input formed
        y = fused_noisy_sum(const, parts, st.segs, st.n_samples, noise_w, key, start,
                            None if take is None else take(st.n_samples))
        if y is None:
            y = _sum_terms(const, parts, st.segs, st.n_samples, fused=True)
            add_counter_awgn(y, noise_w, key, start=start)
        return Segment.own(st.t0_s, st.fs_hz, fc_k, y)
    return Segment.own(st.t0_s, st.fs_hz, fc_k, _sum_terms(const, parts, st.segs, st.n_samples, fused=True))


def _direct(st: StepState, k: int, rcv, fc_k: float) -> tuple[dict, list]:
    """Receiver k's direct contributions: ``(const, parts)`` — per emitter index the complex
    factor of x_e (narrowband, static contributions on the receiver's carrier; a coupling
    replaces the channel's link) and the full-length contributions (…, n) [√W], added after the
    constants in this order."""
    r_ant = rcv.antenna
    coupling = getattr(rcv, "coupling", None)
    const: dict = {}  # emitter index -> complex factor of x_e (narrowband, static contributions)
    parts: list = []  # full-length contributions, added after the constants in this order
    for i, seg in st.live:
        off = seg.fc_hz - fc_k
        if off != 0.0 and abs(off) >= st.half:
            st.dropped.append((i, "receiver", k, off))
            continue
        c = coupling(st.emitters[i]) if coupling is not None else None
        if c is not None:
            if off == 0.0:
                const[i] = const.get(i, 0j) + c
            else:
                parts.append(st.shift(c * seg.samples, off))
            continue
        p = require_link(st.links, st.emitters[i].antenna, r_ant, fc_hz=seg.fc_hz, t_s=st.t0_s,
                         what=f"emitter[{i}] → receiver[{k}]")
        if st.keep:
            st.used[("emitter", i, "receiver", k)] = p
        g, y = through(p, seg, None, fc_hz=seg.fc_hz, bandwidth_hz=st.bw, propagation=st.propagation, memo=st.memo)
        if g is not None and off == 0.0:
            const[i] = const.get(i, 0j) + g
        else:
            parts.append(st.shift(y if y is not None else g * seg.samples, off))
    return const, parts


def _direct_component(st: StepState, const: dict, parts: list) -> np.ndarray:
    """The emitters' contribution at a receiver, (…, n) complex128 [√W] (``keep_components``)."""
    d = np.zeros(st.n_samples, dtype=np.complex128)
    for i, g in const.items():
        d = d + g * st.segs[i].samples
    for v in parts:
        d = d + v
    return d


def _backscatter(st: StepState, k: int, r_ant, fc_k: float, const: dict, parts: list, back_l) -> None:
    """Receiver k's backscatter, added to ``const``/``parts`` in member order: a group that
    took the shortcut as one (:func:`rfsim.air.groups.group_backscatter`), every other member
    on its own. ``back_l[j][k]`` receives member j's part with ``keep_components``."""
    backs = None  # the held constants of the reflector → receiver links (as ``gains``)
    if st.single is not None and st.gains is not None:
        backs = st.held(r_ant, st.member_antennas, fc_hz=st.seg0.fc_hz, bandwidth_hz=st.bw,
                        propagation=st.propagation, inbound=True)
    n_mem = len(st.members)
    fast = st.single is not None and not st.keep
    for start, stop, grp in st.entries:
        gr = st.shortcut.get(start) if grp is not None else None
        if gr is not None and backs is not None and st.seg0.fc_hz == fc_k:
            group_backscatter(gr, start, stop == n_mem and start == 0, st.gains, backs, st.members, r_ant, st.seg0,
                              st.links, const, parts, i0=st.i0, t0_s=st.t0_s, n_samples=st.n_samples, bw=st.bw,
                              propagation=st.propagation, memo=st.memo)
            continue
        for j in range(start, stop):
            if fast:
                _member_single(st, j, k, r_ant, fc_k, backs, const, parts)
            else:
                _member_each(st, j, k, r_ant, fc_k, const, parts, back_l)


def _member_single(st: StepState, j: int, k: int, r_ant, fc_k: float, backs, const: dict, parts: list) -> None:
    """Member j's backscatter at receiver k with one emitter on the reference carrier
    (:func:`_member_each` shortened): a reflector that does not modulate adds one constant,
    a modulating one with narrowband static links is kept as its factors
    (:class:`rfsim.air.fused.Backscatter`), else its field goes through the backward link."""
    refl = st.members[j]
    r = st.reflections[j]
    comps = st.per_emitter[j]  # (:meth:`StepState.comps_of`)
    i, seg, g, y = comps[0] if comps is not None else (st.i0, st.seg0, st.gains[j], None)
    links, t0_s, fc_e = st.links, st.t0_s, seg.fc_hz
    if backs is not None:
        pj = None
    else:
        pj = links.paths(refl.antenna, r_ant, fc_hz=fc_e, t_s=t0_s)
        if pj is None:
            require_link(links, refl.antenna, r_ant, fc_hz=fc_e, t_s=t0_s, what=f"reflector[{j}] → receiver[{k}]")
    if r is None or not r.scatters:
        return
    off = fc_e - fc_k
    if off != 0.0 and abs(off) >= st.half:
        return
    rc = r.constant_reradiation
    if rc is not None and g is not None and off == 0.0:
        b = backs[j] if backs is not None else link_constant(pj, fc_e, st.bw, st.propagation, st.memo)
        if b is not None:  # a reflector that does not modulate: one constant, no pass
            const[i] = const.get(i, 0j) + b * (rc * g)
            return
    lazy = lazy_backscatter(r, pj, seg, g, y, rc, off, st.n_samples, st.bw, st.propagation, st.memo,
                            b=backs[j] if backs is not None else None)
    if lazy is not None:  # b·((A_s − Γ)·(g·x)): formed with the sum
        parts.append(lazy)
        return
    if pj is None:
        pj = links.paths(refl.antenna, r_ant, fc_hz=fc_e, t_s=t0_s)
    inc_e = y if y is not None else g * seg.samples
    scattered = (rc * inc_e) if rc is not None else r.reradiation(st.n_samples) * inc_e
    gb, yb = through(pj, seg, scattered, fc_hz=fc_e, bandwidth_hz=st.bw, propagation=st.propagation, memo=st.memo)
    parts.append(st.shift(yb if yb is not None else gb * scattered, off))


def _member_each(st: StepState, j: int, k: int, r_ant, fc_k: float, const: dict, parts: list, back_l) -> None:
    """Member j's backscatter at receiver k, per emitter: r_j times its incident field from
    that emitter, through the backward link at that emitter's carrier, shifted to the
    receiver's carrier (dropped outside ±fs/2)."""
    refl = st.members[j]
    r = st.reflections[j]
    comps = st.comps_of(j)
    links, t0_s, keep = st.links, st.t0_s, st.keep
    # the links are asked for whatever the reflector does (the draws do not depend on it)
    pj = fc_j = None
    for i, seg, g, y in comps:
        if seg.fc_hz != fc_j:
            fc_j = seg.fc_hz
            pj = links.paths(refl.antenna, r_ant, fc_hz=fc_j, t_s=t0_s)
            if pj is None:
                require_link(links, refl.antenna, r_ant, fc_hz=fc_j, t_s=t0_s, what=f"reflector[{j}] → receiver[{k}]")
            if keep:
                st.used[("reflector", j, "receiver", k)] = pj
    part = None
    if r is not None and r.scatters:
        rc = r.constant_reradiation
        r_t = None if rc is not None else r.reradiation(st.n_samples)
        multi = len(comps) > 1
        for i, seg, g, y in comps:
            off = seg.fc_hz - fc_k
            if off != 0.0 and abs(off) >= st.half:
                continue
            if multi:
                pj = links.paths(refl.antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
            if rc is not None and g is not None and off == 0.0 and not keep:
                b = link_constant(pj, seg.fc_hz, st.bw, st.propagation, st.memo)
                if b is not None:  # a reflector that does not modulate: one constant, no pass
                    const[i] = const.get(i, 0j) + b * (rc * g)
                    continue
            inc_e = y if y is not None else g * seg.samples
            scattered = (rc * inc_e) if rc is not None else r_t * inc_e
            gb, yb = through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=st.bw, propagation=st.propagation,
                             memo=st.memo)
            v = st.shift(yb if yb is not None else gb * scattered, off)
            parts.append(v)
            if keep:
                part = v if part is None else part + v
    if keep:
        back_l[j][k] = np.zeros(st.n_samples, dtype=np.complex128) if part is None else part


def _sum_terms(const: dict, parts: list, segs: list, n_samples: int, *, fused: bool) -> np.ndarray:
    """y = Σ_e a_e·x_e + Σ parts, (…, n) complex128 [√W]: the constant-factor terms (with the
    fused kernel where it applies and ``fused`` asks for it, :func:`rfsim.air.fused.fused_sum`),
    then the parts in order; zeros when nothing arrives."""
    y = fused_sum(const, parts, segs, n_samples, fused=fused)
    for v in parts:
        if isinstance(v, Backscatter):
            v = v.samples()
        if y is None:
            y = np.array(v, dtype=np.complex128)
        elif y.shape == v.shape:
            y += v
        else:
            y = y + v
    if y is None:
        y = np.zeros(n_samples, dtype=np.complex128)
    return y


def noise(st: StepState, seg: Segment, rcv, rng: np.random.Generator | None):
    """Stage 5, noise: add the receiver's complex white noise to its input, in place.

    n = √(N/2)·(a + j·b) with N = ``rcv.noise_power_w`` [W], drawn as the run's strategy says
    (``Strategy.noise``, :func:`rfsim.air.noise.add_receiver_noise`): every a then every b
    from ``rng`` (``"pcg64"``), or, from the receiver's :func:`first_read` sample on, from a
    counter-based stream keyed by one draw of ``rng`` (``"counter"``).

    Parameters
    ----------
    st : StepState
        The step (its time base, ``keep`` and ``cache.strategy``).
    seg : Segment
        The receiver's input from :func:`superpose`; its samples (…, n) complex128 [√W] are
        updated in place.
    rcv : Receiver
        The receiver (``noise_power_w`` [W]; optional ``first_read_sample``).
    rng : numpy.random.Generator or None
        The step's generator (needed when the receiver has noise).

    Returns
    -------
    ndarray or None
        The noise added, (…, n) complex128 [√W], with ``keep_components`` (also appended to
        ``st.noise_l``); else None. None when the receiver has no noise.

    Raises
    ------
    ConfigError
        A receiver with noise and no ``rng``.
    """
    noise_w = float(rcv.noise_power_w)
    n_k = None
    if noise_w > 0:
        if rng is None:
            raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
        n_k = add_receiver_noise(seg.samples, noise_w, rng, method=st.cache.strategy.noise,
                                 start=first_read(rcv, st.t0_s, st.fs_hz, st.n_samples), keep=st.keep)
    if st.keep:
        st.noise_l.append(n_k)
    return n_k


def receive(st: StepState, rcv, seg: Segment, *, decide: bool):
    """Stage 6, receive: hand the receiver its input and keep what it returns.

    Parameters
    ----------
    st : StepState
        The step (``st.inputs`` and ``st.outputs`` are appended to).
    rcv : Receiver
        The receiver.
    seg : Segment
        Its input, noise included: samples (…, n) complex128 [√W] on its carrier.
    decide : bool
        Call ``rcv.receive(seg)``; else the output is None.

    Returns
    -------
    object
        What ``rcv.receive`` returned (its decisions or measurements), or None.
    """
    out = rcv.receive(seg) if decide else None
    st.inputs.append(seg)
    st.outputs.append(out)
    return out


def first_read(rcv, t0_s: float, fs_hz: float, n_samples: int) -> int:
    """Return the first sample of an input that a receiver reads.

    Parameters
    ----------
    rcv : Receiver
        The receiver; its optional ``first_read_sample(t0_s, fs_hz, n_samples)`` is asked.
    t0_s : float
        Start time of the input [s].
    fs_hz : float
        Sample rate [Hz].
    n_samples : int
        Samples of the input.

    Returns
    -------
    int
        ``rcv.first_read_sample(t0_s, fs_hz, n_samples)`` when it has one, else 0.
    """
    f = getattr(rcv, "first_read_sample", None)
    return 0 if f is None else int(f(t0_s, fs_hz, n_samples))
