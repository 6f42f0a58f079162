"""Plain-NumPy reference twins of the compiled kernels, and the comparison contracts the tests
hold them to.

A reference here is the obviously right, slow formulation of one kernel (STYLE.md: "every fast
kernel has a slow reference in the tests"); production modules do not import this package.
Modules are named after the production module whose kernels they mirror
(``gen2_linecode`` ↔ :mod:`rfsim.gen2.linecode`). :mod:`reference.ulp` holds the numerical
contract used wherever a transcendental function, a different summation order or SIMD stands
between a kernel and its reference.
"""
