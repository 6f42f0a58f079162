"""The fused backscatter fast path of the air step (:func:`rfsim.air.step.propagate`).

One modulating reflector at a receiver on the emitter's carrier, with narrowband static
links, contributes b·((A_s − Γ(t))·(g·x(t))); the step keeps it as its factors
(:class:`Backscatter`) until the receiver's sum is formed, and when that sum is one constant
term a·x plus this one contribution, :func:`fused_sum` forms it in one kernel pass
(:mod:`rfsim.air._step_kernels`) when the run's strategy asks for it
(:attr:`rfsim.air.cache.Strategy.fused_backscatter`, chosen by the owner of the run, not by a
probe of the machine); otherwise the step keeps NumPy's array operations.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.air.links import link_constant
from rfsim.air.segment import Segment

_ak = lazy_import("rfsim.air._step_kernels")
_ek = lazy_import("rfsim.air._exchange_kernels")

__all__ = ["Backscatter", "lazy_backscatter", "fused_sum", "fused_noisy_sum"]


#: Python numbers (NumPy's float64 and complex128 scalars among them): ``np.ndim`` 0 without an
#: array made for them.
_NUMBER = (complex, float, int)


class Backscatter:
    r"""The contribution of one modulating reflector at a receiver, kept as its factors.

    :math:`b\,((A_s - \Gamma(t))\,(g\,x(t)))` on the emitter's carrier (narrowband, static links
    g and b; re-radiation r = A_s − Γ, rfsim.devices.tag), kept until the receiver's sum is
    formed (:func:`fused_sum`).

    Parameters
    ----------
    x : ndarray, shape (n,), complex128
        The emitter's segment samples [√W].
    g : complex
        Forward (emitter → reflector) link constant.
    a_s : complex
        Antenna structural-mode term A_s of the re-radiation.
    gamma : ndarray, shape (n,), complex128
        Chip reflection coefficient Γ(t) per sample.
    b : complex
        Backward (reflector → receiver) link constant.
    """

    __slots__ = ("x", "g", "a_s", "gamma", "b")

    def __init__(self, x, g, a_s, gamma, b):
        self.x, self.g, self.a_s, self.gamma, self.b = x, g, a_s, gamma, b

    def samples(self) -> np.ndarray:
        r"""Form the contribution with the step's array operations.

        Returns
        -------
        ndarray, shape (n,), complex128
            :math:`b\,((A_s - \Gamma)\,(g\,x))` [√W], the products in that order.
        """
        return self.b * ((self.a_s - self.gamma) * (self.g * self.x))


def lazy_backscatter(r, pj, seg: Segment, g, y, rc, off: float, n_samples: int, bw: float, propagation: str,
                     memo: dict, b=None):
    """Keep one reflector's contribution as its factors when it has the fused form.

    The form is b·((A_s − Γ(t))·(g·x(t))): one-dimensional samples, a forward constant ``g``, a
    backward constant, no carrier offset, and r(t) = A_s − Γ(t) given by the reflection's
    ``reradiation_terms``.

    Parameters
    ----------
    r : Reflection
        The reflector's reflection (:class:`rfsim.air.roles.Reflection`).
    pj : PathSet-like or None
        Backward link, reflector → receiver (None when ``b`` is given).
    seg : Segment
        The emitter's segment.
    g : complex or None
        Forward link constant (None: the forward link is not one constant).
    y : ndarray or None
        The incident samples when the forward link is not one constant, else None.
    rc : complex or None
        The reflection's constant re-radiation (None: it modulates).
    off : float
        Carrier offset emitter − receiver [Hz].
    n_samples : int
        Samples of the step.
    bw : float
        Simulated bandwidth [Hz] (for the link's narrowband rule).
    propagation : str
        Propagation policy (:data:`rfsim.air.links.PROPAGATION_METHODS`).
    memo : dict
        The step's memo of narrowband link constants (:func:`rfsim.air.links.link_constant`).
    b : complex or None, default None
        The backward link's held constant (the links' ``held_constants``); None: asked of ``pj``
        (:func:`rfsim.air.links.link_constant`).

    Returns
    -------
    Backscatter or None
        The contribution as factors, or None when it does not have that form.
    """
    # (a number: a Python complex, the common case, is told by its type without a call)
    if (y is not None or rc is not None or off != 0.0 or g is None
            or not (type(g) is complex or isinstance(g, _NUMBER) or np.ndim(g) == 0)):
        return None
    terms = getattr(r, "reradiation_terms", None)
    if terms is None:
        return None
    x = seg.samples
    a_s = terms[0]
    if (x.ndim != 1 or terms[1].shape != (n_samples,)
            or not (type(a_s) is complex or isinstance(a_s, _NUMBER) or np.ndim(a_s) == 0)):
        return None
    if b is None:
        b = link_constant(pj, seg.fc_hz, bw, propagation, memo)
    if b is None or not (type(b) is complex or isinstance(b, _NUMBER) or np.ndim(b) == 0):
        return None
    return Backscatter(x, g, a_s, terms[1], b)


def fused_sum(const: dict, parts: list, segs: list, n_samples: int, *, fused: bool = True):
    r"""Sum a receiver's constant-factor terms, with one backscatter part fused in when possible.

    Forms :math:`\sum_e a_e x_e` (in ``const`` order). With ``fused`` (the run's
    :attr:`rfsim.air.cache.Strategy.fused_backscatter`), when that is one term a·x and ``parts``
    is one :class:`Backscatter` of the same x, the part is added in the same kernel pass
    (:mod:`rfsim.air._step_kernels`: the same products and sums as the array operations) and
    ``parts`` is emptied.

    Parameters
    ----------
    const : dict
        Emitter index → complex factor a_e of its segment.
    parts : list
        The receiver's full-length contributions still to add; emptied when fused.
    segs : list of Segment
        The emitters' segments, by emitter index.
    n_samples : int
        Samples of the step.
    fused : bool, default True
        Whether the fused kernel may be used.

    Returns
    -------
    ndarray or None
        The sum [√W], shape of the segments' samples, or None when ``const`` is empty.
    """
    one = _one_backscatter(const, parts, segs) if fused else None
    if one is not None:
        a, bs = one
        out = np.empty(n_samples, dtype=np.complex128)
        _ak.backscatter_kernel(bs.x, a, complex(bs.g), complex(bs.a_s), bs.gamma, complex(bs.b), out)
        parts.clear()
        return out
    y = None
    for i, a in const.items():
        v = a * segs[i].samples
        y = v if y is None else y + v
    return y


def _one_backscatter(const: dict, parts: list, segs: list):
    """``(a, Backscatter)`` when the sum is one term a·x plus one :class:`Backscatter` of the same
    x (complex128, one-dimensional), else None."""
    if len(parts) == 1 and type(parts[0]) is Backscatter and len(const) == 1:
        (i, a), = const.items()
        bs = parts[0]
        x = segs[i].samples
        if (x is bs.x and (type(a) is complex or isinstance(a, _NUMBER) or np.ndim(a) == 0)
                and x.dtype == np.complex128 and bs.gamma.dtype == np.complex128):
            return complex(a), bs
    return None


def fused_noisy_sum(const: dict, parts: list, segs: list, n_samples: int, noise_w: float, key: int, start: int,
                    out: np.ndarray | None = None):
    r"""A receiver's input with its noise in one kernel call, when it is one term and one backscatter part.

    :math:`y = a\,x + b\,((A_s - \Gamma)\,(g\,x)) + n` with n the counter-based noise of
    stream ``key`` (:func:`rfsim.air.noise.add_counter_awgn`) on the samples ``start:`` only
    (:mod:`rfsim.air._exchange_kernels`; the numbers of :func:`fused_sum` followed by
    :func:`rfsim.air.noise.add_counter_awgn`, to the bit). ``parts`` is emptied on success.

    Parameters
    ----------
    const : dict
        Emitter index → complex factor a_e of its segment.
    parts : list
        The receiver's full-length contributions.
    segs : list of Segment
        The emitters' segments, by emitter index.
    n_samples : int
        Samples of the step.
    noise_w : float
        Noise power N [W per complex sample]; the noise is √(N/2)·(a + j·b).
    key : int
        Key of the counter-based stream (:func:`rfsim.air.noise.noise_key`).
    start : int
        First sample that gets noise (the first the receiver reads).
    out : ndarray, shape (n,), complex128, or None, optional
        Where to form the input (the receiver's ``input_array``); default None, a new array.

    Returns
    -------
    ndarray, shape (n,), complex128, or None
        The noisy input [√W], or None (nothing formed, ``parts`` untouched) when the sum does
        not have that form.
    """
    one = _one_backscatter(const, parts, segs)
    if one is None:
        return None
    a, bs = one
    out = np.empty(n_samples, dtype=np.complex128) if out is None else out
    _ek.backscatter_noise_kernel(bs.x, a, complex(bs.g), complex(bs.a_s), bs.gamma, complex(bs.b), np.uint64(key),
                                 int(start), math.sqrt(noise_w / 2.0), out)
    parts.clear()
    return out
