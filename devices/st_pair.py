"""The dual-antenna sense-a-tag (ST) at sample level: mutual coupling of its λ/4 antenna pair,
the ASK-PSK stamp decision and the four techniques run on many ST positions at once.

Antennas (auris-sense-a-tag.md §1.5/§1.6, §5): SA1 feeds the receive-only path P1, SA2 the full
ST path P2; a single-antenna ST is SA2 alone. Techniques (R3-5, R5-1; closed forms in
:func:`rfsim.devices.st_analytic.technique_outcomes`): single = the chain on SA2; combination =
one chain on the RF sum SA1 + SA2; selection = Algorithm 1 (SA2, else SA1); stamp = the
transmitter sends an ASK-PSK stamp (:data:`STAMP_CYCLES` + :data:`STAMP_CYCLES` subcarrier
cycles, PSK ψ = :data:`STAMP_PSI_RAD`, then :data:`STAMP_SETTLE_CYCLES` ASK settling cycles,
:func:`rfsim.devices.st_receiver.stamp_frame`) before the reply and the ST decodes on SA2 unless
the ASK stamp symbol is '-' (then on SA1). A technique *detects* when its chain decodes the
reply exactly; a sample is *cancelled* when it is detectable (the single-antenna ST with the CW
synchronised, ``sync_sa2_v`` above the threshold) and not detected.

Pair coupling (:func:`couple_ports`): the λ/4 pair's mutual coupling (Z11 = 73.1 + j42.5 Ω, Z12
from the induced-EMF formula, 40.4 − j28.4 Ω at λ/4, conjugate-matched loads,
:func:`rfsim.devices.st_analytic.coupling_matrix`) mixes the two ports' signals, CW and
backscatter alike. In the phase-cancellation scenario (full run, seed 1) it raises path
selection's P(cancel) from 12.7 % to 13.3 % (7.5 % → 11.3 % with PASS's tag antenna file) by
correlating the ports.

Stamp vs selection. Identical in closed form; at sample level the stamp lost (i) the first
pilot cycles after its PSK part, whose envelope swing (up to 2|b|, 5–10× the ASK swing) the
band-pass carries into the reply — fixed by the settling cycles — and (ii) commits to P2 from
four subcarrier cycles, which pass a comparator at a swing a few % below what Miller data need,
where Algorithm 1 falls back to P1 after P2's decode fails; a 3 % decision margin
(:data:`STAMP_DECISION_MARGIN`) removes most of that. Phase-cancellation full run, seed 1: 0.93
points apart before, 0.44 after (with pair coupling; 81 stamp-only against 31 selection-only
failures of 11 464; 0.72 with PASS's tag antenna file); what is left are samples whose SA2
swing is within ±3.5 % of the threshold.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices import st_analytic as sa
from rfsim.devices import st_receiver as sr
from rfsim.core.lazy import lazy_import

_kernels = lazy_import("rfsim.devices._st_pair_kernels")
_sat = lazy_import("rfsim.devices.sense_a_tag")

#: Subcarrier cycles of each stamp part (ASK, then PSK)
STAMP_CYCLES = 8
#: ASK pilot cycles between the PSK stamp and the reply: the band-pass settles after the
#: PSK swing (:func:`rfsim.devices.st_receiver.stamp_frame`)
STAMP_SETTLE_CYCLES = 8
#: Relative margin of the ASK-stamp decision over the data threshold. Four regular
#: subcarrier cycles toggle the comparator at a swing a few % below the one Miller data
#: need (the band-pass overshoot depends on the run lengths), so without a margin the stamp
#: commits to P2 where P2's reply then fails and Algorithm 1 would have fallen back to P1
#: (phase-cancellation full run, seed 1: 110 of the 118 stamp-only failures had P2 within
#: ±3.5 % of 5 mV).
STAMP_DECISION_MARGIN = 0.03
#: PSK state separation ψ of the stamp (S3 = S1·e^{jψ}) [rad]
STAMP_PSI_RAD = math.pi


def couple_ports(mix, x) -> np.ndarray:
    """Port signals of the λ/4 pair after mutual coupling, ``y_i = Σ_j M_ij·x_j``.

    Parameters
    ----------
    mix : array_like, shape (2, 2), complex
        Coupling matrix M (:func:`rfsim.devices.st_analytic.coupling_matrix`).
    x : array_like, shape (N, 2, ...), complex
        Uncoupled port signals (SA1, SA2 on axis 1): waveforms (N, 2, n_samples) [√W] or
        narrowband gains (N, 2).

    Returns
    -------
    numpy.ndarray, shape (N, 2, ...), complex128
        The coupled port signals. Waveforms go through a numba kernel
        (:func:`rfsim.devices._st_pair_kernels.couple_ports_kernel`: the operations of
        ``np.einsum("ij,nj...->ni...", mix, x)``, equal bit for bit); other shapes through that
        ``einsum`` itself (its loop over (N, 2) sums from +0, which turns a −0 sum into +0).

    Raises
    ------
    ValueError
        If ``x`` is not of shape (N, 2, ...).
    """
    x = np.asarray(x)
    if x.ndim < 2 or x.shape[1] != 2:
        raise ValueError(f"x must be (N, 2, ...), got shape {x.shape}")
    if x.ndim != 3:
        return np.einsum("ij,nj...->ni...", mix, x)
    x = np.ascontiguousarray(x, dtype=np.complex128)
    out = np.empty_like(x)
    _kernels.couple_ports_kernel(np.ascontiguousarray(mix, dtype=np.complex128), x, out)
    return out


def ask_stamp_transitions(bandpassed_v, frame: sr.StampFrame, threshold_v: float) -> np.ndarray:
    """Comparator transitions over the settled half of the ASK stamp, per row.

    A comparator of hysteresis width ``threshold_v`` runs from −1 at the ASK stamp's first
    sample ``frame.start``; its transitions are counted over the second half of the ASK
    stamp, from ``(start + ask_stop)//2`` to ``ask_stop`` (numba kernel
    :func:`rfsim.devices._st_pair_kernels.comparator_changes_rows_kernel`; the twin is
    ``ask_stamp_transitions_reference``).

    Parameters
    ----------
    bandpassed_v : numpy.ndarray, shape (n_rows, n_samples)
        Band-pass output of each row [V].
    frame : rfsim.devices.st_receiver.StampFrame
        The stamped frame (``start``, ``ask_stop`` index the samples).
    threshold_v : float
        Comparator hysteresis width [V].

    Returns
    -------
    numpy.ndarray, shape (n_rows,), int64
        Transitions in the second half of the ASK stamp.
    """
    seg = np.ascontiguousarray(bandpassed_v[:, frame.start:frame.ask_stop], dtype=np.float64)
    out = np.empty(seg.shape[0], dtype=np.int64)
    skip = (frame.start + frame.ask_stop) // 2 - frame.start
    _kernels.comparator_changes_rows_kernel(seg, 0.5 * threshold_v, -0.5 * threshold_v, skip, out)
    return out


def stamp_rows(rx: sr.STReceiver, stamp_inputs, frame: sr.StampFrame, *, expected_bits, fs_hz: float,
               blf_hz: float, memo: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """ASK-PSK stamp technique (§5) on many positions: stamp symbols on SA2, decode on the chosen path.

    The ASK symbol is '1' when a comparator at (1 + :data:`STAMP_DECISION_MARGIN`)·threshold
    makes at least ``STAMP_CYCLES − 1`` transitions in the second (settled) half of the ASK
    stamp (the band-pass starts from rest at the stamp's first edge); otherwise the ST decodes
    on SA1 (auris-sense-a-tag.md §5, seed L5984-5990).

    Parameters
    ----------
    rx : rfsim.devices.st_receiver.STReceiver
        The ST receive chain.
    stamp_inputs : numpy.ndarray, shape (n_rows, 2, n_samples), complex128
        SA1 and SA2 inputs during the stamped frame [√W].
    frame : rfsim.devices.st_receiver.StampFrame
        The stamped frame (indices into the inputs' samples).
    expected_bits : array_like of uint8
        The reply's bits.
    fs_hz : float
        Sample rate [Hz].
    blf_hz : float
        Backscatter link frequency [Hz] (the decoder searches the reply start within
        ``2·fs/BLF`` samples of ``frame.reply_start``).
    memo : dict or None
        Decodings shared between the calls of :func:`rfsim.devices.sense_a_tag.decode_rows`
        (None: one for this call's two paths).

    Returns
    -------
    use_p1 : numpy.ndarray of bool, shape (n_rows,)
        The ASK stamp read '-' on SA2 (decode on SA1).
    detected : numpy.ndarray of bool, shape (n_rows,)
        The chosen path decoded ``expected_bits`` exactly.
    """
    # the ASK symbol reads SA2's band-pass up to the ASK stamp's end only: the chain (causal, from
    # the frame's first sample, rows independent) runs over that head for every row, and over the
    # whole frame on the path each row decodes on (the same samples as one chain of every row)
    head = _sat.chain_rows(rx, stamp_inputs[:, 1, :max(frame.ask_stop, 1)])[1]
    thr = (1.0 + STAMP_DECISION_MARGIN) * rx.threshold_v
    use_p1 = ask_stamp_transitions(head, frame, thr) < STAMP_CYCLES - 1
    head = None
    kw = dict(expected_bits=expected_bits, start_sample=frame.reply_start, search_samples=int(2 * fs_hz / blf_hz),
              memo={} if memo is None else memo)
    det = np.zeros(use_p1.size, bool)
    for path, chosen in ((1, ~use_p1), (0, use_p1)):
        if chosen.any():
            idx = np.flatnonzero(chosen)
            chain = _sat.chain_rows(rx, stamp_inputs[idx, path])
            det[idx] = _sat.decode_rows(rx, *chain, rows=np.ones(idx.size, bool), **kw)
            chain = None  # one path's chain at a time
    return use_p1, det


def technique_rows(rx: sr.STReceiver, cw, bs1, bs2, reply, *, detector_gain: float,
                   threshold_v: float) -> dict[str, np.ndarray]:
    """Sample-level ST chains of the four techniques for n positions, and the closed forms from the same phasors.

    Techniques (module docstring; R3-5, R5-1): single, combination, selection, stamp; the
    closed forms are :func:`rfsim.devices.st_analytic.technique_outcomes` through the
    receiver's detector law.

    Parameters
    ----------
    rx : rfsim.devices.st_receiver.STReceiver
        The ST receive chain (its detector law is also the closed forms' law).
    cw, bs1, bs2 : numpy.ndarray, shape (n, k), complex
        Antenna-level phasors [V] (RF peak at 50 Ω) of the CW and of the backscatter in the
        modulating and absorbing states (k = 2: SA1, SA2; k = 1: SA2).
    reply : object
        The reply heard, with attributes ``inputs`` (n, k, samples) complex [√W] (SA1, SA2
        inputs during the reply), ``stamp_inputs`` (the same during the stamped frame, k = 2),
        ``levels`` (samples,) the true line-code levels, ``frame``
        (:class:`rfsim.devices.st_receiver.StampFrame`), ``rn16`` (the reply's bits, None
        when the tag did not reply), ``search`` (decoder search window [samples]), ``fs_hz``,
        ``blf_hz``.
    detector_gain : float
        Linear-law detector gain [V/V].
    threshold_v : float
        Comparator threshold [V].

    Returns
    -------
    dict of str to numpy.ndarray, each shape (n,)
        A_R, A_T1, A_T2, θ per antenna [V, rad] (``a_r_sa2_v``, ...), ``sync_sa2_v``,
        closed-form differences ``closed_diff_*_v`` and flags ``closed_cancelled_*``,
        sample-level detector differences ``diff_*_v``, ``detectable``,
        ``detected_<technique>``, ``cancelled_<technique>``, ``stamp_use_p1``
        (:func:`describe_column` describes each).
    """
    n, k = cw.shape
    det = rx.envelope_detector
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(("sa1", "sa2")[-k:]):
        out[f"a_r_{name}_v"] = np.abs(cw[:, j])
        out[f"a_t1_{name}_v"] = np.abs(bs1[:, j])
        out[f"a_t2_{name}_v"] = np.abs(bs2[:, j])
        out[f"theta_{name}_rad"] = np.angle(bs1[:, j] * np.conj(cw[:, j]))
    two = k == 2
    # column 0 is SA1 for a dual-antenna ST (with one antenna, SA2 stands in for SA1 unused)
    if det.law == "agc":
        # the AGC scales each input by venv(peak)/peak: its gain at SA2's envelope peak
        gain_rows = det.agc_gain(np.maximum(np.abs(cw[:, -1] + bs1[:, -1]), np.abs(cw[:, -1] + bs2[:, -1])))
        transfer = lambda v: gain_rows * v  # noqa: E731
    else:
        transfer = None if det.law == "linear" else det.transfer_v
    closed = sa.technique_outcomes(cw[:, 0], bs1[:, 0], bs2[:, 0], cw[:, -1], bs1[:, -1], bs2[:, -1],
                                   detector_gain=detector_gain, threshold_v=threshold_v, transfer=transfer)
    out["sync_sa2_v"] = closed.sync_sa2_v
    out["closed_diff_sa2_v"] = closed.diff_sa2_v
    if two:
        out["closed_diff_sa1_v"] = closed.diff_sa1_v
        out["closed_diff_combined_v"] = closed.diff_combined_v
    detectable = closed.sync_sa2_v > threshold_v
    out["detectable"] = detectable
    for t in _sat.TECHNIQUES:
        out[f"closed_cancelled_{t}"] = getattr(closed, f"cancelled_{t}")
    if reply.rn16 is None:
        for t in _sat.TECHNIQUES:
            out[f"detected_{t}"] = np.zeros(n, bool)
        for name in ("sa1", "sa2", "combined")[(0 if two else 1):(3 if two else 2)]:
            out[f"diff_{name}_v"] = np.zeros(n)
        out["stamp_use_p1"] = np.zeros(n, bool)
    else:
        out.update(_decoded_rows(rx, reply, two))
    for t in _sat.TECHNIQUES:
        if f"detected_{t}" in out:
            out[f"cancelled_{t}"] = detectable & ~out[f"detected_{t}"]
    return out


def _decoded_rows(rx: sr.STReceiver, reply, two: bool) -> dict[str, np.ndarray]:
    """Sample-level differences and decisions of :func:`technique_rows` for a tag that replied."""
    out: dict[str, np.ndarray] = {}
    n = reply.inputs.shape[0]
    inputs = {"sa2": lambda: reply.inputs[:, -1]}
    if two:
        inputs["sa1"] = lambda: reply.inputs[:, 0]
        inputs["combined"] = lambda: reply.inputs[:, 0] + reply.inputs[:, -1]
    dec = {}
    memo: dict = {}  # decodings by comparator output, shared by the chains (sense_a_tag.decode_rows)
    for name in ("sa2", "combined", "sa1"):
        if name not in inputs:
            continue
        # one chain at a time: its four (n, samples) arrays are the largest of the cell's memory
        chain = None
        chain = _sat.chain_rows(rx, inputs[name]())
        out[f"diff_{name}_v"] = np.abs(_sat.level_differences(chain[0], reply.levels, rx))
        # Algorithm 1 returns ID2 whenever P2 decodes: P1's result matters only where P2 failed
        rows = ~dec["sa2"] if name == "sa1" else np.ones(n, bool)
        dec[name] = _sat.decode_rows(rx, *chain, rows=rows, expected_bits=reply.rn16, start_sample=0,
                                     search_samples=reply.search, memo=memo)
    chain = None
    out["detected_single"] = dec["sa2"]
    if two:
        out["detected_combination"] = dec["combined"]
        out["detected_selection"] = sa.select_detected(dec["sa1"], dec["sa2"])
        use_p1, det_stamp = stamp_rows(rx, reply.stamp_inputs, reply.frame, expected_bits=reply.rn16,
                                       fs_hz=reply.fs_hz, blf_hz=reply.blf_hz, memo=memo)
        out["detected_stamp"] = det_stamp
        out["stamp_use_p1"] = use_p1
    return out


# ----------------------------------------------------------------------------- column descriptions

#: The antennas as the column descriptions name them (key: the name inside a column name)
ANTENNAS = {
    "sa1": "SA1 (receive-only path P1)",
    "sa2": "SA2 (full ST path P2; the single-antenna ST)",
    "combined": "the RF sum SA1 + SA2 (simple combination)",
}
#: The techniques as the column descriptions name them
TECHNIQUE_NAMES = {
    "single": "single antenna (SA2 alone)",
    "combination": "simple combination (one chain on SA1 + SA2)",
    "selection": "receiving-path selection (Algorithm 1: SA2, else SA1)",
    "stamp": "ASK-PSK stamp (the stamp's ASK symbol picks SA2 or SA1)",
}
_VOLTS = ("antenna-level amplitude sqrt(2R)|phasor| at R = 50 ohm of the narrowband phasor at the "
          "reference sample (the reader's CW after its command)")
#: (unit, description) of the :func:`technique_rows` columns that are neither per antenna nor per technique
OUTCOME_COLUMNS: dict[str, tuple[str, str]] = {
    "sync_sa2_v": ("V", "detector-output envelope difference at SA2 with the CW synchronised to the "
                        "backscatter: max over the CW phase phi of ||c e^{j phi} + b1| - |c e^{j phi} + b2|| "
                        "(= |b1 - b2| when the CW dominates) through the detector law: the detectability "
                        "condition (R3-5, rfsim.devices.st_analytic.synchronised_difference)"),
    "detectable": ("1", "sync_sa2_v above the comparator threshold st.threshold_v: a single-antenna ST "
                        "would see the tag without phase cancellation"),
    "stamp_use_p1": ("1", "the ASK stamp symbol was '-' on SA2, so the stamp technique decoded on SA1"),
}
#: (name prefix, description template) of the per-antenna columns; {ant} names the antenna.
ANTENNA_COLUMNS = (
    ("a_r_", "A_R, amplitude of the reader's CW at {ant}: " + _VOLTS),
    ("a_t1_", "A_T1, backscatter amplitude at {ant} in the tag's modulating state (re-radiated A_s - Gamma_B "
              "times the incident field): " + _VOLTS),
    ("a_t2_", "A_T2, backscatter amplitude at {ant} in the tag's absorbing state (re-radiated A_s - Gamma_A "
              "times the incident field): " + _VOLTS),
    ("theta_", "theta, phase of the backscatter (state 1) relative to the reader's CW at {ant}, (-pi, pi]"),
    ("diff_", "sample-level envelope difference |A(+1) - A(-1)| at the detector output of {ant}: mean detector "
              "level in the tag's two states over the RN16 reply (0 when the tag did not reply)"),
    ("closed_diff_", "closed-form envelope difference |A1 - A2| (Eq. 3.4, Eq. 3.21 for the sum) at {ant} from "
                     "the measured phasors through the detector law (detector.law; |f(|c + b1|) - f(|c + b2|)|)"),
)
#: (name prefix, description template) of the per-technique columns (of :func:`technique_rows`
#: and of per-cell probabilities); {tech} names the technique.
TECHNIQUE_COLUMNS = (
    ("detected_", "the ST decoded the tag's RN16 exactly with {tech} (sample-level receive chain)"),
    ("closed_cancelled_", "phase cancellation predicted by the closed forms (Eq. 3.4/3.21, R3-5) for {tech}: "
                          "detectable, but the technique's envelope difference is below the threshold"),
    ("cancelled_", "phase cancellation with {tech}: detectable and not detected (sample level)"),
    ("p_", "probability of phase cancellation with {tech} in the cell: cancelled samples / n_samples (R3-5)"),
    ("ci_lo_", "lower bound of the Clopper-Pearson 95 % interval of p_{key} (n_samples trials)"),
    ("ci_hi_", "upper bound of the Clopper-Pearson 95 % interval of p_{key} (n_samples trials)"),
)


def column_unit(key: str) -> str:
    """Unit of a column from its name's suffix.

    Parameters
    ----------
    key : str
        Column name.

    Returns
    -------
    str
        ``"V"`` for ``_v``, ``"m"`` for ``_m``, ``"rad"`` for ``_rad``, ``"W"`` for ``_w``,
        else ``"1"``.
    """
    for suffix, unit in (("_v", "V"), ("_m", "m"), ("_rad", "rad"), ("_w", "W")):
        if key.endswith(suffix):
            return unit
    return "1"


def describe_column(key: str) -> str | None:
    """Description of a column of :func:`technique_rows` or of a per-cell probability.

    Parameters
    ----------
    key : str
        Column name: an :data:`OUTCOME_COLUMNS` key, a per-antenna column (prefix of
        :data:`ANTENNA_COLUMNS` + antenna) or a per-technique column (prefix of
        :data:`TECHNIQUE_COLUMNS`, e.g. ``p_``, ``ci_lo_``, ``ci_hi_``, + technique).

    Returns
    -------
    str or None
        The description, None for other names.
    """
    if key in OUTCOME_COLUMNS:
        return OUTCOME_COLUMNS[key][1]
    ant = next((a for a in ANTENNAS if f"_{a}_" in f"_{key}_"), None)
    tech = next((t for t in TECHNIQUE_NAMES if key.endswith(f"_{t}")), None)
    if ant:
        for prefix, template in ANTENNA_COLUMNS:
            if key.startswith(prefix):
                return template.format(ant=ANTENNAS[ant])
    if tech:
        for prefix, template in TECHNIQUE_COLUMNS:
            if key.startswith(prefix):
                return template.format(tech=TECHNIQUE_NAMES[tech], key=tech)
    return None


def cell_probabilities(flags: dict[str, np.ndarray], cell, n_cells: int, keep=None) -> dict[str, np.ndarray]:
    """P(cancel) per cell and technique with its Clopper–Pearson 95 % interval.

    Each cell's flags go through :func:`rfsim.devices.st_analytic.cancellation_probability`
    (R3-5).

    Parameters
    ----------
    flags : dict of str to numpy.ndarray
        Technique → (n,) bool cancelled flags of the samples.
    cell : numpy.ndarray, shape (n,), int
        Cell index of each sample, in ``range(n_cells)``.
    n_cells : int
        Number of cells.
    keep : numpy.ndarray of bool, shape (n,), optional
        Samples that count (default all).

    Returns
    -------
    dict of str to numpy.ndarray, each shape (n_cells,)
        ``p_<t>``, ``ci_lo_<t>``, ``ci_hi_<t>`` per technique (in the order of ``flags``) and
        ``n_samples`` (samples kept per cell) after the first technique.

    Raises
    ------
    ValueError
        If a cell has no sample.
    """
    out: dict[str, np.ndarray] = {}
    for t, f in flags.items():
        p, lo, hi, nn = np.empty(n_cells), np.empty(n_cells), np.empty(n_cells), np.empty(n_cells, int)
        for c in range(n_cells):
            sel = (cell == c) if keep is None else (cell == c) & keep
            p[c], lo[c], hi[c], nn[c] = sa.cancellation_probability(f[sel])
        out[f"p_{t}"], out[f"ci_lo_{t}"], out[f"ci_hi_{t}"] = p, lo, hi
        out["n_samples"] = nn
    return out


__all__ = ["STAMP_CYCLES", "STAMP_SETTLE_CYCLES", "STAMP_DECISION_MARGIN", "STAMP_PSI_RAD", "couple_ports",
           "ask_stamp_transitions", "stamp_rows", "technique_rows", "ANTENNAS", "TECHNIQUE_NAMES", "OUTCOME_COLUMNS",
           "ANTENNA_COLUMNS", "TECHNIQUE_COLUMNS", "column_unit", "describe_column", "cell_probabilities"]
