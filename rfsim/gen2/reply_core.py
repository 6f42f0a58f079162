"""The steps the tag-reply decoders share, each written once.

Three decoders read FM0/Miller replies ``r = h·s(t) + c + noise``:

* :func:`rfsim.gen2.linecode.decode_reply` — one known BLF: preamble search over every lag,
  refined to 1/16 sample, (h, c) from the preamble, half-bit sums, Viterbi or bitwise
  decisions (the reader with ``blf_search`` off);
* the reader's BLF search :func:`rfsim.devices.reader_search.search_decode` — coarse preamble
  correlation over a BLF grid and the T1 lags, then decoding at BLFs across the coarse one
  with the preamble's centre held, the least residual of the remodulated reply wins;
* the capture decoder :mod:`rfsim.gen2.replies` (``rfsim decode``) — the same search over link
  hypotheses at a working rate with a detection threshold, then the fine BLF search, the
  reply's length, timing tracking on the tag's clock and the E_h/N₀ gate.

Steps written once (this module and :mod:`rfsim.gen2._reply_core_kernels`), which every
decoder that performs them calls:

* the preamble's element count and a reply's (:func:`n_pre_elements`,
  :func:`n_reply_elements`), the coarse BLF step 1/(2·preamble elements)
  (:func:`coarse_blf_step`), the geometric BLF grid (:func:`geometric_blf_grid_hz`) and the
  fine search's half-width (:data:`FINE_SPAN_STEPS`);
* the zero-mean sampled preamble template (:func:`preamble_template0`);
* the normalised correlation from its sums, the parabolic refinement of its peak, the
  preamble's least-squares (h, c), the decisions from the half-bit sums, the sums of the
  fit of a remodulated reply with its rest level and the residual over its steady samples
  (kernels).

Where the decoders still compute a step differently, the difference changes results in the
last bits (the inventory dataset depends on the reader's), so it is kept as the caller's
argument or as a second computation, named here:

* sums of the preamble segment and of |r|²: the reader adds sample by sample (|r|² as
  ``(P + re²) + im²``), the capture decoder from cumulative sums (``P + (re² + im²)``);
* preamble samples: the reader ⌊n_el/ρ⌋ with ρ = 2·BLF/fs, the capture search
  ⌊n_el·fs/(2·BLF)⌋; the fine BLF grid: the reader in ρ, the capture decoder in Hz;
* half-bit sums: the reader and ``decode_reply`` sample by sample
  (``projected_halfbit_sums_kernel``), the capture decoder's fine search element by element
  from cumulative sums;
* the fit of the remodulated reply: the reader over the whole window with c = (Σr − h·Σref)/n
  and the residual summed sample by sample, the capture decoder over the reply up to its end
  with c from the normal equations and the residual in closed form;
* ``decode_reply`` computes (h, c) and the correlation with NumPy reductions (pairwise sums).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from rfsim.gen2.linecode import preamble_levels, reply_waveform

__all__ = ["FINE_SPAN_STEPS", "n_pre_elements", "n_reply_elements", "coarse_blf_step", "geometric_blf_grid_hz",
           "preamble_template0"]

#: Half-width of the fine BLF searches of the reader and the capture decoder, and of the
#: capture decoder's narrow search around an earlier reply's BLF, in coarse steps
#: (:func:`coarse_blf_step`; a short FM0 preamble, 12 elements, can correlate best one coarse
#: step off).
FINE_SPAN_STEPS = 2


@functools.lru_cache(maxsize=32)
def n_pre_elements(m: int, trext: bool) -> int:
    """Elements (half subcarrier cycles) of a reply's pilot + preamble.

    Parameters
    ----------
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.

    Returns
    -------
    int
        Half-bit levels of pilot + preamble times M.
    """
    return preamble_levels(m=m, trext=trext)[0].size * m


def n_reply_elements(n_bits: int, m: int, trext: bool) -> int:
    """Elements of a whole reply: pilot + preamble, ``n_bits`` data bits and the dummy 1.

    Parameters
    ----------
    n_bits : int
        Data bits (without the dummy 1).
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.

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
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.

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
    m : int
        Miller M (1 = FM0).
    trext : bool
        Pilot tone before the preamble.
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
