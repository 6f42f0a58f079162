"""The Gen2 slot counter's rules (:func:`decremented`, :func:`slot_replies`) and S1 persistence
(:func:`s1_reverts`): for one tag or many, the one definition, re-exported by
:mod:`rfsim.devices.gen2_tag_arrays`; and the numba kernel of a population's silent step of a
QueryRep, QueryAdjust, ACK or NAK (wrapped and documented in
:meth:`rfsim.devices.gen2_tag_arrays.StateArrays.step_silently`; the plain-NumPy reference is
``StateArrays.silent_steps`` followed by ``StateArrays.take_silent_steps``, and
``StateArrays.redraw_steps``, used by the tests only).

The kernel reads the rules it applies: the rows of :func:`rfsim.devices.gen2_tag_arrays.round_step`
(``round_step_rows``, passed in) and the rules below, compiled into it. They live
here, in a kernel module, so that an edit of them changes the kernel cache's folder.
"""

from __future__ import annotations

from rfsim.core._jit import njit, njit_inline


def slot_replies(slot):
    """Tell whether a tag in a round replies with its slot counter ``slot``: at 0 it
    backscatters a new RN16 and goes to Reply, else it goes to (or stays in) Arbitrate.

    EPC Gen2 "Tag states and slot counter". For one tag or many.

    Parameters
    ----------
    slot : int or ndarray of int, shape (n_tags,)
        The counter(s).

    Returns
    -------
    bool or ndarray of bool
        The tag replies.
    """
    return slot == 0


def decremented(slot):
    """Return a slot counter after a QueryRep's decrement: (slot − 1) mod 2^15.

    EPC Gen2 "Tag states and slot counter" (0000h decrements to 7FFFh). For one tag or many.

    Parameters
    ----------
    slot : int or ndarray of int, shape (n_tags,)
        The counter(s), 0 … 7FFFh.

    Returns
    -------
    int or ndarray of int
        The decremented counter(s), the type and shape of ``slot``.
    """
    return (slot - 1) & 0x7FFF


def s1_reverts(t_s, s1_set_s, s1_keep_s):
    """Tell whether the S1 inventoried flag, set to B at ``s1_set_s``, has reverted to A by ``t_s``.

    S1 reverts from B to A once its persistence time has passed, powered or not (EPC Gen2
    "Sessions and inventoried flags", anchors §4.4): :math:`t - t_{set} \\ge t_{keep}`. For
    one tag or many.

    Parameters
    ----------
    t_s : float or ndarray
        The time now [s].
    s1_set_s : float or ndarray
        Time S1 was set to B [s] (NaN for many tags: not set; compares False).
    s1_keep_s : float or ndarray
        The S1 persistence time [s].

    Returns
    -------
    bool or ndarray of bool
        S1 has reverted.
    """
    return t_s - s1_set_s >= s1_keep_s


_decremented = njit_inline(decremented)
_slot_replies = njit_inline(slot_replies)
_s1_reverts = njit_inline(s1_reverts)

#: Rows of the kernel's ``moves``: tags that start / stop counting with the clock, start /
#: stop following its time, the tags that react (neither quiet nor redrawing), the silent tags
#: whose S1 flag reverts (they take the step through their own state) and the tags that load
#: a new slot counter (a QueryAdjust's redraw).
JOIN_COUNT, LEAVE_COUNT, JOIN_FOLLOW, LEAVE_FOLLOW, REACT, OWN_STEP, REDRAW = range(7)


