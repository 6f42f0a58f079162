"""The transition rules of the Gen2 tag state machine over arrays, and the Gen2 state of many
tags in arrays (:class:`StateArrays`) that applies them to a population at once: its silent
steps and a QueryAdjust's new slot counters.

The rules are written once, for one tag (Python ints, bools, strings) or many (arrays):
:func:`query_matches` (Query: Sel and Target), :func:`round_step` (what Query, QueryRep,
QueryAdjust, ACK and NAK do in each state: the end of an access with its inventoried-flag
flip, the slot counter's decrement and wrap, the QueryAdjust redraw, the ACK checks, NAK),
:func:`s1_reverts` (S1 persistence) and :func:`select_step` (the Select action table); the
slot counter's :func:`rfsim.devices._gen2_tag_kernels.decremented` and
:func:`rfsim.devices._gen2_tag_kernels.slot_replies` (re-exported here; in the kernel module
whose kernel they are compiled into), the Q adjustment
:func:`rfsim.devices.gen2_tag_values.adjusted_q` and the slot-counter draw
:func:`rfsim.gen2.tag_draws.slot_draw`. :class:`rfsim.devices.gen2_tag_state.TagState` is a
population of one that applies them to itself (its row of :func:`round_step` evaluated for
every state at once, :func:`round_step_of_one`); :class:`StateArrays` applies them to every
row.

``TagState`` below is :class:`rfsim.devices.gen2_tag_state.TagState`; ``STATES`` and
``SharedClock`` are in :mod:`rfsim.devices.gen2_tag_values`.
"""

from __future__ import annotations

import operator
from typing import Any, NamedTuple

import numpy as np

from rfsim.gen2.commands import ACK, NAK, Query, QueryAdjust, QueryRep
from rfsim.gen2.generator_words import GeneratorWords
from rfsim.gen2.tag_draws import _slot_drawer, _top_bits
from rfsim.devices import _gen2_tag_kernels as _kernels
from rfsim.devices._gen2_tag_kernels import decremented, s1_reverts, slot_replies
from rfsim.devices.gen2_tag_values import STATE_CODES, STATES, SharedClock, adjusted_q

_ARBITRATE, _REPLY = STATE_CODES["arbitrate"], STATE_CODES["reply"]
_ACKNOWLEDGED, _OPEN, _KILLED = STATE_CODES["acknowledged"], STATE_CODES["open"], STATE_CODES["killed"]
#: The columns of :class:`StateArrays`, in the order of :meth:`TagState.row`.
_COLUMNS = ("powered", "code", "session", "slot", "t_s", "s1_set_s", "s1_keep_s", "q")


class RoundStep(NamedTuple):
    """What an inventory-round command does to one tag or to many (:func:`round_step`).

    Each field is a bool (one tag, :func:`round_step_of_one`) or an ndarray of bool, shape
    (n_tags,) (many); at most one of ``close``, ``wrap``, ``decrement``, ``redraw``,
    ``acknowledge``, ``confirm`` and ``to_arbitrate`` holds for a tag.

    Attributes
    ----------
    silent : bool or ndarray of bool
        No reply, no random draw, no change but the time and a ``decrement`` (that one silent
        unless the decremented counter replies, :func:`slot_replies`).
    close : bool or ndarray of bool
        The tag ends its access: the round's inventoried flag inverts (A↔B) and, on a QueryRep
        or QueryAdjust, the tag returns to Ready with no round (a Query is evaluated afterwards).
    wrap : bool or ndarray of bool
        Reply → Arbitrate with the counter at 7FFFh (no second reply in the round).
    decrement : bool or ndarray of bool
        The slot counter goes to :func:`decremented` (slot); the tag then replies with a new
        RN16 where :func:`slot_replies` (Reply), else stays in Arbitrate.
    redraw : bool or ndarray of bool
        Q → :func:`rfsim.devices.gen2_tag_values.adjusted_q`, a new counter is drawn, and the
        tag replies with a new RN16 where :func:`slot_replies`.
    acknowledge : bool or ndarray of bool
        An ACK is compared with the tag's RN16: equal → Acknowledged and the EPC reply,
        else → Arbitrate.
    confirm : bool or ndarray of bool
        An ACK is compared with the tag's handle (Open/Secured): equal → the EPC reply
        (state kept), else → Arbitrate.
    to_arbitrate : bool or ndarray of bool
        A NAK sends the tag to Arbitrate.
    """

    silent: Any
    close: Any
    wrap: Any
    decrement: Any
    redraw: Any
    acknowledge: Any
    confirm: Any
    to_arbitrate: Any


