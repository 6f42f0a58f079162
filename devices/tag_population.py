"""A population of passive tags as one reflector group of the air step (rfsim.air.step).

In an inventory almost every tag does nothing on almost every command: it stays unpowered,
or it takes a silent step of its state machine (a QueryRep counting down its slot counter,
an ACK or NAK not for it; :meth:`rfsim.devices.gen2_tag_state.TagState.on_command_if_silent`).
:class:`TagPopulation` keeps the Gen2 state of all its tags in arrays
(:class:`rfsim.devices.gen2_tag_state.StateArrays`) and, on an exchange where every tag sees a
scaled copy g_j·x(t) of one reader segment (the round's held, narrowband, static links),

1. decides for all tags at once which of them stay quiet — the remembered power decision of
   each tag's P_inc = |g_j·x_m|² (``PassiveTag.quiet_point``, made for every tag when the
   gains are new — a round's first exchange, a frequency hop — without changing the tag: its
   own full path's power-up rule; for all members at once, ``PassiveTag.quiet_points``)
   agrees with its powered state, and an unpowered tag stays unpowered or a powered one takes
   a silent step of the decoded command (the rules of ``on_command_if_silent``);
2. takes those steps in the same pass over the arrays (``StateArrays.step_silently``, one
   compiled loop per envelope group; then ``PassiveTag.take_quiet_step``): each tag is left
   exactly as its own ``reflect`` would have left it;
3. on a QueryAdjust (members with generators of their own), loads the new slot counters of
   every tag of the round in that pass (``StateArrays.step_silently``'s redraws,
   ``take_redraw_steps``: Q ± 1, each counter drawn from its tag's own generator exactly as
   ``TagState.on_command`` draws it); the tags whose counter is not 0 are quiet, those that
   reply form their reply (``PassiveTag.respond_reply``);
4. asks only the other tags — those that reply, power up or down, load a slot counter on a
   Query, change state — through their own path (``PassiveTag.reflect``, or from the decoded
   command on where the power decision is known, ``respond_decoded``, also for a tag that
   it powers up): a tag with its own
   reply parameters (clock, T1, line code) answers with them. A powered tag whose power
   decision is known and that takes a Query, or a round command (QueryRep, QueryAdjust, ACK,
   NAK) but not silently, has its state machine take it at the command's end
   (``PassiveTag.take_command``: ``TagState.on_command``, after a Query's TRcal, as its own
   path does); when it does not reply (a counter not 0 after a Query, an ACK with another
   RN16, the end of an access) it is quiet as well, else it forms its reply
   (``respond_reply``).

The quiet tags re-radiate r_j = A_s − Γ_A, a constant (rfsim.devices.tag, step 6), so at a
receiver with backward constants b_j their sum is one constant,
c = Σ_j b_j·(r_j·g_j) over the quiet, scattering tags (:meth:`PopulationReflection.terms`),
added to the factor of x(t) in tag order: the air step accumulates it sequentially
(``numpy.add.accumulate``) over the products formed in Python complex arithmetic once per
round, the same operations in the same order as the per-tag step, so the records are
bit-identical to every tag reflecting on its own (tested).

The arrays are read back from the tags after every exchange in which all tags reflect on
their own (:meth:`TagPopulation.reflect_each`: the first exchange of a round) and after each
tag's own reflection; the power decisions are kept while the gains and the reader's CW
level stay the same (a round). Between exchanges change the tags (states, configs, chips)
only through the air, or call :meth:`TagPopulation.refresh` afterwards (EngineAir.cw_off
does).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from itertools import repeat
from typing import NamedTuple

import numpy as np

from rfsim.devices.gen2_tag_state import StateArrays
from rfsim.air.step import Segment
from rfsim.gen2.commands import ACK, NAK, Query, QueryAdjust, QueryRep

_antenna = operator.attrgetter("antenna")
_config = operator.attrgetter("config")
_rng = operator.attrgetter("rng")
_powered = operator.attrgetter("powered")
_p_dbm = operator.attrgetter("p_dbm")
_structural_mode = operator.attrgetter("structural_mode")
_gamma_rest = operator.attrgetter("gamma_rest")
#: The commands a powered member with a known power decision takes through its state machine
#: alone (reflect_scaled, ``PassiveTag.take_command``): a Query (never a silent step) and the
#: round commands it does not take silently.
_STEPPED_COMMANDS = (Query, QueryRep, QueryAdjust, ACK, NAK)


def _counting_class(members):
    """The members' one class when it counts the settings of its ``antenna`` property
    (``antenna_changes``, rfsim.devices.tag.PassiveTag), else None."""
    cls = type(members[0]) if members else None
    if cls is None or not all(type(m) is cls for m in members):
        return None
    if not isinstance(getattr(cls, "antenna", None), property) or not hasattr(cls, "antenna_changes"):
        return None
    return cls


class TagPopulation:
    """Passive tags (``rfsim.devices.tag.PassiveTag`` or alike) as one reflector group of
    :func:`rfsim.air.step.propagate` (:class:`rfsim.air.step.ReflectorGroup`).

    Parameters
    ----------
    tags : sequence of tags with ``state`` (TagState), ``reflect``, ``antenna``,
        ``quiet_point`` (with ``decide``), ``take_quiet_step``, ``take_command``, ``silent_response``,
        ``front_end_of`` and ``config.envelope_rc_s`` (and ``rng``, ``respond_reply`` for the QueryAdjust
        shortcut, module docstring)
    """

    def __init__(self, tags):
        self.members = list(tags)
        for t in self.members:
            if not callable(getattr(t, "quiet_point", None)):
                raise TypeError(f"a population member must be a PassiveTag-like tag, got {type(t).__name__}")
        self.arrays = StateArrays([t.state for t in self.members])
        self._antennas: tuple | None = None
        self._counting = _counting_class(self.members)
        self._antenna_count = None  # the class's antenna_changes when _antennas was checked
        self._round: _Round | None = None
        self._truth_memo: RecordValues | None = None  # the last exchange's record values
        self._facts: _Facts | None = None  # the members' generators and configs (_member_facts)

    def __len__(self) -> int:
        return len(self.members)

    @property
    def antennas(self) -> tuple:
        """The members' antennas (the same tuple object while none of them changes). Members
        whose ``antenna`` is the counted property of :class:`rfsim.devices.tag.PassiveTag` are not
        compared one by one while no tag's antenna has been set since they last were."""
        ants = self._antennas
        count = self._counting.antenna_changes if self._counting is not None else None
        if ants is not None and count is not None and count == self._antenna_count and len(ants) == len(self.members):
            return ants
        if ants is None or len(ants) != len(self.members) or not all(
                map(operator.is_, map(_antenna, self.members), ants)):
            ants = self._antennas = tuple(map(_antenna, self.members))
        self._antenna_count = count
        return ants

    def refresh(self) -> None:
        """Read every member's state into the arrays again and forget the round's remembered
        power decisions (after changing tags — states, configs, chips — from outside)."""
        self.arrays.read(range(len(self.members)))
        self._round = self._facts = None
        self._counting, self._antenna_count = _counting_class(self.members), None

    def reflect_each(self, incident) -> list:
        """Every member reflects its own incident segment, in order.

        The arrays are read back from the tags afterwards (module docstring).

        Parameters
        ----------
        incident : sequence of rfsim.air.segment.Segment
            ``incident[j]`` is the segment member j sees.

        Returns
        -------
        list of rfsim.devices.tag_response.TagResponse
            Each member's reaction, in member order.
        """
        out = [m.reflect(inc) for m, inc in zip(self.members, incident)]
        self.arrays.read(range(len(self.members)))
        if self._round is not None:
            self._round.needs.update(range(len(self.members)))
        return out

    def reflect_scaled(self, base: Segment, gains, fc_hz: float) -> PopulationReflection | None:
        """The population's reaction when member j sees ``gains[j]·base`` (module docstring).

        Quiet members (unpowered and staying so, or taking a silent step of their state machine,
        or loading a new non-zero slot counter on a QueryAdjust) are answered from the arrays;
        the others reflect through their own path.

        Parameters
        ----------
        base : rfsim.air.segment.Segment
            The emitted segment (not itself a scaled copy; 1-D samples [√W]).
        gains : sequence of complex
            Complex gain g_j of each member's link, in member order.
        fc_hz : float
            Carrier frequency [Hz] (for the scaled segments of the members that reflect on
            their own).

        Returns
        -------
        PopulationReflection or None
            What the population did; None when the shortcut does not apply (no members, a scaled
            ``base``, multi-dimensional samples or no flat CW plateau): the caller then uses
            :meth:`reflect_each`.
        """
        if not self.members or base.base is not None or base.samples.ndim != 1:
            return None
        fe = self.members[0].front_end_of(base)
        if fe.plateau is None:
            return None
        rnd = self._sync(gains, fe)
        arrays = self.arrays
        on = rnd.stays_on & arrays.powered  # powered, and stays so
        quiet = react = None  # quiet: unpowered and stays so, silent or redrawn (react: the others)
        steps, decoded_by = [], []  # decoded_by: (members, their decoded command)
        replies = {}  # member → (decoded command, its reply) of the members that redrew a counter of 0
        if np.count_nonzero(on):
            for rc, group in rnd.rc_groups:
                sel = on if group is None else on & group
                if group is not None and not np.count_nonzero(sel):
                    continue
                decoded = fe.command(rc)
                cmd, frame = decoded
                if cmd is None:
                    decoded_by.append((sel, decoded, None))
                    continue
                t_end_s = base.t0_s + frame.end / base.fs_hz
                decoded_by.append((sel, decoded, t_end_s))
                if isinstance(cmd, Query):  # no silent step: every powered tag takes it below
                    continue
                # the silent steps decided and taken in one pass; on a QueryAdjust the tags of the
                # round (members with generators of their own) load new counters, and those that
                # do not reply are quiet
                done = arrays.step_silently(cmd, sel, rnd.stays_off, t_end_s, redraw=rnd.own_rngs)
                if done.silent is not None:
                    steps.append((cmd, done.silent, None, t_end_s))
                if done.redrawn is not None:
                    steps.append((cmd, done.redrawn, None, t_end_s))
                for j, reply in done.replies:
                    replies[j] = (decoded, reply)
                if group is None:  # (one group: the pass's own lists)
                    quiet, react = done.quiet, done.react
                    if done.replies:
                        react = sorted(react + [j for j, _ in done.replies])
                else:
                    quiet = done.quiet if quiet is None else quiet | done.quiet
        if quiet is None:
            quiet = np.greater(rnd.stays_off, arrays.powered)
        needs, members, points = rnd.needs, self.members, rnd.points
        if needs:
            # a new round's first exchange needs every member: the quiet ones found in the mask
            done = np.flatnonzero(quiet).tolist() if len(needs) == len(members) else [j for j in needs if quiet[j]]
            for j in done:
                members[j].take_quiet_step(points[j])
            needs.difference_update(done)
        reactions, stepped = {}, {}
        if react is None:
            react = np.flatnonzero(~quiet).tolist()
        for j in react:
            m = members[j]
            decoded = t_end_s = None
            for sel, d, t_end in decoded_by:
                if sel[j]:
                    decoded, t_end_s = d, t_end
                    break
            replied = replies.get(j)
            if replied is not None:  # its state machine took the QueryAdjust above: the reply's Γ(t)
                reactions[j] = m.respond_reply(points[j], replied[0], base, replied[1])
            elif decoded is not None and type(decoded[0]) in _STEPPED_COMMANDS:
                # its power decision is known and the command is a Query or a round command that
                # it does not take silently: its state machine takes it (as the tag's own path
                # would, at the command's end); without a reply the tag re-radiates its
                # constant, as a quiet one
                reply = m.take_command(points[j], decoded, t_end_s, base.fs_hz)
                if reply is None:
                    stepped[j] = _Stepped(decoded[0], t_end_s)
                else:
                    reactions[j] = m.respond_reply(points[j], decoded, base, reply)
            elif decoded is not None:  # its power decision is known: the tag's own path from the command on
                reactions[j] = m.respond_decoded(points[j], decoded, base)
            elif rnd.stays_on[j] and not m.state.powered:  # it powers up, its decision known
                reactions[j] = m.respond_decoded(points[j], fe.command(m.config.envelope_rc_s), base, power_up=True)
            else:
                reactions[j] = m.reflect(Segment.scaled(base, gains[j], fc_hz))
                if not rnd.known[j]:
                    rnd.learn(j, m.quiet_point(fe, gains[j]))
        if react:
            arrays.read(react)
            needs.update(react)
            if stepped:
                quiet[list(stepped)] = True
        return PopulationReflection(self, rnd, quiet, reactions, steps, stepped)

    def record_values(self, incident_power_dbm: np.ndarray, powered: np.ndarray) -> RecordValues:
        """The incident powers and the powered members of an exchange as the values of its record.

        The same tuples as the previous exchange's while both arrays are equal to the bit
        (within a round almost every exchange): the record then holds no new Python object
        per member.

        Parameters
        ----------
        incident_power_dbm : numpy.ndarray, shape (n,)
            Incident power per member [dBm].
        powered : numpy.ndarray of bool, shape (n,)
            Power state per member.

        Returns
        -------
        RecordValues
            ``incident_power_dbm`` (tuple of n floats [dBm]) and ``powered`` (tuple of the
            indices of the powered members, ascending).
        """
        memo = self._truth_memo
        if (memo is not None and memo.dbm.size == incident_power_dbm.size
                and np.array_equal(memo.dbm.view(np.int64), incident_power_dbm.view(np.int64))
                and np.array_equal(memo.mask, powered)):
            return memo
        memo = self._truth_memo = RecordValues(tuple(incident_power_dbm.tolist()),
                                               tuple(np.flatnonzero(powered).tolist()),
                                               incident_power_dbm.copy(), powered.copy())
        return memo

    def _round_record(self, rnd: _Round) -> RecordValues:
        """:meth:`record_values` of the round's own incident powers and power states (kept with
        the round until a member's quiet point becomes known)."""
        record = rnd.record
        if record is None:
            record = rnd.record = self.record_values(rnd.dbm, rnd.powered)
        return record

    def _member_facts(self) -> _Facts:
        """The members' generators and configs, whether each member has a generator of its own,
        and the members grouped by envelope RC (kept while every member holds the same
        generator and config objects: one identity check per member at a new round)."""
        members = self.members
        try:
            rngs = list(map(_rng, members))
        except AttributeError:
            rngs = [getattr(m, "rng", None) for m in members]
        configs = list(map(_config, members))
        facts = self._facts
        if (facts is not None and len(facts.rngs) == len(rngs) and all(map(operator.is_, rngs, facts.rngs))
                and all(map(operator.is_, configs, facts.configs))):
            return facts
        n = len(members)
        own = None not in rngs and len(set(map(id, rngs))) == n and all(
            callable(getattr(m, "respond_reply", None)) for m in members)
        rcs = np.array([c.envelope_rc_s for c in configs], dtype=float)
        groups = [(float(rc), rcs == rc) for rc in dict.fromkeys(rcs.tolist())]
        if len(groups) == 1:
            groups = [(groups[0][0], None)]
        self._facts = facts = _Facts(rngs, configs, own, groups)
        return facts

    def _sync(self, gains, fe) -> _Round:
        """The round's quiet points for these gains and the segment's CW sample (kept while
        both stay the same; the sign of the CW sample does not matter: |g·(−x_m)|² = |g·x_m|²
        exactly, negation being exact in IEEE arithmetic)."""
        cw = fe.cw_sample
        if cw.real < 0 or (cw.real == 0 and cw.imag < 0):
            cw = -cw
        rnd = self._round
        if rnd is not None and rnd.cw == cw and (rnd.gains is gains or rnd.gains == list(gains)):
            return rnd
        self._round = rnd = _Round(self.members, gains, cw, fe, self._member_facts())
        if rnd.own_rngs:
            self.arrays.use_generators(rnd.rngs)
        return rnd


