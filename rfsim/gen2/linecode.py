"""FM0 and Miller-M line codes of the tag→interrogator link: encoders, sampled
baseband and coherent decoders.

Encoding (gen2-and-validation-anchors.md §3.6, §4.2; pass-paris-simulator.md §2.2
``tag_encoding``). Levels are ±1; a bit is two half-bits.

* FM0: the level inverts at every bit boundary; data-0 has a mid-bit inversion. Preamble
  half-bits ``1 1 | −1 1 | −1 −1 | 1 −1 | −1 −1 | 1 1`` (symbols 1 0 1 0 v 1, v = no
  boundary inversion); TRext = 1 prepends a pilot of 12 data-0 (``1 −1`` × 12).
* Miller-M: the baseband level inverts mid-bit for data-1 and between two consecutive
  data-0s, and is multiplied by a square subcarrier with M cycles per bit. The pilot is
  4·M (TRext 0) or 16·M (TRext 1) subcarrier cycles at level +1, followed by ``010111``;
  the first preamble 0 continues the pilot level (encoder state: level +1, previous bit 1).
* Every reply ends with a dummy data-1.

The rules themselves are written once, as the transition tables of
:mod:`rfsim.gen2._linecode_kernels` (half-bit levels and next encoder state per state and bit,
subcarrier sign per element), which the encoder, the Viterbi trellis and every decoder read.

An *element* is half a subcarrier cycle, 1/(2·BLF) s (FM0: one per half-bit, Miller-M:
M per half-bit); :func:`halfsymbols` returns the element sequence (the PASS golden
representation). :func:`reply_waveform` samples it at any fs: sample n takes the element
``floor((n − t0·fs)·2·BLF/fs + 1e−9)`` — no cumulative drift for non-integer samples per
element.

Decoding of a complex baseband ``r = h·s(t) + c + noise`` (unknown complex gain h and
offset c): the preamble (incl. pilot) is found by correlation over a search window, h and
c follow from the correlation peak by least squares, ``y = Re((r − c)/h)`` is summed per
half-bit (times the subcarrier sign for Miller), then either

* ``method="bitwise"``: each bit alone, compare |a + b| with |a − b| (anchors §4.8:
  P_b = 2p(1 − p), p = Q(√(Eb/N0))), or
* ``method="viterbi"``: maximum-likelihood sequence detection over the code trellis
  (state = last level, plus the previous bit for Miller), starting from the known state
  after the preamble and ending with the dummy 1 (≈ 3 dB better, anchors §4.8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rfsim.gen2.bits import as_bits
from rfsim.core.lazy import lazy_import
from rfsim.core.memo import PureCache

_k = lazy_import("rfsim.gen2._linecode_kernels")
_dk = lazy_import("rfsim.gen2._decode_reply_kernels")

M_VALUES = (1, 2, 4, 8)
FM0_PREAMBLE = np.array([1, 1, -1, 1, -1, -1, 1, -1, -1, -1, 1, 1], dtype=np.int8)
MILLER_PREAMBLE_BITS = np.array([0, 1, 0, 1, 1, 1], dtype=np.uint8)
METHODS = ("viterbi", "bitwise")


def _check_m(m: int) -> int:
    if m not in M_VALUES:
        raise ValueError(f"m must be one of {M_VALUES} (1 = FM0), got {m!r}")
    return int(m)


# ----------------------------------------------------------------------------- encoder


def _levels(bits: np.ndarray, m: int, state: int) -> tuple[np.ndarray, int]:
    """Half-bit levels ``(2·n,) int8`` of ``bits`` from encoder ``state`` and the final state
    (the tables of :mod:`rfsim.gen2._linecode_kernels`)."""
    out = np.empty(2 * bits.size, dtype=np.int8)
    state = _k.levels_kernel(bits, m, state, out)
    return out, int(state)


def _make_preamble(m: int, trext: bool) -> tuple[np.ndarray, int]:
    """Pilot + preamble half-bit levels (read-only) and the encoder state after them
    (:func:`preamble_levels`) of one line code: the values of :data:`PREAMBLES`."""
    m, trext = _check_m(m), bool(trext)
    if m == 1:
        parts = []
        if trext:
            parts.append(_levels(np.zeros(12, dtype=np.uint8), 1, _k.state_index(-1, 0, 1))[0])
        parts.append(FM0_PREAMBLE)
        levels, state = np.concatenate(parts), _k.state_index(int(FM0_PREAMBLE[-1]), 0, 1)
    else:
        pilot = np.ones(32 if trext else 8, dtype=np.int8)
        pre, state = _levels(MILLER_PREAMBLE_BITS, m, _k.state_index(1, 1, m))
        levels = np.concatenate([pilot, pre])
    levels.setflags(write=False)
    return levels, int(state)


#: Pilot + preamble half-bit levels and the encoder state after them, per line code (M, TRext):
#: a pure function of the module's constants (not run state), made on first use because it
#: calls the compiled encoder, which importing this module must not compile; 8 line codes.
PREAMBLES = PureCache(_make_preamble, 2 * len(M_VALUES))
_preamble = PREAMBLES


def preamble_levels(*, m: int, trext: bool) -> tuple[np.ndarray, int, int]:
    """Half-bit levels of pilot + preamble and the encoder state after them.

    Miller pilot half-bits are at level +1 (8 or 32 of them: 4·M or 16·M subcarrier cycles
    of M/2 cycles each); module docstring, gen2-and-validation-anchors.md §4.2.

    Parameters
    ----------
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.

    Returns
    -------
    levels : numpy.ndarray
        ``(2·n_pre,) int8`` half-bit levels ±1.
    level, previous_bit : int
        Encoder state after the preamble: baseband level (±1) and previous bit (0/1).
    """
    levels, state = _preamble(_check_m(m), bool(trext))
    return levels.copy(), int(_k.LEVEL_OF_STATE[state]), int(_k.PREV_BIT_OF_STATE[state])


def preamble_state(*, m: int, trext: bool) -> int:
    """Encoder state after pilot + preamble: where the data bits' encoder and trellis start.

    Parameters
    ----------
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.

    Returns
    -------
    int
        State index of :mod:`rfsim.gen2._linecode_kernels` (level + 2·previous bit).
    """
    return _preamble(_check_m(m), bool(trext))[1]


def halfbit_levels(bits, *, m: int, trext: bool, dummy: bool = True) -> tuple[np.ndarray, int]:
    """Baseband half-bit levels of a whole reply (pilot, preamble, data, dummy-1).

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` data bits.
    m, trext, dummy : int, bool, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone; dummy data-1 appended.

    Returns
    -------
    levels : numpy.ndarray
        ``int8`` half-bit levels ±1 (before the Miller subcarrier).
    n_preamble_halfbits : int
        Half-bits of pilot + preamble at the start of ``levels``.
    """
    arr = as_bits(bits)
    if dummy:
        arr = np.concatenate([arr, np.ones(1, dtype=np.uint8)])
    pre, state = _preamble(_check_m(m), bool(trext))
    data, _ = _levels(arr, m, state)
    return np.concatenate([pre, data]), pre.size


def elements_of_levels(levels, m: int, dtype=np.int8) -> np.ndarray:
    """Elements of half-bit ``levels``: each level held for ``m`` elements, times the subcarrier sign for Miller.

    Parameters
    ----------
    levels : array_like
        ``(n,) int8`` half-bit levels ±1.
    m : int
        Symbols per bit M.
    dtype : numpy.dtype
        Output dtype.

    Returns
    -------
    numpy.ndarray
        ``(n·m,)`` elements ±1.
    """
    levels = np.ascontiguousarray(levels, dtype=np.int8)
    out = np.empty(levels.size * _check_m(m), dtype=dtype)
    _k.level_elements_kernel(levels, m, out)
    return out


def _element_values(bits, m: int, trext: bool, dummy: bool, dtype) -> np.ndarray:
    """Element sequence of a reply as ``dtype`` (numba kernel)."""
    m = _check_m(m)
    if isinstance(bits, np.ndarray) and bits.dtype == np.uint8 and bits.ndim == 1:
        arr = np.ascontiguousarray(bits)  # values checked by the kernel
    else:
        arr = as_bits(bits)
    pre, state = _preamble(m, bool(trext))
    out = np.empty((pre.size + 2 * (arr.size + int(bool(dummy)))) * m, dtype=dtype)
    if not _k.elements_kernel(arr, bool(dummy), m, pre, state, out):
        raise ValueError("bits must contain only 0 and 1")
    return out


def halfsymbols(bits, *, m: int, trext: bool, dummy: bool = True) -> np.ndarray:
    """Element sequence of a reply, one value per half subcarrier cycle 1/(2·BLF).

    Pilot, preamble, data and dummy-1 — the PASS ``tag_encoding`` format
    (pass-paris-simulator.md §2.2; numba kernel).

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` data bits.
    m, trext, dummy : int, bool, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone; dummy data-1 appended.

    Returns
    -------
    numpy.ndarray
        ``(n_el,) int8`` of ±1.
    """
    return _element_values(bits, m, trext, dummy, np.int8)


def reply_duration_s(n_bits: int, *, m: int, trext: bool, blf_hz: float, dummy: bool = True) -> float:
    """Duration of a reply of ``n_bits`` data bits: elements / (2·BLF).

    Parameters
    ----------
    n_bits : int
        Data bits (without the dummy-1).
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.
    blf_hz : float
        Backscatter link frequency [Hz].
    dummy : bool
        Count the dummy data-1.

    Returns
    -------
    float
        Duration [s].
    """
    m = _check_m(m)
    n_pre = _preamble(m, bool(trext))[0].size
    return (n_pre + 2 * (n_bits + int(dummy))) * m / (2.0 * blf_hz)


def _check_rates(blf_hz: float, fs_hz: float) -> float:
    if not blf_hz > 0 or not fs_hz > 0:
        raise ValueError(f"blf_hz and fs_hz must be > 0, got {blf_hz}, {fs_hz}")
    return 2.0 * float(blf_hz) / float(fs_hz)


def reply_waveform(
    bits, *, m: int, trext: bool, blf_hz: float, fs_hz: float, t0_s: float = 0.0,
    dummy: bool = True, n_samples: int | None = None,
) -> np.ndarray:
    """Sampled tag reply (numba kernel).

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` data bits.
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.
    blf_hz, fs_hz : float
        BLF and sample rate [Hz].
    t0_s : float
        Start of the reply [s].
    dummy, n_samples : bool, int or None
        Dummy data-1 appended; output length (default: ends with the reply).

    Returns
    -------
    numpy.ndarray
        ``(n_samples,) float64``: ±1 during the reply (the two modulation states; the caller
        maps them to reflection coefficients) and 0 before ``t0_s`` and after the reply (the
        tag's rest state).
    """
    el, t0, r, n_samples = reply_waveform_arguments(bits, m=m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=t0_s,
                                                    dummy=dummy, n_samples=n_samples)
    out = np.empty(n_samples, dtype=np.float64)
    _k.waveform_kernel(el, t0, r, out)
    return out


def reply_waveform_arguments(
    bits, *, m: int, trext: bool, blf_hz: float, fs_hz: float, t0_s: float = 0.0,
    dummy: bool = True, n_samples: int | None = None, keep: bool = True,
) -> tuple:
    """The arguments of the sampling kernel of :func:`reply_waveform` (for a kernel that samples the
    reply itself, e.g. the tag's Γ(t), :func:`rfsim.devices.tag.reply_gamma`).

    :func:`reply_waveform` is ``out[n] = elements[floor((n − t0)·r + ε)]`` inside the reply and 0
    outside (``rfsim.gen2._linecode_kernels.waveform_kernel``), with the reply's elements
    (:func:`halfsymbols` as float64), t0 = ``t0_s``·fs [samples] and r = 2·BLF/fs [elements per
    sample].

    Parameters
    ----------
    bits, m, trext, blf_hz, fs_hz, t0_s, dummy, n_samples : see :func:`reply_waveform`
        The reply's bits, line code, BLF and sample rate [Hz], start [s], dummy data-1 and
        output length.
    keep : bool, default True
        Remember the elements of these bits for the next call (False for bits drawn anew, e.g. a
        tag's RN16, which would only push out the elements of replies that come again).

    Returns
    -------
    tuple
        ``(elements, t0, r, n_samples)``: ``(n_el,) float64`` elements (read-only use: they may
        be shared by later calls), t0 [samples], r [elements per sample] (floats) and the output
        length (int).
    """
    key = None
    if keep and isinstance(bits, np.ndarray) and bits.dtype == np.uint8 and bits.ndim == 1:
        key = (bits.tobytes(), m, bool(trext), bool(dummy))
    el = _WAVEFORM_ELEMENTS.get(key) if key is not None else None
    if el is None:
        el = _element_values(bits, m, trext, dummy, np.float64)
        if key is not None:
            if len(_WAVEFORM_ELEMENTS) >= 64:
                _WAVEFORM_ELEMENTS.pop(next(iter(_WAVEFORM_ELEMENTS)))
            _WAVEFORM_ELEMENTS[key] = el
    r = _check_rates(blf_hz, fs_hz)
    t0 = float(t0_s) * float(fs_hz)
    if n_samples is None:
        n_samples = int(math.ceil(t0 + el.size / r))
    return el, t0, r, int(n_samples)


#: Element sequences (float64) of recent replies, by (bit bytes, M, TRext, dummy): a tag sends
#: its EPC round after round, and the reader forms the reference of the reply it decoded.
#: Only :func:`reply_waveform` reads them (never handed out).
_WAVEFORM_ELEMENTS: dict = {}


def reply_waveform_for_profile(bits, profile, *, fs_hz: float, t0_s: float = 0.0, **kwargs) -> np.ndarray:
    """:func:`reply_waveform` with M, TRext and the nominal BLF of a ``LinkProfile``.

    Parameters
    ----------
    bits : array_like or str
        ``(n,) uint8`` data bits.
    profile : rfsim.gen2.link.LinkProfile
        The link.
    fs_hz : float
        Sample rate [Hz].
    t0_s : float
        Start of the reply [s].
    **kwargs
        ``dummy``, ``n_samples`` of :func:`reply_waveform`.

    Returns
    -------
    numpy.ndarray
        ``(n_samples,) float64`` waveform (±1, 0 at rest).
    """
    return reply_waveform(bits, m=profile.m, trext=profile.trext, blf_hz=profile.blf_hz, fs_hz=fs_hz,
                          t0_s=t0_s, **kwargs)


# ----------------------------------------------------------------------------- decoders


@dataclass(frozen=True)
class ReplyDetection:
    """Result of :func:`decode_reply`.

    Attributes
    ----------
    bits : (n_bits,) uint8, decoded data bits (dummy-1 removed)
    start_sample : float, sample position where the reply (pilot/preamble) starts
        (correlation peak refined to 1/16 sample)
    gain : complex, estimated channel gain h (same units as the input)
    dc : complex, estimated offset c
    corr : float in [0, 1], normalised correlation of the preamble at ``start_sample``
    """

    bits: np.ndarray
    start_sample: float
    gain: complex
    dc: complex
    corr: float


def _kernel_sums(part, g, dc_g, start, r, m, nh):
    out = np.empty(nh)
    _k.projected_halfbit_sums_kernel(part, g.real, g.imag, dc_g, float(start), r, m, out)
    return out


#: Sub-sample shifts [samples] at which the preamble correlation peak is refined (1/16 sample).
_REFINE_SHIFTS = np.linspace(-0.5, 0.5, 17)


def _template(m: int, trext: bool, ratio: float, delta: float) -> tuple:
    """Preamble (incl. pilot) template over the samples fully inside it, starting ``delta``
    samples late: ``(t, t − mean(t), mean(t), Σ(t − mean(t))²)``, the arrays ``(n_pre,)
    float64`` and read-only.

    A pure function of its arguments; the decoders keep what they derive from it
    (:func:`search_arrays`) per link and sample rate.
    """
    pre_el = elements_of_levels(_preamble(m, trext)[0], m, np.float64)
    n_pre = int(math.floor(pre_el.size / ratio))  # samples fully inside the preamble
    t = np.empty(n_pre)
    _k.waveform_kernel(pre_el, float(delta), ratio, t)
    mean = t.mean()
    t0 = t - mean
    t.setflags(write=False)
    t0.setflags(write=False)
    return t, t0, mean, float(t0 @ t0)


def _refine_bank(m: int, trext: bool, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-mean templates ``(n_shifts, n_pre) float64`` at the shifts of
    :data:`_REFINE_SHIFTS` and their norms ``(n_shifts,)`` (read-only; a pure function of its
    arguments)."""
    shifted = [_template(m, trext, ratio, float(d)) for d in _REFINE_SHIFTS]
    rows = np.array([t[1] for t in shifted])
    norms = np.array([math.sqrt(t[3]) for t in shifted])
    rows.setflags(write=False)
    norms.setflags(write=False)
    return rows, norms


def _refine_runs(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The runs of equal values of :func:`_refine_bank`'s templates ``rows`` (read-only):
    ``run_begin`` ``(n_shifts, max runs + 1) int64`` (row j: the first sample of each run, then
    n_pre), ``run_value`` ``(n_shifts, max runs) float64`` (their values), ``n_runs``
    ``(n_shifts,) int64`` and ``same_as_previous`` ``(n_shifts,) bool`` (the template equals the
    previous shift's: the shifts move no sample across an element boundary)."""
    begins = [np.flatnonzero(np.concatenate(([True], row[1:] != row[:-1]))) for row in rows]
    n_runs = np.array([b.size for b in begins], dtype=np.int64)
    run_begin = np.full((rows.shape[0], int(n_runs.max()) + 1), rows.shape[1], dtype=np.int64)
    run_value = np.zeros((rows.shape[0], int(n_runs.max())))
    for j, b in enumerate(begins):
        run_begin[j, :b.size] = b
        run_value[j, :b.size] = rows[j, b]
    same = np.array([j > 0 and np.array_equal(rows[j], rows[j - 1]) for j in range(rows.shape[0])])
    for a in (run_begin, run_value, n_runs, same):
        a.setflags(write=False)
    return run_begin, run_value, n_runs, same


def corr_abs_reference(r, t0) -> np.ndarray:
    """|valid correlation| of ``r`` with the real template ``t0`` (scipy; twin of the kernel).

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` complex samples, any unit.
    t0 : numpy.ndarray
        ``(L,) float64`` template.

    Returns
    -------
    numpy.ndarray
        ``(n − L + 1,) float64``, unit of ``r``.
    """
    from scipy.signal import correlate  # the twin only: scipy.signal costs ≈ 1 s to import

    return np.abs(correlate(r, t0, mode="valid"))


#: Fewest runs per sample of the template below which the search correlates over runs of
#: equal template samples (cumulative sums) rather than sample by sample.
_RUNS_PER_SAMPLE_MAX = 0.5


def _kernel_corr_abs(r, t0):
    """|valid correlation| of the preamble search (numba kernels): over runs of equal
    template samples when the template has few runs per sample (any sample rate of a few
    samples per element and more: O(lags · elements), so the search over a T1 window grows
    as fs, not as fs²), else sample by sample."""
    n_lags = r.size - t0.size + 1
    if n_lags < 1:
        return corr_abs_reference(r, t0)
    out = np.empty(n_lags)
    _k.corr_abs_auto_kernel(r, t0, _RUNS_PER_SAMPLE_MAX, out)
    return out


def _kernel_candidates(c, half_width: int, n_max: int = 5) -> tuple[int, np.ndarray]:
    out = np.empty(n_max, dtype=np.int64)
    lag, n = _k.peak_candidates_kernel(c, half_width, n_max, out)
    return int(lag), out[:n]


def _kernel_refine(r, cands, shifts, templates, norms):
    best, start = _k.refine_kernel(r, np.ascontiguousarray(cands, dtype=np.int64), shifts, templates, norms)
    return float(best), float(start)


@dataclass(frozen=True)
class _DecodePlan:
    """What :func:`decode_reply` derives from its arguments before it looks at a sample."""

    n_bits: int
    m: int
    trext: bool
    method: str
    ratio: float
    state: int
    nh: int
    n_reply: int
    n_pre: int


def _plan(n_bits, m, trext, blf_hz, fs_hz, method) -> _DecodePlan:
    m = _check_m(m)
    trext = bool(trext)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    ratio = _check_rates(blf_hz, fs_hz)
    pre, state = _preamble(m, trext)
    nh = pre.size + 2 * (int(n_bits) + 1)
    return _DecodePlan(n_bits=int(n_bits), m=m, trext=trext, method=method, ratio=ratio, state=state, nh=nh,
                       n_reply=int(math.ceil(nh * m / ratio)),
                       n_pre=int(math.floor(pre.size * m / ratio)))  # samples fully inside the preamble


def _decode(r, n_bits, m, trext, blf_hz, fs_hz, method, search_samples, start_sample, gain, arrays=None):
    plan = _plan(n_bits, m, trext, blf_hz, fs_hz, method)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    if r.ndim != 1:
        raise ValueError(f"r must be 1-D, got shape {r.shape}")
    return _decode_planned(plan, r, search_samples, start_sample, gain, arrays)


class SearchArrays(NamedTuple):
    """What the preamble search of :func:`decode_reply` reads, derived from (M, TRext,
    elements per sample) only (:func:`search_arrays`; read-only arrays)."""

    t0: np.ndarray  # (n_pre,) zero-mean template at the integer lags
    max_runs_per_sample: float  # correlate over runs of equal template samples up to this many per sample
    half_width: int  # candidates within ± this many lags of the integer peak
    shifts: np.ndarray  # (17,) sub-sample shifts of the refinement [samples]
    templates: np.ndarray  # (17, n_pre) zero-mean templates at the shifts
    norms: np.ndarray  # (17,) their norms
    pre_el: np.ndarray  # (elements,) float64 pilot + preamble elements
    pre_levels: np.ndarray  # (half-bits,) int8 pilot + preamble half-bit levels
    state: int  # encoder state after the preamble
    run_begin: np.ndarray  # (17, max runs + 1) int64 first sample of each run of equal values of templates
    run_value: np.ndarray  # (17, max runs) their values
    n_runs: np.ndarray  # (17,) int64 runs per template
    same_as_previous: np.ndarray  # (17,) bool template equal to the previous shift's


def search_arrays(m: int, trext: bool, ratio: float) -> SearchArrays:
    """The arrays of the preamble search and of the template at the refined start.

    A pure function of its arguments (read-only arrays), run state of one link and sample
    rate: the callers keep it (the reader's decode plan,
    :meth:`rfsim.gen2.reply_decoder.DecodePlan.arrays`; ``decode_reply(..., arrays=...)``).

    Parameters
    ----------
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.
    ratio : float
        Elements per sample, 2·BLF/fs.

    Returns
    -------
    SearchArrays
        Template, candidate half-width, refinement bank, preamble elements and levels, the
        encoder state after the preamble and the runs of the refinement bank's templates.
    """
    levels, state = _preamble(_check_m(m), bool(trext))
    pre_el = elements_of_levels(levels, m, np.float64)
    pre_el.setflags(write=False)
    rows, norms = _refine_bank(m, trext, ratio)
    return SearchArrays(_template(m, trext, ratio, 0.0)[1], _RUNS_PER_SAMPLE_MAX, int(math.ceil(m / ratio)) + 1,
                        _REFINE_SHIFTS, rows, norms, pre_el, levels, state, *_refine_runs(rows))


def _decode_planned(plan: _DecodePlan, r, search_samples, start_sample, gain, arrays=None) -> ReplyDetection:
    """The steps of :func:`decode_reply` on ``r`` ((n,) complex128, C-contiguous): the argument
    checks, then every step in one kernel call (:mod:`rfsim.gen2._decode_reply_kernels`)."""
    m, trext, ratio, n_reply, n_pre = plan.m, plan.trext, plan.ratio, plan.n_reply, plan.n_pre
    if start_sample is None:
        last = r.size - n_reply
        if search_samples is not None:
            last = min(last, int(search_samples))
        if last < 0:
            raise ValueError(f"input of {r.size} samples is shorter than the reply ({n_reply} samples)")
    else:
        start = float(start_sample)
        if not 0 <= start <= r.size - n_reply:
            raise ValueError(f"start_sample {start_sample} leaves no room for the reply ({n_reply} samples)")
    a = search_arrays(m, trext, ratio) if arrays is None else arrays
    sums, bits = np.empty(plan.nh), np.empty(plan.n_bits + 1, dtype=np.uint8)
    status, start, corr, h, dc = _dk.decode_reply_kernel(
        r, -1 if start_sample is not None else last + n_pre, math.nan if start_sample is None else start,
        0j if gain is None else complex(gain), gain is not None, a.t0, a.max_runs_per_sample, a.half_width, 5,
        a.shifts, a.templates, a.norms, a.run_begin, a.run_value, a.n_runs, a.same_as_previous, a.pre_el, ratio,
        n_pre, m, a.pre_levels.size, a.state, plan.method != "bitwise", sums, bits)
    if status == _dk.ZERO_GAIN:
        raise ValueError("zero channel gain: no reply to decode")
    return ReplyDetection(bits=bits[:plan.n_bits], start_sample=float(start), gain=complex(h), dc=complex(dc),
                          corr=float(corr))


def _decisions(r, lag, frac, h, dc, ratio, m, n_bits, method, nh, state) -> np.ndarray:
    """Bits of the reply starting ``frac`` samples after ``r[lag]``: half-bit sums of
    Re((r − dc)/h), then bit-by-bit or Viterbi decisions (:func:`decode_reply` steps 3–4), in one
    kernel call."""
    if h == 0:
        raise ValueError("zero channel gain: no reply to decode")
    g = 1.0 / h
    part = r[lag: lag + int(math.ceil(nh * m / ratio)) + 2]
    sums, out = np.empty(nh), np.empty(n_bits + 1, dtype=np.uint8)
    _dk.decisions_kernel(part, g.real, g.imag, (dc * g).real, float(frac), ratio, m, nh - 2 * (n_bits + 1),
                         state, method != "bitwise", sums, out)
    return out[:n_bits]


def decode_bits(r, *, n_bits: int, m: int, trext: bool, blf_hz: float, fs_hz: float, start_sample: float,
                gain: complex, method: str = "viterbi") -> np.ndarray:
    """Decisions of a reply whose start and gain are known (numba kernels).

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband ``h·s(t) + noise`` at ``fs_hz``.
    n_bits : int
        Data bits (without the dummy 1).
    m, trext : int, bool
        Symbols per bit M (1 = FM0, 2/4/8 = Miller); pilot tone present.
    blf_hz, fs_hz : float
        BLF and sample rate [Hz].
    start_sample : float
        Reply start [samples].
    gain : complex
        Channel gain h, unit of ``r``.
    method : {"viterbi", "bitwise"}
        ML sequence or bit-by-bit coherent decisions.

    Returns
    -------
    numpy.ndarray
        ``(n_bits,) uint8`` decoded bits.

    Raises
    ------
    ValueError
        If ``start_sample`` leaves no room for the reply in ``r``.
    """
    plan = _plan(n_bits, m, trext, blf_hz, fs_hz, method)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    start = float(start_sample)
    if r.ndim != 1 or not 0 <= start <= r.size - plan.n_reply:
        raise ValueError(f"start_sample {start_sample} leaves no room for the reply in r of shape {r.shape}")
    lag = int(math.floor(start))
    return _decisions(r, lag, start - lag, complex(gain), 0.0, plan.ratio, plan.m, plan.n_bits, method, plan.nh,
                      plan.state)


def decode_reply(
    r, *, n_bits: int, m: int, trext: bool, blf_hz: float, fs_hz: float, method: str = "viterbi",
    search_samples: int | None = None, start_sample: float | None = None, gain: complex | None = None,
    arrays: SearchArrays | None = None,
) -> ReplyDetection:
    """Detect and decode one FM0/Miller reply of ``n_bits`` bits (numba kernels).

    Module docstring: preamble correlation, least-squares (h, c), bitwise or Viterbi decisions.

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex, baseband ``h·s(t) + c + noise`` sampled at ``fs_hz``.
    n_bits : int
        Number of data bits (without the dummy 1).
    m, trext : int, bool
        Line code (1 = FM0, 2/4/8 = Miller); pilot tone present.
    blf_hz, fs_hz : float
        BLF and sample rate [Hz].
    method : {"viterbi", "bitwise"}
        ML sequence or bit-by-bit coherent.
    search_samples : int or None
        The reply start is searched among sample lags 0…search_samples (default: every lag
        that leaves room for the whole reply).
    start_sample, gain : float or None, complex or None
        Known start [samples] / gain h (then c = 0): skip the search / the estimation.
    arrays : SearchArrays or None
        :func:`search_arrays` of (m, trext, 2·blf_hz/fs_hz), kept by a caller that decodes
        the same link again; default None, made for this call.

    Returns
    -------
    ReplyDetection
        Bits, refined start [samples], gain, offset and preamble correlation.

    Raises
    ------
    ValueError
        If there is no room for the reply in ``r``, the gain is zero or an argument is invalid.
    """
    return _decode(r, n_bits, m, trext, blf_hz, fs_hz, method, search_samples, start_sample, gain, arrays)


def decode_reply_rows(
    r, rows, *, n_bits: int, m: int, trext: bool, blf_hz: float, fs_hz: float, method: str = "viterbi",
    search_samples: int | None = None,
) -> list[ReplyDetection | None]:
    """:func:`decode_reply` on the rows ``rows`` of ``r``, the argument checks and per-profile setup done once.

    Parameters
    ----------
    r : array_like
        ``(R, n)`` complex baseband at ``fs_hz``.
    rows : array_like of int
        Row indices to decode.
    n_bits, m, trext, blf_hz, fs_hz, method, search_samples
        As in :func:`decode_reply` (``blf_hz``, ``fs_hz`` [Hz]).

    Returns
    -------
    list of ReplyDetection or None
        One per row of ``rows``; None where :func:`decode_reply` raises ``ValueError`` for
        that row (no room for the reply, zero gain).

    Raises
    ------
    ValueError
        If ``r`` is not 2-D.
    """
    plan = _plan(n_bits, m, trext, blf_hz, fs_hz, method)
    r = np.asarray(r)
    if r.ndim != 2:
        raise ValueError(f"r must be 2-D (rows, samples), got shape {r.shape}")
    out: list[ReplyDetection | None] = []
    arrays = search_arrays(plan.m, plan.trext, plan.ratio)
    for i in np.asarray(rows, dtype=np.int64).tolist():
        row = np.ascontiguousarray(r[i], dtype=np.complex128)
        try:
            out.append(_decode_planned(plan, row, search_samples, None, None, arrays))
        except ValueError:
            out.append(None)
    return out


__all__ = [
    "M_VALUES",
    "METHODS",
    "FM0_PREAMBLE",
    "MILLER_PREAMBLE_BITS",
    "ReplyDetection",
    "preamble_levels",
    "preamble_state",
    "halfbit_levels",
    "halfsymbols",
    "elements_of_levels",
    "reply_duration_s",
    "reply_waveform",
    "reply_waveform_arguments",
    "reply_waveform_for_profile",
    "decode_reply",
    "decode_reply_rows",
    "decode_bits",
    "corr_abs_reference",
    "SearchArrays",
    "search_arrays",
    "PREAMBLES",
]
