"""The compiled dispatch of the term operations, and the kernels that evaluate terms.

The operations themselves (value, derivative, text, LaTeX, SymPy and CasADi forms) are the
entries of :data:`~._optable.OPERATIONS` (:mod:`._optable`). :func:`op_value` and
:func:`op_derivative` are written from that table when this module is imported (numba needs
one static branch per code) and are called by every compiled user of the terms: the NumPy
evaluation (:func:`evaluate_kernel`, :func:`evaluate_jacobian_kernel`), the simulator and the
sensitivity kernel. These two are ordinary numba calls, not ``inline="always"``: LLVM
inlines them into each kernel all the same (the same bits and speed), while numba's own
inlining re-ran its front end on every copy (16-46 % of the first call's compilation;
``benchmarks/bench_compile.py``). The smaller helpers (:func:`apply_factor`, :func:`apply_op`,
``power``, the divergence test) stay inlined by numba: called, they made the free run 5 %
slower. Each takes ``user``, the address of the compiled table of
user operations (:func:`~sindybench.dynamics.user_table`), which they call for a code ``>= USER``.
:func:`apply_factor` and :func:`apply_op` multiply a factor into a product, an indicator
(``gate``, ``STEP``) making it 0 outside its interval whatever the other factors are.
"""

import inspect
import textwrap

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from . import _optable
from ._optable import ABS_POW, HINGE, LOGISTIC, OPERATIONS, POW, SIGN, SQRT, STEP, power

__all__ = [
    "ABS_POW",
    "BUILTIN_OPS",
    "HINGE",
    "LOGISTIC",
    "POW",
    "SIGN",
    "SQRT",
    "STEP",
    "USER",
    "USER_SIGNATURE",
    "call_rows",
    "call_user",
    "apply_factor",
    "apply_op",
    "evaluate_jacobian_kernel",
    "evaluate_kernel",
    "no_user_ops",
    "op_derivative",
    "op_value",
    "power",
]

BUILTIN_OPS = tuple(op.code for op in OPERATIONS)
USER = 16
"""First code of the user operations (:func:`~sindybench.dynamics.register_op`)."""

USER_SIGNATURE = types.float64(types.int64, types.int64, types.float64)
"""``user(code, which, z)``: the value (``which = 0``) or derivative (``which = 1``) of user op ``code``."""


no_user_ops = None
"""The user table of a model without user operations: the kernels are compiled without the indirect call."""


@intrinsic
def call_user(typingctx, address, code, which, z):
    """Call the user table at ``address`` (an int: a ``cfunc`` of :data:`USER_SIGNATURE`); NaN for None.

    The table goes into the kernels as a plain integer, which numba passes
    without the cost of boxing a function object (about 40 us per call); for
    models without user operations it is None, and the kernels are compiled
    without the indirect call (which would keep LLVM from optimizing the loops).
    """
    sig = types.float64(address, types.int64, types.int64, types.float64)
    if isinstance(address, types.NoneType):
        return sig, lambda context, builder, signature, args: context.get_constant(types.float64, np.nan)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.DoubleType(), [ir.IntType(64), ir.IntType(64), ir.DoubleType()])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(fn, [args[1], args[2], args[3]])

    return sig, codegen


@intrinsic
def call_rows(typingctx, address, z, par, out):
    """Call the compiled rows function at ``address``: ``out = rows(z, par)`` (nothing for None)."""
    sig = types.void(address, z, par, out)
    if isinstance(address, types.NoneType):
        return sig, lambda context, builder, signature, args: context.get_dummy_value()

    def codegen(context, builder, signature, args):
        pointers = []
        for ty, value in zip(signature.args[1:], args[1:]):
            array = context.make_array(ty)(context, builder, value=value)
            pointers += [array.data, builder.extract_value(array.shape, 0)]
        dbl, i64 = ir.DoubleType().as_pointer(), ir.IntType(64)
        fnty = ir.FunctionType(ir.VoidType(), [dbl, i64, dbl, i64, dbl, i64])
        builder.call(builder.inttoptr(args[0], fnty.as_pointer()), pointers)
        return context.get_dummy_value()

    return sig, codegen