class _Round:
    """The quiet points of every member for one set of gains (a round's held links)."""

    def __init__(self, members, gains, cw, fe, facts: _Facts):
        self.members, self.cw = members, cw
        self.gains = gains if isinstance(gains, list) else list(gains)
        # every member's power decision for its gain (made now where not known: a new carrier)
        # (at once where the members' class offers it: ``quiet_points``, one array operation)
        batch = getattr(type(members[0]), "quiet_points", None) if members else None
        self.points = points = (batch(members, fe, self.gains) if batch is not None else
                                [m.quiet_point(fe, g, decide=True) for m, g in zip(members, self.gains)])
        n = len(members)
        # the columns of _set for every member at once (unknown: not known, not powered, NaN dBm)
        self.known = np.fromiter(map(operator.is_not, points, repeat(None)), bool, n)
        if self.known.all():  # (every decision made: each column in one pass over the points)
            self.powered = np.fromiter(map(_powered, points), bool, n)
            self.scatter = np.fromiter(map(operator.ne, map(_structural_mode, points), map(_gamma_rest, points)),
                                       bool, n)
            self.dbm = np.fromiter(map(_p_dbm, points), float, n)
        else:
            self.powered = np.array([q is not None and q.powered for q in points], bool)
            self.scatter = np.array([q is not None and q.structural_mode != q.gamma_rest for q in points], bool)
            self.dbm = np.array([math.nan if q is None else q.p_dbm for q in points], float)
        self._known_masks()
        #: the members whose quiet step must still set the tag's operating point
        self.needs = set(range(n))
        self.record = None  # the record values of dbm and powered (TagPopulation._round_record)
        self.rngs = facts.rngs
        #: every member draws from its own generator, so the order in which members draw does
        #: not matter (else a QueryAdjust goes through each member's own path, in member order)
        self.own_rngs = facts.own_rngs
        #: (RC time constant [s], its members (bool mask; None: every member))
        self.rc_groups = facts.rc_groups
        self._terms: dict = {}

    def _known_masks(self) -> None:
        """``stays_on`` (known and powered) and ``stays_off`` (known and not powered) from
        ``known`` and ``powered``."""
        self.stays_on = self.known & self.powered
        self.stays_off = np.greater(self.known, self.powered)  # known & ~powered

    def _set(self, j: int, q) -> None:
        if q is not None:
            # new arrays: a PopulationReflection made before holds the ones it was made with
            self.powered, self.dbm = self.powered.copy(), self.dbm.copy()
            self.known[j], self.powered[j], self.dbm[j] = True, q.powered, q.p_dbm
            self.stays_on[j], self.stays_off[j] = q.powered, not q.powered
            self.record = None
            self.scatter[j] = q.structural_mode != q.gamma_rest

    def learn(self, j: int, q) -> None:
        """Member ``j``'s quiet point became known (its own reflection made it)."""
        if q is not None:
            self.points[j] = q
            self._set(j, q)
            self._terms.clear()

    def terms(self, backs) -> np.ndarray:
        """(n,) complex: b_j·((A_s − Γ_A)·g_j) per member in Python complex arithmetic, as
        the air step forms it for one tag (0 where the quiet point is unknown)."""
        hit = self._terms.get(id(backs))
        if hit is not None and (hit.backs is backs or hit.backs == list(backs)):
            return hit.terms
        out = np.array([b * ((q.structural_mode - q.gamma_rest) * g) if q is not None else 0j
                        for b, g, q in zip(backs, self.gains, self.points)], dtype=np.complex128)
        self._terms[id(backs)] = _Terms(backs, out)
        return out


