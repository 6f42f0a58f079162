"""Reflector groups in the air step (:func:`rfsim.air.step.propagate`, "Groups"): the flat
member list of a step's reflectors, the per-member lists whose entries for a group that
took the shortcut are formed when read, and a group's backscatter at a receiver (its quiet
members' held constants summed in member order, its reacting members one by one).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rfsim.air.links import through

__all__ = ["members_of", "entries_of", "UNSET", "PerMember", "accumulate", "modulates", "group_backscatter"]


def members_of(reflectors: Sequence) -> list:
    """The reflectors of a step with every :class:`ReflectorGroup` replaced by its members
    (the indices every per-reflector list of the step uses)."""
    return entries_of(reflectors)[0]


def entries_of(reflectors: Sequence) -> tuple[list, list]:
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


UNSET = object()


class PerMember(Sequence):
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
        if v is UNSET:
            v = self._items[j] = self._fill(j)
        return v


def accumulate(start: complex, values: np.ndarray) -> complex:
    """``start + values[0] + values[1] + …`` added left to right (``numpy.add.accumulate`` is
    sequential: the same sums, in the same order, as a Python loop)."""
    acc = np.empty(values.size + 1, dtype=np.complex128)
    acc[0] = start
    acc[1:] = values
    return complex(np.add.accumulate(acc)[-1])


def modulates(entries: list, reflections: list, shortcut: dict) -> bool:
    """Whether any reflection of the step (of a group that took the shortcut: its reactions,
    its quiet members being constant) scatters a field that is not a constant multiple of its
    incident one."""
    for start, stop, _ in entries:
        gr = shortcut.get(start)
        for r in (gr.reactions.values() if gr is not None else reflections[start:stop]):
            if r is not None and r.scatters and r.constant_reradiation is None:
                return True
    return False


def group_backscatter(gr, start: int, whole: bool, gains, backs, members, r_ant, seg, links, const: dict,
                      parts: list, *, i0: int, t0_s: float, n_samples: int, bw: float, propagation: str,
                      memo: dict) -> None:
    """A group that took the shortcut, at a receiver on the emitter's carrier with held
    backward constants ``backs``: its quiet members' held constants b_j·(r_j·g_j) and its
    reacting members' contributions, in member order (the per-member branch of
    :func:`rfsim.air.step.propagate`, members added to the factor of x one after the other)."""
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
        gb, yb = through(pj, seg, scattered, fc_hz=seg.fc_hz, bandwidth_hz=bw, propagation=propagation, memo=memo)
        parts.append(yb if yb is not None else gb * scattered)
    vals = terms if vals is None else vals
    if use.any():
        const[i0] = accumulate(const.get(i0, 0j), vals[use])
