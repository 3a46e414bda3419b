"""The table of term operations: every form of each built-in operation, in one entry.

A *term* is a product of *factors* ``(col, op, a, b)``; a factor applies operation ``op`` to
column ``col`` of ``Z = [states, inputs]`` with the operation's two numbers ``a`` and ``b``.
Each :class:`Operation` of :data:`OPERATIONS` holds all of one operation:

========  =================================  =========================================  ======================
op        value                              derivative                                 text
========  =================================  =========================================  ======================
POW       ``z ** a``                         ``a z^(a-1)`` (0 for ``a = 0``)            ``z^a``
ABS_POW   ``|z| ** a``                       ``a |z|^(a-1) sign(z)``, 0 at ``z = 0``    ``|z|^a``
SQRT      ``sqrt(clip(z, a, b))``            ``1 / (2 sqrt(z))`` inside ``(a, b)``,     ``sqrt(z)``
                                             else 0
SIGN      ``sign(z)``                        0                                          ``sign(z)``
STEP      ``1`` if ``a <= z <= b``, else 0   0                                          ``[z>=a]``, ``[z<=b]``,
                                                                                        ``[a<=z<=b]``
HINGE     ``max(z - a, 0)`` (``b >= 0``),    1 above ``a`` (``b >= 0``), -1 below       ``max(z-a, 0)``,
          ``max(a - z, 0)`` (``b < 0``)      ``a`` (``b < 0``), else 0                  ``max(a-z, 0)``
LOGISTIC  ``1 / (1 + exp(-b (z - a)))``      ``b value (1 - value)``                    ``logistic(b*(z-a))``
========  =================================  =========================================  ======================

``HINGE`` is a continuous piecewise-linear factor with its kink at the level ``a``: the
amount by which ``z`` passes the level upwards (``b >= 0``) or downwards (``b < 0``). A
saturation of ``z`` at ``a`` is ``z - max(z - a, 0)``; its text writes the level exactly
(the shortest decimal that reads back as the same float).

``LOGISTIC`` is the smoothed indicator ``[z>=a]`` of slope ``b > 0`` (its width ``1 / b``; the
step as ``b -> inf``): a fit that refines the level of an indicator by gradients uses it,
narrowed, and writes the exact ``STEP`` into the final model
(:func:`~sindybench.hidden._latent_hard.fit_range_levels`). It is computed as
``0.5 + 0.5 tanh(b (z - a) / 2)``, without a division.

**No division in a value function.** numba compiles ``x / y`` with a ``ZeroDivisionError``
path (its Python error model); one in ``op_value`` makes the free-run kernel
(``_kernels.run_state_into``) 5-7x slower for every model, whether it uses that operation or
not (``benchmarks/bench_ops.py --add div``: one ``(v - a) / b`` branch; the same branch compiled
with ``error_model="numpy"`` costs nothing, nor does one ``exp`` alone; hinge2's ``LOGISTIC`` of
width ``b``, which divided, made it 5.0-7.5x slower; CPU time of the kernels). Hence
``LOGISTIC`` takes the slope, not the width. The derivatives may divide (``SQRT``'s does): the
sensitivity kernel carries that path already.

``value(v, a, b)`` and ``derivative(v, value, a, b)`` are plain functions of scalars in the
subset of Python that numba compiles: the compiled dispatch of :mod:`._ops` (``op_value``,
``op_derivative``) is written from this table, each function's body one branch (so the
kernels compile exactly the code of one hand-written ``if`` chain), and every compiled user
of the terms (features, simulator, sensitivities, one-step map) calls it. ``text``, ``latex``, ``sympy`` and ``casadi`` write the factor for
:func:`~sindybench.libraries.term_name`, :func:`~sindybench.libraries.term_latex`,
:func:`~sindybench.libraries.term_sympy` and :func:`~sindybench.export.to_casadi`; the CasADi
form is the simulator's value with the simulator's derivative (a ``SQRT`` clipped at ``a``
has derivative 0 at and below ``a``, as in :func:`op_derivative`).

At ``z = 0`` the derivative of ``|z|^a`` is taken as 0 (``sign(0) = 0``, also for ``a < 1``),
so that a product such as ``z |z|^0.5``, whose derivative is 0 there, gets 0 by the product
rule rather than ``0 * inf``. ``gate`` marks an indicator (``STEP``): outside its interval
the product is 0 whatever the other factors are (``inf * 0`` is not NaN).

**Adding a built-in operation** is one entry: two functions (value, derivative; they may
call :func:`power` and ``np``) and an :class:`Operation` with the next free code below :data:`~sindybench.dynamics.USER`,
appended to :data:`OPERATIONS` (codes are stored in model files: never renumber one). Then
give it a name in :mod:`sindybench.dynamics`. numba's cache of a kernel does not see a change in a
function it calls; the cached kernels are stamped with a hash of this file and of :mod:`._ops`
(:func:`sindybench._numba_cache.stamp_kernels_with_op_table`), so they are recompiled.
"""

