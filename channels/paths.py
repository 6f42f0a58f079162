"""Propagation paths of a link and how they act on a complex-baseband waveform.

A link response is a :class:`PathSet`: per path an amplitude gain g (complex, linear, carrier
phase *not* included), a delay τ [s] and a Doppler shift f_D [Hz] (STYLE.md §3: a channel
yields gains and delays; applying them is a separate step). Applied to the baseband
waveform x(t) (√W, carrier fc implicit; DESIGN.md "Signal model")::

    y(t) = Σ_p g_p · e^{−j2π·fc·τ_p} · e^{j2π·f_D,p·(t − t_ref)} · x(t − τ_p)

The carrier phase −2π·fc·τ is computed in float64 from the exact delay (reduced modulo one
cycle first), never from a sample-rounded delay. The envelope delay x(t − τ) is a fractional
delay by a Kaiser-windowed sinc interpolator (half-width ``half_width`` samples, β = 8, taps
normalised to unit DC gain). The Doppler term is the first-order evolution of the carrier
phase of a moving path, f_D = −(fc/c)·dℓ/dt; the drift of the *envelope* delay within one
waveform (ℓ̇·T/c, e.g. 3 ps per m/s over 1 ms) is neglected.

Samples outside the span of ``x`` are taken as zero; ``y`` has the length and time base of
``x`` (pad ``x`` with zeros to keep a delayed tail).

Narrowband fast path (``method="narrowband"``): when every |τ_p| ≪ 1/B (B the one-sided
bandwidth of x), x(t − τ_p) ≈ x(t) and ``y = (Σ g_p e^{−j2πfcτ_p} e^{j2πf_D,p t}) · x``. By
Bernstein's inequality |x(t − τ) − x(t)| ≤ 2πB·|τ|·max|x|, so its error is bounded by
:func:`narrowband_error_bound`. The carrier phases stay exact; only envelope delays are dropped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.lazy import lazy_import

_pk = lazy_import("rfsim.channels._paths_kernels")


__all__ = [
    "PathSet",
    "DelayTerms",
    "concatenate",
    "compose_backscatter",
    "fractional_delay_taps",
    "apply_paths",
    "apply_backscatter",
    "narrowband_error_bound",
    "narrowband_rms_error",
    "propagation_method",
    "NARROWBAND_TOLERANCE",
    "PROPAGATION_METHODS",
]

#: Kaiser window shape of the fractional-delay interpolator.
_KAISER_BETA = 8.0
_METHODS = ("exact", "narrowband")
#: Propagation policies: "auto" chooses per link (:func:`propagation_method`).
PROPAGATION_METHODS = ("auto", "exact", "narrowband")
#: Relative RMS envelope error below which "auto" propagation is narrowband.
NARROWBAND_TOLERANCE = 0.1


def _ro(a):
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class PathSet:
    """Paths of one link (or of a composed round trip).

    Parameters
    ----------
    gain : (n,) complex128, amplitude gains [linear, √W per √W], carrier phase excluded
    delay_s : (n,) float64, propagation delays [s]
    doppler_hz : (n,) float64, Doppler shifts [Hz] (default 0)

    Arrays are stored read-only. ``gain·e^{−j2π·fc·τ}`` is the path's complex coefficient.
    """

    gain: np.ndarray
    delay_s: np.ndarray
    doppler_hz: np.ndarray | None = None

    def __post_init__(self):
        g = np.atleast_1d(np.asarray(self.gain, dtype=np.complex128)).copy()
        d = np.atleast_1d(np.asarray(self.delay_s, dtype=np.float64)).copy()
        f = np.zeros(d.shape) if self.doppler_hz is None else np.asarray(self.doppler_hz, dtype=np.float64)
        # a (n,) Doppler array is copied as it is; anything else is broadcast to the delays' shape
        f = f.copy() if f.shape == d.shape else np.broadcast_to(np.atleast_1d(f), d.shape).copy()
        if g.ndim != 1 or g.shape != d.shape:
            raise ValueError(f"gain {g.shape} and delay_s {d.shape} must be 1-D of equal length")
        if not (np.isfinite(d).all() and np.isfinite(g).all() and np.isfinite(f).all()):
            raise ValueError("PathSet values must be finite")
        object.__setattr__(self, "gain", _ro(g))
        object.__setattr__(self, "delay_s", _ro(d))
        object.__setattr__(self, "doppler_hz", _ro(f))

    @classmethod
    def _own(cls, gain: np.ndarray, delay_s: np.ndarray, doppler_hz: np.ndarray, *,
             delay_terms: "DelayTerms | None" = None) -> "PathSet":
        """A PathSet holding the given arrays themselves (made read-only), without the
        constructor's copies and checks: for arrays its caller has just made, (n,) complex128,
        float64 and float64, C-contiguous, finite (a channel's assembly of a link). With
        ``delay_terms``, the :class:`DelayTerms` of ``delay_s`` and ``doppler_hz`` (read-only
        arrays that links of successive draws share): what depends on them alone is formed once
        for all those links."""
        out = object.__new__(cls)
        for name, a in (("gain", gain), ("delay_s", delay_s), ("doppler_hz", doppler_hz)):
            if a.flags.writeable:
                a.setflags(write=False)
            object.__setattr__(out, name, a)
        if delay_terms is not None:
            out.__dict__["_delay_terms"] = delay_terms
            out.__dict__["_static"] = delay_terms.static
        return out

    @property
    def n_paths(self) -> int:
        """Number of paths."""
        return int(self.gain.size)

    def coefficients(self, fc_hz: float) -> np.ndarray:
        """Complex path coefficients ``g·e^{−j2π·fc·τ}``, the phase reduced modulo one cycle in float64.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        numpy.ndarray
            ``(n,) complex128`` [√W per √W].
        """
        terms = self.__dict__.get("_delay_terms")
        return self.gain * (_carrier_phasors(self.delay_s, fc_hz) if terms is None else terms.phasors(fc_hz))

    def narrowband_gain(self, fc_hz: float, t_s: float = 0.0) -> complex:
        """Total narrowband gain ``Σ g·e^{−j2π·fc·τ}·e^{j2π·f_D·t}`` at time ``t_s``.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].
        t_s : float
            Time relative to the paths' reference time [s].

        Returns
        -------
        complex
            Gain [√W per √W].
        """
        dop = np.exp(2j * np.pi * np.mod(self.doppler_hz * float(t_s), 1.0))
        return complex(np.sum(self.coefficients(fc_hz) * dop))

    def scaled(self, factor) -> "PathSet":
        """All gains multiplied by ``factor``.

        Parameters
        ----------
        factor : complex
            Scalar factor [1].

        Returns
        -------
        PathSet
            A new path set.
        """
        return PathSet(self.gain * factor, self.delay_s, self.doppler_hz)

    def delayed(self, delay_s: float) -> "PathSet":
        """All delays increased by ``delay_s``.

        Parameters
        ----------
        delay_s : float
            Extra delay [s].

        Returns
        -------
        PathSet
            A new path set.
        """
        return PathSet(self.gain, self.delay_s + float(delay_s), self.doppler_hz)

    def power(self) -> float:
        """Σ|g|², the incoherent path power gain.

        Returns
        -------
        float
            Power gain [W per W].
        """
        return float(np.sum(np.abs(self.gain) ** 2))

    # The air interface (rfsim.air.step) uses a link through these members only.

    @property
    def static(self) -> bool:
        """No path has a Doppler shift (the narrowband link is then one constant)."""
        st = self.__dict__.get("_static")
        if st is None:
            st = self.__dict__["_static"] = np.count_nonzero(self.doppler_hz) == 0
        return st

    def method(self, bandwidth_hz: float, propagation: str = "auto") -> str:
        """"narrowband" or "exact" for this link (:func:`propagation_method`), remembered per (bandwidth, policy).

        Parameters
        ----------
        bandwidth_hz : float
            One-sided bandwidth B of the signal [Hz].
        propagation : {"auto", "exact", "narrowband"}
            Policy.

        Returns
        -------
        str
            "narrowband" or "exact".
        """
        memo = self.__dict__.setdefault("_methods", {})
        key = (float(bandwidth_hz), propagation)
        m = memo.get(key)
        if m is None:
            m = memo[key] = propagation_method(self, bandwidth_hz, propagation)
        return m

    def constant_gain(self, fc_hz: float) -> complex:
        """Σ_p g_p·e^{−j2π·fc·τ_p} summed in path order.

        Bit for bit the factor by which :func:`apply_paths` (``method="narrowband"``) multiplies a
        static link's input; remembered per carrier.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        complex
            Gain [√W per √W].
        """
        memo = self.__dict__.setdefault("_constant", {})
        a = memo.get(float(fc_hz))
        if a is None:
            a = 0j
            for c in self.coefficients(fc_hz).tolist():
                a += c
            memo[float(fc_hz)] = a
        return a

    def narrowband_constant(self, fc_hz: float, bandwidth_hz: float, propagation: str = "auto") -> complex | None:
        """:meth:`constant_gain` when the link is static and :meth:`method` says "narrowband", else None.

        The link then multiplies its input by that one constant; remembered.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].
        bandwidth_hz : float
            One-sided signal bandwidth [Hz].
        propagation : {"auto", "exact", "narrowband"}
            Policy.

        Returns
        -------
        complex or None
            The constant [√W per √W], or None.
        """
        memo = self.__dict__.setdefault("_nb_constant", {})
        key = (fc_hz, bandwidth_hz, propagation)
        hit = memo.get(key, memo)
        if hit is memo:
            hit = self.constant_gain(fc_hz) if (self.static and self.method(bandwidth_hz, propagation)
                                                 == "narrowband") else None
            memo[key] = hit
        return hit

    def apply(self, x, *, fs_hz: float, fc_hz: float, t0_s: float = 0.0, method: str = "exact") -> np.ndarray:
        """:func:`apply_paths` of this link to ``x``.

        Parameters
        ----------
        x : array_like
            ``(n,) complex128`` baseband [√W].
        fs_hz : float
            Sample rate [Hz].
        fc_hz : float
            Carrier frequency [Hz].
        t0_s : float
            Time of x[0] [s].
        method : {"exact", "narrowband"}
            As in :func:`apply_paths`.

        Returns
        -------
        numpy.ndarray
            ``(n,) complex128`` [√W].
        """
        return apply_paths(x, fs_hz=fs_hz, fc_hz=fc_hz, paths=self, t0_s=t0_s, method=method)


def concatenate(*sets: PathSet) -> PathSet:
    """One :class:`PathSet` holding the paths of all ``sets`` (in order).

    Parameters
    ----------
    *sets : PathSet
        Path sets.

    Returns
    -------
    PathSet
        The union (empty without arguments).
    """
    if not sets:
        return PathSet(np.zeros(0, complex), np.zeros(0))
    return PathSet(
        np.concatenate([s.gain for s in sets]),
        np.concatenate([s.delay_s for s in sets]),
        np.concatenate([s.doppler_hz for s in sets]),
    )


def compose_backscatter(forward: PathSet, backward: PathSet) -> PathSet:
    """Round-trip paths of a reflector: every (forward, backward) pair.

    Gains multiply, delays add, Dopplers add (gen2-and-validation-anchors.md §4.7: round trip
    h_f·h_b). Valid for a constant reflection coefficient; for a time-varying Γ(t) use
    :func:`apply_backscatter`. Path order: forward-major (``i_f·n_b + i_b``).

    Parameters
    ----------
    forward : PathSet
        Emitter → reflector.
    backward : PathSet
        Reflector → receiver.

    Returns
    -------
    PathSet
        ``n_f·n_b`` round-trip paths.
    """
    g = (forward.gain[:, None] * backward.gain[None, :]).ravel()
    d = (forward.delay_s[:, None] + backward.delay_s[None, :]).ravel()
    f = (forward.doppler_hz[:, None] + backward.doppler_hz[None, :]).ravel()
    return PathSet(g, d, f)


def fractional_delay_taps(frac: np.ndarray, half_width: int) -> np.ndarray:
    """Kaiser-windowed-sinc taps h_k(μ) = sinc(k − μ)·w(k − μ), k = −L+1 … L, unit DC gain.

    ``x(n − D − μ) ≈ Σ_k h_k(μ)·x[n − D − k]``.

    Parameters
    ----------
    frac : (m,) float64, fractional delays μ in [0, 1) [samples]
    half_width : L, taps per side

    Returns
    -------
    (m, 2L) float64
    """
    L = int(half_width)
    k = np.arange(-L + 1, L + 1, dtype=float)
    u = k[None, :] - np.asarray(frac, dtype=float)[:, None]
    arg = np.clip(1.0 - (u / L) ** 2, 0.0, None)
    h = np.sinc(u) * np.i0(_KAISER_BETA * np.sqrt(arg)) / np.i0(_KAISER_BETA)
    return h / h.sum(axis=1, keepdims=True)


def _validate(x, fs_hz, paths, half_width):
    x = np.ascontiguousarray(np.asarray(x, dtype=np.complex128))
    if x.ndim != 1:
        raise ValueError(f"x must be 1-D, got shape {x.shape}")
    if not fs_hz > 0:
        raise ValueError(f"fs_hz must be > 0, got {fs_hz!r}")
    if not isinstance(paths, PathSet):
        raise TypeError("paths must be a PathSet")
    if int(half_width) < 1:
        raise ValueError("half_width must be ≥ 1")
    return x


def _doppler_phase(doppler_hz, fs_hz, t0_s):
    w = 2.0 * np.pi * doppler_hz / fs_hz
    phi0 = 2.0 * np.pi * np.mod(doppler_hz * t0_s, 1.0)
    return w, phi0


def _fir_rows(paths: PathSet, fs_hz: float, fc_hz: float, half_width: int):
    """FIR rows for the kernel: one dense row per Doppler group, or one row per path when denser."""
    L = int(half_width)
    coef = paths.coefficients(fc_hz)
    pos = paths.delay_s * fs_hz
    dint = np.floor(pos).astype(np.int64)
    frac = pos - dint
    h = fractional_delay_taps(frac, L) * coef[:, None]  # (P, 2L)
    rows, starts, lengths, dops = [], [], [], []
    for f in np.unique(paths.doppler_hz):
        idx = np.flatnonzero(paths.doppler_hz == f)
        lo, hi = dint[idx].min(), dint[idx].max()
        span = int(hi - lo) + 2 * L
        if span <= idx.size * 2 * L:  # one dense row is cheaper than per-path rows
            row = np.zeros(span, dtype=np.complex128)
            for p in idx:
                o = int(dint[p] - lo)
                row[o : o + 2 * L] += h[p]
            rows.append(row)
            starts.append(lo - L + 1)
            lengths.append(span)
            dops.append(f)
        else:
            for p in idx:
                rows.append(h[p])
                starts.append(dint[p] - L + 1)
                lengths.append(2 * L)
                dops.append(f)
    taps = np.zeros((len(rows), max(lengths, default=0)), dtype=np.complex128)
    for r, row in enumerate(rows):
        taps[r, : row.size] = row
    return taps, np.array(starts, np.int64), np.array(lengths, np.int64), np.array(dops, float)


def apply_paths(x, *, fs_hz: float, fc_hz: float, paths: PathSet, t0_s: float = 0.0,
                method: str = "exact", half_width: int = 16) -> np.ndarray:
    """Apply a :class:`PathSet` to a complex-baseband waveform (compiled kernel).

    Parameters
    ----------
    x : (N,) complex128, baseband waveform [√W], sample k at time t0_s + k/fs_hz
    fs_hz : sample rate [Hz]
    fc_hz : carrier frequency [Hz] (for the exact carrier phase −2π·fc·τ)
    paths : the link's paths
    t0_s : time of x[0] [s] relative to the reference time of the Doppler phases (the time at
        which the paths were evaluated)
    method : ``"exact"`` (fractional delays) or ``"narrowband"`` (envelope delays dropped; see
        the module docstring and :func:`narrowband_error_bound`)
    half_width : taps per side of the fractional-delay interpolator

    Returns
    -------
    y : (N,) complex128 [√W]
    """
    x = _validate(x, fs_hz, paths, half_width)
    y = np.zeros_like(x)
    if paths.n_paths == 0 or x.size == 0:
        return y
    if method == "narrowband":
        w, phi0 = _doppler_phase(paths.doppler_hz, fs_hz, t0_s)
        return _pk.narrowband_kernel(x, paths.coefficients(fc_hz), w, phi0, y)
    if method != "exact":
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    taps, starts, lengths, dops = _fir_rows(paths, fs_hz, fc_hz, half_width)
    w, phi0 = _doppler_phase(dops, fs_hz, t0_s)
    return _pk.fir_rows_kernel(x, taps, starts, lengths, w, phi0, y)


def apply_backscatter(x_tx, gamma_t, forward: PathSet, backward: PathSet, *, fs_hz: float,
                      fc_hz: float, t0_s: float = 0.0, method: str = "exact") -> np.ndarray:
    """Backscattered waveform ``backward(Γ(t)·forward(x_tx))``.

    Parameters
    ----------
    x_tx : (N,) complex128, transmitted waveform at the emitter's port [√W]
    gamma_t : (N,) complex or scalar, reflection coefficient Γ(t) of the tag on the same time base
    forward, backward : paths emitter → tag and tag → receiver
    fs_hz, fc_hz, t0_s, method : as in :func:`apply_paths`

    Returns
    -------
    (N,) complex128, at the receiver port [√W]
    """
    incident = apply_paths(x_tx, fs_hz=fs_hz, fc_hz=fc_hz, paths=forward, t0_s=t0_s, method=method)
    return apply_paths(np.asarray(gamma_t) * incident, fs_hz=fs_hz, fc_hz=fc_hz, paths=backward,
                       t0_s=t0_s, method=method)


def narrowband_error_bound(paths: PathSet, bandwidth_hz: float) -> float:
    """Bound on max|y_narrowband − y_delayed| / max|x|: Σ|g_p|·2π·B·|τ_p| (Bernstein).

    Parameters
    ----------
    paths : PathSet
        The link.
    bandwidth_hz : float
        One-sided bandwidth B of x (its spectrum within |f| ≤ B) [Hz].

    Returns
    -------
    float
        Relative error bound [1].
    """
    return float(np.sum(np.abs(paths.gain) * 2.0 * np.pi * bandwidth_hz * np.abs(paths.delay_s)))


def narrowband_rms_error(paths: PathSet, bandwidth_hz: float) -> float:
    """Relative RMS envelope error of dropping the envelope delays of ``paths``.

    √(Σ|g|²·(2π·B·(τ − τ0))²) / √(Σ|g|²), τ0 the earliest delay: the Bernstein bound
    2π·B·τ on each path's envelope change, added in power (the paths' carrier phases are
    independent — diffuse taps, reflections at different lengths). The common delay τ0 (time
    of flight, 3.3 ns/m) is dropped from the envelope only: it shifts a reply by tens of ns,
    far below the Gen2 T1 tolerance, and leaves RSSI, phase and Doppler (exact carrier phase
    of every path) unchanged.

    Parameters
    ----------
    paths : PathSet
        The link.
    bandwidth_hz : float
        One-sided signal bandwidth B [Hz].

    Returns
    -------
    float
        Relative RMS error [1] (0 for no power).
    """
    # ufunc reductions (the sums and the minimum of np.sum / np.min, without their wrappers)
    p = np.abs(paths.gain) ** 2
    total = float(np.add.reduce(p))
    if total == 0.0:
        return 0.0
    terms = paths.__dict__.get("_delay_terms")
    rel2 = (_relative_delay_squared(paths.delay_s, bandwidth_hz) if terms is None
            else terms.relative_squared(bandwidth_hz))
    return math.sqrt(float(np.add.reduce(p * rel2)) / total)


def _carrier_phasors(delay_s: np.ndarray, fc_hz: float) -> np.ndarray:
    """e^{−j2π·fc·τ} per path, (n,) complex128 [1], the phase fc·τ reduced modulo one cycle in float64."""
    return np.exp(-2j * np.pi * np.mod(float(fc_hz) * delay_s, 1.0))


def _relative_delay_squared(delay_s: np.ndarray, bandwidth_hz: float) -> np.ndarray:
    """(2π·B·(τ − τ0))², (n,) float64 [1]: the squared envelope phase of each path
    (:func:`narrowband_rms_error`)."""
    rel = 2.0 * np.pi * bandwidth_hz * (delay_s - np.minimum.reduce(delay_s))
    return rel**2


class DelayTerms:
    """What depends only on a link's delays and Doppler shifts, formed once for the links of
    successive draws that share them (a channel's static link: its diffuse gains are drawn anew,
    its delays are not).

    Parameters
    ----------
    delay_s : ndarray, shape (n,), float64
        The delays [s] (read-only: every link that holds these terms holds this array).
    doppler_hz : ndarray, shape (n,), float64
        The Doppler shifts [Hz] (read-only).

    Attributes
    ----------
    static : bool
        No path has a Doppler shift (:attr:`PathSet.static`).
    """

    __slots__ = ("delay_s", "doppler_hz", "static", "_phasors", "_relative")

    def __init__(self, delay_s: np.ndarray, doppler_hz: np.ndarray):
        self.delay_s, self.doppler_hz = delay_s, doppler_hz
        self.static = bool(np.count_nonzero(doppler_hz) == 0)
        self._phasors: dict = {}   # carrier [Hz] -> (n,) complex128
        self._relative: dict = {}  # bandwidth [Hz] -> (n,) float64

    def phasors(self, fc_hz: float) -> np.ndarray:
        """The carrier phasors of these delays, remembered per carrier.

        Parameters
        ----------
        fc_hz : float
            Carrier frequency [Hz].

        Returns
        -------
        ndarray, shape (n,), complex128
            The carrier phasors [1] (read-only; :meth:`PathSet.coefficients` is the gains times these).
        """
        fc_hz = float(fc_hz)
        out = self._phasors.get(fc_hz)
        if out is None:
            out = _carrier_phasors(self.delay_s, fc_hz)
            out.setflags(write=False)
            self._phasors[fc_hz] = out
        return out

    def relative_squared(self, bandwidth_hz: float) -> np.ndarray:
        """(2π·B·(τ − τ0))² per path (:func:`narrowband_rms_error`).

        Parameters
        ----------
        bandwidth_hz : float
            One-sided signal bandwidth B [Hz].

        Returns
        -------
        ndarray, shape (n,), float64
            The squared envelope phases [1] (read-only).
        """
        out = self._relative.get(bandwidth_hz)
        if out is None:
            out = _relative_delay_squared(self.delay_s, bandwidth_hz)
            out.setflags(write=False)
            self._relative[bandwidth_hz] = out
        return out


def propagation_method(paths: PathSet, bandwidth_hz: float, propagation: str = "auto") -> str:
    """The one narrowband/fractional-delay decision: "narrowband" or "exact" for ``paths``.

    ``propagation="auto"``: narrowband (exact carrier phase and Doppler of every path, envelope
    delays dropped) when :func:`narrowband_rms_error` on the one-sided bandwidth
    ``bandwidth_hz`` (a Gen2 reply: B = 2·BLF, the main lobe of FM0/Miller) is at most
    :data:`NARROWBAND_TOLERANCE`, else every path with its exact fractional delay (which also
    avoids the interpolator's ringing on hard-switched FM0/Miller edges being taken for a
    delay effect). ``"exact"`` and ``"narrowband"`` force the method.

    Parameters
    ----------
    paths : PathSet
        The link.
    bandwidth_hz : float
        One-sided signal bandwidth [Hz].
    propagation : {"auto", "exact", "narrowband"}
        Policy.

    Returns
    -------
    str
        "narrowband" or "exact".

    Raises
    ------
    ValueError
        For an unknown policy.
    """
    if propagation not in PROPAGATION_METHODS:
        raise ValueError(f"propagation must be one of {PROPAGATION_METHODS}, got {propagation!r}")
    if propagation != "auto":
        return propagation
    ok = paths.n_paths == 0 or narrowband_rms_error(paths, bandwidth_hz) <= NARROWBAND_TOLERANCE
    return "narrowband" if ok else "exact"