@njit
def silent_step_kernel(on, stays_off, powered, row, step_silent, step_decrement, step_redraw, redraw, t_col, t_s,
                       check_t, slot, counting, following, s1_set_s, s1_keep_s, check_s1, quiet, silent, moves,
                       n_moves):
    """One pass over the tags: decide their silent steps and a QueryAdjust's redraws, and apply
    the silent steps to the columns.

    Tag i steps silently when ``on[i]``, ``step_silent[row[i]]``, its time ``t_col[i] ≤ t_s``
    (checked only where ``check_t``) and, where it decrements (``step_decrement[row[i]]``),
    its decremented counter does not reply. A silent tag whose S1 flag reverts by ``t_s``
    (:func:`s1_reverts` of ``s1_set_s[i]``, ``s1_keep_s[i]``; checked only where ``check_s1``)
    is listed in :data:`OWN_STEP` and its columns are left alone (the caller steps it through
    its own state); it leaves the clock's followers and counters like a tag that is not
    silent. Every other silent tag's time becomes ``t_s`` and it follows the clock
    (``following``); a decrementing one's counter is decremented and counts with the clock
    (``counting``). Where ``redraw``, a tag that is not silent but would be, at that time, by
    ``step_redraw[row[i]]`` and whose S1 flag does not revert is listed in :data:`REDRAW` (the
    caller draws its counter) and follows the clock as well. When any tag decrements (not
    counting those of :data:`OWN_STEP`), the others stop counting with the clock; when any tag
    steps silently or redraws, the others stop following it (both taken in the pass and undone
    at its end when no tag did). ``quiet[i]`` = ``silent[i]``, a redraw, or (``stays_off[i]``
    and not ``powered[i]``). ``moves[k, :n_moves[k]]`` (int64, (7, n)) receive the tags of
    :data:`JOIN_COUNT` … :data:`REDRAW`, in order (the caller moves the :class:`TagState`
    objects: leaving before joining). Returns the number of silent tags (those of
    :data:`OWN_STEP` included)."""
    n = row.size
    n_silent = 0
    n_dec = 0
    n_moves[JOIN_COUNT] = 0
    n_moves[LEAVE_COUNT] = 0
    j_follow = 0
    l_follow = 0
    n_react = 0
    n_own = 0
    n_redraw = 0
    for i in range(n):
        s = False
        d = False
        own = False
        rd = False
        if on[i] and (not check_t or t_col[i] <= t_s):
            r = row[i]
            if step_silent[r]:
                v = slot[i]
                if step_decrement[r]:
                    v = _decremented(v)
                    if not _slot_replies(v):  # (else it replies: not silent)
                        s = True
                        d = True
                else:
                    s = True
                if s and check_s1 and _s1_reverts(t_s, s1_set_s[i], s1_keep_s[i]):
                    moves[OWN_STEP, n_own] = i  # its own state takes the step
                    n_own += 1
                    own = True
                    s = False
                    d = False
                elif d:
                    slot[i] = v
            elif redraw and step_redraw[r] and not (check_s1 and _s1_reverts(t_s, s1_set_s[i], s1_keep_s[i])):
                moves[REDRAW, n_redraw] = i
                n_redraw += 1
                rd = True
        silent[i] = s or own
        if d:
            n_dec += 1
        if d != counting[i]:  # joins (d) or leaves the clock's counters (rare: listed as it comes)
            k = JOIN_COUNT if d else LEAVE_COUNT
            moves[k, n_moves[k]] = i
            n_moves[k] += 1
            counting[i] = d
        f = following[i]
        if s or rd:
            if s:
                n_silent += 1
                t_col[i] = t_s
            moves[JOIN_FOLLOW, j_follow] = i
            j_follow += not f
            following[i] = True
        elif f:
            moves[LEAVE_FOLLOW, l_follow] = i
            l_follow += 1
            following[i] = False
        q = s or own or rd or (stays_off[i] and not powered[i])
        quiet[i] = q
        moves[REACT, n_react] = i
        n_react += not q
    n_silent += n_own
    if n_dec == 0:  # a step without decrements changes no counter
        for k in range(n_moves[LEAVE_COUNT]):
            counting[moves[LEAVE_COUNT, k]] = True
        n_moves[LEAVE_COUNT] = 0
    if n_silent == 0 and n_redraw == 0:  # no silent step: no follower changes
        for k in range(l_follow):
            following[moves[LEAVE_FOLLOW, k]] = True
        l_follow = 0
    n_moves[JOIN_FOLLOW] = j_follow
    n_moves[LEAVE_FOLLOW] = l_follow
    n_moves[REACT] = n_react
    n_moves[OWN_STEP] = n_own
    n_moves[REDRAW] = n_redraw
    return n_silent