def round_step(cmd, code, session) -> RoundStep:
    """Decide what an inventory-round command does to powered tags: the one definition of the
    transitions of Query (the end of an access), QueryRep, QueryAdjust, ACK and NAK.

    Over arrays (the columns of :class:`StateArrays`); a single tag reads its row of the same
    rules evaluated for every state at once (:func:`round_step_of_one`). The rules (EPC Gen2
    "Tag states and slot counter", "Sessions and inventoried flags", the
    QueryRep/QueryAdjust/ACK/NAK sections; anchors §4.4–4.5):

    * a Query, QueryRep or QueryAdjust of the tag's round (``session`` equal to the command's)
      in Acknowledged, Open or Secured ends the access (``close``); one of another session
      (or with no round, ``session`` −1) is ignored by QueryRep/QueryAdjust;
    * a QueryRep of the round in Reply wraps the counter (``wrap``); in Arbitrate it
      decrements the counter, silently unless the tag then replies (:func:`slot_replies`);
    * a QueryAdjust of the round in Arbitrate or Reply adjusts Q and redraws (``redraw``);
    * an ACK in Reply or Acknowledged checks the RN16 (``acknowledge``), in Open or Secured
      the handle (``confirm``); a NAK in any of these four goes to Arbitrate; both are
      ignored in Ready and Arbitrate;
    * a killed tag takes none of these steps (it ignores every command), and any other command
      (Req_RN, the access commands, Select: :class:`TagState`'s own) is none of these.

    The states of a round are compared by their order in :data:`STATES` (ready < arbitrate <
    reply < acknowledged < open < secured < killed).

    Parameters
    ----------
    cmd : rfsim.gen2.commands command
        The received command.
    code : ndarray of int, shape (n_tags,)
        Index of the tag's state in :data:`STATES`.
    session : ndarray of int, shape (n_tags,)
        Session of the tag's round, −1 for no round.

    Returns
    -------
    RoundStep
        The transition, per tag (ndarrays of bool, shape (n_tags,)).
    """
    kind = type(cmd)
    no = np.zeros(np.shape(code), bool)
    if kind is QueryRep or kind is QueryAdjust or kind is Query:
        in_round = (session >= 0) & (session == cmd.session)
        close = in_round & (code >= _ACKNOWLEDGED) & (code < _KILLED)  # Acknowledged, Open or Secured
        if kind is QueryRep:
            dec = in_round & (code == _ARBITRATE)
            return RoundStep(~in_round | dec, close, in_round & (code == _REPLY), dec, no, no, no, no)
        if kind is QueryAdjust:
            redraw = in_round & ((code == _ARBITRATE) | (code == _REPLY))
            return RoundStep(~in_round, close, no, no, redraw, no, no, no)
        return RoundStep(no, close, no, no, no, no, no, no)
    if kind is ACK or kind is NAK:
        engaged = (code >= _REPLY) & (code < _KILLED)  # Reply, Acknowledged, Open or Secured
        silent = code < _REPLY  # Ready or Arbitrate
        if kind is NAK:
            return RoundStep(silent, no, no, no, no, no, no, engaged)
        by_handle = code >= _OPEN  # Open or Secured
        return RoundStep(silent, no, no, no, no, engaged & ~by_handle, engaged & by_handle, no)
    return RoundStep(no, no, no, no, no, no, no, no)


#: Round sessions a tag can be in: −1 (no round) and 0–3.
_N_ROUND_SESSIONS = 5


def _round_tables() -> tuple[dict, dict]:
    """:func:`round_step` evaluated once for every state, round session and command (ACK and
    NAK: no session): ``({(command class, its session or None): RoundStep of (len(STATES)·5,)
    bool arrays, row :func:`round_row` (code, session)}, {(command class, its session or None,
    state name, session or None): RoundStep of bools}``)."""
    grid = np.meshgrid(np.arange(len(STATES)), np.arange(-1, _N_ROUND_SESSIONS - 1), indexing="ij")
    code, session = (g.ravel() for g in grid)
    cmds = [kind(session=s) for kind in (Query, QueryRep, QueryAdjust) for s in range(4)] + [ACK(rn16=0), NAK()]
    states = [(STATES[c], None if s < 0 else s) for c, s in zip(code.tolist(), session.tolist())]
    rows, one = {}, {}
    for cmd in cmds:
        key = (type(cmd), getattr(cmd, "session", None))
        step = rows[key] = round_step(cmd, code, session)
        for f in step:
            f.setflags(write=False)
        for state, values in zip(states, zip(*(f.tolist() for f in step))):
            one[(*key, *state)] = RoundStep._make(values)
    return rows, one


#: :func:`round_step` for every state and command, over the rows :func:`round_row` (what a
#: population reads, :func:`round_step_rows`) and by state name and session (what one tag
#: reads, :func:`round_step_of_one`).
_ROUND_ROWS, _ROUND_TABLE = _round_tables()
#: The step of a command that is not a round command (Req_RN, Read, Select …): none.
_NO_STEP = RoundStep(False, False, False, False, False, False, False, False)
_NO_ROWS = RoundStep(*[np.zeros(len(STATES) * _N_ROUND_SESSIONS, bool)] * len(RoundStep._fields))


