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

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.air.links import link_constant
from rfsim.air.segment import Segment

_ak = lazy_import("rfsim.air._step_kernels")

__all__ = ["Backscatter", "lazy_backscatter", "fused_sum"]


class Backscatter:
    """The contribution b·((A_s − Γ(t))·(g·x(t))) of one modulating reflector at a receiver on
    the emitter's carrier (narrowband, static links g and b; re-radiation r = A_s − Γ), kept
    as its factors until the receiver's sum is formed (:func:`fused_sum`)."""

    __slots__ = ("x", "g", "a_s", "gamma", "b")

    def __init__(self, x, g, a_s, gamma, b):
        self.x, self.g, self.a_s, self.gamma, self.b = x, g, a_s, gamma, b

    def samples(self) -> np.ndarray:
        """The contribution as the step's array operations form it (n,)."""
        return self.b * ((self.a_s - self.gamma) * (self.g * self.x))


def lazy_backscatter(r, pj, seg: Segment, g, y, rc, off: float, n_samples: int, bw: float, propagation: str,
                     memo: dict):
    """A :class:`Backscatter` for reflection ``r`` through backward link ``pj`` when the
    contribution has that form (one-dimensional samples, forward constant ``g``, backward
    constant, no carrier offset, r(t) = A_s − Γ(t) given by ``r.reradiation_terms``), else None."""
    if y is not None or rc is not None or off != 0.0 or g is None or np.ndim(g) != 0:
        return None
    terms = getattr(r, "reradiation_terms", None)
    if terms is None or seg.samples.ndim != 1 or terms[1].shape != (n_samples,) or np.ndim(terms[0]) != 0:
        return None
    b = link_constant(pj, seg.fc_hz, bw, propagation, memo)
    if b is None or np.ndim(b) != 0:
        return None
    return Backscatter(seg.samples, g, terms[0], terms[1], b)


def fused_sum(const: dict, parts: list, segs: list, n_samples: int, *, fused: bool = True):
    """A receiver's constant-factor terms Σ_e a_e·x_e (in ``const`` order) and, with ``fused``
    (:attr:`rfsim.air.cache.Strategy.fused_backscatter`) when they are one term a·x and
    ``parts`` is one :class:`Backscatter` of the same x, that part too, in one kernel pass
    (:mod:`rfsim.air._step_kernels`: the same products and sums as the array operations;
    ``parts`` is then emptied). None when ``const`` is empty."""
    if fused and len(const) == 1 and len(parts) == 1 and isinstance(parts[0], Backscatter):
        (i, a), = const.items()
        bs = parts[0]
        x = segs[i].samples
        if (x is bs.x and np.ndim(a) == 0 and x.dtype == np.complex128 and bs.gamma.dtype == np.complex128):
            out = np.empty(n_samples, dtype=np.complex128)
            _ak.backscatter_kernel(x, complex(a), complex(bs.g), complex(bs.a_s), bs.gamma, complex(bs.b), out)
            parts.clear()
            return out
    y = None
    for i, a in const.items():
        v = a * segs[i].samples
        y = v if y is None else y + v
    return y