import math
from typing import Callable, NamedTuple

import numpy as np
from numba import njit

__all__ = ["ABS_POW", "HINGE", "LOGISTIC", "OPERATIONS", "Operation", "POW", "SIGN", "SQRT", "STEP", "builtin_operation",
           "power"]


class Operation(NamedTuple):
    """One term operation: its code, name, compiled value and derivative, and written forms.

    Attributes
    ----------
    code : int
    name : str
    value : function
        ``value(v, a, b) -> float`` (numba-compilable; its body becomes a branch of ``op_value``).
    derivative : function
        ``derivative(v, value, a, b) -> float``, ``value`` the factor's value at ``v``.
    text, latex : callable
        ``text(z, a, b) -> str`` with ``z`` the column's name (``latex``: its LaTeX).
    sympy : callable
        ``sympy(sp, z, a, b)``: a SymPy expression of the symbol ``z`` (``sp`` the module).
    casadi : callable
        ``casadi(ca, v, a, b)``: a CasADi expression of ``v`` (``ca`` the module).
    gate : bool
        An indicator: a factor of value 0 makes the product 0 whatever the other factors.
    """

    code: int
    name: str
    value: Callable
    derivative: Callable
    text: Callable
    latex: Callable
    sympy: Callable
    casadi: Callable
    gate: bool = False


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


def _text_power(base, a):
    return base if a == 1 else f"{base}^{a:g}"


def _latex_power(z, a):
    if a == 1:
        return z
    return f"{{{z}}}^{{{a:g}}}" if "'" in z else f"{z}^{{{a:g}}}"  # y_0'^2 would be a double superscript


def _interval(z, a, b, ge, le):
    """``[z>=a]``, ``[z<=b]`` or ``[a<=z<=b]`` with the given comparison signs."""
    if np.isinf(b):
        return f"[{z}{ge}{a:g}]"
    if np.isinf(a):
        return f"[{z}{le}{b:g}]"
    return f"[{a:g}{le}{z}{le}{b:g}]"


def _sympy_number(sp, a):
    return sp.Integer(int(a)) if float(a).is_integer() else sp.Float(a)


def _casadi_power(w, a):
    """``w ** a`` with the simulator's products for the powers 1, 2, 3 (:func:`power`)."""
    return w if a == 1.0 else w * w if a == 2.0 else w * w * w if a == 3.0 else w**a


def _constant_sqrt(c):
    return math.sqrt(c) if c >= 0 else math.nan  # the value of a branch taken only when c is the clip


# ------------------------------------------------------------------------------------------------ POW
def _pow_value(v, a, b):
    return power(v, a)


def _pow_derivative(v, value, a, b):
    return 0.0 if a == 0.0 else a * power(v, a - 1.0)


# -------------------------------------------------------------------------------------------- ABS_POW
def _abs_pow_value(v, a, b):
    return power(abs(v), a)


def _abs_pow_derivative(v, value, a, b):
    if a == 0.0 or v == 0.0:
        return 0.0
    return a * power(abs(v), a - 1.0) * (1.0 if v > 0.0 else -1.0)


# ----------------------------------------------------------------------------------------------- SQRT
def _sqrt_value(v, a, b):
    return np.sqrt(min(max(v, a), b))


def _sqrt_derivative(v, value, a, b):
    if a < v < b:
        return 0.5 / value  # value = sqrt(v) inside the clip
    return 0.0


def _sqrt_casadi(ca, v, a, b):
    """``sqrt(clip(v, a, b))`` with the derivative 0 outside ``(a, b)`` (a constant there, not a clipped sqrt)."""
    outside = ca.if_else(v <= a, _constant_sqrt(a), _constant_sqrt(b)) if np.isfinite(b) else _constant_sqrt(a)
    inside = ca.logic_and(v > a, v < b) if np.isfinite(b) else v > a
    return ca.if_else(inside, ca.sqrt(v), outside)


# ----------------------------------------------------------------------------------------------- SIGN
def _sign_value(v, a, b):
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v  # sign(0) = 0 (with the sign of the zero), sign(nan) = nan


def _zero_derivative(v, value, a, b):
    return 0.0


# ----------------------------------------------------------------------------------------------- STEP
def _step_value(v, a, b):
    return 1.0 if a <= v <= b else 0.0


def _step_sympy(sp, z, a, b):
    inside = sp.And(*([z >= a] if np.isfinite(a) else []) + ([z <= b] if np.isfinite(b) else []))
    return sp.Piecewise((1, inside), (0, True))


# ---------------------------------------------------------------------------------------------- HINGE
def _hinge_value(v, a, b):
    d = v - a if b >= 0.0 else a - v
    return 0.0 if d <= 0.0 else d  # NaN stays NaN


def _hinge_derivative(v, value, a, b):
    if b >= 0.0:
        return 1.0 if v > a else 0.0
    return -1.0 if v < a else 0.0