def round_row(code, session):
    """Return the row of tags in the tables of :func:`round_step_rows`: code·5 + session + 1.

    Parameters
    ----------
    code : int or ndarray of int, shape (n_tags,)
        Index of the tag's state in :data:`STATES`.
    session : int or ndarray of int, shape (n_tags,)
        Session of the tag's round, −1 for no round.

    Returns
    -------
    int or ndarray of int
        The row(s), 0 … 5·len(STATES) − 1.
    """
    return code * _N_ROUND_SESSIONS + (session + 1)


def round_step_rows(cmd) -> RoundStep:
    """Return :func:`round_step` of a command evaluated for every state and round session.

    A population reads its tags' rows (:func:`round_row`): ``round_step_rows(cmd).silent[row]``
    is ``round_step(cmd, code, session).silent`` (tested), one gather per field instead of the
    rules' comparisons.

    Parameters
    ----------
    cmd : rfsim.gen2.commands command
        The received command.

    Returns
    -------
    RoundStep
        Each field a read-only (5·len(STATES),) bool array; all False for a command that is
        not a round command.
    """
    return _ROUND_ROWS.get((type(cmd), getattr(cmd, "session", None)), _NO_ROWS)


def round_step_of_one(cmd, state: str, session: int | None) -> RoundStep:
    """Return :func:`round_step` for one tag: its row of the rules evaluated for every state.

    Parameters
    ----------
    cmd : rfsim.gen2.commands command
        The received command.
    state : str
        The tag's state, one of :data:`STATES`.
    session : int or None
        Session of the tag's round, None for no round.

    Returns
    -------
    RoundStep
        The transition, its fields Python bools.
    """
    return _ROUND_TABLE.get((type(cmd), getattr(cmd, "session", None), state, session), _NO_STEP)


def query_matches(sel: str, target: str, sl, flag):
    """Tell whether tags take part in a Query's round: its Sel and Target.

    EPC Gen2 "Query": Sel ``"sl"`` takes the tags whose SL flag is asserted, ``"~sl"`` those
    whose SL is deasserted, ``"all"``/``"all01"`` every tag; of those, the tags whose
    inventoried flag of the Query's session equals Target. For one tag or many.

    Parameters
    ----------
    sel : {"all", "all01", "~sl", "sl"}
        The Query's Sel.
    target : {"A", "B"}
        The Query's Target.
    sl : bool or ndarray of bool, shape (n_tags,)
        The tags' SL flags.
    flag : str or ndarray of str, shape (n_tags,)
        The tags' inventoried flags (``"A"``/``"B"``) of the Query's session.

    Returns
    -------
    bool or ndarray of bool
        The tag matches (then it loads a slot counter), else it leaves any round.
    """
    return ((sel != "sl") | sl) & ((sel != "~sl") | (sl == False)) & (flag == target)  # noqa: E712 (arrays)


#: The Select action table (EPC Gen2 "Select"): action → (matching tag, non-matching tag),
#: each 0 = do nothing, 1 = assert SL or inventoried → A, 2 = deassert SL or inventoried → B,
#: 3 = negate SL or A ↔ B.
SELECT_ACTIONS = np.array([[1, 2], [1, 0], [0, 2], [3, 0], [2, 1], [2, 0], [0, 1], [0, 3]], np.int8)


def select_step(action: int, match, asserted):
    """Apply the Select action table to tags' target flags.

    EPC Gen2 "Select" (:data:`SELECT_ACTIONS`). For one tag or many.

    Parameters
    ----------
    action : int
        The Select's Action, 0–7.
    match : bool or ndarray of bool, shape (n_tags,)
        The tag matches the Select's mask.
    asserted : bool or ndarray of bool, shape (n_tags,)
        The target flag now: SL asserted, or the inventoried flag at A.

    Returns
    -------
    acts : numpy bool or ndarray of bool
        The action changes (sets) the flag; where False the flag is left alone.
    new : numpy bool or ndarray of bool
        The flag afterwards where ``acts`` (asserted / A: True).
    """
    todo = SELECT_ACTIONS[action, 1 - np.asarray(match, dtype=np.int8)]
    return todo != 0, (todo == 1) | ((todo == 3) & (asserted == False))  # noqa: E712 (arrays)


