"""Pointer arithmetic for the compiled glue (imported by generated modules only; needs numba).

The glue receives the flat parameter array as a data pointer (``pf_p``). A block's matrix is a
C-contiguous view of its slice: ``carray(offset(pf_p, a), shape)`` builds it from the pointer
moved ``a`` elements on, where ``pf[a:b].reshape(shape)`` would call numba's C helper for a
reshape at every call.
"""
from numba.extending import intrinsic


@intrinsic
def offset(typingctx, ptr, k):
    """``ptr + k`` (elements, not bytes) for a numba ``CPointer``."""
    def codegen(context, builder, signature, args):
        return builder.gep(args[0], [args[1]])

    return ptr(ptr, k), codegen