def _same_float(a: float, b: float) -> bool:
    """``a`` and ``b`` are the same float to the bit (NaN: never; ±0 told apart)."""
    return a == b and (a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b))


class RecordValues(NamedTuple):
    """An exchange's incident powers and powered members as its record holds them
    (:meth:`TagPopulation.record_values`), with the arrays they were made of.

    Attributes
    ----------
    incident_power_dbm : tuple of float
        Incident power per member [dBm].
    powered : tuple of int
        Indices of the powered members, ascending.
    dbm : numpy.ndarray, shape (n,)
        The incident powers they were made of [dBm].
    mask : numpy.ndarray of bool, shape (n,)
        The power states they were made of.
    """

    incident_power_dbm: tuple
    powered: tuple
    dbm: np.ndarray
    mask: np.ndarray


class _Facts(NamedTuple):
    """What a round reads of the members themselves (TagPopulation._member_facts)."""

    rngs: list
    configs: list
    own_rngs: bool
    rc_groups: list


class _Stepped(NamedTuple):
    """A round command a quiet member took through its state machine without replying: the
    command and its end [s]."""

    command: object
    t_end_s: float


class _Terms(NamedTuple):
    """A round's quiet terms at one receiver, kept with the backward constants they were made of."""

    backs: Sequence
    terms: np.ndarray