class SilentPass(NamedTuple):
    """What :meth:`StateArrays.step_silently` did.

    Attributes
    ----------
    quiet : ndarray of bool, shape (n_tags,)
        Tags that stay quiet: the silent ones, the unpowered ones that stay so and those that
        loaded a new non-zero slot counter.
    silent : ndarray of bool, shape (n_tags,) or None
        Tags that took a silent step; None when none did.
    react : list of int
        The tags the caller steps (neither quiet nor redrawn), ascending.
    redrawn : ndarray of bool, shape (n_tags,) or None
        Tags that loaded a new non-zero slot counter; None when no tag redrew.
    replies : list of tuple (int, Reply)
        ``(row, reply)`` of the tags whose new counter is 0 (not quiet, not in ``react``).
    """

    quiet: np.ndarray
    silent: np.ndarray | None
    react: list
    redrawn: np.ndarray | None
    replies: list


class StateArrays:
    """The Gen2 state of many tags in arrays, for the silent steps of a population.

    Columns (one row per tag, :meth:`TagState.row`): ``powered`` (bool), ``code`` (index into
    :data:`STATES`), ``session`` (−1: none), ``slot`` (−1: none), ``t_s`` [s], ``s1_set_s``
    (NaN: S1 not set to B), ``s1_keep_s`` and ``q``. :meth:`step_silently` takes
    :meth:`TagState.on_command_if_silent`'s step for every row at once in one compiled pass
    (both read their rows of :func:`round_step`, :func:`round_step_rows`), leaving the rows and
    the :class:`TagState` objects exactly as ``on_command_if_silent`` would have left them,
    and the other frequent step of an inventory: a QueryAdjust that makes every tag of the
    round load a new slot counter (:meth:`take_redraw_steps`, the branch of ``on_command``
    taken without the dispatch, each counter drawn from its tag's own generator).
    :meth:`silent_steps`, :meth:`take_silent_steps` and :meth:`redraw_steps` are the pass's
    plain-NumPy reference (the tests hold the pass equal to them; the code does not call
    them).

    The tags whose last step was a silent one follow the arrays' :class:`SharedClock`
    (``clock``; ``following`` marks them): the next silent step advances them all by setting
    the clock, and only the tags that join or leave that set are touched one by one. The
    slot counters and Q of the tags whose last step was a QueryRep's decrement or a
    QueryAdjust's non-zero counter (``counting``) are held by the columns ``slot`` and ``q``
    themselves (the clock's ``slots`` and ``qs``: the tag reads its row), so those steps
    write the columns and touch only the tags that join or leave that set. A tag's own step
    (``on_command`` …) sets its time and counter, which ends its following; :meth:`read`
    notes it.

    Parameters
    ----------
    states : iterable of TagState
        The tags, one row each, in this order.
    rngs : sequence of numpy.random.Generator, optional
        Each tag's own generator (distinct), for :meth:`take_redraw_steps` without
        generators (:meth:`use_generators`).

    Attributes
    ----------
    states : list of TagState
        The tags.
    clock : SharedClock
        The clock the silently stepping tags follow.
    following, counting : ndarray of bool, shape (n_tags,)
        Tags whose time / slot counter follows ``clock``.
    row : ndarray of int, shape (n_tags,)
        Each tag's row of the tables of :func:`round_step_rows`, :func:`round_row` of its
        ``code`` and ``session`` (kept with them).

    Notes
    -----
    Two bounds kept with the columns spare a command its whole-population comparisons where
    they cannot hold: the latest time in ``t_s`` (a tag whose clock is past the command's
    time is left to ``on_command``: none while the command is not earlier than every tag's
    time) and whether any tag has S1 set to B (none: no S1 flag can revert). Each is
    conservative (raised as rows are read or stepped, never lowered but by a read of every
    row), so the decisions are those of the full comparisons.
    """


    def __init__(self, states, rngs=None):
        self.states = list(states)
        self._rngs: list | None = None
        self._draws: list | None = None
        self._words: GeneratorWords | None = None
        if rngs is not None:
            self.use_generators(rngs)
        n = len(self.states)
        self.powered = np.zeros(n, bool)
        self.code = np.zeros(n, np.int8)
        self.session = np.full(n, -1, np.int64)
        self.slot = np.full(n, -1, np.int64)
        self.t_s = np.zeros(n)
        self.s1_set_s = np.full(n, np.nan)
        self.s1_keep_s = np.zeros(n)
        self.q = np.zeros(n, np.int64)
        self._columns = [getattr(self, name) for name in _COLUMNS]  # (written in place, never rebound)
        self.clock = SharedClock(slots=self.slot, qs=self.q)  # (the columns, not copies)
        self.following = np.zeros(n, bool)
        self.counting = np.zeros(n, bool)
        self.row = np.zeros(n, np.int64)
        #: step_silently's scratch: the tags each TagState move is for, and their counts
        self._moves = np.zeros((7, n), np.int64), np.zeros(7, np.int64)
        self._t_max = -np.inf  # no tag's time is later (Notes)
        self._s1_set = False  # whether any tag may have S1 set to B (Notes)
        self.read(range(n))

    def use_generators(self, rngs) -> None:
        """Give every row its tag's own generator, for :meth:`take_redraw_steps` called
        without generators: the words of the slot draws of many tags are then drawn in one
        compiled loop (:class:`rfsim.gen2.generator_words.GeneratorWords`), or, for
        generators without NumPy's C interface, one by one (each generator's slot draw,
        :func:`rfsim.gen2.tag_draws.slot_draw`, made here).

        Parameters
        ----------
        rngs : sequence of numpy.random.Generator
            ``rngs[i]`` is tag i's own generator (distinct generators).

        Raises
        ------
        ValueError
            When there is not one generator per row.
        """
        rngs = list(rngs)
        if len(rngs) != len(self.states):
            raise ValueError(f"one generator per tag: {len(rngs)} for {len(self.states)} tags")
        words = self._words
        if words is None or len(words) != len(rngs) or not all(map(operator.is_, words.rngs, rngs)):
            words = GeneratorWords(rngs)  # (the same generators as before: their addresses kept)
        self._rngs, self._words = rngs, (words if words.usable else None)
        self._draws = None if words.usable else [_slot_drawer(r) for r in rngs]

    def read(self, index) -> None:
        """Copy rows from their :class:`TagState` objects.

        Parameters
        ----------
        index : iterable of int
            Rows (tag indices) to read: their columns, and whether each tag's time and slot
            counter follow the arrays' clock.
        """
        index = list(index)
        if not index:
            return
        states, clock = self.states, self.clock
        if len(index) <= 8:  # the few tags of one exchange that reacted: element by element
            columns = self._columns
            following, counting, rows = self.following, self.counting, self.row
            t_max, s1_set = self._t_max, self._s1_set
            for i in index:
                st = states[i]
                values = st.row()
                for col, value in zip(columns, values):
                    col[i] = value
                following[i] = st._clock is clock
                counting[i] = st._slot_clock is clock
                rows[i] = round_row(values[1], values[2])
                t_row = values[4]
                if not t_row <= t_max:
                    t_max = t_row if t_row == t_row else np.inf  # (a NaN time: no bound)
                s1_set = s1_set or values[5] == values[5]  # not NaN: S1 set to B
            self._t_max, self._s1_set = t_max, s1_set
            return
        cols = list(zip(*[states[i].row() for i in index]))
        for name, col in zip(_COLUMNS, cols):
            getattr(self, name)[index] = col
        whole = len(index) == len(states)  # every row read: the bounds anew
        t_max = float(np.max(self.t_s)) if whole else float(np.max(self.t_s[index], initial=self._t_max))
        self._t_max = t_max if t_max == t_max else np.inf  # (a NaN time: no bound)
        self._s1_set = bool(not np.isnan(self.s1_set_s).all()) if whole else (
            self._s1_set or any(v == v for v in cols[5]))
        self.row[index] = round_row(self.code[index], self.session[index])
        self.following[index] = [states[i]._clock is clock for i in index]
        self.counting[index] = [states[i]._slot_clock is clock for i in index]

    def silent_steps(self, cmd, candidates: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Decide which tags take a silent step for a command (:func:`round_step`): the
        plain-NumPy reference of :meth:`step_silently`'s decision (for the tests).

        The rules of :meth:`TagState.on_command_if_silent` for every row at once; a tag whose
        clock is past ``t_s`` is left to ``on_command`` (it raises).

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            The received command.
        candidates : ndarray of bool, shape (n_tags,)
            Tags to consider (only powered ones can step).
        t_s : float
            Time the command is received [s].

        Returns
        -------
        silent : ndarray of bool, shape (n_tags,)
            Candidates that take a silent step.
        decrement : ndarray of bool, shape (n_tags,)
            Those of them that decrement their slot counter (a QueryRep in Arbitrate of the
            round's session).
        """
        step, row = round_step_rows(cmd), self.row
        silent = candidates & self.powered & step.silent[row]
        if not self._t_max <= t_s:  # some tag's clock may be past t_s
            silent &= self.t_s <= t_s
        dec = silent & step.decrement[row]
        if np.count_nonzero(dec):  # a decrement is silent unless the tag then replies
            silent = np.greater(silent, dec & slot_replies(decremented(self.slot)))  # silent & ~(…)
            dec &= silent
        return silent, dec

    def step_silently(self, cmd, on: np.ndarray, stays_off: np.ndarray, t_s: float,
                      redraw: bool = False) -> SilentPass:
        """Decide and take the silent steps of a command in one pass over the rows, and a
        QueryAdjust's redraws.

        :meth:`silent_steps` followed by :meth:`take_silent_steps` (the same rows, rules and
        :class:`TagState` moves), and where ``redraw`` :meth:`redraw_steps` with
        :meth:`take_redraw_steps`, in one compiled loop
        (:func:`rfsim.devices._gen2_tag_kernels.silent_step_kernel`), with the tags that stay
        quiet: the silent ones, those unpowered that stay so and those whose new counter is not
        0. Only the tags that join or leave the clock's followers or counters, those whose S1
        flag reverts (each takes the step through :meth:`TagState.on_command_if_silent`, its
        row read back), those that redraw and those that react cost a step in Python.

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            The received command (a command of no silent step leaves every row alone).
        on : ndarray of bool, shape (n_tags,)
            Tags to consider: powered ones that stay powered.
        stays_off : ndarray of bool, shape (n_tags,)
            Tags whose power decision keeps them unpowered (quiet where not powered).
        t_s : float
            Time the command is received [s].
        redraw : bool, default False
            A QueryAdjust's tags of the round load their new counters here, each from its own
            generator (those given to :meth:`use_generators`); else they react.

        Returns
        -------
        SilentPass
            The quiet tags, the silent ones, the tags that react and the redraws.

        Raises
        ------
        RuntimeError
            When a tag refuses a step decided silent (the rules disagree; a bug).
        """
        t_s = float(t_s)
        step, n = round_step_rows(cmd), len(self.states)
        quiet, silent = np.empty(n, bool), np.empty(n, bool)
        moves, n_moves = self._moves
        n_silent = _kernels.silent_step_kernel(
            on, stays_off, self.powered, self.row, step.silent, step.decrement, step.redraw, redraw, self.t_s,
            t_s, not self._t_max <= t_s, self.slot, self.counting, self.following, self.s1_set_s,
            self.s1_keep_s, self._s1_set, quiet, silent, moves, n_moves)
        join_count, leave_count, join_follow, leave_follow, n_react, n_own, n_redraw = n_moves.tolist()
        react = moves[_kernels.REACT, :n_react].tolist()
        if not n_silent and not n_redraw:
            return SilentPass(quiet, None, react, None, [])
        states, clock = self.states, self.clock
        # (each list only where the pass has put tags in it: most commands move few or none)
        if leave_count:
            for i in moves[_kernels.LEAVE_COUNT, :leave_count].tolist():  # (their rows: not decremented now)
                states[i].follow_decrements(None)
        if join_count:
            for i in moves[_kernels.JOIN_COUNT, :join_count].tolist():
                states[i].count_with(clock, i)  # (the row decremented)
        if leave_follow:
            for i in moves[_kernels.LEAVE_FOLLOW, :leave_follow].tolist():
                states[i].follow(None)
        clock.t_s = t_s
        if join_follow:
            for i in moves[_kernels.JOIN_FOLLOW, :join_follow].tolist():
                states[i].follow(clock)
        if t_s > self._t_max:
            self._t_max = t_s
        if n_own:
            self._own_silent_steps(cmd, moves[_kernels.OWN_STEP, :n_own].tolist(), t_s)
        redrawn, replies = None, []
        if n_redraw:
            index = moves[_kernels.REDRAW, :n_redraw].copy()  # (an index array: no Python ints)
            replies = self.take_redraw_steps(cmd, index, None, t_s)
            redrawn = np.zeros(n, bool)
            redrawn[index] = True
            for i, _ in replies:  # (a counter of 0: the tag replies)
                redrawn[i] = quiet[i] = False
        return SilentPass(quiet, silent if n_silent else None, react, redrawn, replies)

    def _own_silent_steps(self, cmd, index: list, t_s: float) -> None:
        """The tags ``index`` take the silent step of ``cmd`` at ``t_s`` [s] through their own
        state (:meth:`TagState.on_command_if_silent`: their S1 flags revert), and their rows
        are read back."""
        for i in index:
            if not self.states[i].on_command_if_silent(cmd, t_s=t_s):
                raise RuntimeError("a silent step was refused")  # the rules disagree
        self.read(index)

    def redraw_steps(self, cmd, candidates: np.ndarray, t_s: float) -> np.ndarray:
        """Decide which tags load a new slot counter on a QueryAdjust: the plain-NumPy
        reference of :meth:`step_silently`'s redraw decision (for the tests).

        Those are the powered tags in Arbitrate or Reply of the command's session
        (``TagState._query_adjust``) whose clock is not past ``t_s`` and whose S1 flag is not
        due to revert (those are left to ``on_command``).

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            The received command; any other than a QueryAdjust redraws nothing.
        candidates : ndarray of bool, shape (n_tags,)
            Tags to consider.
        t_s : float
            Time the command is received [s].

        Returns
        -------
        ndarray of bool, shape (n_tags,)
            Tags that redraw their counter; all False when ``cmd`` is not a QueryAdjust.
        """
        if type(cmd) is not QueryAdjust:
            return np.zeros(len(self.states), bool)
        t_s = float(t_s)
        ok = candidates & self.powered & round_step_rows(cmd).redraw[self.row]
        if not self._t_max <= t_s:  # some tag's clock may be past t_s
            ok &= self.t_s <= t_s
        if self._s1_set:
            ok = np.greater(ok, s1_reverts(t_s, self.s1_set_s, self.s1_keep_s))  # ok & ~reverts
        return ok

    def take_redraw_steps(self, cmd, index: list, rngs: list | None, t_s: float) -> list:
        """Apply a QueryAdjust to the tags that redraw their slot counter.

        Each tag's clock advances to ``t_s``, :math:`Q \\leftarrow \\min(15, \\max(0, Q +
        \\mathrm{UpDn}))`, and it loads a slot counter uniform in [0, 2^Q − 1] and replies with
        an RN16 when it is 0 (``TagState._load_slot``: the same draws in the same order as
        ``on_command``). Rows and :class:`TagState` objects are both updated.

        A tag that follows the arrays' clock while the clock is at ``t_s`` (a step of
        :meth:`take_silent_steps` at ``t_s`` that it joined, its ``joining`` argument) keeps
        following it; the others take ``t_s`` as their own time. A non-zero counter counts down
        with the clock from here on (``counting``): the next QueryRep's decrements touch none
        of these tags one by one.

        Parameters
        ----------
        cmd : rfsim.gen2.commands.QueryAdjust
            The command.
        index : list of int or ndarray of int
            Rows that redraw (from :meth:`redraw_steps`, e.g. ``numpy.flatnonzero`` of its mask).
        rngs : list of numpy.random.Generator or None
            The tags' own generators, ``rngs[k]`` for tag ``index[k]``, distinct (every tag
            draws its counter, and at 0 its RN16 after it, from its own; the order among tags
            does not matter); None: those given to :meth:`use_generators`.
        t_s : float
            Time the command is received [s].

        Returns
        -------
        list of tuple (int, Reply)
            ``(row, reply)`` of the tags whose new counter is 0, each an RN16 reply.

        Raises
        ------
        ValueError
            When ``rngs`` is None and no generators were given.
        """
        if len(index) == 0:
            return []
        t_s = float(t_s)
        idx = np.asarray(index, dtype=np.int64)  # (rows as Python ints only where a tag is touched)
        q_new = adjusted_q(self.q[idx], int(cmd.updn))
        states, clock = self.states, self.clock
        if rngs is None and self._words is not None:  # the words of every draw in one loop
            draw = q_new > 0  # Q = 0 draws nothing: counter 0
            if draw.all():
                slot = _top_bits(self._words.draw(idx), q_new)
            else:
                slot = np.zeros(idx.size, dtype=np.int64)
                slot[draw] = _top_bits(self._words.draw(idx[draw]), q_new[draw])
        else:
            if rngs is None:
                if self._rngs is None:
                    raise ValueError("take_redraw_steps without generators needs use_generators first")
                draws = list(map(self._draws.__getitem__, idx.tolist()))
            else:
                draws = list(map(_slot_drawer, rngs))
            slot = np.array([draw(q) for draw, q in zip(draws, q_new.tolist())], dtype=np.int64)
        # Q and the counter into the columns: a tag that counted with the clock reads them there
        # (its rows), so only the tags that join or leave that set are touched one by one
        counting = self.counting[idx]
        self.q[idx] = q_new
        self.slot[idx] = slot
        zero = slot_replies(slot)
        # TagState._reply_if_zero: a non-zero counter → Arbitrate (from Reply), counting with the
        # clock; 0 → Reply with an RN16 from the tag's own generator
        join = np.greater(~zero, counting)  # ~zero & ~counting
        if np.count_nonzero(join):
            for i in idx[join].tolist():
                states[i].count_with(clock, i)  # (the row written above)
        fix = ~zero & (self.code[idx] == _REPLY)
        if np.count_nonzero(fix):
            for st in _picked_of(states, idx, fix):
                st.state = "arbitrate"
        replies = []
        if np.count_nonzero(zero):
            ks = np.flatnonzero(zero)
            for k, i, q in zip(ks.tolist(), idx[ks].tolist(), q_new[ks].tolist()):
                st = states[i]
                st.slot, st.q = 0, q  # its own counter and Q
                replies.append((i, st._reply_if_zero(self._rngs[i] if rngs is None else rngs[k])))
        own = ~self.following[idx] if clock.t_s == t_s else np.ones(idx.size, bool)
        if np.count_nonzero(own):  # (else every one follows the clock already)
            for st in _picked_of(states, idx, own):
                st._clock, st._t_s = None, t_s  # its own time (the t_s setter)
            self.following[idx] = ~own
        self.counting[idx] = ~zero
        self.t_s[idx] = t_s
        if t_s > self._t_max:
            self._t_max = t_s
        self.code[idx] = code = np.where(zero, _REPLY, _ARBITRATE)
        self.row[idx] = round_row(code, self.session[idx])
        return replies

    def take_silent_steps(self, cmd, silent: np.ndarray, decrement: np.ndarray, t_s: float,
                          joining: np.ndarray | None = None) -> None:
        """Apply the silent steps decided by :meth:`silent_steps`: the plain-NumPy reference
        of :meth:`step_silently`'s updates (for the tests).

        Each tag's clock advances to ``t_s`` and a decrementing tag's slot counter goes to
        (slot − 1) mod 2^15, through the shared clock. A tag whose S1 flag is due to revert
        takes the step through :meth:`TagState.on_command_if_silent` itself (and its row is
        read back).

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            The command received.
        silent : ndarray of bool, shape (n_tags,)
            Tags that take a silent step.
        decrement : ndarray of bool, shape (n_tags,)
            Those of them that decrement their slot counter.
        t_s : float
            Time the command is received [s].
        joining : ndarray of bool, shape (n_tags,), optional
            Tags that are not silent but follow the clock at ``t_s`` too: those that redraw
            their counter on this QueryAdjust (:meth:`take_redraw_steps`, called next with the
            same ``t_s``, keeps them following). Their counters are not touched here.

        Raises
        ------
        RuntimeError
            When a tag refuses a step decided silent (the rules disagree; a bug).
        """

        t_s = float(t_s)
        # NaN (S1 not set) compares False; no tag with S1 set: none due
        due = silent & s1_reverts(t_s, self.s1_set_s, self.s1_keep_s) if self._s1_set else None
        if due is not None and np.count_nonzero(due):
            self._own_silent_steps(cmd, np.flatnonzero(due).tolist(), t_s)
            silent = np.greater(silent, due)  # silent & ~due
            decrement = np.greater(decrement, due)
        if np.count_nonzero(decrement):
            np.copyto(self.slot, decremented(self.slot), where=decrement)  # (the others' values unchanged)
            self._count_down(decrement)
        np.copyto(self.t_s, t_s, where=silent)  # (a masked assignment costs more)
        if t_s > self._t_max:
            self._t_max = t_s
        self._follow(silent if joining is None else silent | joining, t_s)

    def _count_down(self, decrement: np.ndarray) -> None:
        """The tags ``decrement`` (bool mask), whose counters the column ``slot`` holds
        decremented, count with the clock: those that counted with it and do not decrement now
        keep their counter (and Q) as their own, and the decrementing ones that did not count
        with it join it (their rows hold their values: the arrays mirror the tags). A step
        without decrements changes no counter."""
        if not np.count_nonzero(decrement):
            return
        clock, states = self.clock, self.states
        leave = np.greater(self.counting, decrement)  # counting & ~decrement
        if np.count_nonzero(leave):
            for st in _picked(states, leave):  # (their rows: their counters, not decremented now)
                st.follow_decrements(None)
        join = np.greater(decrement, self.counting)  # decrement & ~counting
        if np.count_nonzero(join):
            for i in np.flatnonzero(join).tolist():
                states[i].count_with(clock, i)  # (the row decremented above)
        self.counting = decrement.copy()

    def _follow(self, silent: np.ndarray, t_s: float) -> None:
        """The tags ``silent`` (bool mask) advance to ``t_s`` [s] through the shared clock:
        those that followed it and are not silent now keep the clock's time as their own,
        the clock moves to ``t_s``, and the silent ones follow it."""
        clock, states = self.clock, self.states
        leave = np.greater(self.following, silent)  # following & ~silent
        if np.count_nonzero(leave):
            for st in _picked(states, leave):
                st.follow(None)
        clock.t_s = t_s
        join = np.greater(silent, self.following)  # silent & ~following
        if np.count_nonzero(join):
            for st in _picked(states, join):
                st.follow(clock)
        self.following = silent.copy()


def _picked(objects: list, mask: np.ndarray):
    """The objects where ``mask`` (bool, one per object) is True, in order: the indices found
    in the array, so that only the picked objects cost a step in Python."""
    return map(objects.__getitem__, np.flatnonzero(mask).tolist())


def _picked_of(objects: list, index: np.ndarray, mask: np.ndarray):
    """The objects ``objects[index[k]]`` where ``mask[k]`` (bool, one per entry of ``index``) is
    True, in order."""
    return map(objects.__getitem__, index[mask].tolist())


__all__ = ["StateArrays", "SilentPass", "RoundStep", "round_step", "round_row", "round_step_rows", "round_step_of_one", "query_matches", "slot_replies",
           "decremented", "s1_reverts", "SELECT_ACTIONS", "select_step"]
