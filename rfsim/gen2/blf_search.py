"""The reader's BLF search: estimating a reply's BLF and decoding it in one pass
(:func:`search_decode`, numba kernel: the "blf grid" search step of the one reply decoder,
:func:`rfsim.gen2.reply_decoder.decode`), the coarse BLF grid and the RN16 acceptance threshold
(:meth:`rfsim.devices.reader.Reader.receive` with ``blf_search = "preamble"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.gen2.link import LinkProfile
from rfsim.gen2.linecode import elements_of_levels, preamble_levels, preamble_state
from rfsim.gen2.reply_core import (FINE_SPAN_STEPS, coarse_blf_step, geometric_blf_grid_hz, n_reply_elements,
                                   preamble_template0)
from rfsim.core.lazy import lazy_import

_bk = lazy_import("rfsim.gen2._blf_search_kernels")
_rck = lazy_import("rfsim.gen2._reply_core_kernels")

__all__ = ["SearchDecode", "search_decode", "blf_grid_hz", "rn16_threshold_db", "search_setup", "search_result",
           "FINE_SPAN_STEPS", "FINE_PER_SIDE", "FINE_FIRST_BITS"]


#: Fine BLF search: BLFs per side of each pass (its half-width, ``FINE_SPAN_STEPS`` coarse
#: steps, is the capture decoder's, :mod:`rfsim.gen2.reply_core`); bits of its first phase (a
#: longer reply is searched again over all its bits).
FINE_PER_SIDE = 4
FINE_FIRST_BITS = 16


@dataclass(frozen=True)
class SearchDecode:
    """Result of :func:`search_decode` for B windows (all arrays of length B).

    Attributes
    ----------
    bits : ndarray of uint8, shape (B, n_bits)
        Decoded data bits.
    blf_hz : ndarray of float, shape (B,)
        BLF decoded at [Hz].
    start : ndarray of float, shape (B,)
        Reply start [samples into the window].
    corr : ndarray of float, shape (B,)
        The coarse normalised preamble correlation.
    gain : ndarray of complex, shape (B,)
        h [√W].
    sigma2 : ndarray of float, shape (B,)
        Residual power per sample over the reply's steady samples [W].
    ebn0_db : ndarray of float, shape (B,)
        10·log10(|h|²·(2M/ρ)/σ²) [dB], ρ = 2·BLF/fs (samples per bit 2M/ρ).
    sigma2_bit : ndarray of float, shape (B,)
        σ_eff² [W], the disturbance that reaches the decisions: per data half-bit j the
        matched-filter output of the projection y = Re((r − c)·h*)/|h| on the decided levels
        minus |h|·N_j (N_j steady samples), σ_eff² = 2·Σδ_j²/ΣN_j (σ² for white noise; a
        second tag's in-band reply is not reduced by the matched filter's gain).
    decision_ebn0_db : ndarray of float, shape (B,)
        The acceptance statistic, Eb/(N0 + I) in the decision domain
        = 10·log10(|h|²·(2M/ρ)/σ_eff²) [dB].
    """

    bits: np.ndarray
    blf_hz: np.ndarray
    start: np.ndarray
    corr: np.ndarray
    gain: np.ndarray
    sigma2: np.ndarray
    ebn0_db: np.ndarray
    sigma2_bit: np.ndarray
    decision_ebn0_db: np.ndarray


def blf_grid_hz(link: LinkProfile, lo_hz: float | None = None, hi_hz: float | None = None) -> np.ndarray:
    """Return the coarse BLF hypotheses of the search.

    A geometric grid over BLF·(1 ± FrT) of ``link`` (or [lo, hi]) with relative step
    1/(2·preamble elements), the correlation peak's half-width (as the capture decoder,
    :mod:`rfsim.gen2.replies` step 2; :func:`rfsim.gen2.reply_core.geometric_blf_grid_hz`,
    :func:`rfsim.gen2.reply_core.coarse_blf_step`).

    Parameters
    ----------
    link : LinkProfile
        Line code (M, TRext), nominal BLF and tolerance FrT.
    lo_hz, hi_hz : float or None, optional
        Range of the grid [Hz], both given or neither; default None, the link's BLF range.

    Returns
    -------
    ndarray of float, shape (n_blfs,)
        BLF hypotheses [Hz], increasing.
    """
    lo, hi = link.blf_range_hz if lo_hz is None else (float(lo_hz), float(hi_hz))
    return geometric_blf_grid_hz(lo, hi, coarse_blf_step(link.m, link.trext))


def search_setup(m: int, trext: bool, n_bits: int, blfs_hz, fs_hz: float):
    """Prepare the preamble, coarse templates and fine-search parameters of :func:`search_decode`.

    Shared with its NumPy twin in the tests.

    Parameters
    ----------
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.
    n_bits : int
        Data bits of the reply (without the dummy 1).
    blfs_hz : array_like of float, shape (K,)
        Coarse BLF hypotheses [Hz].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    tuple
        ``(pre_levels, state, pre_el, ratios, tpl0, lens, span, target1, target)``: the
        preamble levels (int8), the line-code state after the preamble, the preamble's
        elements (float64), ρ_k = 2·BLF_k/fs (K,), the zero-mean coarse templates (K, L_max)
        and their lengths (K,), the fine search's initial relative half-span
        (``FINE_SPAN_STEPS`` coarse steps), and the relative BLF precision targets
        1/(4·elements) of its first phase (``FINE_FIRST_BITS`` bits) and of the whole reply.
    """
    pre_levels = preamble_levels(m=m, trext=trext)[0]
    pre_el = elements_of_levels(pre_levels, m, np.float64)
    ratios = 2.0 * np.asarray(blfs_hz, dtype=np.float64) / fs_hz
    lens = np.floor(pre_el.size / ratios).astype(np.int64)
    tpl0 = np.zeros((ratios.size, int(lens.max())))
    for k, (ratio, n) in enumerate(zip(ratios, lens)):
        # the reader's count ⌊n_pre/ρ⌋ at BLF ρ·fs/2 (the capture decoder's: ⌊n_pre·fs/(2·BLF)⌋)
        tpl0[k, :n] = preamble_template0(m, trext, 0.5 * ratio * fs_hz, fs_hz, int(n))
    n_el = n_reply_elements(n_bits, m, trext)
    n_el1 = n_reply_elements(min(int(n_bits), FINE_FIRST_BITS), m, trext)
    return (pre_levels.astype(np.int8), preamble_state(m=m, trext=trext), pre_el, ratios, tpl0, lens,
            FINE_SPAN_STEPS * coarse_blf_step(m, trext), _rck.blf_resolution(n_el1), _rck.blf_resolution(n_el))


def search_decode(rs, *, m: int, trext: bool, n_bits: int, blfs_hz, fs_hz: float, lo: int, hi: int,
                  threads: int = 1, known_within: float | None = None) -> SearchDecode:
    """Estimate the BLF of, and decode, one reply in each window of ``rs`` (numba kernel).

    Parameters
    ----------
    rs : ndarray of complex, shape (B, n) or (n,)
        Windows ``h·s(t) + c + noise`` [√W] (any constant offset c); one window when 1-D.
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.
    n_bits : int
        Data bits of the reply (without the dummy 1).
    blfs_hz : array_like of float
        Coarse BLF hypotheses [Hz] (:func:`blf_grid_hz`).
    fs_hz : float
        Sample rate [Hz].
    lo, hi : int
        First and last reply start lag searched [samples].
    threads : int, optional
        The windows are split into this many blocks decoded on as many threads (the kernel
        releases the GIL and draws nothing at random: the result does not depend on it);
        default 1.
    known_within : float or None, optional
        The BLF is known to this relative precision (``blfs_hz`` = the one known BLF, e.g.
        measured on the RN16 of the tag an ACK addresses): the fine search starts across ±
        that. Default None: ``FINE_SPAN_STEPS`` coarse steps.

    Returns
    -------
    SearchDecode
        BLF, start, bits, gain and statistics of each window.

    Notes
    -----
    Method (the reader with ``blf_search = "preamble"``; the capture decoder
    :mod:`rfsim.gen2.replies` steps 2–3 do the same on recordings):

    1. Coarse: the largest zero-mean normalised preamble correlation
       |Σ r[l+i]·t_k[i]| / (‖t_k‖·‖r[l:l+L] − mean‖) over the BLF grid b_k and the lags l,
       refined between lags by a parabola.
    2. Fine: with the preamble's centre held, decode (preamble gain and offset, half-bit
       matched filter, Viterbi) at 2·FINE_PER_SIDE + 1 BLFs across ±FINE_SPAN_STEPS coarse
       steps; the one whose remodulated reply (rest level −1 around it) leaves the least
       least-squares residual over the whole window wins; the span narrows to one step until the step is
       ≤ 1/(4·reply elements) (decoding needs the BLF to about that) — first over the first
       FINE_FIRST_BITS bits, then, for a longer reply, over twice as many bits at a time (all
       at last) across ±4 final steps of the previous phase (a long reply misaligned by a
       coarse step has a residual with many local minima).
    3. Statistic: h and the residual σ² (noise plus whatever the fit does not explain, e.g. a
       second tag) over the reply's steady samples; Eb/(N0 + I) = |h|²·(2M/ρ)/σ².
    """
    r = np.ascontiguousarray(rs, dtype=np.complex128)
    if r.ndim == 1:
        r = r[None, :]
    pre_levels, state, pre_el, ratios, tpl0, lens, span, target1, target = search_setup(m, trext, n_bits,
                                                                                  blfs_hz, fs_hz)
    first_bits = FINE_FIRST_BITS
    if known_within is not None:
        span = float(known_within)
    b = r.shape[0]
    bits = np.zeros((b, int(n_bits)), np.uint8)
    ratio, start, corr, sigma2, sigma2_bit = (np.empty(b) for _ in range(5))
    gain = np.empty(b, np.complex128)

    def block(i0: int, i1: int) -> None:
        _bk.search_decode_kernel(r[i0:i1], ratios, tpl0, lens, int(lo), int(hi), pre_el, pre_levels, state, int(m), int(n_bits), first_bits, span, FINE_PER_SIDE,
                                 target1, target, bits[i0:i1],
                                 ratio[i0:i1], start[i0:i1], corr[i0:i1], gain[i0:i1], sigma2[i0:i1],
                                 sigma2_bit[i0:i1])

    edges = np.linspace(0, b, max(1, min(int(threads), b)) + 1).astype(int)
    if edges.size <= 2:
        block(0, b)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(edges.size - 1) as pool:
            list(pool.map(block, edges[:-1], edges[1:]))
    return search_result(bits, ratio, start, corr, gain, sigma2, sigma2_bit, m, fs_hz)


def search_result(bits, ratio, start, corr, gain, sigma2, sigma2_bit, m, fs_hz) -> SearchDecode:
    """Assemble the :class:`SearchDecode` of the kernel's outputs.

    BLF = ρ·fs/2; Eb/N0 = 10·log10(|h|²·(2M/ρ)/σ²) and the decision-domain Eb/(N0 + I) with
    σ_eff² in place of σ², in dB.

    Parameters
    ----------
    bits : ndarray of uint8, shape (B, n_bits)
        Decoded bits.
    ratio : ndarray of float, shape (B,)
        ρ = 2·BLF/fs decoded at.
    start : ndarray of float, shape (B,)
        Reply start [samples into the window].
    corr : ndarray of float, shape (B,)
        Coarse normalised preamble correlation.
    gain : ndarray of complex, shape (B,)
        h [√W].
    sigma2 : ndarray of float, shape (B,)
        Residual power per sample [W].
    sigma2_bit : ndarray of float, shape (B,)
        σ_eff², the disturbance in the decision domain [W].
    m : int
        Miller M (1 = FM0).
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    SearchDecode
        The result record.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        e_bit = np.abs(gain) ** 2 * (2.0 * m / ratio)
        ebn0 = 10.0 * np.log10(e_bit / sigma2)
        ebn0_min = 10.0 * np.log10(e_bit / sigma2_bit)
    return SearchDecode(bits, 0.5 * ratio * fs_hz, start, corr, gain, sigma2, ebn0, sigma2_bit, ebn0_min)


