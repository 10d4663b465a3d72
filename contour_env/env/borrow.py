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

Borrow once per call, before the loop, and inline the per-env code into it
(``inline="always"``): a null meminfo is then a constant and LLVM removes the increments and
decrements altogether; a non-inlined function that receives the views as arguments still makes
a call and a null check per array and env (issue 35: 1.6x slower).

In a ``parallel=True`` function the parfor pass removes stores into an array that nothing
reads afterwards unless the array aliases an argument; a call it does not know is taken for a
new array (in the env step's ``prange`` over borrowed views every reward was lost). The view is
therefore registered with numba's alias analysis as an alias of its argument (below), so the
stores stay. The env drivers borrow outside any ``prange`` all the same: both call
:func:`contour_env.env.kernel.step_range` (the parallel one once per block of envs), which
borrows once per call and runs its envs in a plain loop.
"""

from __future__ import annotations

from numba import njit, types
from numba.core import cgutils, ir_utils
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


def _alias_of_argument(lhs, args, alias_map, arg_aliases):
    # numba's alias analysis (ir_utils.find_potential_aliases): ``lhs = borrowed(arr)`` makes
    # lhs an alias of arr, as ``lhs = arr.reshape(...)`` does
    ir_utils._add_alias(lhs, args[0].name, alias_map, arg_aliases)


ir_utils.alias_func_extensions[(borrowed.__name__, __name__)] = _alias_of_argument


def _alias_of_fields(lhs, args, alias_map, arg_aliases):
    # ``rec = Record(a, b, ...)`` makes rec an alias of every array it holds
    for arg in args:
        ir_utils._add_alias(lhs, arg.name, alias_map, arg_aliases)


def register_record(cls):
    """Tell numba's alias analysis that a record (a named tuple of arrays, built in compiled
    code) aliases the arrays it holds. Without it the parfor pass of a ``parallel=True``
    function drops the stores made through a record built in its ``prange`` body (a named
    tuple's fields are not seen as the arrays they are: every reward of the parallel env step
    was lost). Returns ``cls``."""
    ir_utils.alias_func_extensions[(cls.__name__, cls.__module__)] = _alias_of_fields
    return cls


def record_borrower(record_class):
    """A compiled function (inlined where it is called) that returns a record of
    ``record_class`` (a named tuple of arrays, :func:`register_record`) with every array
    :func:`borrowed`: made from the record's declared fields, so the field list is written once
    (:mod:`contour_env.env.layout`). (Written as a plain inlined function: an ``overload`` of a
    generic borrower inlined into the drivers, each of which inlines the step twice, lost
    stores of the step — numba 0.6x; measured.)"""
    body = ", ".join(f"borrowed(record.{name})" for name in record_class._fields)
    namespace = {"cls": record_class, "borrowed": borrowed}
    source = f"def borrow(record):\n    return cls({body})\n"
    exec(source, namespace)  # noqa: S102  (made from the record's declaration)
    borrow = namespace["borrow"]
    borrow.__name__ = borrow.__qualname__ = f"borrow_{record_class.__name__}"
    return njit(inline="always")(borrow)
