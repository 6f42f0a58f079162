"""numba kernel of :mod:`rfsim.gen2.generator_words`: one 32-bit word from each of many NumPy
bit generators, in one compiled loop.

Each NumPy bit generator exposes its C interface (``bit_generator.ctypes``, NumPy "Random
sampling: C API", ``bitgen_t``): the address of its state and the function ``next_uint32``
that draws the next 32-bit word from that state. The kernel calls that function of each
generator on its state — NumPy's own code, so every generator advances exactly as
``rng.integers(0, 2**32, dtype=np.uint32)`` advances it (for PCG64 also the buffered upper
half of a 64-bit output), without a Python call per generator. The addresses are plain
integers here (:func:`next_uint32`, an LLVM indirect call): the caller keeps the generators
alive while it uses them.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from rfsim.core._jit import njit


@intrinsic
def next_uint32(typingctx, function_address, state_address):
    """``next_uint32(state)`` of a NumPy ``bitgen_t``: the C function at ``function_address``
    (``uint32_t (*)(void *)``) called on the state at ``state_address`` (both intp)."""
    sig = types.uint32(types.intp, types.intp)

    def codegen(context, builder, signature, args):
        fn_type = ir.FunctionType(ir.IntType(32), [ir.IntType(8).as_pointer()])
        fn = builder.inttoptr(args[0], fn_type.as_pointer())
        state = builder.inttoptr(args[1], ir.IntType(8).as_pointer())
        return builder.call(fn, [state])

    return sig, codegen


@njit
def draw_words_kernel(functions, states, index, out):
    """out[k] = next_uint32 of generator ``index[k]`` (its ``functions`` and ``states``
    addresses, (n,) intp), for k in order; ``out`` (m,) uint32."""
    for k in range(index.size):
        i = index[k]
        out[k] = next_uint32(functions[i], states[i])
