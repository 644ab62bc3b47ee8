"""A cache prefetch hint for compiled (numba) kernels: ``prefetch(a, i)`` asks the CPU to bring
the cache line of ``a[i]`` (a one-dimensional array) towards the core, without waiting for it.

Why: a kernel that walks sorted but sparse grid cells (the water drops' occupied cells, say)
touches a handful of arrays per cell, each a line the hardware prefetcher does not guess; every
first touch then stalls for the memory's latency (about 140 ns on the benchmark machine), one
after the other, because the work per cell is too long for the core to run ahead.  Hinting the
lines a few cells ahead overlaps those waits.  The hint changes no value, only timing.

numba has no prefetch of its own, so this is an ``@intrinsic`` emitting LLVM's
``llvm.prefetch`` (read, high temporal locality, data cache).  Kernel modules import it; like
them, this module needs numba and is never imported by procgen's numpy paths.
"""
from __future__ import annotations

from llvmlite import binding, ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def prefetch(typingctx, arr, index):
    """Hint: ``arr[index]`` will be read soon (``arr`` one-dimensional; the index unchecked)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and isinstance(index, types.Integer)):
        return None
    sig = types.void(arr, index)
    # the intrinsic's name carries its pointer type: typed ``i8*`` before LLVM 15, opaque after
    name = "llvm.prefetch.p0" if binding.llvm_version_info >= (15,) else "llvm.prefetch.p0i8"

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]], wraparound=False)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, name)
        builder.call(fn, [builder.bitcast(ptr, i8p), ir.Constant(i32, 0), ir.Constant(i32, 3),
                          ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen
