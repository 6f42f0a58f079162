"""The reader's statistic-level receiver model (``ReaderConfig.rx_model = "statistic"``): the
same receiver as :meth:`rfsim.devices.reader.Reader.receive`, its noise drawn as the statistics
the receiver reads instead of sample by sample.

Why it is the same model
------------------------
The receiver's input is ``r = x + n``, ``x`` the noise-free waveform at the RX port [√W] (leakage,
backscatter of every tag) and ``n`` complex white Gaussian noise of power σ² per sample
(kT0·fs·F, :meth:`Reader.noise_power_w` of the sample-level model). Every quantity the receiver
forms from ``r`` is a function of a few linear functionals Σ_i w_i·r_i, and the receiver's
functionals have weights of a simple shape outside the preamble search:

* the half-bit sums behind the Viterbi: w_i = σ_i (the Miller subcarrier sign (−1)^k of the
  sample's element k, +1 for FM0) over the samples of one half-bit;
* the measurement blocks (RSSI, phase, Doppler): w_i = s_i = L_j·σ_i over the *steady*
  samples of the reply (both neighbours on the same level), L_j the decoded level of half-bit j,
  cut into :data:`~rfsim.devices.reader_measure.DOPPLER_BLOCKS` blocks;
* the gain/offset fit on the known levels: w_i = level_i or 1 over the steady samples before
  the reply, on the preamble and after the reply (the rest level −1).

Pieces. The samples after the search block are partitioned so that every one of these weights
is a constant times σ_i on each piece (:func:`piece_map`): per half-bit the samples inside one
element (steady whatever the bits), per Miller half-bit the samples at its inner element edges
(never steady: the subcarrier flips there), every sample at a half-bit edge (its steadiness
depends on the bits) on its own, and the samples after the reply as one piece. The noise then
enters every functional only through the piece sums P_p = Σ_{i∈p} σ_i·n_i, which are independent
CN(0, σ²·|p|) (disjoint pieces of white noise). The model draws these sums and spreads each one
over its piece as ñ_i = σ_i·P_p/|p|: every functional of the receiver then takes exactly the value
it has on a sample-level draw with the same piece sums, so the receiver's decisions and
measurements have exactly the sample-level joint distribution. The receiver code that runs on
``x + ñ`` is the sample-level code (:func:`rfsim.gen2.linecode.decode_reply`,
:func:`rfsim.gen2.capture.fit_gain_offset`, :func:`rfsim.gen2.linecode.decode_bits`, the
measurement kernel): the decisions are literally the same functions of the same statistics.

Step by step (the steps of :meth:`Reader.receive`):

1. DC pre-subtraction (the mean of the samples before the search window): sample 0 and the rest
   of that stretch are two pieces (the known-level fit reads from sample 1 on). **Exact.**
2. Preamble search, sub-sample refinement and the normalised correlation: noise drawn **per
   sample** over the search block (every sample a searched lag's window or a refinement reads,
   plus a margin of :data:`SEARCH_MARGIN` samples, ≈ 550 samples per reply). **Exact** (the same
   model, drawn the same way). The search's own decisions are linear: the integer-lag
   correlations C_l = Σ_i w_{l+i}·t0_i and the refinement's R_{c,j} = Σ_i w_{c+i}·T_{j,i} (w the
   input less the DC estimate, which the zero-mean templates cancel) are jointly Gaussian given
   ``x``, C with the Toeplitz covariance σ²·Σ_i t0_i·t0_{i+l'−l} and R at the chosen candidates
   conditionally Gaussian given C, so drawing (C, then R) instead of samples is exact for the
   search. What else reads the block is what keeps it per sample: the normalised correlation
   of the preamble fit at the found start (a quadratic form, Σ|seg − mean|², over samples the
   drawn correlations do not determine: exact only with the noise's projections on the
   segment's noise-free part drawn conditionally and a σ²/2·χ² of the remaining dimensions) and
   the half-bit, known-level and measurement sums of the reply samples inside the block (piece
   sums conditioned on C and R). All conditional Gaussians, so exact in distribution, but the
   conditioning needs a Cholesky factor over the L searched lags (L ≈ the block less the
   preamble's samples; kept by content per plan) and costs ≈ L²/2 multiply-adds per reply
   against the ≈ 550 normals and the correlation by runs the per-sample draw needs: not faster,
   so not done. Measured (EPC read of the canonical exchange, CPU time): the search by runs
   ≈ 14 µs, its ≈ 550 normals ≈ 3, the block's samples read one by one after it ≈ 8 (preamble
   fit, half-bit sums, known-level fit, measurement), ≈ 25 µs in all; drawn instead (kernels of
   those sizes timed alone), C over the 45 lags ≈ 1.2 µs (a 45×45 triangular factor), R at the
   5 candidates' 17 shifts given C ≈ 7 (an 85×45 conditional mean and an 85×85 factor), and
   the ≈ 100 functionals of the block the later steps read (the segment's projections, 22
   half-bit sums, the fit's and the blocks' sums, the rotation's second-order moments per
   half-bit) given C and R ≈ 14 (a 100×130 conditional mean ≈ 10, a 100×100 factor ≈ 4), their
   factors per reply start (≈ 2 ms each made anew): ≈ 22 µs against ≈ 25, with the rotation of
   the block's samples then to second order only.
3. Gain/offset fit on the known levels, the search's own decisions and the final decisions
   (half-bit sums, Viterbi), CRC: functionals of piece sums. **Exact.** The pieces depend on the
   reply start the search found, so the search block is drawn first, the start found, then the
   pieces after the block drawn (the search reads nothing after the block: exact).
4. Measurement blocks: a block edge (fixed by the count of steady samples, so by the decisions)
   can fall inside a steady piece; that piece is split into its two parts by a Gaussian bridge
   (independent CN(0, σ²|a|), CN(0, σ²|b|) draws corrected to sum to the drawn P_p: exactly the
   conditional law of the two partial sums given P_p). **Exact.**
5. Gain with the Doppler rotation removed, h = Σ z_i·s_i·e^{−j·ω·t_i}/Σ s_i²: the weights are not
   constant over a piece. Per piece p (s_i = L_p·σ_i on it), about an anchor a_p (the sample
   nearest the mean of its sample indices, δ_i = i − a_p, ω' = ω/fs):
   Σ_{i∈p} z_i·s_i·e^{−jωt_i} = L_p·e^{−jω't(a_p)}·(Σσu·E − c·ΣσE + (P_p/|p|)·ΣE) with
   u = x − DC, E = e^{−jω'δ_i} taken to second order, 1 − jω'δ − ω'²δ²/2, so that the sums
   Σσ_i·u_i·δ_i^k (k ≤ 2, of the noise-free input: formed in the one pass over it) and
   Σσ_i·δ_i^k, Σδ_i^k (of the piece map, kept by content) carry it. **Not exact**: the
   error of each term is ≈ (ω'δ)³/6 relative (|δ| ≤ half a half-bit: ≈ 12 samples at
   Miller-4, 320 kHz, 4 MS/s; below 1e−9 for the Doppler a static link estimates at any SNR
   that decodes, ≈ 1e−7 at a 1 kHz Doppler). The samples of the search block and of the cut
   pieces of step 4 are read one by one with the exact rotation (the measurement kernel's
   e^{−jω·t}, walked from sample to sample by a table of steps). The block sums behind the
   Doppler slope (no rotation) are exact: L_p·(Σσu − c·Σσ + P_p) per piece. RSSI and phase
   are exact to the order above.
6. Residual power σ̂² (SNR, Eb/N0 of the read; no decision depends on it): a quadratic form,
   formed by the least-squares identity Σ|z − h·s·e^{jωt}|² = Σ|z|² − |h|²·m (m samples read,
   s² = 1; exact for the least-squares h, to the order of step 5 for the h formed) with per
   piece Σ|z|² = Σ|u|² − 2·Re(c̄·Σu) + |p|·|c|² + 2·Re(conj(P_p/|p|)·(Σσu − c·Σσ)) + |P_p|²/|p|
   (the spread piece's energy |P_p|²/|p| and its cross term with the noise-free input, exact);
   u = x − DC keeps the leakage out of the squares (no cancellation of its power). The energy of
   the noise within a steady piece about its mean, an independent σ²·Gamma(|p| − 1) per piece,
   is added as one Gamma draw over the pieces the measurement reads (:func:`residual_correction`).
   **Exact** where the noise-free residual is a constant times σ_i on each piece (one tag, no
   rotation); with a second tag's reply or a Doppler rotation its cross term with the in-piece
   noise (zero mean, of the order of the second tag's power against σ² times the in-piece
   fraction) is **omitted**.
7. BLF search (``blf_search = "preamble"``): not modelled (a one-line ConfigError:
   ``rx_model = "statistic"`` needs ``blf_search = "off"``).

Noise stream: the air adds no noise to a statistic-level reader's input (its
:meth:`Reader.noise_power_w` is 0 for the air step); the receiver draws from its own generator
(a PCG64 one), spawned from the reader's ``rng`` when the reader is made, in the order of its
``receive`` calls (:func:`receive_many`: in trial order, the same draws), so a run is
reproducible from its seed, but its records differ from the sample-level model draw by draw
(the same distribution). Per call the draws are, in order: the search block's (one (2, k)
block of standard normals), the pieces' sums (one (2, n_pieces) block), the bridges' (one
(2, 2·cuts) block, when a block edge cuts a piece), the Gamma of step 6 (NumPy's
``Generator.gamma`` draw, made in the kernel for more than one degree of freedom, by NumPy
otherwise).

Implementation: steps 1–4 and the draw of step 6 run in one numba call per batch of trials
(:func:`receive_many`; :func:`receive` is a batch of one; the reader's
:meth:`~rfsim.devices.reader.Reader.receive_batch`, the reads of one command's trials on one
time base, is one :func:`receive_many`;
:func:`rfsim.devices._reader_statistic_kernels.receive_kernel`): it draws NumPy's own standard
normals from the generator's PCG64 state (:mod:`rfsim.air._noise_kernels`, the same numbers in
the same order as ``rng.standard_normal``; the state read from and written back to the
generator once per kernel call) and searches with the sample-level decoder's own kernel and
template bank on the search block (noise added per sample). After the block no noise is spread
over samples: one pass over the noise-free input after the block forms per piece Σσ_i·u_i,
Σu_i, Σ|u_i|² and Σσ_i·u_i·δ_i^k (k = 1, 2; u = x − DC,
:func:`~rfsim.devices._reader_statistic_piece_kernels.piece_moments_kernel`), and every functional
the receiver uses is formed from these, the drawn piece sums P_p and the samples of the block:
the half-bit sums S_j = Σσ_i·r_i (the block's samples, then per piece of half-bit j
Σσu + P_p; both decisions of step 3 project them: Re(g·S_j) − Re(dc·g)·C_j), the known-level
fit (the block's samples, then the pieces after the reply: Σr = Σu + P_p at level −1), the
measurement (steps 4–6 above; the members of a cut piece written as samples). Where a piece
would be read only in part (a reference whose element edges disagree with the piece map's by
rounding) the kernel spreads the pieces over the samples and measures with the reader's
measurement kernel instead (the model as before: the same values). Python applies the
reader's measurement rule (``Reader._measurements``) to the gain, slope and residual power and
builds the :class:`ReadResult`. What depends only on the link, the reply's length, the BLF and
the sample rate (templates, refinement bank and its runs, sizes) is kept in the run's
:class:`~rfsim.air.cache.AirCache` (:class:`_Plans`, derived from the link), and per search
window (:class:`_Call`) what depends only on content
(:class:`~rfsim.devices._reader_statistic_kernels.Memo`, four slots by reply start: an EPC
reply's start takes a few values): the piece map of a reply start, its moments and its runs
(the pass over the input walks them), the reference of the last decided bits and its samples of
known level before the pieces, the block cuts and the measurement's plan of the last span;
and the CRC check of decoded bits (pure functions of their keys, checked on every call: the same
numbers as made anew). The NumPy twin of the steps (the sample-level decoder's calls on
``x + ñ``, the spread noise) is ``reference.devices_reader_statistic.receive_reference`` in the
tests: the same draws, decisions and generator state, the measurements equal up to the order
of the sums and the order of step 5.

Cost: complex normals ≈ search block + pieces (≈ 550 + 1,040 for an EPC reply at Miller-4,
320 kHz, 4 MS/s, against 7,090 samples: ≈ 4.5× fewer). Kernel per EPC reply (200 calls of
one input, CPU time on a loaded host): ≈ 98 µs against ≈ 148 µs with the spread and the
per-sample passes (RN16 ≈ 41 against 46 µs: the search block is most of a short reply). Of it:
the search with its draws ≈ 21 µs, the pass over the input ≈ 23, the piece sums' draws ≈ 7,
the measurement ≈ 10–15, the two Viterbi decisions ≈ 6, the half-bit sums, fit and preamble
fit ≈ 3 each; with a new reply start (a memo slot made anew) the piece map and its moments
(≈ 60 µs) and the measurement's plan (≈ 35 µs) on top. Python around a call ≈ 30–40 µs (≈ 8
µs of it the reader's measurement rule; the phase is referred to the carrier by the sample
receiver's rule, :func:`rfsim.devices.reader_measure.refer_phase`). The draws
(≈ 11 µs, PCG64 normals) are not the larger part; the pass over the input and the search are.
Measured again per part (one captured input of the canonical exchange, memo slots made, CPU
time): EPC 87–89 µs, of it the search with its draws 21–22, the pass over the input 23, the
measurement from the pieces 21, the pieces' draws 6–7, the known-level fit 3.5, the two
decisions 3 each, the half-bit sums 3, the bridge 2.7, the preamble fit 2; RN16 42 µs, of it
the search 21 and the measurement 9. In the batched exchange the RN16 reads are one call per
command (≈ 50 µs a read in the kernel, ≈ 12 µs of Python each), each EPC read its own call
(its window starts where the trial's ACK ended: ≈ 100 µs in the kernel, ≈ 27 µs of Python).
Since then (the canonical exchange's 256 trials, their kernel calls captured and replayed, CPU
time on a loaded host, best of 7–21 replays): ≈ 156 → ≈ 137 µs of kernel per trial (EPC read
≈ 105 → 91–95, RN16 ≈ 51 → 45–46), of it the measurement from the pieces 20 → 11 µs (the phasor
walk's state in scalars, not an array on its chain), the pass over the input ≈ 10 % less (by
the piece map's runs: a run of one subcarrier sign sums u and takes the sign once, exactly; an
inner-edge piece, which the measurement never reads, only Σσu), the known-level fit's sample
selection kept with the reference (1.7 → 0.7 µs). What is left per EPC read: the search ≈ 17 µs
and its draws ≈ 3, the pass ≈ 18–20, the pieces' draws ≈ 7 (2,064 normals; the square roots
are not the cost), the measurement ≈ 11 (of it ≈ 5 the ≈ 470 samples of the search block and
the cut pieces read one by one), the two Viterbi decisions ≈ 9, the half-bit sums ≈ 4.

Not built: the statistics from the reply's content. In the static narrowband window
x = c·x_cw + κ·Γ(t), so every per-piece sum of the pass would be a·L(1) + κ·L(Γ), L(Γ) kept by
content. The receiver is handed samples only: the form (a, κ and the content of Γ: bits, the
tag's own start, BLF; a sum of such terms under capture) would have to come from the air step
with the input, and checking it on the samples is itself a pass over them (the pass costs
≈ 3.5 ns a sample). Formed that way the sums also differ from the pass's in the last bits
(another order of rounding), so the records would change. It would save the pass's 23 µs of
an EPC read (≈ 4 % of a batched trial's CPU time): the rest of the exchange, not the receiver,
holds most of a trial's time.

Against the sample-level receiver: **more CPU time, not less**, today. In the batched canonical
exchange (B = 128, two batches, the same trials) a trial took 749 µs against 623 µs with
``rx_model = "sample"`` at 4 MS/s, and 1,966 against 1,471 µs at 16 MS/s; replayed kernel calls
give an EPC read ≈ 135 µs against ≈ 76 µs, an RN16 read ≈ 50 against ≈ 26 µs. The sample-level
receiver draws its noise counter-based and only on the samples it reads, so the pieces (≈ 4
samples each at Miller-4, 320 kHz, 4 MS/s) save few draws while their bookkeeping costs more
than the draws. The model's use today is an independent form of the receiver's statistics (its
equivalence tests check the sample-level receiver's decisions and measurements), not speed.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.gen2.crc import crc16_ok
# the decoder's own preamble, search template and refinement bank (the same search)
from rfsim.gen2.linecode import (_REFINE_SHIFTS, _RUNS_PER_SAMPLE_MAX, _preamble, _refine_bank, _refine_runs,
                                 _template, elements_of_levels, reply_duration_s)
from rfsim.devices.reader_measure import DOPPLER_BLOCKS, ReadResult, refer_phase

_sk = lazy_import("rfsim.devices._reader_statistic_kernels")
_nk = lazy_import("rfsim.air._noise_kernels")  # NumPy's normals drawn in a kernel from a PCG64 state

__all__ = ["RX_MODELS", "SEARCH_MARGIN", "piece_map", "draw_piece_sums", "spread", "bridge_split",
           "block_cuts", "residual_correction", "refer_phase", "receive", "receive_many"]

#: Receiver models of ``ReaderConfig.rx_model``.
RX_MODELS = ("sample", "statistic")
#: Samples drawn one by one on either side of the search block beyond what the search reads.
SEARCH_MARGIN = 3


def piece_map(n: int, i_first: int, start: float, elements_per_sample: float, m: int,
              n_elements: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Partition the samples after the search block into noise pieces.

    The samples ``i_first … n − 1`` of a reply starting at sample ``start`` (module
    docstring, "Pieces"; numba kernel).

    Parameters
    ----------
    n : int
        Samples of the receiver's input.
    i_first : int
        First sample of the pieces.
    start : float
        Reply start [samples, fractional].
    elements_per_sample : float
        Line-code elements per sample, 2·BLF/fs.
    m : int
        Miller M (1: FM0).
    n_elements : int
        Elements of the reply (preamble, bits, dummy).

    Returns
    -------
    piece_of : ndarray of int64, shape (n − i_first,)
        The piece of each sample.
    sign : ndarray of float64, shape (n − i_first,)
        σ_i (±1), the subcarrier sign of each sample.
    kind : ndarray of int64, shape (n_pieces,)
        The class of each piece (``STEADY``, ``INNER_EDGE``, ``SINGLE``, ``REST`` of
        ``rfsim.devices._reader_statistic_kernels``).
    """
    size = max(int(n) - int(i_first), 0)
    piece_of = np.empty(size, np.int64)
    sign = np.empty(size)
    kind = np.empty(size, np.int64)
    n_p = _sk.piece_map_kernel(int(n), int(i_first), float(start), float(elements_per_sample), int(m),
                               int(n_elements), piece_of, sign, kind)
    return piece_of, sign, kind[:n_p]


