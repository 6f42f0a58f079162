"""numba kernel of the reader's batched receive (:meth:`rfsim.devices.reader.Reader.receive_batch`):
the reply windows of B trials read in one call from Python.

The trial loop runs inside the kernel; each trial is one call of
:func:`rfsim.devices._reader_receive_kernels.receive_kernel` (steps 1–5 of
:meth:`rfsim.devices.reader.Reader.receive`) on that trial's samples, with its own search window
and detection threshold, so every trial's status, start, correlation, decisions and measurements
are those of :meth:`~rfsim.devices.reader.Reader.receive` of that trial alone, to the bit
(tests/test_reader_batch.py). Nothing of the rule is written here: the kernel only hands each
trial its samples (one typed list of the trials' arrays, no copy) and its rows of the output
arrays.
"""

from __future__ import annotations

from rfsim.core._jit import njit
from rfsim.devices._reader_receive_kernels import receive_kernel


@njit
def receive_batch_kernel(rxs, lo, hi, threshold, n_reply, fs_hz, blf_hz, m, n_pre, n_pre_el, t0,
                         max_runs_per_sample, half_width, shifts, templates, norms, run_begin, run_value, n_runs,
                         same_as_previous, pre_el, pre_levels, state0, viterbi, n_blocks, det_bits, bits, out_f, out_c,
                         status):
    """:func:`~rfsim.devices._reader_receive_kernels.receive_kernel` of B trials, one after another.

    Trial b reads ``rxs[b]`` (a ``numba.typed.List`` of (n_b,) complex128 arrays: its receiver
    input from the listen start [√W], not copied) with search window ``lo[b]`` … ``hi[b]``
    (int64, samples of its input) and detection threshold ``threshold[b]`` (float64, a
    normalised correlation); every other argument up to ``n_blocks`` is that of
    ``receive_kernel`` and the same for every trial (one reader, link and reply length
    ``n_reply`` [samples]). Trial b writes its rows
    ``det_bits[b]``, ``bits[b]`` ((B, n_bits + 1) uint8), ``out_f[b]`` ((B, 4) float64: start
    [samples of its input], corr, slope [rad/s], σ² [W]), ``out_c[b]`` ((B, 1) complex128: the
    measured gain [√W]) and ``status[b]`` ((B,) int64, ``receive_kernel``'s status).
    """
    for b in range(status.size):
        status[b] = receive_kernel(rxs[b], lo[b], hi[b], n_reply, threshold[b], fs_hz,
                                   blf_hz, m, n_pre, n_pre_el, t0, max_runs_per_sample, half_width, shifts, templates,
                                   norms, run_begin, run_value, n_runs, same_as_previous, pre_el, pre_levels, state0,
                                   viterbi, n_blocks, det_bits[b], bits[b], out_f[b], out_c[b])