def _exact(a):
    """The level ``a`` as the shortest decimal that reads back as the same float (``7.5``, ``9.937``)."""
    return repr(float(a))


def _hinge_text(z, a, b, minus):
    """``max(z-a, 0)`` or ``max(a-z, 0)``, with ``z+|a|`` for a negative level."""
    if b >= 0.0:
        inner = f"{z}{minus}{_exact(a)}" if a > 0 else f"{z}+{_exact(-a)}" if a < 0 else z
    else:
        inner = f"{_exact(a)}{minus}{z}" if a != 0 else f"{minus}{z}"
    return f"max({inner}, 0)"


def _hinge_sympy(sp, z, a, b):
    level = sp.Float(repr(float(a)))
    return sp.Max(z - level, 0) if b >= 0.0 else sp.Max(level - z, 0)


# ------------------------------------------------------------------------------------------- LOGISTIC
def _logistic_value(v, a, b):
    return 0.5 + 0.5 * math.tanh(0.5 * b * (v - a))  # no division (see the module); NaN stays NaN


def _logistic_derivative(v, value, a, b):
    return b * value * (1.0 - value)


def _logistic_inner(z, a, minus):
    return f"{z}{minus}{_exact(a)}" if a > 0 else f"{z}+{_exact(-a)}" if a < 0 else z


def _logistic_sympy(sp, z, a, b):
    return 1 / (1 + sp.exp(-sp.Float(repr(float(b))) * (z - sp.Float(repr(float(a))))))


OPERATIONS = (
    Operation(0, "POW", _pow_value, _pow_derivative,
              text=lambda z, a, b: _text_power(z, a),
              latex=lambda z, a, b: _latex_power(z, a),
              sympy=lambda sp, z, a, b: z ** _sympy_number(sp, a),
              casadi=lambda ca, v, a, b: _casadi_power(v, a)),
    Operation(1, "ABS_POW", _abs_pow_value, _abs_pow_derivative,
              text=lambda z, a, b: _text_power(f"|{z}|", a),
              latex=lambda z, a, b: f"|{z}|" if a == 1 else f"|{z}|^{{{a:g}}}",
              sympy=lambda sp, z, a, b: sp.Abs(z) ** _sympy_number(sp, a),
              casadi=lambda ca, v, a, b: _casadi_power(ca.fabs(v), a)),
    Operation(2, "SQRT", _sqrt_value, _sqrt_derivative,
              text=lambda z, a, b: f"sqrt({z})",
              latex=lambda z, a, b: rf"\sqrt{{{z}}}",
              sympy=lambda sp, z, a, b: sp.sqrt(z),  # the clip dropped
              casadi=_sqrt_casadi),
    Operation(3, "SIGN", _sign_value, _zero_derivative,
              text=lambda z, a, b: f"sign({z})",
              latex=lambda z, a, b: rf"\operatorname{{sign}}({z})",
              sympy=lambda sp, z, a, b: sp.sign(z),
              casadi=lambda ca, v, a, b: ca.sign(v)),
    Operation(4, "STEP", _step_value, _zero_derivative,
              text=lambda z, a, b: _interval(z, a, b, ">=", "<="),
              latex=lambda z, a, b: _interval(z, a, b, r" \geq ", r" \leq "),
              sympy=_step_sympy,
              casadi=lambda ca, v, a, b: ca.if_else(ca.logic_and(v >= a, v <= b), 1.0, 0.0),
              gate=True),
    Operation(5, "HINGE", _hinge_value, _hinge_derivative,
              text=lambda z, a, b: _hinge_text(z, a, b, "-"),
              latex=lambda z, a, b: _hinge_text(z, a, b, " - ").replace("max(", r"\max(", 1),
              sympy=_hinge_sympy,
              casadi=lambda ca, v, a, b: ca.fmax(v - a if b >= 0.0 else a - v, 0.0)),
    Operation(6, "LOGISTIC", _logistic_value, _logistic_derivative,
              text=lambda z, a, b: f"logistic({_exact(b)}*({_logistic_inner(z, a, '-')}))",
              latex=lambda z, a, b: rf"\sigma({_exact(b)} ({_logistic_inner(z, a, ' - ')}))",
              sympy=_logistic_sympy,
              casadi=lambda ca, v, a, b: 0.5 + 0.5 * ca.tanh(0.5 * b * (v - a))),
)
"""The built-in operations, by code (``OPERATIONS[code].code == code``)."""

POW, ABS_POW, SQRT, SIGN, STEP, HINGE, LOGISTIC = (op.code for op in OPERATIONS)


def builtin_operation(code):
    """The :class:`Operation` of a built-in ``code``, or None.

    Examples
    --------
    >>> builtin_operation(SQRT).text("x1", 0.0, float("inf")), builtin_operation(7) is None
    ('sqrt(x1)', True)
    """
    code = int(code)
    return OPERATIONS[code] if 0 <= code < len(OPERATIONS) else None
