"""The sense-a-tag receive chain run on many inputs at once (one row per listener position or
draw): detector output, band-pass and comparator of every row (:class:`RowsChain`), and the
decisions read from them — which frame the Miller decoder recovers exactly, the settled
envelope difference over the reply, the ASK and PSK stamp symbols.

The chain is :func:`rfsim.devices.sense_a_tag.chain_rows` (one numba pass per row, equal to
:meth:`rfsim.devices.st_receiver.STReceiver.chain` row by row); the reply decision is that of
:func:`rfsim.devices.sense_a_tag.decode_rows` (comparator toggles at least ``rx.min_toggles``
times, preamble correlation at least ``rx.min_corr``, bits equal; auris-sense-a-tag.md §5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.lazy import lazy_import

sr = lazy_import("rfsim.devices.st_receiver")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_linecode = lazy_import("rfsim.gen2.linecode")


@dataclass(frozen=True, eq=False)
class RowsChain:
    """The receive chain run on many inputs: detector output, band-pass, comparator (r, n) [V],
    comparator toggles (r,)."""

    envelope_v: np.ndarray
    bandpassed_v: np.ndarray
    comparator: np.ndarray
    toggles: np.ndarray

    @classmethod
    def run(cls, rx: sr.STReceiver, x) -> "RowsChain":
        """The chain of ``rx`` on the inputs ``x`` (r, n) complex128 [√W]."""
        return cls(*_sense_a_tag.chain_rows(rx, x))

    def matched(self, rx: sr.STReceiver, frames, rows=None) -> np.ndarray:
        """(r,) int64: index in ``frames`` of the frame whose bits the chain decodes exactly from
        the reply start on, −1 for none; only ``rows`` (bool (r,), default all) are decoded.

        The frames share their timing (reply start and bit count of ``frames[0]``), as the
        frames of one slot sent together. The decision of
        :func:`rfsim.devices.sense_a_tag.decode_rows` (module docstring), without its
        envelope-level measurement (:meth:`level_difference_v` does that for all rows at once).
        """
        rows = np.ones(self.comparator.shape[0], bool) if rows is None else np.asarray(rows, bool)
        start = frames[0].stamp.reply_start
        search = int(2 * rx.fs_hz / rx.blf_hz)
        toggles = np.count_nonzero(np.diff(self.comparator[:, start:], axis=1), axis=1)
        out = np.full(rows.size, -1, dtype=np.int64)
        for i in np.flatnonzero(rows & (toggles >= rx.min_toggles)):
            try:
                det = _linecode.decode_reply(self.comparator[i, start:].astype(np.complex128),
                                             n_bits=frames[0].bits.size, m=rx.m, trext=rx.trext, blf_hz=rx.blf_hz,
                                             fs_hz=rx.fs_hz, method=rx.method, search_samples=search)
            except ValueError:
                continue
            if det.corr < rx.min_corr:
                continue
            for j, frame in enumerate(frames):
                if np.array_equal(det.bits, frame.bits):
                    out[i] = j
        return out

    def decoded(self, rx: sr.STReceiver, frame, rows=None) -> np.ndarray:
        """(r,) bool: the payload of ``frame`` decoded exactly from the reply start on, in
        ``rows`` (default all) (:meth:`matched` with one frame)."""
        return self.matched(rx, [frame], rows) == 0

    def level_difference_v(self, rx: sr.STReceiver, frame) -> np.ndarray:
        """(r,) |A(+1) − A(−1)| of the settled detector output over the reply [V]."""
        return np.abs(_sense_a_tag.level_differences(self.envelope_v, frame.stamp.levels, rx))

    def stamp_symbols(self, rx: sr.STReceiver, frame, min_transitions: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Decoded ASK and PSK stamp symbols, (r,) bool each (True = '1', False = '-').

        A stamp part decodes as '1' when the comparator makes at least ``min_transitions``
        transitions in it; 0 means one per subcarrier cycle of the part (half the transitions of
        an undisturbed part), the rule of :func:`rfsim.devices.st_receiver.receive_stamp`.
        """
        st = frame.stamp
        need = min_transitions or max(1, int(round((st.ask_stop - st.start) * rx.blf_hz / rx.fs_hz)))
        d = np.diff(self.comparator, axis=1) != 0
        ask = d[:, st.start:st.ask_stop - 1].sum(axis=1) >= need
        psk = d[:, st.ask_stop:st.psk_stop - 1].sum(axis=1) >= need
        return ask, psk


__all__ = ["RowsChain"]