def rn16_threshold_db(false_accept: float, *, n_bits: int = 16) -> float:
    """Eb/(N0 + I) threshold [dB] of the RN16 acceptance for a stated false-accept probability p.

    With Gaussian noise plus interference of density N0 + I, coherent antipodal decisions give
    a bit error probability Q(√(2·Eb/(N0 + I))) (FM0 and Miller-M decoded by the matched
    filter, anchors §4.8), and an n-bit word is wrong with probability
    1 − (1 − P_b)^n ≈ n·P_b. Accepting only when the measured Eb/(N0 + I) ≥ γ with
    n·Q(√(2γ)) = p bounds the probability that an accepted word is wrong by p (within this
    model): γ = (Q⁻¹(p/n))²/2. p = 1e−2 → 7.2 dB for 16 bits. An approximation: the
    interference of a second tag is not Gaussian, so the measured false-ACK rate against γ
    is what sets the default (``inventory`` scenario, ``acceptance`` table).

    Parameters
    ----------
    false_accept : float
        False-accept probability p, in (0, 0.5).
    n_bits : int, optional
        Keyword-only: bits of the word, default 16.

    Returns
    -------
    float
        γ [dB].

    Raises
    ------
    ValueError
        When ``false_accept`` is outside (0, 0.5).
    """

    from scipy.special import ndtri

    if not 0.0 < false_accept < 0.5:
        raise ValueError(f"false_accept must be in (0, 0.5), got {false_accept}")
    q = -float(ndtri(false_accept / n_bits))  # Q⁻¹(p/n)
    return 10.0 * math.log10(0.5 * q * q)
