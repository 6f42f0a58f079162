"""Settled envelope levels per reflection state: the sample-level counterpart of the
envelope difference ``A1 − A2`` between the two reflection states that phase cancellation
is judged on (auris-sense-a-tag.md Eq. 3.3/3.4; used by
:class:`rfsim.devices.st_receiver.STReceiver` and importable from there).
"""

from __future__ import annotations

import numpy as np


def settled_mask(states, settle_samples: int, guard_samples: int = 0) -> np.ndarray:
    """True where ``states`` has kept its value for at least ``settle_samples`` samples and
    keeps it for at least ``guard_samples`` more (margin against a misaligned state
    sequence)."""
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
    envelope_v : (n,) float64 detector output [V]
    states : (n,) state label of each sample (e.g. ±1 line-code level, or 0/1/2)
    values : the state labels to report
    settle_samples : samples skipped after every state change (RC settling)
    guard_samples : samples skipped before every state change

    Returns
    -------
    (len(values),) float64 mean envelope per state (NaN when a state has no settled sample)
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

    The sample-level counterpart of ``A1 − A2`` (Eq. 3.3/3.4): mean of the settled detector
    output in the +1 state minus that in the −1 state.
    """
    hi, lo = state_levels(envelope_v, states, (1, -1), settle_samples=settle_samples,
                          guard_samples=guard_samples)
    return float(hi - lo)


__all__ = ["settled_mask", "state_levels", "state_envelope_difference"]
