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
    """The receive chain run on many inputs (one row per input).

    Attributes
    ----------
    envelope_v : numpy.ndarray, shape (n_rows, n_samples), float64
        Detector output [V].
    bandpassed_v : numpy.ndarray, shape (n_rows, n_samples), float64
        Band-pass output [V].
    comparator : numpy.ndarray, shape (n_rows, n_samples), float64
        Comparator output (±1).
    toggles : numpy.ndarray, shape (n_rows,), int64
        Comparator toggles per row.
    """

    envelope_v: np.ndarray
    bandpassed_v: np.ndarray
    comparator: np.ndarray
    toggles: np.ndarray

    @classmethod
    def run(cls, rx: sr.STReceiver, x) -> "RowsChain":
        """The chain of ``rx`` on many inputs (:func:`rfsim.devices.sense_a_tag.chain_rows`).

        Parameters
        ----------
        rx : rfsim.devices.st_receiver.STReceiver
            Receive chain (detector, band-pass, comparator).
        x : array_like, shape (n_rows, n_samples), complex128
            Baseband inputs [√W].

        Returns
        -------
        RowsChain
            Detector, band-pass and comparator outputs of every row.
        """
        return cls(*_sense_a_tag.chain_rows(rx, x))

    def matched(self, rx: sr.STReceiver, frames, rows=None) -> np.ndarray:
        """Which frame each row decodes exactly from the reply start on.

        The frames share their timing (reply start and bit count of ``frames[0]``), as the
        frames of one slot sent together. The decision of
        :func:`rfsim.devices.sense_a_tag.decode_rows` (module docstring): at least
        ``rx.min_toggles`` comparator toggles, a preamble correlation of at least
        ``rx.min_corr`` and equal bits; without its envelope-level measurement
        (:meth:`level_difference_v` does that for all rows at once).

        Parameters
        ----------
        rx : rfsim.devices.st_receiver.STReceiver
            The receive chain that produced this object (decoder settings).
        frames : sequence of rfsim.devices.own_schedule.Frame
            Candidate frames (``stamp.reply_start`` and ``bits`` are read).
        rows : array_like of bool, shape (n_rows,), optional
            Rows to decode (default all); the others get −1.

        Returns
        -------
        numpy.ndarray, shape (n_rows,), int64
            Index in ``frames`` of the decoded frame (the last one if several have equal bits),
            −1 for none.
        """
        rows = np.ones(self.comparator.shape[0], bool) if rows is None else np.asarray(rows, bool)
        start = frames[0].stamp.reply_start
        search = int(2 * rx.fs_hz / rx.blf_hz)
        toggles = np.count_nonzero(np.diff(self.comparator[:, start:], axis=1), axis=1)
        out = np.full(rows.size, -1, dtype=np.int64)
        arrays = rx.search_arrays  # the preamble search's arrays of the receiver's link, kept with it
        for i in np.flatnonzero(rows & (toggles >= rx.min_toggles)):
            try:
                det = _linecode.decode_reply(self.comparator[i, start:].astype(np.complex128),
                                             n_bits=frames[0].bits.size, m=rx.m, trext=rx.trext, blf_hz=rx.blf_hz,
                                             fs_hz=rx.fs_hz, method=rx.method, search_samples=search, arrays=arrays)
            except ValueError:
                continue
            if det.corr < rx.min_corr:
                continue
            for j, frame in enumerate(frames):
                if np.array_equal(det.bits, frame.bits):
                    out[i] = j
        return out

    def decoded(self, rx: sr.STReceiver, frame, rows=None) -> np.ndarray:
        """Whether the payload of ``frame`` is decoded exactly from the reply start on.

        :meth:`matched` with one frame.

        Parameters
        ----------
        rx : rfsim.devices.st_receiver.STReceiver
            The receive chain that produced this object.
        frame : rfsim.devices.own_schedule.Frame
            The frame sent (``stamp.reply_start`` and ``bits`` are read).
        rows : array_like of bool, shape (n_rows,), optional
            Rows to decode (default all); the others are False.

        Returns
        -------
        numpy.ndarray of bool, shape (n_rows,)
            True where the frame's bits are decoded.
        """
        return self.matched(rx, [frame], rows) == 0

    def level_difference_v(self, rx: sr.STReceiver, frame) -> np.ndarray:
        """Settled envelope difference ``|A(+1) − A(−1)|`` over the reply, per row [V].

        The sample-level counterpart of ``|A1 − A2|`` (auris-sense-a-tag.md Eq. 3.3/3.4), settled
        with ``rx.settle_samples`` / ``rx.guard_samples``.

        Parameters
        ----------
        rx : rfsim.devices.st_receiver.STReceiver
            The receive chain that produced this object (settling margins).
        frame : rfsim.devices.own_schedule.Frame
            The frame sent (``stamp.levels``: line-code level per sample).

        Returns
        -------
        numpy.ndarray, shape (n_rows,), float64
            ``|A(+1) − A(−1)|`` [V].
        """
        return np.abs(_sense_a_tag.level_differences(self.envelope_v, frame.stamp.levels, rx))

    def stamp_symbols(self, rx: sr.STReceiver, frame, min_transitions: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Decoded ASK and PSK stamp symbols of every row (auris-sense-a-tag.md §5).

        A stamp part decodes as '1' when the comparator makes at least ``min_transitions``
        transitions in it; 0 means one per subcarrier cycle of the part (half the transitions of
        an undisturbed part), the rule of :func:`rfsim.devices.st_receiver.receive_stamp`.

        Parameters
        ----------
        rx : rfsim.devices.st_receiver.STReceiver
            The receive chain that produced this object (``fs_hz``, ``blf_hz``).
        frame : rfsim.devices.own_schedule.Frame
            The frame sent (``stamp.start``, ``stamp.ask_stop``, ``stamp.psk_stop``).
        min_transitions : int, default 0
            Comparator transitions needed for a '1'; 0 = one per subcarrier cycle of the part.

        Returns
        -------
        ask : numpy.ndarray of bool, shape (n_rows,)
            ASK stamp symbol per row (True = '1', False = '-').
        psk : numpy.ndarray of bool, shape (n_rows,)
            PSK stamp symbol per row (True = '1', False = '-').
        """
        st = frame.stamp
        need = min_transitions or max(1, int(round((st.ask_stop - st.start) * rx.blf_hz / rx.fs_hz)))
        d = np.diff(self.comparator, axis=1) != 0
        ask = d[:, st.start:st.ask_stop - 1].sum(axis=1) >= need
        psk = d[:, st.ask_stop:st.psk_stop - 1].sum(axis=1) >= need
        return ask, psk


__all__ = ["RowsChain"]