class PopulationReflection:
    """What a :class:`TagPopulation` did with one exchange (:class:`rfsim.air.step.GroupReflection`).

    Indexing (``r[j]``) and iteration give each member's
    :class:`rfsim.devices.tag_response.TagResponse`.

    Attributes
    ----------
    quiet : numpy.ndarray of bool, shape (n,)
        Members answered by the population (constant re-radiation).
    reactions : dict of int to TagResponse
        ``{member index: its own reflection}`` for the others, in member order.
    powered : numpy.ndarray of bool, shape (n,)
        Power state per member.
    incident_power_dbm : numpy.ndarray, shape (n,)
        Incident power per member [dBm].
    """

    def __init__(self, population, rnd: _Round, quiet, reactions: dict, steps: list, stepped: dict | None = None):
        self._population, self._round, self._steps = population, rnd, steps
        #: {member: _Stepped} of the quiet members that took a round command through their
        #: state machine without replying (reflect_scaled)
        self._stepped = stepped if stepped is not None else {}
        self.quiet, self.reactions = quiet, reactions
        self._arrays = None  # (powered, incident_power_dbm), formed when first read
        #: the round's power states and incident powers now (a round that learns a member's
        #: power decision later makes new arrays, _Round._set)
        self._base = powered, dbm = rnd.powered, rnd.dbm
        #: every reacting member's power state and incident power are the round's own (to the
        #: bit): then the arrays are the round's, and so are the record values
        self._as_round = True
        for j, r in reactions.items():
            if bool(r.powered) != powered[j] or not _same_float(r.incident_power_dbm, dbm[j]):
                self._as_round = False
                break

    @property
    def powered(self) -> np.ndarray:
        """Power state per member ((n,) bool)."""
        return self._formed()[0]

    @property
    def incident_power_dbm(self) -> np.ndarray:
        """Incident power per member ((n,) float [dBm])."""
        return self._formed()[1]

    def _formed(self) -> tuple:
        """``(powered, incident_power_dbm)``: the round's, with the reacting members' own."""
        if self._arrays is None:
            powered, dbm = self._base
            powered, dbm = powered & self.quiet, dbm.copy()
            for j, r in self.reactions.items():
                powered[j] = bool(r.powered)
                dbm[j] = r.incident_power_dbm
            self._arrays = (powered, dbm)
        return self._arrays

    def terms(self, backs) -> tuple[np.ndarray, np.ndarray]:
        """The quiet members' constant contributions at one receiver.

        ``b_j·(r_j·g_j)`` with ``r_j = A_s − Γ_A`` (module docstring), formed in Python complex
        arithmetic as the air step forms it for one tag.

        Parameters
        ----------
        backs : sequence of complex
            Backward constant b_j of each member towards the receiver, in member order.

        Returns
        -------
        terms : numpy.ndarray, shape (n,), complex128
            ``b_j·((A_s − Γ_A)·g_j)`` per member (0 where the power decision is unknown).
        use : numpy.ndarray of bool, shape (n,)
            Mask of the quiet members that scatter (``A_s ≠ Γ_A``).
        """
        return self._round.terms(backs), self.quiet & self._round.scatter

    def record_values(self) -> RecordValues:
        """:attr:`incident_power_dbm` and the indices of the :attr:`powered` members as the
        values of the exchange's record (:meth:`TagPopulation.record_values`).

        Returns
        -------
        RecordValues
            The tuples (shared with the previous exchange's while equal).
        """
        if self._as_round:
            return self._population._round_record(self._round)
        return self._population.record_values(self.incident_power_dbm, self.powered)

    def __len__(self) -> int:
        return len(self.quiet)

    def __getitem__(self, j: int):
        r = self.reactions.get(j)
        if r is not None or not self.quiet[j]:
            return r
        point = self._round.points[j]
        if not point.powered:
            return point.unpowered
        step = self._stepped.get(j)
        if step is not None:
            return self._population.members[j].silent_response(point, step.command, step.t_end_s)
        for cmd, silent, _, t_end_s in self._steps:
            if silent[j]:
                return self._population.members[j].silent_response(point, cmd, t_end_s)
        raise IndexError(j)

    def __iter__(self):
        return (self[j] for j in range(len(self)))


__all__ = ["TagPopulation", "PopulationReflection", "RecordValues"]