def _branch(function, args):
    """The body of a table entry's function, indented as one branch of the dispatch."""
    names = list(inspect.signature(function).parameters)
    if names != args:
        raise TypeError(f"{function.__name__} must take ({', '.join(args)}); it takes ({', '.join(names)}).")
    source = textwrap.dedent(inspect.getsource(function))
    body = source[source.index(":\n", source.index(")")) + 2:]  # after the def line
    return textwrap.indent(textwrap.dedent(body), "        ")


def _dispatch(kind):
    """``op_value(o, v, a, b, user)`` or ``op_derivative(o, v, value, a, b, user)``: for each entry of
    :data:`OPERATIONS`, ``if o == code:`` and that entry's function body; then the user table.

    Generated (numba needs static branches) from the entries' own code, so the kernels compile one
    plain ``if`` chain: no extra layer of inlined calls, whose copies would cost compilation time.
    """
    args = ["v", "a", "b"] if kind == "value" else ["v", "value", "a", "b"]
    lines = [f"def op_{kind}(o, {', '.join(args)}, user):"]
    for op in OPERATIONS:
        lines += [f"    if o == {op.code}:", _branch(getattr(op, kind), args).rstrip()]
    lines.append(f"    return call_user(user, o, {0 if kind == 'value' else 1}, v)")
    names = {**vars(_optable), "call_user": call_user}
    exec("\n".join(lines), names)  # noqa: S102 - generated from the table's own functions
    function = names[f"op_{kind}"]
    function.__doc__ = ("Value of the factor ``op(v)``." if kind == "value" else
                        "Derivative of the factor ``op(v)`` with respect to ``v``; ``value`` is :func:`op_value`'s.")
    return njit(function)  # compiled with its first caller (exec'd: no file to cache); the callers' caches hold it


op_value = _dispatch("value")
op_derivative = _dispatch("derivative")


def _gate_test():
    """``is_gate(o)``: True for the codes of the indicators (``Operation.gate``) of :data:`OPERATIONS`."""
    codes = [op.code for op in OPERATIONS if op.gate]
    names = {}
    exec("def is_gate(o):\n    return " + (" or ".join(f"o == {c}" for c in codes) or "False"), names)  # noqa: S102
    return njit(inline="always")(names["is_gate"])


is_gate = _gate_test()


@njit(cache=True, inline="always")
def apply_factor(value, o, fv):
    """``value`` times a factor of value ``fv``; outside an indicator (``STEP``) the product is 0 whatever ``value`` is."""
    if is_gate(o):
        return value if fv != 0.0 else 0.0
    return value * fv


@njit(cache=True, inline="always")
def apply_op(value, o, v, a, b, user):
    """``apply_factor(value, o, op_value(o, v, a, b, user))`` (one copy of the dispatch: compiled once)."""
    return apply_factor(value, o, op_value(o, v, a, b, user))


@njit(cache=True)
def evaluate_kernel(Z, ptr, col, op, a, b, user, out):
    """``out[k, j]`` = term ``j`` at sample ``k`` of ``Z`` (samples by variables; written row by row, in place)."""
    for k in range(Z.shape[0]):
        for j in range(ptr.shape[0] - 1):
            value = 1.0
            for f in range(ptr[j], ptr[j + 1]):
                value = apply_op(value, op[f], Z[k, col[f]], a[f], b[f], user)
            out[k, j] = value


@njit(cache=True)
def evaluate_jacobian_kernel(Z, ptr, col, op, a, b, user, fv, out):
    for k in range(Z.shape[0]):
        for f in range(col.shape[0]):
            fv[f] = op_value(op[f], Z[k, col[f]], a[f], b[f], user)
        for j in range(ptr.shape[0] - 1):
            for f in range(ptr[j], ptr[j + 1]):
                d = op_derivative(op[f], Z[k, col[f]], fv[f], a[f], b[f], user)
                for g in range(ptr[j], ptr[j + 1]):
                    if g != f:
                        d *= fv[g]
                out[k, j, col[f]] += d
