"""numba kernel of the receiver noise of the air step (wrapped in :func:`rfsim.noise.add_awgn`).

numba compiles ``Generator.standard_normal`` from NumPy's own ziggurat over the generator's
bit generator (PCG64 here), so the kernel draws the same numbers, in the same order, as
``rng.standard_normal(out=ab)`` and advances the same generator state — about 3× faster, as
it avoids NumPy's per-draw call through the bit generator's interface. The plain-NumPy
reference is :func:`rfsim.noise.add_awgn_reference`; the tests compare the two bit for bit.

:func:`add_awgn_compiled` calls the kernel's compiled entry point for the one argument kind
the wrapper passes (a Generator, a writeable aligned C-contiguous complex128 (n,) array, a
fresh float64 (2, n) array, a float): the dispatcher would otherwise type the Generator
argument anew on every call (``numba.typeof`` of a Generator costs more than drawing a few
thousand numbers).
"""

from __future__ import annotations

from rfsim._jit import njit


@njit
def add_awgn_kernel(rng, y, ab, scale):
    """Draw ``ab`` (2, n) from ``rng`` (row 0 then row 1, in order), scale it by ``scale``
    and add it to complex ``y`` (n,): ``y += ab[0] + j·ab[1]``, each part added on its own
    (``y.real += ab[0]; y.imag += ab[1]``)."""
    n = y.size
    for i in range(n):
        ab[0, i] = rng.standard_normal()
    for i in range(n):
        ab[1, i] = rng.standard_normal()
    for i in range(n):
        a = ab[0, i] * scale
        b = ab[1, i] * scale
        ab[0, i] = a
        ab[1, i] = b
        v = y[i]
        y[i] = complex(v.real + a, v.imag + b)


_ENTRY: list = []  # the compiled entry point of add_awgn_kernel for the wrapper's argument kind


def add_awgn_compiled(rng, y, ab, scale: float) -> None:
    """:func:`add_awgn_kernel` for the argument kind of :func:`rfsim.noise.add_awgn` (module
    docstring; the caller guarantees it): the first call goes through the dispatcher
    (compilation or cache load) and keeps the compiled entry point, later calls use it."""
    if _ENTRY:
        _ENTRY[0](rng, y, ab, scale)
        return
    add_awgn_kernel(rng, y, ab, scale)
    from numba import typeof

    sig = tuple(typeof(a) for a in (rng, y, ab, scale))
    cres = add_awgn_kernel.overloads.get(sig)
    # the dispatcher itself where no overload matches: typed once here, not on every call
    _ENTRY.append(add_awgn_kernel if cres is None else cres.entry_point)
