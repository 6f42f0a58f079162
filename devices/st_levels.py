"""Settled envelope levels per reflection state: the sample-level counterpart of the
envelope difference ``A1 − A2`` between the two reflection states that phase cancellation
is judged on (auris-sense-a-tag.md Eq. 3.3/3.4; used by
:class:`rfsim.devices.st_receiver.STReceiver` and importable from there).
"""

from __future__ import annotations

import numpy as np


def settled_mask(states, settle_samples: int, guard_samples: int = 0) -> np.ndarray:
    """Samples where a state sequence has settled.

    True where ``states`` has kept its value for at least ``settle_samples`` samples and
    keeps it for at least ``guard_samples`` more (margin against a misaligned state
    sequence).

    Parameters
    ----------
    states : array_like, shape (n_samples,)
        State label of each sample.
    settle_samples : int
        Samples since the last state change required (RC settling).
    guard_samples : int, default 0
        Samples before the next state change required.

    Returns
    -------
    numpy.ndarray of bool, shape (n_samples,)
        The settled-sample mask.
    """
    s = np.asarray(states)
    n = np.arange(s.size)
    change = np.ones(s.size, dtype=bool)
    change[1:] = s[1:] != s[:-1]
    last_change = np.maximum.accumulate(np.where(change, n, 0))
    ok = (n - last_change) >= int(settle_samples)
    if guard_samples > 0:
        nxt = np.ones(s.size, dtype=bool)  # True where the next sample starts a new run
        nxt[:-1] = change[1:]
        next_change = np.minimum.accumulate(np.where(nxt, n, s.size)[::-1])[::-1]
        ok &= (next_change - n) >= int(guard_samples)
    return ok


def state_levels(envelope_v, states, values, *, settle_samples: int, guard_samples: int = 0) -> np.ndarray:
    """Mean settled envelope per reflection state [V].

    Parameters
    ----------
    envelope_v : array_like, shape (n_samples,)
        Detector output [V].
    states : array_like, shape (n_samples,)
        State label of each sample (e.g. ±1 line-code level, or 0/1/2).
    values : sequence
        The state labels to report.
    settle_samples : int
        Samples skipped after every state change (RC settling).
    guard_samples : int, default 0
        Samples skipped before every state change.

    Returns
    -------
    numpy.ndarray, shape (len(values),), float64
        Mean envelope per state [V] (NaN when a state has no settled sample).

    Raises
    ------
    ValueError
        If ``envelope_v`` and ``states`` differ in shape.
    """
    env = np.asarray(envelope_v, dtype=np.float64)
    s = np.asarray(states)
    if env.shape != s.shape:
        raise ValueError(f"envelope and states differ in shape: {env.shape} vs {s.shape}")
    ok = settled_mask(s, settle_samples, guard_samples)
    out = np.full(len(values), np.nan)
    for i, val in enumerate(values):
        sel = ok & (s == val)
        if sel.any():
            out[i] = env[sel].mean()
    return out


def state_envelope_difference(envelope_v, states, *, settle_samples: int, guard_samples: int = 0) -> float:
    """Signed envelope difference ``A(+1) − A(−1)`` between the two line-code states [V].

    The sample-level counterpart of ``A1 − A2`` (auris-sense-a-tag.md Eq. 3.3/3.4): mean of
    the settled detector output in the +1 state minus that in the −1 state.

    Parameters
    ----------
    envelope_v : array_like, shape (n_samples,)
        Detector output [V].
    states : array_like, shape (n_samples,)
        Line-code level of each sample (±1; other labels are ignored).
    settle_samples : int
        Samples skipped after every state change (RC settling).
    guard_samples : int, default 0
        Samples skipped before every state change.

    Returns
    -------
    float
        ``A(+1) − A(−1)`` [V]; NaN if a state has no settled sample.
    """
    hi, lo = state_levels(envelope_v, states, (1, -1), settle_samples=settle_samples,
                          guard_samples=guard_samples)
    return float(hi - lo)


__all__ = ["settled_mask", "state_levels", "state_envelope_difference"]
