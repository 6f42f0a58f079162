"""Reflector groups in the air step (:func:`rfsim.air.step.propagate`, "Groups"): the flat
member list of a step's reflectors, the per-member lists whose entries for a group that
took the shortcut are formed when read, and a group's backscatter at a receiver (its quiet
members' held constants summed in member order, its reacting members one by one).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rfsim.air import _group_kernels as _kernels
from rfsim.air.fused import lazy_backscatter
from rfsim.air.links import through

__all__ = ["members_of", "entries_of", "UNSET", "PerMember", "accumulate", "masked_sum", "modulates", "group_backscatter"]


def members_of(reflectors: Sequence) -> list:
    """Flatten a step's reflectors, every reflector group replaced by its members.

    Parameters
    ----------
    reflectors : sequence
        The step's reflectors; a :class:`rfsim.air.roles.ReflectorGroup` stands for its members.

    Returns
    -------
    list
        The members, in the indices every per-reflector list of the step uses.
    """
    return entries_of(reflectors)[0]


def entries_of(reflectors: Sequence) -> tuple[list, list]:
    """Flatten a step's reflectors and record where each given reflector lies in the flat list.

    Parameters
    ----------
    reflectors : sequence
        The step's reflectors; a :class:`rfsim.air.roles.ReflectorGroup` stands for its members.

    Returns
    -------
    members : list
        The flat member list.
    entries : list of tuple
        Per given reflector ``(start, stop, group or None)``: its members' slice of ``members``
        and the group itself (None for a single reflector).
    """
    if len(reflectors) == 1:  # one reflector or one population: nothing to flatten
        one = reflectors[0]
        if hasattr(one, "reflect_scaled"):
            return one.members, [(0, len(one.members), one)]
        return [one], [(0, 1, None)]
    members, entries = [], []
    for r in reflectors:
        if hasattr(r, "reflect_scaled"):
            entries.append((len(members), len(members) + len(r.members), r))
            members.extend(r.members)
        else:
            entries.append((len(members), len(members) + 1, None))
            members.append(r)
    return members, entries


UNSET = object()


class PerMember(Sequence):
    """A per-member list of the step whose entries are formed when first read.

    The entries of the members of a group that took the shortcut
    (:meth:`rfsim.air.roles.ReflectorGroup.reflect_scaled`) are held as :data:`UNSET` until read.

    Parameters
    ----------
    items : list
        The entries, :data:`UNSET` where not yet formed (filled in place).
    fill : callable
        ``fill(j)`` forms entry j.
    """

    def __init__(self, items: list, fill):
        self._items, self._fill = items, fill

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, j):
        if isinstance(j, slice):
            return [self[k] for k in range(*j.indices(len(self._items)))]
        j = range(len(self._items))[j]
        v = self._items[j]
        if v is UNSET:
            v = self._items[j] = self._fill(j)
        return v


def accumulate(start: complex, values: np.ndarray) -> complex:
    """Add complex values to a start value strictly left to right.

    The same sums, in the same order, as a Python loop ``start + values[0] + values[1] + …``
    (:func:`masked_sum` of every value).

    Parameters
    ----------
    start : complex
        The start value.
    values : ndarray, shape (n,), complex
        The values to add, in order.

    Returns
    -------
    complex
        The sum.
    """
    return masked_sum(start, values, np.ones(values.size, bool))[1]


def masked_sum(start: complex, values: np.ndarray, use: np.ndarray) -> tuple[int, complex]:
    """Add the values picked by a mask to a start value strictly left to right, in one pass.

    ``start + values[i0] + values[i1] + …`` over the ``i`` where ``use[i]``, in index order: the
    same complex additions as a Python loop (and as ``numpy.add.accumulate`` of the picked values),
    so bit for bit the per-member sum of the air step.

    Parameters
    ----------
    start : complex
        The start value.
    values : ndarray, shape (n,), complex128
        The values, in order.
    use : ndarray of bool, shape (n,)
        The values to add.

    Returns
    -------
    count : int
        How many values were added.
    total : complex
        The sum (``start`` when none was added).
    """
    n, total = _kernels.masked_sum_kernel(complex(start), np.ascontiguousarray(values, np.complex128), use)
    return int(n), complex(total)


def modulates(entries: list, reflections: list, shortcut: dict) -> bool:
    """Tell whether any reflection of the step modulates.

    A reflection modulates when it scatters a field that is not a constant multiple of its
    incident one; of a group that took the shortcut only its reactions are looked at (its quiet
    members are constant).

    Parameters
    ----------
    entries : list of tuple
        ``(start, stop, group or None)`` per given reflector (:func:`entries_of`).
    reflections : list
        Per member its reflection (None: scatters nothing).
    shortcut : dict
        Start index → :class:`rfsim.air.roles.GroupReflection` of the groups that took the shortcut.

    Returns
    -------
    bool
        True when at least one reflection modulates.
    """
    for start, stop, _ in entries:
        gr = shortcut.get(start)
        for r in (gr.reactions.values() if gr is not None else reflections[start:stop]):
            if r is not None and r.scatters and r.constant_reradiation is None:
                return True
    return False


def group_backscatter(gr, start: int, whole: bool, gains, backs, members, r_ant, seg, links, const: dict,
                      parts: list, *, i0: int, t0_s: float, n_samples: int, bw: float, propagation: str,
                      memo: dict) -> None:
    """Add the backscatter of a group that took the shortcut at one receiver.

    The receiver is on the emitter's carrier and the backward links have held constants
    ``backs``. The quiet members' constants b_j·(r_j·g_j) and a non-modulating reacting member's
    constant are summed in member order into the factor of x (``const[i0]``, with
    :func:`accumulate`); a modulating reacting member's contribution is appended to ``parts``
    (the per-member branch of :func:`rfsim.air.step.propagate`; b_j times its scattered field
    when its backward link has a held constant, the link then not asked: kept as its factors,
    :func:`rfsim.air.fused.lazy_backscatter`, where it has their form).

    Parameters
    ----------
    gr : GroupReflection
        What the group returned from ``reflect_scaled``.
    start : int
        Index of the group's first member in the step's member list.
    whole : bool
        Whether the group's members are all the step's members (``backs`` is then the group's
        own list; otherwise its slice from ``start`` is used).
    gains : sequence of complex
        Per member the forward link constant g_j.
    backs : sequence of complex
        Per member the backward link constant b_j (None where not held).
    members : sequence
        The step's flat member list.
    r_ant : object
        The receiver's antenna.
    seg : Segment
        The emitter's segment x.
    links : Links
        The step's links.
    const : dict
        Emitter index → complex factor of its segment; updated in place.
    parts : list
        Full-length contributions of the receiver; appended to.
    i0 : int
        Index of the emitter whose segment is x.
    t0_s : float
        Start time of the step [s] (for the links).
    n_samples : int
        Samples of the step.
    bw : float
        Simulated bandwidth [Hz].
    propagation : str
        Propagation policy (:data:`rfsim.air.links.PROPAGATION_METHODS`).
    memo : dict
        The step's memo of narrowband link constants.
    """
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
        if backs[j] is not None:  # its backward link's held constant: what through() gives, the link not asked
            # b·((A_s − Γ)·(g·x)) kept as its factors where it has that form (formed with the sum,
            # in one kernel pass with the noise where it is the receiver's one part)
            lazy = lazy_backscatter(r, None, seg, g, None, rc, 0.0, n_samples, bw, propagation, memo, b=backs[j])
            if lazy is not None:
                parts.append(lazy)
                continue
        inc_e = g * seg.samples
        scattered = (rc * inc_e) if rc is not None else r.reradiation(n_samples) * inc_e
        if backs[j] is not None:
            parts.append(backs[j] * scattered)
            continue
        pj = links.paths(members[j].antenna, r_ant, fc_hz=seg.fc_hz, t_s=t0_s)
        gb, yb = through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=bw, propagation=propagation, memo=memo)
        parts.append(yb if yb is not None else gb * scattered)
    vals = terms if vals is None else vals
    n_used, total = masked_sum(const.get(i0, 0j), vals, use)  # (one pass over the members)
    if n_used:
        const[i0] = total
