"""The steps the tag-reply decoder's searches share, each written once.

The reader in the loop and ``rfsim decode`` call one decoder,
:func:`rfsim.gen2.reply_decoder.decode`, whose plan chooses one of three searches over
FM0/Miller replies ``r = h·s(t) + c + noise`` (the map of their steps is that module's
docstring):

* "known": :func:`rfsim.gen2.linecode.decode_reply`'s kernels — one known BLF: preamble search over every lag,
  refined to 1/16 sample, (h, c) from the preamble, half-bit sums, Viterbi or bitwise
  decisions (the reader with ``blf_search`` off);
* "blf": the reader's BLF search :func:`rfsim.gen2.blf_search.search_decode` — coarse preamble
  correlation over a BLF grid and the T1 lags, then decoding at BLFs across the coarse one
  with the preamble's centre held, the least residual of the remodulated reply wins;
* "link": the capture decoder :mod:`rfsim.gen2.replies` (``rfsim decode``) — the same search over link
  hypotheses at a working rate with a detection threshold, then the fine BLF search, the
  reply's length, timing tracking on the tag's clock and the E_h/N₀ gate.

Steps written once (this module and :mod:`rfsim.gen2._reply_core_kernels`), which every
decoder that performs them calls:

* element counts, coarse BLF step and grid, fine span: :func:`n_pre_elements`,
  :func:`n_reply_elements`, :func:`coarse_blf_step`, :func:`geometric_blf_grid_hz`,
  :data:`FINE_SPAN_STEPS` (``decode_reply``: its own ``_plan``, one BLF);
* the zero-mean pilot + preamble template: :func:`preamble_template0`, each caller its own
  length (``decode_reply``: its own, cached);
* cumulative sums of r and |r|²: ``cumulative_sums_into`` (the grouping of |r|² an argument);
* the normalised correlation from its sums: ``normalised_correlation``; the peak between
  lags: ``parabola_offset`` (``decode_reply``: its energy in two passes and a bank of
  1/16-sample shifts, :mod:`rfsim.gen2._decode_reply_kernels`);
* the start of a reply whose preamble is centred on a sample: ``centred_start`` (the reply
  length that must fit an argument);
* the preamble's least-squares (h, c): ``preamble_gain_offset`` (the segment's mean an
  argument);
* decisions from the half-bit sums: ``halfbit_decisions``;
* the fit of a remodulated reply with its rest level: ``rest_level_sums``; the residual over
  its steady samples: ``steady_residual``.

Where the decoders still compute a step differently, the results differ in the last bits
(the datasets depend on the reader's), so the difference is kept as the caller's argument or
as its own computation, named here:

* sums of |r|²: the reader adds ``(P + re²) + im²``, the capture decoder ``P + (re² + im²)``
  (on a 3,000-sample window 2,965 of the 3,001 running sums differ, by up to 16 ulp);
* the preamble segment's mean: the reader sums it sample by sample, the capture decoder takes
  it from cumulative sums (993 of 1,000 lags differ in the last bits);
* the correlation's numerator: the reader sums r·t₀ sample by sample with t₀ from NumPy
  (pairwise mean), the capture search over runs of equal template samples,
  Σ_runs t·(C[end] − C[begin]) − t̄·Σr (on that window all 1,000 lags differ, by up to 9e−11
  relative; the best lag is the same);
* the fine BLF grid: the reader steps ρ = 2·BLF/fs as ρ_c·(1 + s·j), the capture decoder
  steps the BLF and divides, 2·(BLF_c·(1 + s·j))/fs (a third of the grid differs in the last
  bit); the preamble's length: ⌊n_el/ρ⌋ against ⌊n_el·fs/(2·BLF)⌋ (equal in every case
  tried, not by construction);
* half-bit sums: the reader and ``decode_reply`` sample by sample
  (``projected_halfbit_sums_kernel``), the capture decoder's fine search element by element
  from cumulative sums;
* the fit of the remodulated reply: the reader over the whole window with c = (Σr − h·Σref)/n
  and the residual summed sample by sample, the capture decoder over the reply up to its end
  with c from the normal equations and the residual in closed form;
* ``decode_reply`` (and the reader's receive, :mod:`rfsim.gen2._receive_kernels`)
  adds its sums sample by sample, in order.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2.linecode import PREAMBLES, reply_waveform

__all__ = ["FINE_SPAN_STEPS", "n_pre_elements", "n_reply_elements", "coarse_blf_step", "geometric_blf_grid_hz",
           "preamble_template0"]

#: Half-width of the fine BLF searches of the reader and the capture decoder, and of the
#: capture decoder's narrow search around an earlier reply's BLF, in coarse steps
#: (:func:`coarse_blf_step`; a short FM0 preamble, 12 elements, can correlate best one coarse
#: step off).
FINE_SPAN_STEPS = 2


def n_pre_elements(m: int, trext: bool) -> int:
    """Elements (half subcarrier cycles) of a reply's pilot + preamble.

    Parameters
    ----------
    m, trext : int, bool
        Line code: Miller M (1 = FM0) and the pilot tone.

    Returns
    -------
    int
        Half-bit levels of pilot + preamble times M.
    """
    return PREAMBLES(m, trext)[0].size * m


def n_reply_elements(n_bits: int, m: int, trext: bool) -> int:
    """Elements of a whole reply: pilot + preamble, ``n_bits`` data bits and the dummy 1.

    Parameters
    ----------
    n_bits : int
        Data bits (without the dummy 1).
    m, trext : int, bool
        Line code: Miller M (1 = FM0) and the pilot tone.

    Returns
    -------
    int
        n_pre + 2·M·(n_bits + 1).
    """
    return n_pre_elements(m, trext) + 2 * m * (int(n_bits) + 1)


def coarse_blf_step(m: int, trext: bool) -> float:
    """Relative step of the coarse BLF grid, 1/(2·preamble elements).

    The preamble correlation falls to about half its peak when the template's BLF is off by
    1/(preamble elements) (its last element then slides by one element), so a grid of half
    that step keeps every BLF within the peak's half-width.

    Parameters
    ----------
    m, trext : int, bool
        Miller M (1 = FM0) and pilot tone of the reply searched.

    Returns
    -------
    float
        The relative step [1].
    """
    return 1.0 / (2.0 * n_pre_elements(m, trext))


def geometric_blf_grid_hz(lo_hz: float, hi_hz: float, step: float) -> np.ndarray:
    """BLF hypotheses ``lo_hz`` … ``hi_hz`` on a geometric grid of relative step ≤ ``step``.

    n = ⌈ln(hi/lo) / ln(1 + step)⌉ + 1 values (at least 2) in equal ratios
    (:func:`numpy.geomspace`); the one middle value when hi ≤ lo. The coarse BLF grid of the
    capture decoder (step 2) and of the reader's BLF search, with step
    :func:`coarse_blf_step`.

    Parameters
    ----------
    lo_hz, hi_hz : float
        Lowest and highest BLF [Hz].
    step : float
        Largest relative step between neighbours [1].

    Returns
    -------
    numpy.ndarray
        ``(n,) float64`` BLFs [Hz].
    """
    lo, hi = float(lo_hz), float(hi_hz)
    if hi <= lo:
        return np.array([0.5 * (lo + hi)])
    n = int(math.ceil(math.log(hi / lo) / math.log1p(step))) + 1
    return np.geomspace(lo, hi, max(n, 2))


def preamble_template0(m: int, trext: bool, blf_hz: float, fs_hz: float, n_samples: int) -> np.ndarray:
    """Zero-mean pilot + preamble template: the first ``n_samples`` samples of a reply
    without data (:func:`rfsim.gen2.linecode.reply_waveform`, start 0) minus their mean.

    The callers choose ``n_samples`` (the samples fully inside the preamble, computed in their
    own arithmetic: module docstring).

    Parameters
    ----------
    m, trext : int, bool
        Line code: Miller M (1 = FM0) and the pilot tone.
    blf_hz, fs_hz : float
        BLF and sample rate [Hz].
    n_samples : int
        Template length [samples].

    Returns
    -------
    numpy.ndarray
        ``(n_samples,) float64`` template (±1 levels minus their mean).
    """
    t = reply_waveform(np.zeros(0, np.uint8), m=m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, dummy=False,
                       n_samples=int(n_samples))
    return t - t.mean()
