"""Pointer arithmetic for the compiled glue (imported by generated modules only; needs numba).

The glue receives the flat parameter array as a data pointer (``pf_p``). A block's matrix is a
C-contiguous view of its slice: ``carray(offset(pf_p, a), shape)`` builds it from the pointer
moved ``a`` elements on, where ``pf[a:b].reshape(shape)`` would call numba's C helper for a
reshape at every call.

The compiled core receives a diagram's glue as the addresses of its functions (an integer
array): ``function_at(address, T)`` makes the first-class function of type ``T`` that numba
would otherwise unbox from a Python object at every call of the core.
"""
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def offset(typingctx, ptr, k):
    """``ptr + k`` (elements, not bytes) for a numba ``CPointer``."""
    def codegen(context, builder, signature, args):
        return builder.gep(args[0], [args[1]])

    return ptr(ptr, k), codegen


@intrinsic
def function_at(typingctx, address, ftype):
    """The compiled function at ``address`` (an int64) as a value of the numba ``FunctionType``
    ``ftype``: called through its C entry (no Python object behind it)."""
    fn = ftype.instance_type

    def codegen(context, builder, signature, args):
        f = cgutils.create_struct_proxy(fn)(context, builder)
        null = cgutils.get_null_value(cgutils.voidptr_t)
        f.c_addr = builder.inttoptr(args[0], cgutils.voidptr_t)
        f.py_addr = f.jit_addr = null
        return f._getvalue()

    return fn(address, ftype), codegen
