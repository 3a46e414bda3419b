"""Term operations: each one's value and derivative, defined once and compiled by numba.

A *term* is a product of *factors* ``(col, op, a, b)``; a factor applies one
operation ``op`` to column ``col`` of ``Z = [states, inputs]``. The operations
and their derivatives with respect to the column:

========  =================================  =========================================
op        value                              derivative
========  =================================  =========================================
POW       ``z ** a``                         ``a z^(a-1)`` (0 for ``a = 0``)
ABS_POW   ``|z| ** a``                       ``a |z|^(a-1) sign(z)``, 0 at ``z = 0``
SQRT      ``sqrt(clip(z, a, b))``            ``1 / (2 sqrt(z))`` inside ``(a, b)``, else 0
SIGN      ``sign(z)``                        0
STEP      ``1`` if ``a <= z <= b``, else 0   0
user      ``f(z)`` (a registered function)   the given derivative, a rule, or differences
========  =================================  =========================================

At ``z = 0`` the derivative of ``|z|^a`` is taken as 0 (``sign(0) = 0``, also
for ``a < 1``), so that a product such as ``z |z|^0.5``, whose derivative is 0
there, gets 0 by the product rule rather than ``0 * inf``.

:func:`op_value`, :func:`op_derivative` and :func:`apply_factor` are numba
functions, inlined into every compiled user of the terms: the NumPy
evaluation (:func:`evaluate_terms`, :func:`evaluate_terms_jacobian`), the
simulator and the sensitivity kernel. Each takes ``user``, the address of the
compiled table of user operations (:func:`~sindybench.dynamics.user_table`),
which they call for a code ``>= USER``.
"""

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

__all__ = [
    "ABS_POW",
    "BUILTIN_OPS",
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

POW, ABS_POW, SQRT, SIGN, STEP = 0, 1, 2, 3, 4
BUILTIN_OPS = (POW, ABS_POW, SQRT, SIGN, STEP)
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


@njit(cache=True, inline="always")
def power(v, p):
    """``v ** p``, with the small integer powers as products (``v ** 0 = 1`` for every ``v``, NaN included)."""
    if p == 1.0:
        return v
    if p == 0.0:
        return 1.0
    if p == 2.0:
        return v * v
    if p == 3.0:
        return v * v * v
    return v**p


@njit(cache=True, inline="always")
def op_value(o, v, a, b, user):
    """Value of the factor ``op(v)``."""
    if o == POW:
        return power(v, a)
    if o == ABS_POW:
        return power(abs(v), a)
    if o == SQRT:
        return np.sqrt(min(max(v, a), b))
    if o == SIGN:
        if v > 0.0:
            return 1.0
        if v < 0.0:
            return -1.0
        return v  # sign(0) = 0 (with the sign of the zero), sign(nan) = nan
    if o == STEP:
        return 1.0 if a <= v <= b else 0.0
    return call_user(user, o, 0, v)


@njit(cache=True, inline="always")
def apply_factor(value, o, fv):
    """``value`` times a factor of value ``fv``; outside a ``STEP`` the product is 0 whatever ``value`` is."""
    if o == STEP:
        return value if fv != 0.0 else 0.0
    return value * fv


@njit(cache=True, inline="always")
def apply_op(value, o, v, a, b, user):
    """``apply_factor(value, o, op_value(o, v, a, b, user))`` without evaluating a ``STEP`` twice."""
    if o == STEP:
        return value if a <= v <= b else 0.0
    return value * op_value(o, v, a, b, user)


@njit(cache=True, inline="always")
def op_derivative(o, v, value, a, b, user):
    """Derivative of the factor ``op(v)`` with respect to ``v``; ``value`` is :func:`op_value`'s."""
    if o == POW:
        return 0.0 if a == 0.0 else a * power(v, a - 1.0)
    if o == ABS_POW:
        if a == 0.0 or v == 0.0:
            return 0.0
        return a * power(abs(v), a - 1.0) * (1.0 if v > 0.0 else -1.0)
    if o == SQRT:
        if a < v < b:
            return 0.5 / value  # value = sqrt(v) inside the clip
        return 0.0
    if o == SIGN or o == STEP:
        return 0.0
    return call_user(user, o, 1, v)


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