def draw_piece_sums(sizes: np.ndarray, sigma2_w: float, *, rng: np.random.Generator) -> np.ndarray:
    """Draw the sums of white noise over pieces: :math:`P_p \\sim \\mathcal{CN}(0, \\sigma^2 |p|)`.

    Independent; real and imaginary parts each N(0, σ²·|p|/2), drawn as one (2, n_pieces)
    standard-normal array.

    Parameters
    ----------
    sizes : array_like of float, shape (n_pieces,)
        Samples |p| of each piece.
    sigma2_w : float
        Noise power per complex sample σ² [W].
    rng : numpy.random.Generator
        Keyword-only: the receiver's noise generator.

    Returns
    -------
    ndarray of complex128, shape (n_pieces,)
        The sums P_p [√W].
    """
    scale = np.sqrt(0.5 * float(sigma2_w) * np.asarray(sizes, dtype=np.float64))
    z = rng.standard_normal((2, scale.size))
    return scale * z[0] + 1j * (scale * z[1])


def spread(piece_of: np.ndarray, sign: np.ndarray, sums: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Spread the piece sums over their samples: :math:`\\tilde n_i = \\sigma_i P_p / |p|`, i in p.

    Every functional with weights c·σ_i on a piece then reads c·P_p, as on white noise with
    those piece sums.

    Parameters
    ----------
    piece_of : ndarray of int, shape (n,)
        The piece of each sample.
    sign : ndarray of float, shape (n,)
        σ_i (±1).
    sums : ndarray of complex, shape (n_pieces,)
        Piece sums P_p [√W].
    sizes : ndarray of int or float, shape (n_pieces,)
        Samples |p| of each piece (0 is read as 1).

    Returns
    -------
    ndarray of complex128, shape (n,)
        The noise samples ñ_i [√W].
    """
    return sign * (sums / np.maximum(sizes, 1))[piece_of]


def bridge_split(total, n_a, n_b, sigma2_w: float, *, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Split noise sums into two partial sums by a Gaussian bridge.

    Partial sums (A, B) of n_a and n_b samples of white noise (power σ² per sample) given their
    sum ``total``: independent draws :math:`a \\sim \\mathcal{CN}(0, \\sigma^2 n_a)`,
    :math:`b \\sim \\mathcal{CN}(0, \\sigma^2 n_b)` moved by the shares n_a/n, n_b/n of
    ``total − a − b`` (n = n_a + n_b), exactly the conditional law of (A, B) given A + B.

    Parameters
    ----------
    total : array_like of complex, shape (k,)
        The sums A + B [√W].
    n_a, n_b : array_like of int, shape (k,)
        Samples in each part.
    sigma2_w : float
        Noise power per complex sample σ² [W].
    rng : numpy.random.Generator
        Keyword-only: the receiver's noise generator.

    Returns
    -------
    a, b : ndarray of complex128, shape (k,)
        The partial sums [√W]; ``a + b == total``.
    """
    n_a = np.asarray(n_a, dtype=np.float64)
    n_b = np.asarray(n_b, dtype=np.float64)
    ab = draw_piece_sums(np.concatenate([n_a, n_b]), sigma2_w, rng=rng)
    a, b = ab[: n_a.size], ab[n_a.size:]
    miss = np.asarray(total, dtype=np.complex128) - a - b
    return a + miss * (n_a / (n_a + n_b)), b + miss * (n_b / (n_a + n_b))


def residual_correction(n_free: int, sigma2_w: float, n_used: int, *, rng: np.random.Generator) -> float:
    """Draw the per-sample noise energy the spread pieces lack in the measurement's residual.

    The energy of white noise about its mean within the pieces,
    :math:`\\sigma^2 \\, \\mathrm{Gamma}(\\sum_p (|p| - 1))`, divided by the ``n_used`` samples the
    residual is averaged over (module docstring, step 6).

    Parameters
    ----------
    n_free : int
        Degrees of freedom Σ(|p| − 1) over the pieces the measurement reads.
    sigma2_w : float
        Noise power per complex sample σ² [W].
    n_used : int
        Samples the residual is averaged over.
    rng : numpy.random.Generator
        Keyword-only: the receiver's noise generator (no draw when either count is ≤ 0).

    Returns
    -------
    float
        Energy per sample to add to the residual power [W]; 0 when either count is ≤ 0.
    """
    if n_free <= 0 or n_used <= 0:
        return 0.0
    return float(sigma2_w) * float(rng.gamma(float(n_free))) / int(n_used)


class _Plan(NamedTuple):
    """What :func:`receive` derives from the link, the reply's bits, the BLF and the sample rate
    before it looks at a sample (:func:`_make_plan`)."""

    pre_n: int  # samples fully inside the preamble, as the detector correlates
    n_reply: int  # samples of the whole reply, ⌈duration·fs⌉
    n_decode: int  # the decoder's own reply length, ⌈elements/ratio⌉
    n_pre_elements: int
    n_elements: int
    ratio: float  # elements per sample, 2·BLF/fs
    ints: np.ndarray  # the plan's slots of receive_kernel's ``ip``
    arrays: "_sk.PlanArrays"  # the search template, refinement bank and preamble


def _make_plan(m: int, trext: bool, n_bits: int, blf_hz: float, fs_hz: float) -> _Plan:
    """The :class:`_Plan` of a reply (a pure function of its arguments, kept by
    :class:`_Plans`)."""
    ratio = 2.0 * blf_hz / fs_hz
    levels, state = _preamble(m, trext)
    n_pre_el = levels.size * m
    n_el = n_pre_el + 2 * m * (n_bits + 1)
    nh = levels.size + 2 * (n_bits + 1)
    pre_n = int(math.floor(n_pre_el / ratio))
    n_decode = int(math.ceil(n_el / ratio))
    n_reply = int(math.ceil(reply_duration_s(n_bits, m=m, trext=trext, blf_hz=blf_hz) * fs_hz))
    ints = np.zeros(17, np.int64)
    for slot, value in ((_sk.IP_HALF_WIDTH, int(math.ceil(m / ratio)) + 1), (_sk.IP_N_CANDIDATES, 5),
                        (_sk.IP_STATE, state), (_sk.IP_M, m), (_sk.IP_N_PRE, pre_n), (_sk.IP_NH, nh),
                        (_sk.IP_N_BITS, n_bits), (_sk.IP_N_ELEMENTS, n_el), (_sk.IP_N_REPLY, n_reply),
                        (_sk.IP_N_DECODE, n_decode), (_sk.IP_N_PRE_ELEMENTS, n_pre_el),
                        (_sk.IP_N_BLOCKS, DOPPLER_BLOCKS)):
        ints[slot] = value
    templates, norms = _refine_bank(m, trext, ratio)
    arrays = _sk.PlanArrays(*(np.array(a) for a in (_template(m, trext, ratio, 0.0)[1], _REFINE_SHIFTS, templates,
                                                     norms, elements_of_levels(levels, m, np.float64))),
                            np.array(levels, np.int8), *(np.array(a) for a in _refine_runs(templates)))
    return _Plan(pre_n, n_reply, n_decode, n_pre_el, n_el, ratio, ints, arrays)


class _Call(NamedTuple):
    """What :func:`receive` keeps for one plan, input length and search window
    (:func:`_make_call`): the kernel's integer parameters, its scratch arrays (rewritten by every
    call) and its content memo."""

    last: int  # the last searched lag less lo (< 0: the input is shorter than the reply)
    ip: np.ndarray  # receive_kernel's integer parameters
    r: np.ndarray  # (n,) complex128: the kernel's input buffer (it adds the noise in place)
    z: np.ndarray  # (n_reply + 4,) complex128: the reply span r − c
    memo: "_sk.Memo"  # the piece map of the last start, the reference of the last bits, the cuts


def _make_call(plan: _Plan, n: int, lo: int, hi: int) -> _Call:
    """The :class:`_Call` of ``plan`` on ``n`` samples searched over the lags ``lo … hi``."""
    last = min(n - lo - plan.n_decode, hi - lo)
    b1 = min(n, lo + last + int(math.floor(plan.n_pre_elements / plan.ratio)) + SEARCH_MARGIN)
    b0 = max(0, lo - SEARCH_MARGIN)
    ip = plan.ints.copy()
    ip[[_sk.IP_LO, _sk.IP_B0, _sk.IP_B1, _sk.IP_HEAD, _sk.IP_N_SEARCH]] = (lo, b0, b1, min(b0, 2), last + plan.pre_n)
    n_q = max(n - b1, 0)
    k = int(plan.ints[_sk.IP_N_BLOCKS]) - 1
    S = _sk.MEMO_SLOTS
    flags = np.zeros((S, _sk.MEMO_FLAGS))
    flags[:, _sk.MEMO_PM_PIECES] = -1.0
    memo = _sk.Memo(flags, np.empty((S, n_q), np.int64), np.empty((S, n_q)), np.empty((S, n_q), np.int64),
                    np.zeros((S, n_q)), np.zeros((S, int(plan.ints[_sk.IP_N_BITS])), np.uint8), np.zeros((S, n)),
                    np.zeros((S, 6, max(k, 3)), np.int64), np.zeros((S, 7, n_q)), np.zeros((S, 2, n_q)),
                    np.zeros((S, 2, plan.n_reply + 4), np.int64), np.zeros((S, _sk.MB_RR + 2 * (k + 1))),
                    np.zeros((S, 3, n_q), np.int64), np.zeros((S, 2, min(b1 + 1, n))))
    return _Call(last, ip, np.empty(n, np.complex128), np.empty(plan.n_reply + 4, np.complex128), memo)


def _kept(table: dict, key, make, *args):
    """``table[key]``, made as ``make(*args)`` when it is missing (a pure function of ``key``);
    the table is cleared when it holds :attr:`_Plans.SIZE` entries (a bounded memo)."""
    hit = table.get(key)
    if hit is None:
        if len(table) >= _Plans.SIZE:
            table.clear()
        hit = table[key] = make(*args)
    return hit


class _Plans:
    """The receiver's plans of one link profile (:class:`_Plan` by reply bits, BLF and sample
    rate; :class:`_Call` by those, input length and search window) and the CRC checks of the
    decoded replies (by their bits: a 128-bit check costs ≈ 7 µs, a lookup 0.3 µs), kept in the
    run's :class:`~rfsim.air.cache.AirCache` (:meth:`~rfsim.air.cache.AirCache.derived` of the
    link), each table a bounded memo (:func:`_kept`)."""

    #: Entries per table.
    SIZE = 64

    def __init__(self, link):
        self.m, self.trext = int(link.m), bool(link.trext)
        self.plans: dict = {}
        self.calls: dict = {}
        self.crcs: dict = {}


#: The ValueError of each failure status of the kernel (those the sample-level decoder raises).
#: (status codes ZERO_GAIN, CONSTANT_REFERENCE, NO_ROOM of the kernel module)
_RAISES = {2: "zero channel gain: no reply to decode",
           3: "the reference s is constant: gain and offset cannot be separated",
           4: "the decoded start leaves no room for the reply"}


def receive(reader, x, *, t0_s: float, n_bits: int, expect_crc: bool, cmd_end_s: float | None = None,
            blf_hz: float | None = None, carrier: complex | None = None,
            rng: np.random.Generator) -> ReadResult:
    """Receive ``x + n`` with the noise drawn as the statistics the receiver reads.

    :meth:`rfsim.devices.reader.Reader.receive` at statistic level (module docstring, steps
    1–6; the BLF search is not modelled): :func:`receive_many` of a batch of one.

    Parameters
    ----------
    reader : rfsim.devices.reader.Reader
        The reader (its link, sample rate, noise figure, thresholds and measurement step).
    x : ndarray of complex, shape (n,)
        The noise-free waveform at the RX port [√W].
    t0_s, n_bits, expect_crc, cmd_end_s, blf_hz
        Keyword-only (like the others): as in :func:`receive_many` (``t0_s`` the time of
        ``x[0]`` [s]).
    carrier : complex or None, optional
        The reader's transmitted baseband during the reply window, the phase reference;
        default None (phase 0).
    rng : numpy.random.Generator
        The receiver's noise generator (a PCG64 one).

    Returns
    -------
    ReadResult
        As :meth:`Reader.receive` (failure reasons "preamble not found" or "crc error").

    Raises
    ------
    ValueError
        When ``x`` is not 1-D, or as :func:`receive_many`.
    """
    r = np.asarray(x)
    if r.ndim != 1:
        raise ValueError(f"rx must be 1-D, got shape {r.shape}")
    return receive_many(reader, r[None], t0_s=t0_s, n_bits=n_bits, expect_crc=expect_crc, cmd_end_s=cmd_end_s,
                        blf_hz=blf_hz, carriers=(carrier,), rng=rng)[0]


def receive_many(reader, xs, *, t0_s: float, n_bits: int, expect_crc: bool, cmd_end_s: float | None = None,
                 blf_hz: float | None = None, carriers=None, rng: np.random.Generator) -> list[ReadResult]:
    """Receive B inputs of one reply plan and search window, the noise drawn as the statistics
    the receiver reads: the batch entry of the statistic-level receiver.

    Trial b is :func:`receive` of ``xs[b]`` with ``carrier=carriers[b]`` and the same ``rng``,
    the trials in order: the same draws, decisions and results as B calls of :func:`receive`
    (steps 1–4 and step 6's draw for all trials in one numba call,
    :func:`rfsim.devices._reader_statistic_kernels.receive_kernel`, which draws NumPy's normals
    and Gamma from ``rng``'s PCG64 state; a trial that leaves a draw to NumPy or raises ends the
    call and the next call goes on from the trial after it), then per trial the reader's
    measurement rule (``Reader._measurements``) on its gain, slope and residual power. A batched
    caller (B trials of one command whose reader inputs share their length and time base) calls
    this once instead of :func:`receive` B times.

    Parameters
    ----------
    reader : rfsim.devices.reader.Reader
        The reader (its link, sample rate, noise figure, thresholds and measurement step).
    xs : ndarray of complex, shape (B, n)
        The noise-free waveforms at the RX port [√W], one row per trial.
    t0_s : float
        Keyword-only (like the others): absolute time of ``xs[:, 0]`` [s].
    n_bits : int
        Data bits of the reply.
    expect_crc : bool
        Check the last 16 bits as CRC-16 over the reply.
    cmd_end_s : float or None, optional
        End of the command [s] (the search window as in :meth:`Reader.receive`); default
        None, anywhere.
    blf_hz : float or None, optional
        The tags' BLF [Hz]; default None, the profile's nominal BLF.
    carriers : sequence of complex or None, optional
        Per trial the reader's transmitted baseband during the reply window, the phase
        reference (None entries or ``carriers=None``: phase 0).
    rng : numpy.random.Generator
        The receiver's noise generator (a PCG64 one).

    Returns
    -------
    list of ReadResult
        One per trial, as :meth:`Reader.receive` (failure reasons "preamble not found" or "crc
        error").

    Raises
    ------
    ValueError
        When ``xs`` is not 2-D, ``blf_hz`` is not positive, ``rng`` is not a PCG64 Generator, or
        where the sample-level decoder raises (no room for the reply, a zero gain; the trials
        before the failing one drawn, as B calls of :func:`receive` would).
    """
    xs = np.ascontiguousarray(xs, dtype=np.complex128)
    if xs.ndim != 2:
        raise ValueError(f"xs must be 2-D (trials, samples), got shape {xs.shape}")
    if type(rng) is not np.random.Generator or type(rng.bit_generator) is not np.random.PCG64:
        raise ValueError(f"the statistic-level receiver draws from a PCG64 Generator, got {rng!r}")
    n_bits, (n_trials, n) = int(n_bits), xs.shape
    lk, fs = reader.link, reader.fs_hz
    sigma2 = reader._fixed().noise_w  # k·T0·fs·F, the sample-level model's noise power
    blf = lk.blf_hz if blf_hz is None else float(blf_hz)
    if not blf > 0:
        raise ValueError(f"blf_hz must be > 0, got {blf_hz}")
    plans = reader.air_cache.derived(lk, _Plans)  # the run's, by the (frozen) link profile
    plan = _kept(plans.plans, (n_bits, blf, fs), _make_plan, plans.m, plans.trext, n_bits, blf, fs)
    lo, hi = reader.reply_start_lags(n, plan.n_reply, t0_s=t0_s, cmd_end_s=cmd_end_s)
    if hi < lo or plan.pre_n < 3:
        return [ReadResult(False, None, "preamble not found") for _ in range(n_trials)]
    call = _kept(plans.calls, (n_bits, blf, fs, n, lo, hi), _make_call, plan, n, lo, hi)
    if call.last < 0:
        raise ValueError(f"input of {n - lo} samples is shorter than the reply ({plan.n_decode} samples)")
    fp = np.array([sigma2, plan.ratio, fs, reader.detection_threshold(hi - lo + 1, blf), _RUNS_PER_SAMPLE_MAX])
    bits, res = np.zeros((n_trials, n_bits + 1), np.uint8), np.zeros((n_trials, 14))
    out: list = []
    trial = np.zeros(1, np.int64)
    while len(out) < n_trials:
        full, st = _nk._pcg64_state(rng)
        _nk._run_compiled(_sk.receive_kernel, st, xs, trial, call.r, call.ip, fp, plan.arrays, bits, call.z, res,
                          call.memo)
        _nk._set_pcg64_state(rng, full, st)
        for b in range(len(out), int(trial[0])):
            out.append(_result(reader, bits[b, :n_bits], res[b], lo, float(t0_s), sigma2, blf, expect_crc,
                               None if carriers is None else carriers[b], plans, rng))
    return out


def _result(reader, bits: np.ndarray, res: np.ndarray, lo: int, t0_s: float, sigma2: float, blf: float,
            expect_crc: bool, carrier, plans: _Plans, rng: np.random.Generator) -> ReadResult:
    """The :class:`ReadResult` of one trial from the kernel's ``res`` row and decoded ``bits``
    (:func:`receive_many`; step 6's NumPy draw where the kernel left it)."""
    status, start_rel, corr = int(res[_sk.RES_STATUS]), float(res[_sk.RES_START]), float(res[_sk.RES_CORR])
    if status in _RAISES:
        raise ValueError(_RAISES[status])
    fs = reader.fs_hz
    start_s = t0_s + (lo + start_rel) / fs
    if status == _sk.NOT_FOUND:
        return ReadResult(False, None, "preamble not found", start_s=start_s, corr=corr)
    resid = float(res[_sk.RES_SIGMA2])
    if res[_sk.RES_GAMMA_LEFT] > 0:  # step 6 with one degree of freedom: NumPy's own draw
        resid += residual_correction(int(res[_sk.RES_GAMMA_LEFT]), sigma2, int(res[_sk.RES_N_USED]), rng=rng)
    meas = reader._measurements(complex(res[_sk.RES_H_RE], res[_sk.RES_H_IM]), float(res[_sk.RES_SLOPE]), resid, blf)
    if carrier is not None and complex(carrier) != 0:
        meas["phase_rad"] = refer_phase(meas["phase_rad"], carrier)
    bits = bits.copy()
    ok = (not expect_crc) or _kept(plans.crcs, bits.tobytes(), crc16_ok, bits)
    return ReadResult(success=ok, bits=bits, failure_reason="" if ok else "crc error",
                      start_s=start_s, corr=corr, **meas)


def block_cuts(s: np.ndarray, i0: int, b1: int, piece_of: np.ndarray, kind: np.ndarray,
               reach: int) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Find the measurement's block edges that cut a steady piece (module docstring, step 4).

    Numba kernel over the :data:`~rfsim.devices.reader_measure.DOPPLER_BLOCKS` blocks.

    Parameters
    ----------
    s : ndarray of float, shape (n_s,)
        The ±1 reference reply from sample ``i0`` of the input.
    i0 : int
        Input sample of ``s[0]``.
    b1 : int
        First sample of the pieces (end of the search block).
    piece_of : ndarray of int64
        The piece of each sample from ``b1`` on (:func:`piece_map`).
    kind : ndarray of int64, shape (n_pieces,)
        The class of each piece.
    reach : int
        Samples around a block edge within which a steady piece's members lie.

    Returns
    -------
    n_used : int
        Samples the measurement reads.
    piece : ndarray of int64, shape (n_cuts,)
        The cut pieces.
    edge : ndarray of int64, shape (n_cuts,)
        The block edge of each cut, counted from ``b1``.
    n_before, n_after : ndarray of int64, shape (n_cuts,)
        Members of the piece before and after the edge.
    """

    k = DOPPLER_BLOCKS - 1
    out = [np.empty(k, np.int64) for _ in range(4)]
    n_used, n = _sk.block_cuts_kernel(np.ascontiguousarray(s, dtype=np.float64), int(i0), int(b1), piece_of, kind,
                                      DOPPLER_BLOCKS, int(reach), *out)
    return int(n_used), *(o[:n] for o in out)
