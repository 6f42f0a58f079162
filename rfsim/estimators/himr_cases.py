"""The seven analysis cases of the 2-D HIMR study as post-processing of a recorded
measurement stream (himr-tag.md §3.5, §4.3, §5; seed 000 L1050–L1072, L1243–L1404).

As in the source, link breakage ("submarining") is emulated on recorded data: every sensed
quantity is corrupted over the outage window, 0.39–0.75 s (360 ms ≈ 50 packets at
141 packets/s, L1243). The cases:

1. all measurements;
2. the last value before the outage is repeated through it (L1243–L1261);
3. the gain is switched off during the outage, dx̂/dt = A·x̂ (eq. 52, L1056–L1060);
4. the measurements are linearly interpolated between the last value before and the first
   after the outage (offline reconstruction, L1064–L1066);
5. inertial replay: the IMU outputs are kept (stored on the tag and replayed), the RF
   outputs repeat their last value (L1068);
6. every other packet (70.5 packets/s, L1069, L1354);
7. pylons 1 and 2 only (rows of pylon 3 removed; the gain is re-solved with V = I₈,
   L1070, L1392, L2019).

A measurement is inside the outage when t ∈ [t_start, t_end); the held/interpolation
anchors are the last epoch before t_start and the first at or after t_end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CASES = {
    1: "all measurements",
    2: "repeat the last value during the outage",
    3: "gain off (open loop) during the outage",
    4: "offline linear interpolation over the outage",
    5: "inertial replay, RF held during the outage",
    6: "every other packet",
    7: "pylons 1 and 2 only",
}
OUTAGE_S = (0.39, 0.75)


@dataclass(frozen=True, eq=False)
class CaseStream:
    """A measurement stream prepared for one case.

    Attributes
    ----------
    case : 1…7
    t_s : (n,) epochs;  y : (n, p) outputs in observer order
    gain_on : (n,) bool (False inside the Case-3 outage)
    pylons : indices of the pylons whose outputs ``y`` holds
    """

    case: int
    t_s: np.ndarray
    y: np.ndarray
    gain_on: np.ndarray
    pylons: tuple[int, ...]


def case_stream(case: int, t_s, y, *, n_pylons: int = 3, outage_s=OUTAGE_S) -> CaseStream:
    """Apply case ``case`` (module docstring) to a stream ``y`` (n, 2·n_pylons + 4)."""
    if case not in CASES:
        raise ValueError(f"case must be one of {sorted(CASES)}, got {case!r}")
    t = np.asarray(t_s, float)
    y = np.array(y, dtype=float, copy=True)
    if y.shape != (t.size, 2 * n_pylons + 4):
        raise ValueError(f"y must be ({t.size}, {2 * n_pylons + 4}), got {y.shape}")
    on = np.ones(t.size, bool)
    pylons = tuple(range(n_pylons))
    inside = (t >= outage_s[0]) & (t < outage_s[1])
    if case in (2, 3, 4, 5) and inside.any():
        before = np.nonzero(t < outage_s[0])[0]
        after = np.nonzero(t >= outage_s[1])[0]
        if before.size == 0:
            raise ValueError("the outage starts before the first measurement")
        i0 = before[-1]
        rf = slice(0, 2 * n_pylons)
        if case == 2:
            y[inside] = y[i0]
        elif case == 3:
            on[inside] = False
        elif case == 5:
            y[inside, rf] = y[i0, rf]
        else:
            if after.size == 0:
                raise ValueError("case 4 needs a measurement after the outage")
            i1 = after[0]
            w = ((t[inside] - t[i0]) / (t[i1] - t[i0]))[:, None]
            y[inside] = (1 - w) * y[i0] + w * y[i1]
    if case == 6:
        t, y, on = t[::2], y[::2], on[::2]
    if case == 7:
        pylons = (0, 1)
        keep = [0, 1, 2, 3] + list(range(2 * n_pylons, 2 * n_pylons + 4))
        y = y[:, keep]
    return CaseStream(case=case, t_s=t, y=y, gain_on=on, pylons=pylons)


__all__ = ["CASES", "OUTAGE_S", "CaseStream", "case_stream"]
