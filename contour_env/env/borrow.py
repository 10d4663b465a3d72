"""Borrowed array views for compiled drivers: the same array without its reference count.

numba keeps a reference count on every array that Python hands to a compiled function, and
the compiled code increments and decrements it (atomic instructions) wherever an array is
passed on, put in a tuple or kept in a variable across branches. In the env step that is a
few dozen atomic operations per env and servo period, about half the time of a step at rest
(measured with ``perf``: 52 % of the serial driver's samples in ``NRT_incref``/``NRT_decref``,
hsm2-circle-II, zero actions, 4096 envs). The parallel driver never paid it: numba's thread
team receives the arrays as raw buffers, without a reference count.

:func:`borrowed` gives the serial driver the same: a view of an array (same data, shape,
strides) whose reference count is absent, so the compiled code's increments and decrements
are no-ops. Only for arrays that outlive the call using the view: the arguments of a compiled
function called from Python (Python holds them for the whole call). The arithmetic is
unchanged, so results are bit-identical.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def borrowed(typingctx, arr):
    """A view of ``arr`` without a reference count (see the module docstring)."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(arr)(context, builder, value=args[0])
        out = context.make_array(arr)(context, builder)
        null_meminfo = cgutils.get_null_value(out.meminfo.type)
        null_parent = cgutils.get_null_value(out.parent.type)
        context.populate_array(
            out,
            data=src.data,
            shape=src.shape,
            strides=src.strides,
            itemsize=src.itemsize,
            meminfo=null_meminfo,
            parent=null_parent,
        )
        return out._getvalue()

    return arr(arr), codegen
