"""numba kernel of a population's silent step of a QueryRep, ACK or NAK (wrapped and documented
in :meth:`rfsim.devices.gen2_tag_arrays.StateArrays.step_silently`; the plain-NumPy twin is
``StateArrays.silent_steps`` followed by ``StateArrays.take_silent_steps``).

The kernel reads the rules it applies: the rows of :func:`rfsim.devices.gen2_tag_arrays.round_step`
(``round_step_rows``) and the slot counter's :func:`~rfsim.devices.gen2_tag_values.decremented`
and :func:`~rfsim.devices.gen2_tag_values.slot_replies`, compiled into it from their one
definition.
"""

from __future__ import annotations

from rfsim.core._jit import njit, njit_inline
from rfsim.devices.gen2_tag_values import decremented, slot_replies

_decremented = njit_inline(decremented)
_slot_replies = njit_inline(slot_replies)

#: Rows of the kernel's ``moves``: tags that start / stop counting with the clock, start /
#: stop following its time, and the tags that are not quiet.
JOIN_COUNT, LEAVE_COUNT, JOIN_FOLLOW, LEAVE_FOLLOW, REACT = range(5)


@njit
def silent_step_kernel(on, stays_off, powered, row, step_silent, step_decrement, t_col, t_s, check_t,
                       slot, counting, following, quiet, silent, decrement, moves, n_moves):
    """One pass over the tags: decide their silent steps and apply them to the columns.

    Tag i steps silently when ``on[i]``, ``step_silent[row[i]]``, its time ``t_col[i] ≤ t_s``
    (checked only where ``check_t``) and, where it decrements (``step_decrement[row[i]]``),
    its decremented counter does not reply. A silent tag's time becomes ``t_s`` and it follows
    the clock (``following``); a decrementing one's counter is decremented and counts with the
    clock (``counting``), and, when any tag decrements, the others stop counting with it; when
    any tag steps silently, the others stop following the clock.
    ``quiet[i]`` = silent or (``stays_off[i]`` and not ``powered[i]``). ``moves[k, :n_moves[k]]``
    (int64, (5, n)) receive the tags of :data:`JOIN_COUNT` … :data:`REACT`, in order (the
    caller moves the :class:`TagState` objects: leaving before joining). Returns the number of
    silent tags."""
    n = row.size
    for k in range(5):
        n_moves[k] = 0
    n_silent = 0
    n_dec = 0
    for i in range(n):
        s = False
        d = False
        if on[i]:
            r = row[i]
            if step_silent[r] and (not check_t or t_col[i] <= t_s):
                s = True
                if step_decrement[r]:
                    if _slot_replies(_decremented(slot[i])):  # it replies: not silent
                        s = False
                    else:
                        d = True
        silent[i] = s
        decrement[i] = d
        if d:
            n_dec += 1
            slot[i] = _decremented(slot[i])
            if not counting[i]:
                moves[JOIN_COUNT, n_moves[JOIN_COUNT]] = i
                n_moves[JOIN_COUNT] += 1
                counting[i] = True
        if s:
            n_silent += 1
            t_col[i] = t_s
        q = s or (stays_off[i] and not powered[i])
        quiet[i] = q
        if not q:
            moves[REACT, n_moves[REACT]] = i
            n_moves[REACT] += 1
    if n_silent > 0:  # (no silent step: no counter, clock or follower changes)
        for i in range(n):
            if n_dec > 0 and counting[i] and not decrement[i]:  # (a step without decrements: none)
                moves[LEAVE_COUNT, n_moves[LEAVE_COUNT]] = i
                n_moves[LEAVE_COUNT] += 1
                counting[i] = False
            if silent[i]:
                if not following[i]:
                    moves[JOIN_FOLLOW, n_moves[JOIN_FOLLOW]] = i
                    n_moves[JOIN_FOLLOW] += 1
                    following[i] = True
            elif following[i]:
                moves[LEAVE_FOLLOW, n_moves[LEAVE_FOLLOW]] = i
                n_moves[LEAVE_FOLLOW] += 1
                following[i] = False
    return n_silent
