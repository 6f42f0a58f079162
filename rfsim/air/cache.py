"""The per-run state of the air step (:func:`rfsim.air.step.propagate`): its fast-path strategy and
its caches, in one explicit object that the owner of a run holds (the engine takes the
reader's, a scene may give its own).

* :class:`Strategy` names the fast paths the step may take. It is chosen by the owner, never
  by a probe of the machine at run time.
* :class:`AirCache` holds what the step and its devices may reuse from one call to the next:
  the antenna sets whose positions were found distinct (:class:`CheckedAntennas` entries) and
  the emitted waveforms by their content (:class:`Waveform` entries: a reader's command bits
  → its PIE segment, with the data devices derive from it, e.g. a tag's decoding of it, and
  a weak reference to the run's cache under the key :class:`AirCache`, so that a device
  reacting to the samples finds it without a reference cycle) and where a tag's reply modulates by the reply's content
  (:class:`ReplyStates` entries: reply bits, M, TRext, BLF, fs, fractional start, length →
  the samples where Γ(t) = Γ_B). An entry keeps the objects it was made from alive, so that
  their identities, where part of a key, stay their own; the least recently used entry is
  dropped first beyond ``max_entries``. The content tables keep pure functions of their keys,
  so a run gives the same numbers, bit for bit, with or without them: command waveforms and
  tag replies are kept whatever the strategy (a reader's reply references under
  ``exchange="compiled"``).
* The link timing its exchanges read (T1 and T5 windows, CW after a command, ACK delays) is kept
  by :class:`TimingKey` (the rule, the frozen link profile by value, the rule's other arguments)
  in :attr:`AirCache.timings` (:meth:`AirCache.link_timing`): pure functions of a profile that
  every round of a run asks again.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass, field
from typing import Any, Callable, NamedTuple

import numpy as np

from rfsim.air.noise import NOISE_METHODS
from rfsim.core.errors import ConfigError

__all__ = ["Strategy", "CheckedAntennas", "CommandKey", "Waveform", "ReplyStates", "Derived", "TimingKey", "AirCache",
           "EXCHANGE_METHODS", "run_cache"]

#: How a receiver's input is formed (:attr:`Strategy.exchange`).
EXCHANGE_METHODS = ("sample", "compiled")


@dataclass(frozen=True)
class Strategy:
    """The fast paths of the air step, chosen explicitly.

    Attributes
    ----------
    fused_backscatter : bool
        Form a receiver's sum c·x + b·((A_s − Γ)·(g·x)) of one constant term and one modulating
        reflector in one kernel pass (:mod:`rfsim.air._step_kernels`,
        :func:`rfsim.air.fused.fused_sum`); default True. The kernel's complex products are
        fused multiply-adds, as NumPy's SIMD loop forms them on CPUs with FMA; where NumPy does
        not use them the two differ in the last bit (tests/test_air_kernels.py bounds it).
        False: NumPy's array operations.
    noise : {"counter", "pcg64"}
        How receiver noise is drawn (:data:`rfsim.air.noise.NOISE_METHODS`), default
        ``"counter"``: one key from the step's generator and, from the counter-based stream of
        that key, only the samples the receiver reads (its ``first_read_sample``;
        :func:`rfsim.air.noise.add_receiver_noise`; the algorithm and its streams:
        :mod:`rfsim.air.noise`); ``"pcg64"``: every sample of a receiver's input from the
        step's generator (NumPy's ziggurat on PCG64, the records of versions before the
        counter-based default).
    exchange : {"compiled", "sample"} or None
        How a receiver's input and its noise are formed (:data:`EXCHANGE_METHODS`); None (the
        default) is ``"compiled"`` where ``noise`` and ``fused_backscatter`` allow it (the
        defaults do), else ``"sample"`` (e.g. ``Strategy(noise="pcg64")``), and the attribute
        holds the method chosen. ``"compiled"`` (needs ``noise="counter"`` and
        ``fused_backscatter``): a static
        narrowband exchange — one emitter, constant coupling or direct link, one modulating
        reflector with constant links (:class:`rfsim.air.fused.Backscatter`) — forms the sum and
        adds the counter-based noise of the samples the receiver reads in one kernel call
        (:func:`rfsim.air.fused.fused_noisy_sum`); the same numbers as ``exchange="sample"``
        with ``noise="counter"``, to the bit. Every other exchange falls back to the two
        stages. Devices may keep what repeats from round to round by content under it (a
        reader's reply reference, in :attr:`AirCache.waveforms`). ``"sample"``: the sum
        (:func:`rfsim.air.step.superpose`) then the noise (:func:`rfsim.air.step.noise`), each
        a pass of its own (the only choice with ``noise="pcg64"`` or without
        ``fused_backscatter``).

    Raises
    ------
    ConfigError
        An unknown ``noise`` or ``exchange`` method, or ``exchange="compiled"`` without
        ``noise="counter"`` and ``fused_backscatter``.
    """

    fused_backscatter: bool = True
    noise: str = "counter"
    exchange: str | None = None

    def __post_init__(self):
        if self.noise not in NOISE_METHODS:
            raise ConfigError("air.strategy.noise", self.noise, f"one of {NOISE_METHODS}")
        if self.exchange is None:  # frozen: the default resolved once, here
            compiled = self.noise == "counter" and self.fused_backscatter
            object.__setattr__(self, "exchange", "compiled" if compiled else "sample")
        if self.exchange not in EXCHANGE_METHODS:
            raise ConfigError("air.strategy.exchange", self.exchange, f"one of {EXCHANGE_METHODS}")
        if self.exchange == "compiled" and not (self.noise == "counter" and self.fused_backscatter):
            raise ConfigError("air.strategy.exchange", self.exchange,
                              'noise="counter" and fused_backscatter=True with exchange="compiled"')


@dataclass
class CheckedAntennas:
    """One set of antennas whose positions were found pairwise distinct.

    Found by :func:`rfsim.air.links.check_positions`; the antennas are kept alive with the entry.

    Attributes
    ----------
    emitters : tuple
        The emitters' antennas.
    reflectors : tuple or list
        The reflectors' antennas (a tuple object of a population, or a list).
    receivers : tuple
        The antennas of the receivers that do not share an emitter's antenna.
    """

    emitters: tuple
    reflectors: tuple | list
    receivers: tuple


class CommandKey(NamedTuple):
    """The content key of a reader's command segment in :attr:`AirCache.waveforms`.

    With the reader's frozen config and link profile (the entry's ``makers``) it fixes every
    sample (:meth:`rfsim.devices.reader_tx.PieTransmitter.transmit`).

    Attributes
    ----------
    bits : bytes
        The command's bits (CRC included), one byte per bit.
    preamble : str
        ``"query"`` or ``"frame-sync"``.
    cw_after_s : float
        CW after the command [s].
    cw_before_s : float
        CW before the delimiter [s].
    fs_hz : float
        Sample rate [Hz].
    """

    bits: bytes
    preamble: str
    cw_after_s: float
    cw_before_s: float
    fs_hz: float


@dataclass
class Waveform:
    """One emitted waveform, kept by its content with the objects that fix the rest of it.

    The content key is e.g. a command's bits, preamble and CW lengths.

    Attributes
    ----------
    samples : ndarray, shape (n,), complex128
        The samples, read-only [√W].
    makers : tuple
        The objects the samples also depend on (a reader's frozen config and link profile),
        compared by identity on a hit.
    memo : dict
        Data derived from the samples that devices share (as :attr:`rfsim.air.segment.Segment.memo`;
        a tag's front end on a command: :class:`rfsim.devices.tag.SharedFrontEnd`), and a weak
        reference (:class:`weakref.ref`) to the run's :class:`AirCache` under the key ``AirCache``
        (a reader's command segment; :func:`run_cache` reads it), and :attr:`cw_from` under the
        key ``"cw_from"`` when it is known.
    cw_from : int or None
        Index from which the samples are all equal (a reader's constant CW after its command:
        devices that see the segment may read the samples up to it and count the rest), or None
        when the maker does not know one.
    """

    samples: np.ndarray
    makers: tuple
    memo: dict = field(default_factory=dict)
    cw_from: int | None = None


def run_cache(memo: dict) -> AirCache | None:
    """The run's cache a segment's ``memo`` names (:attr:`Waveform.memo`), or None.

    Parameters
    ----------
    memo : dict
        A segment's memo (:attr:`rfsim.air.segment.Segment.memo`).

    Returns
    -------
    AirCache or None
        The cache, or None when the memo names none or it is gone.
    """
    ref = memo.get(AirCache)
    return None if ref is None else ref()


@dataclass
class ReplyStates:
    """Where a tag's reply modulates, kept by the reply's content.

    The ±1 reply waveform s(t) (:func:`rfsim.gen2.linecode.reply_waveform`) is a pure function
    of the reply bits, M, TRext, BLF, fs, the reply's start within the segment and the segment's
    length (the key); the tag reflects Γ_B where s > 0 and Γ_A elsewhere
    (:class:`rfsim.devices.tag.PassiveTag`, step 5), so Γ(t) of any pair (Γ_A, Γ_B) follows
    from this mask alone.

    Attributes
    ----------
    modulating : ndarray, shape (n,), bool
        True where s > 0 (Γ = Γ_B), read-only.
    gammas : dict
        Γ(t) of this reply seen again, ``(n,) complex128`` read-only, by the exact bits of
        (Γ_B, Γ_A) (:func:`rfsim.devices.tag.reply_gamma`; a few pairs per entry).
    """

    modulating: np.ndarray
    gammas: dict = field(default_factory=dict)


@dataclass
class Derived:
    """A value derived from an immutable object by a pure function, kept with the object.

    E.g. a device's validated config; the object is kept alive: its identity is the key.

    Attributes
    ----------
    source : object
        The object.
    value : object
        What the function gave for it.
    """

    source: object
    value: object


class TimingKey(NamedTuple):
    """The key of one link-timing value in :attr:`AirCache.timings`.

    Attributes
    ----------
    rule : callable
        The pure function ``rule(link, *args)`` that gives the value (e.g.
        :func:`rfsim.gen2.link.t1`).
    link : object
        The frozen, hashable link profile (:class:`rfsim.gen2.link.LinkProfile`), compared by value.
    args : tuple
        The rule's other arguments (e.g. the expected reply's bits), hashable.
    """

    rule: Callable
    link: Any
    args: tuple


@dataclass
class AirCache:
    """Everything the air step reuses between its calls in one run (module docstring).

    Attributes
    ----------
    strategy : Strategy
        The step's fast paths, default ``Strategy()``.
    max_entries : int
        Entries kept per table (the least recently used dropped first), default 64.
    checked : dict
        Antenna sets found at distinct positions (:class:`CheckedAntennas`), keyed by the
        identities of their antennas (emitters, reflectors, receivers).
    checked_tuples : dict
        The same, keyed by the identity of a tuple of reflector antennas (a population's one
        tuple: no look at its members).
    waveforms : dict
        :class:`Waveform` entries by content key.
    derivations : dict
        :class:`Derived` entries by (function, identity of the source).
    replies : dict
        :class:`ReplyStates` entries by the content of a tag's reply (its bits, M, TRext, BLF,
        fs, start and length; :func:`rfsim.devices.tag.reply_gamma`).
    timings : dict
        Link-timing values (seconds, :class:`rfsim.gen2.link.TimingRange` or named tuples of
        seconds) by :class:`TimingKey` (:meth:`link_timing`).
    """

    strategy: Strategy = field(default_factory=Strategy)
    max_entries: int = 64
    checked: dict = field(default_factory=dict)
    checked_tuples: dict = field(default_factory=dict)
    waveforms: dict = field(default_factory=dict)
    derivations: dict = field(default_factory=dict)
    replies: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)

    def link_timing(self, rule: Callable, link, *args):
        """Return ``rule(link, *args)`` for a frozen link profile, computed once per run.

        Kept in :attr:`timings` by ``TimingKey(rule, link, args)`` (the profile by value), the
        oldest entry dropped first beyond :attr:`max_entries`.

        Parameters
        ----------
        rule : callable
            Pure function of the profile and ``args`` (e.g. :func:`rfsim.gen2.link.t1`).
        link : LinkProfile
            The link profile (frozen, hashable).
        *args : hashable
            The rule's other arguments.

        Returns
        -------
        object
            ``rule(link, *args)``, from the cache when it was asked before in this run.
        """
        key = TimingKey(rule, link, args)
        hit = self.timings.get(key)
        if hit is None:
            hit = rule(link, *args)
            self.remember(self.timings, key, hit)
        return hit

    def derived(self, source, make):
        """Return ``make(source)`` for an immutable ``source``, computed once per run.

        The value is kept as a :class:`Derived` entry keyed by ``(make, id(source))``, with
        ``source`` kept alive (the readers of one run made from one config validate it once).

        Parameters
        ----------
        source : object
            An immutable object (e.g. a frozen config); its identity is the key.
        make : callable
            Pure function of ``source``.

        Returns
        -------
        object
            ``make(source)``, from the cache when this source was seen before.
        """
        key = (make, id(source))
        hit = self.derivations.get(key)
        if hit is not None and hit.source is source:
            return hit.value
        value = make(source)
        self.remember(self.derivations, key, Derived(source=source, value=value))
        return value

    def waveform(self, key, makers: tuple) -> Waveform | None:
        """Look up the waveform of content ``key`` made by ``makers``.

        A hit becomes the most recently used entry.

        Parameters
        ----------
        key : hashable
            Content key of the waveform (e.g. a command's bits, preamble and CW lengths).
        makers : tuple
            The objects the samples also depend on, compared by identity with the entry's.

        Returns
        -------
        Waveform or None
            The entry, or None when there is none for ``key`` or it was made by other objects.
        """
        hit = self.waveforms.pop(key, None)
        if hit is None:
            return None
        self.waveforms[key] = hit
        if len(hit.makers) != len(makers) or not all(map(operator.is_, hit.makers, makers)):
            return None
        return hit

    def reply(self, key) -> ReplyStates | None:
        """Look up where the reply of content ``key`` modulates; a hit becomes the most recently used.

        Parameters
        ----------
        key : hashable
            Content key of the reply (:func:`rfsim.devices.tag.reply_gamma`).

        Returns
        -------
        ReplyStates or None
            The entry, or None when there is none for ``key``.
        """
        hit = self.replies.pop(key, None)
        if hit is not None:
            self.replies[key] = hit
        return hit

    def remember(self, table: dict, key, entry) -> None:
        """Store ``table[key] = entry``, the oldest entry dropped first beyond :attr:`max_entries`.

        Parameters
        ----------
        table : dict
            One of the cache's tables (insertion order is the recency order).
        key : hashable
            The entry's key.
        entry : object
            The entry to store.
        """
        if key not in table and len(table) >= self.max_entries:
            table.pop(next(iter(table)))
        table[key] = entry
