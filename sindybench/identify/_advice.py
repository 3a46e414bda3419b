"""Data advice: what a record says about the settings of a model, before any model is fitted.

In the spirit of MATLAB's ``advice``, ``delayest``, ``pexcit``, ``detrend`` and
``feedback`` (System Identification Toolbox), each check is a small function
of the inputs ``X`` and outputs ``y`` of one record, and :func:`advice` runs
them all and returns a :class:`DataAdvice`, logged (never silent) and printed
by ``str()``:

* :func:`estimate_delay`: the input delay in samples (the estimators'
  ``input_delay``), from ARX fits by least squares over candidate delays,
  each scored by its one-step error on a held-out block at the end;
* :func:`detect_input_hold`: zero-order hold (a piecewise-constant input)
  or linear interpolation (a smooth one), from the input's shape;
* offsets (a mean large against the spread: centre, ``normalize=True``),
  drift (an output trend that the inputs do not have);
* :func:`excitation_order`: the persistent-excitation order of each input
  (rank of its autocovariance matrix), too little for a model of many poles;
* :func:`detect_saturation`: an output level where samples pile up (a point
  mass at the top or bottom of the range), with the fraction at it;
* feedback: future inputs that improve an ARX prediction of the output (an
  F test; the record was taken in closed loop, so an open-loop fit may be
  biased, or the output was filtered non-causally);
* sampling: the outputs' bandwidth against the Nyquist frequency (too slow,
  fewer than 4 samples per period of the fastest content; too fast, more
  than 100: decimate).

Detected features propose library terms (:class:`ProposedTerm`): an
indicator at a saturation level, friction (``sign``) terms of a velocity
that changes sign, square roots of a positive signal.
"""

import logging
from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.stats import f as f_dist

from .._validation import check_inputs_outputs, check_integer, check_positive, check_signal
from ..baselines._arx import least_squares
from ..baselines._lags import input_lags, output_lags
from ..dynamics import SIGN, SQRT, STEP

__all__ = ["DataAdvice", "ProposedTerm", "advice", "detect_input_hold", "detect_saturation", "estimate_delay",
           "excitation_order"]

logger = logging.getLogger(__name__)

_HELD_OUT = 0.25  # the block at the end that confirms a delay
_FEEDBACK_P = 1e-3  # F-test level of the feedback check
# the least share of the ARX residual the inputs' innovations must explain to call a record closed-loop: on long
# open-loop records a tiny dependence (a non-Gaussian input's innovations and a nonlinear misfit) is significant; the
# simulated and real closed loops measured explain 0.01 - 0.5 of it, the open-loop ones below 0.003 (docs/identify.rst)
_FEEDBACK_EFFECT = 0.005
_SAMPLES_PER_PERIOD = (4, 100)  # sampling too slow below, too fast above (per period of the 95 % bandwidth)


@dataclass(frozen=True)
class ProposedTerm:
    """A library term that a feature of the data suggests.

    Attributes
    ----------
    kind : {"indicator", "friction", "sqrt"}
    signal : str
        The signal it applies to: ``"y0"``, or ``"y0'"`` for the derivative
        of output 0 (a state of derivative coordinates).
    output : int
        The output column.
    derivative : int
        0 for the output itself, 1 for its derivative.
    low, high : float
        The indicator's interval (``STEP``: 1 where ``low <= z <= high``);
        the square root's clip; unused for friction.
    reason : str
    """

    kind: str
    signal: str
    output: int
    derivative: int
    low: float
    high: float
    reason: str

    def term(self, column):
        """The term as factors ``((column, op, a, b),)`` over column ``column`` of ``Z``.

        Examples
        --------
        >>> ProposedTerm("indicator", "y0", 0, 0, 9.9, np.inf, "").term(0)
        ((0, 4, 9.9, inf),)
        """
        op = {"indicator": STEP, "friction": SIGN, "sqrt": SQRT}[self.kind]
        return ((column, op, float(self.low), float(self.high)),)

    def __str__(self):
        name = {"indicator": f"1[{self.low:.4g} <= {self.signal} <= {self.high:.4g}]",
                "friction": f"sign({self.signal})", "sqrt": f"sqrt({self.signal})"}[self.kind]
        return f"{name} ({self.reason})"


@dataclass
class DataAdvice:
    """What :func:`advice` found in a record; ``str()`` is the report, ``warnings`` the problems.

    Attributes
    ----------
    n_samples, n_inputs, n_outputs : int
    dt : float
    input_delay : int
        Estimated input delay in samples (the estimators' ``input_delay``).
    delay_losses : dict
        Held-out one-step error (relative) of each candidate ARX input lag ``nk``.
    delay_resolved : bool
        False when lags further apart than the ARX window score alike (see
        :func:`estimate_delay`).
    input_hold : str
        ``"zoh"`` or ``"linear"`` (for all inputs; the first input decides
        when they differ, see ``input_holds``).
    input_holds : list of str
    output_mean, output_std, input_mean, input_std : ndarray
    offsets : list of str
        Signals whose mean exceeds their standard deviation.
    drift : list of str
        Outputs with a trend (a straight line in time explains over half of
        their variance) that no input has.
    excitation : list of int
        Persistent-excitation order of each input (up to ``max_order``).
    saturation : list of (int, str, float, float)
        ``(output, "upper" or "lower", level, fraction of samples at it)``.
    feedback : float or None
        p-value of the F test that the inputs' innovations over the next 10
        samples do not improve an ARX prediction of the output; None when the record cannot tell
        (``feedback_note`` says why).
    feedback_effect : float or None
        The share of the ARX residual's sum of squares those innovations explain.
    feedback_note : str or None
        Why the record cannot tell feedback (no residual noise; inputs their own
        past predicts, such as a periodic multisine).
    poles : list of ndarray
        Per output, the discrete poles of its own lags in an ARX model (orders
        up to 8, the smallest within 1 % of the best held-out one-step error).
    unstable, integrating : list of int
        Outputs with a pole that grows within half the record, or that is
        slower than half the record (an integrator, as far as the record tells).
    closed_loop : bool
        The record looks closed-loop: ``feedback`` below 0.001 and
        ``feedback_effect`` above 0.005 (see :func:`advice`).
    bandwidth : ndarray
        Per output, the frequency below which 95 % of its (detrended) power lies.
    samples_per_period : ndarray
        ``1 / (dt * bandwidth)``.
    proposed_terms : list of ProposedTerm
    warnings : list of str
        The problems found, one sentence each.
    """

    n_samples: int
    n_inputs: int
    n_outputs: int
    dt: float
    input_delay: int = 0
    delay_losses: dict = field(default_factory=dict)
    delay_resolved: bool = True
    input_hold: str = "zoh"
    input_holds: list = field(default_factory=list)
    output_mean: np.ndarray = None
    output_std: np.ndarray = None
    input_mean: np.ndarray = None
    input_std: np.ndarray = None
    offsets: list = field(default_factory=list)
    drift: list = field(default_factory=list)
    excitation: list = field(default_factory=list)
    saturation: list = field(default_factory=list)
    feedback: float = None
    feedback_effect: float = None
    feedback_note: str = None
    closed_loop: bool = False
    poles: list = field(default_factory=list)
    unstable: list = field(default_factory=list)
    integrating: list = field(default_factory=list)
    bandwidth: np.ndarray = None
    samples_per_period: np.ndarray = None
    proposed_terms: list = field(default_factory=list)
    warnings: list = field(default_factory=list)

    def __str__(self):
        lines = [f"data advice: {self.n_samples} samples, {self.n_inputs} input(s), {self.n_outputs} output(s), "
                 f"dt = {self.dt:.6g}",
                 f"  input delay: {self.input_delay} sample(s) ({self.input_delay * self.dt:.4g} s)",
                 f"  input hold: {self.input_hold}" + (f" (per input: {self.input_holds})"
                                                        if len(set(self.input_holds)) > 1 else ""),
                 f"  output mean {_fmt(self.output_mean)}, std {_fmt(self.output_std)}",
                 f"  input mean {_fmt(self.input_mean)}, std {_fmt(self.input_std)}",
                 f"  persistent excitation order of the inputs: {self.excitation}",
                 f"  outputs' 95 % bandwidth {_fmt(self.bandwidth)} Hz: {_fmt(self.samples_per_period)} samples "
                 "per period",
                 "  feedback: " + (f"cannot tell ({self.feedback_note or 'not checked'})" if self.feedback is None
                                   else f"p = {self.feedback:.2g} that the inputs' innovations do not predict the "
                                        f"output (they explain {100 * self.feedback_effect:.2g} % of an ARX "
                                        f"residual): {'closed' if self.closed_loop else 'open'} loop")]
        lines += [f"  saturation: y{j} {side} level {level:.6g} ({100 * frac:.1f} % of the samples)"
                  for j, side, level, frac in self.saturation]
        lines += [f"  proposed term: {term}" for term in self.proposed_terms]
        lines += [f"  warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def _fmt(values):
    return "[]" if values is None else "[" + ", ".join(f"{v:.4g}" for v in np.ravel(values)) + "]"


#: the largest magnitude a record may reach: the ARX fits and the candidates' cubic terms square and cube it
MAX_MAGNITUDE = 1e100


def check_magnitude(X, y):
    """Refuse a record whose inputs or outputs reach beyond :data:`MAX_MAGNITUDE` (their squares overflow).

    Examples
    --------
    >>> check_magnitude(np.ones((3, 1)), 1e200 * np.ones((3, 1)))
    Traceback (most recent call last):
    ...
    ValueError: y reaches 1e+200 (output column 0): beyond 1e+100, where squares and cubes of it overflow float64; expected a record in units where it stays below 1e+100 (rescale it, e.g. y / 1e+200).
    """
    for name, values, kind in (("X", X, "input"), ("y", y, "output")):
        if values.size == 0:
            continue
        peak = np.max(np.abs(values), axis=0)
        j = int(np.argmax(peak))
        if peak[j] > MAX_MAGNITUDE:
            raise ValueError(f"{name} reaches {peak[j]:.3g} ({kind} column {j}): beyond {MAX_MAGNITUDE:.0e}, where "
                             f"squares and cubes of it overflow float64; expected a record in units where it stays "
                             f"below {MAX_MAGNITUDE:.0e} (rescale it, e.g. {name} / {peak[j]:.3g}).")


def _check(X, y, dt):
    X, y = check_inputs_outputs(X, y)
    check_positive(dt, "dt")
    check_magnitude(X, y)
    return X, y


# ----------------------------------------------------------------------- delay
def _delay_losses(X, y, max_nk, na, nb):
    """Held-out one-step error of ARX(na, nb, nk) for nk = 0 .. max_nk, each relative to the output's variance."""
    n = y.shape[0]
    start = max(na, max_nk + nb - 1)
    n_fit = start + int((1 - _HELD_OUT) * (n - start))
    if n_fit - start < 4 * (na * y.shape[1] + nb * X.shape[1] + 1) or n - n_fit < 10:
        raise ValueError(f"{n} samples are too few to estimate a delay of up to {max_nk - 1} samples with ARX("
                         f"na={na}, nb={nb}); expected at least {start + 8 * (na + nb + 1) + 20}.")
    target = y[start:]
    scale = np.var(target[n_fit - start:], axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    y_part = output_lags(y, na, start)
    losses = {}
    for nk in range(max_nk + 1):
        phi = np.hstack([y_part, input_lags(X, nb, nk, start)])
        coef, intercept, _ = least_squares(phi[: n_fit - start], target[: n_fit - start])
        residual = target[n_fit - start:] - phi[n_fit - start:] @ coef - intercept
        losses[nk] = float(np.mean(np.mean(residual ** 2, axis=0) / scale))
    return losses


def _chosen_lag(losses, rtol, nb):
    """``(nk, resolved)``: the largest lag whose loss is within ``rtol`` of the best.

    Shorter lags reach the response with their longer windows, so the lags
    within ``rtol`` span at most ``nb`` when the record resolves the delay.
    Otherwise (a smooth input: any window extrapolates to the others) the
    delay is not resolved: ``(None, False)``.
    """
    best = min(losses.values())
    close = [nk for nk, loss in losses.items() if loss <= best * (1 + rtol) + 1e-15]
    if max(close) - min(close) <= nb - 1:
        return max(close), True
    return None, False


def estimate_delay(X, y, dt, *, max_delay=20, hold=None, na=2, nb=3, rtol=0.01):
    """Input delay in samples: the ``input_delay`` of :class:`~sindybench.SINDy` and :class:`~sindybench.HiddenStateSINDy`.

    An ARX model ``y[t] = a_1 y[t-1] + ... + b_0 u[t-nk] + ... + b_{nb-1} u[t-nk-nb+1] + c``
    is fitted by least squares on the first 75 % of the record for each input
    lag ``nk`` from 0 to ``max_delay + 1`` and scored by its one-step error on
    the last 25 % (the held-out block). The lag is the largest ``nk`` whose
    held-out error is within ``rtol`` of the best (shorter lags reach the
    response with their longer windows; longer ones miss its start). A
    continuous-time model driven through a zero-order hold responds at lag 1
    without delay, so its delay is ``nk - 1``; with a linear hold the input
    acts within the sample, so it is ``nk``. An input that is smooth at the
    sampling rate may not resolve the delay (lags further apart than ``nb``
    all score within ``rtol``): then the delay is 0 (no delay) and a warning
    is logged; confirm the delay on validation data (the simulation error of
    models with neighbouring delays).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    dt : float
        Sampling interval (for the message).
    max_delay : int, default=20
    hold : {"zoh", "linear"} or None, default=None
        The input hold; None detects it (:func:`detect_input_hold`).
    na, nb : int, default=2, 3
        ARX orders of the candidates (``na >= 0`` output lags, ``nb >= 1`` input lags).
    rtol : float, default=0.01
        Relative tolerance (``>= 0``) of the lags that score as well as the best.

    Returns
    -------
    int

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((2000, 1))
    >>> y = np.zeros((2000, 1))
    >>> for t in range(5, 2000):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 4]
    >>> estimate_delay(u, y, 0.01, hold="zoh")
    3
    """
    X, y = _check(X, y, dt)
    return _estimate_delay(X, y, dt, max_delay, hold, na, nb, rtol, say=True)[0]


def _estimate_delay(X, y, dt, max_delay, hold, na, nb, rtol, say=False):
    """``(delay, losses, resolved)``; ``say``: warn here when the record does not resolve it (:func:`advice` says it
    in its own warnings)."""
    max_delay = check_integer(max_delay, "max_delay", low=0)
    na, nb = check_integer(na, "na", low=0), check_integer(nb, "nb", low=1)
    rtol = check_positive(rtol, "rtol", strict=False)
    if X.shape[1] == 0:
        return 0, {}, True
    hold = hold if hold is not None else detect_input_hold(X)[0]
    losses = _delay_losses(X, y, max_delay + 1, na, nb)
    nk, resolved = _chosen_lag(losses, rtol, nb)
    delay = 0 if nk is None else max(nk - 1, 0) if hold == "zoh" else min(nk, max_delay)
    if not resolved and say:
        logger.warning("estimate_delay: the record does not resolve the input delay (ARX input lags %s score within "
                       "%g %% of the best, as for a smooth input); taking %d samples (no delay): confirm it on validation data",
                       sorted(k for k, v in losses.items() if v <= min(losses.values()) * (1 + rtol)), 100 * rtol,
                       delay)
    logger.info("estimate_delay: input lag nk = %s (%s hold) -> input_delay = %d samples (%.4g s)", nk, hold, delay,
                delay * dt)
    return delay, losses, resolved


# ------------------------------------------------------------------------ hold
def detect_input_hold(X):
    """``"zoh"`` or ``"linear"`` for each input column, from its shape.

    Piecewise constant (over half of the steps repeat the previous value, or
    the second differences are as large as the first: a new value every
    sample, as a zero-order hold of a random sequence) is ``"zoh"``; smooth
    at the sample rate (second differences under half the first) is
    ``"linear"``.

    Examples
    --------
    >>> t = np.arange(500) * 0.01
    >>> detect_input_hold(np.column_stack([np.sin(t), np.repeat(np.arange(50.0) % 3, 10)]))
    ['linear', 'zoh']
    """
    X = check_signal(X, "X")
    holds = []
    for u in X.T:
        d1 = np.diff(u)
        if d1.size < 3 or not np.any(d1):
            holds.append("zoh")
            continue
        repeats = np.mean(np.abs(d1) <= 1e-12 * (np.ptp(u) or 1.0))
        roughness = np.sqrt(np.mean(np.diff(d1) ** 2) / np.mean(d1 ** 2))
        holds.append("zoh" if repeats > 0.5 or roughness >= 0.5 else "linear")
    return holds


# ------------------------------------------------------------------ excitation
def excitation_order(X, *, max_order=50, tol=1e-9):
    """Persistent-excitation order of each input: the rank of the matrix of its windows of ``max_order`` samples.

    The windows ``u[t:t + max_order]`` span a space whose dimension is the
    order (numerical rank: eigenvalues of their Gram matrix above ``tol``
    times the largest): a sum of ``k`` sines excites order ``2 k``, a
    constant order 1 (the offset), white noise every order, zero none. A
    model with more poles than the order cannot be told apart from others
    on this record.

    Examples
    --------
    >>> t = np.arange(2000) * 0.01
    >>> excitation_order(np.column_stack([np.sin(t) + np.sin(3.7 * t), np.ones_like(t)]), max_order=20)
    [4, 1]
    """
    X = check_signal(X, "X")
    max_order = check_integer(max_order, "max_order")
    tol = check_positive(tol, "tol", strict=False)
    if X.shape[0] < 2:
        raise ValueError(f"X has {X.shape[0]} sample(s); the excitation order of an input needs at least 2.")
    orders = []
    for u in X.T:
        if not np.any(u):
            orders.append(0)
            continue
        m = max(1, min(max_order, u.size // 2))
        u = u / np.max(np.abs(u))  # the rank does not depend on scale: no Gram matrix overflows or underflows
        windows = sliding_window_view(u, m)  # every window of m samples: their span has the order's dimension
        eig = np.linalg.eigvalsh(windows.T @ windows)
        orders.append(int(np.sum(eig > tol * eig[-1])))
    return orders


# ------------------------------------------------------------------ saturation
def _noise_std(y):
    """Measurement-noise estimate from second differences (an upper bound for smooth signals)."""
    return np.sqrt(np.mean(np.diff(y, 2) ** 2) / 6) if y.size > 2 else 0.0


def detect_saturation(y, *, min_fraction=0.005, ratio=4.0):
    """Levels where an output's samples pile up at the top or bottom of its range.

    For each output and each end of its range, the fraction of samples within
    ``tol`` of the extreme (``tol``: 0.1 % of the range, or 3 noise standard
    deviations if larger) is compared with the fraction in the next band of
    the same width: a smooth signal (a sine near its peak) has at most about
    2.4 times as many at its extreme; a saturated one has a point mass there.
    The extreme of a noisy saturated output is a noise sample about ``tol``
    beyond the level, so bands twice as wide are compared too; a pile-up found
    only so is reported at the median of the samples within ``2 tol`` of the extreme.

    Parameters
    ----------
    y : array-like of shape (n_samples, n_outputs)
    min_fraction : float, default=0.005
        Smallest fraction of samples at the level to report, in (0, 1].
    ratio : float, default=4.0
        Least ratio (``>= 1``) of the fraction at the extreme to the fraction in the next band of the same width.

    Returns
    -------
    list of (int, str, float, float)
        ``(output, "upper" or "lower", level, fraction)``.

    Examples
    --------
    >>> t = np.arange(2000) * 0.01
    >>> detect_saturation(np.column_stack([np.minimum(np.sin(t), 0.8), np.sin(t)]))
    [(0, 'upper', 0.8, 0.2...)]
    """
    y = check_signal(y, "y")
    if check_positive(min_fraction, "min_fraction") > 1:
        raise ValueError(f"min_fraction must be a fraction in (0, 1]; got {min_fraction!r}.")
    if check_positive(ratio, "ratio") < 1:
        raise ValueError(f"ratio must be a finite number >= 1 (a pile-up has more samples at the extreme than in the "
                         f"next band); got {ratio!r}.")
    found = []
    for j, v in enumerate(y.T):
        span = np.ptp(v)
        if span == 0:
            continue
        tol = max(1e-3 * span, 3 * _noise_std(v) if v.size > 2 else 0.0)
        for side, extreme, dist in (("upper", v.max(), v.max() - v), ("lower", v.min(), v - v.min())):
            for width in (tol, 2 * tol):  # the extreme itself, then a noisy level (the extreme ~ tol beyond it)
                band = dist <= width
                at = np.mean(band)
                if at >= min_fraction and at > ratio * np.mean((dist > width) & (dist <= 2 * width)):
                    found.append((j, side, float(extreme if width == tol else np.median(v[band])), float(at)))
                    break
    return found


# ------------------------------------------------------------------- the rest
def _trend_share(v):
    """Share of the variance of ``v`` that a straight line in time explains."""
    t = np.arange(v.size, dtype=float)
    var = np.var(v)
    if var == 0:
        return 0.0
    slope = np.polyfit(t, v, 1)[0]
    return float(min(1.0, slope ** 2 * np.var(t) / var))


def _innovations(X, order):
    """Per input, the one-step prediction errors of an AR(``order``) fit, and the smallest share of variance left.

    Row ``k`` of the errors belongs to sample ``order + k``.
    """
    n = X.shape[0]
    errors = np.zeros((n - order, X.shape[1]))
    shares = []
    for i, u in enumerate(X.T):
        _, _, resid = least_squares(output_lags(u[:, None], order, order), u[order:, None])
        errors[:, i] = resid[:, 0]
        var = np.var(u[order:])
        shares.append(float(np.var(resid) / var) if var > 0 else 0.0)
    return errors, min(shares, default=0.0)


def _feedback(X, y, nk, na=4, nb=10, n_future=10, ar_order=20):
    """The feedback check: ``(p, effect)``, or ``(None, reason)`` when the record cannot tell.

    The test asks whether the *innovations* of the inputs (what an AR(``ar_order``)
    model of each input cannot predict from its own past) at the next
    ``n_future`` samples improve an ARX(``na``, ``nb``, ``nk``) prediction of ``y[t]`` (an F test,
    ``p``), and by how much (``effect``: the share of the ARX residual's sum of
    squares they explain). In open loop an input's innovation is independent of
    everything before it, the output's noise and the ARX model's misfit
    included, so it adds nothing however poor the ARX model is (a slow, lightly
    damped or nonlinear plant); with feedback the inputs react to the output's
    noise, and so do their innovations. Raw future inputs, the former
    regressors, are correlated with the past inputs that a misfitting ARX
    model leaves in its residual: on the open-loop Silverbox and Bouc-Wen
    records they gave p = 0 and 1e-105. The innovation of ``u[t]`` itself is
    left out: a band-limited input's value at ``t`` tells what the plant saw
    between the samples (on Silverbox it explained 7 % of the residual). So a
    controller that reacts within the sample to a slow disturbance, and only
    then, is not seen (its later inputs are predictable from ``u[t]``).

    Inputs that their own past predicts (a periodic multisine: less than 1e-8
    of the variance left) have no innovations to test, and a record without
    residual noise has nothing to react to: ``(None, reason)``.
    """
    innovations, share = _innovations(X, ar_order)
    if share < 1e-8:
        return None, "the inputs are predictable from their own past (periodic, e.g. a multisine)"
    start = max(na, nk + nb - 1, ar_order - 1)
    n = y.shape[0] - n_future
    past = np.hstack([output_lags(y[:n], na, start), input_lags(X[:n], nb, nk, start)])
    future = np.hstack([innovations[start - ar_order + k : n - ar_order + k] for k in range(1, n_future + 1)])
    target = y[start:n]
    _, _, r_past = least_squares(past, target)
    _, _, r_both = least_squares(np.hstack([past, future]), target)
    q = future.shape[1] * target.shape[1]
    dof = target.size - (past.shape[1] + future.shape[1] + 1) * target.shape[1]
    rss_past, rss_both = float(np.sum(r_past ** 2)), float(np.sum(r_both ** 2))
    if dof <= 0 or rss_both <= 1e-20 * float(np.sum((target - target.mean(axis=0)) ** 2)):
        return None, "no residual noise"
    p = float(f_dist.sf((rss_past - rss_both) / q / (rss_both / dof), q, dof))
    return p, 1.0 - rss_both / rss_past


def _arx_poles(X, y, nk, orders=(1, 2, 3, 4, 6, 8), rtol=0.01):
    """Discrete poles of each output's own lags in the ARX(n, n, ``nk``) model, ``n`` the smallest of ``orders``
    whose held-out one-step error is within ``rtol`` of the best; an array per output."""
    n_samples = y.shape[0]
    fits = {}
    for n in orders:
        start = max(n, nk + n - 1)
        n_fit = start + int((1 - _HELD_OUT) * (n_samples - start))
        if n_fit - start < 4 * (n * (y.shape[1] + X.shape[1]) + 1) or n_samples - n_fit < 10:
            break
        phi = np.hstack([output_lags(y, n, start), input_lags(X, n, nk, start)])
        target = y[start:]
        coef, intercept, _ = least_squares(phi[: n_fit - start], target[: n_fit - start])
        residual = target[n_fit - start:] - phi[n_fit - start:] @ coef - intercept
        scale = np.where(np.var(target, axis=0) > 0, np.var(target, axis=0), 1.0)
        fits[n] = (float(np.mean(np.mean(residual ** 2, axis=0) / scale)), coef)
    if not fits:
        return []
    best = min(loss for loss, _ in fits.values())
    n = min(k for k, (loss, _) in fits.items() if loss <= best * (1 + rtol) + 1e-15)
    coef = fits[n][1]
    m = y.shape[1]
    return [np.roots(np.concatenate([[1.0], -coef[j: n * m: m, j]])) for j in range(m)]


def _pole_findings(poles, dt, duration):
    """``(unstable, integrating)`` output indices: a pole that grows within half the record, or one whose time
    constant is longer than half the record (its free run drifts as an integrator's does)."""
    unstable, integrating = [], []
    for j, p in enumerate(poles):
        p = p[np.abs(p) > 0]
        rate = np.log(np.abs(p)) / dt  # the real part of the continuous pole
        if np.any(rate > 2.0 / duration):
            unstable.append(j)
        elif np.any((np.abs(rate) <= 2.0 / duration) & (np.abs(np.angle(p)) < np.pi / 4)):
            integrating.append(j)
    return unstable, integrating


def _bandwidth(y, dt, share=0.95):
    """Per output, the frequency below which ``share`` of its detrended power lies."""
    out = []
    for v in y.T:
        v = v - np.polyval(np.polyfit(np.arange(v.size), v, 1), np.arange(v.size))
        power = np.abs(np.fft.rfft(v)) ** 2
        freq = np.fft.rfftfreq(v.size, dt)
        cumulative = np.cumsum(power[1:])
        if cumulative.size == 0 or cumulative[-1] == 0:
            out.append(float(freq[-1]) if freq.size else 0.0)
            continue
        out.append(float(freq[1:][np.searchsorted(cumulative, share * cumulative[-1])]))
    return np.array(out)


def _proposals(y, saturation, dt):
    terms = []
    for j, side, level, frac in saturation:
        tol = max(1e-3 * np.ptp(y[:, j]), 3 * _noise_std(y[:, j]))
        low, high = (level - tol, np.inf) if side == "upper" else (-np.inf, level + tol)
        terms.append(ProposedTerm("indicator", f"y{j}", j, 0, low, high,
                                  f"{100 * frac:.1f} % of the samples at the {side} level {level:.6g}"))
    for j, v in enumerate(y.T):
        velocity = np.gradient(v, dt)
        noise = 3 * np.std(np.diff(velocity)) / np.sqrt(2)  # below this a sign change is noise
        moving = velocity[np.abs(velocity) > noise]
        changes = int(np.sum(np.diff(np.sign(moving)) != 0))
        if changes >= 4:
            terms.append(ProposedTerm("friction", f"y{j}'", j, 1, 0.0, 0.0,
                                      f"the velocity of y{j} changes sign {changes} times: friction"))
        if v.min() > 0.05 * np.ptp(v):
            terms.append(ProposedTerm("sqrt", f"y{j}", j, 0, 0.0, np.inf,
                                      f"y{j} stays positive (min {v.min():.4g}): a power-law flow"))
    return terms


#: what identify does about an advice's finding, said in its place when the advice runs inside identify
_IDENTIFY_REMEDIES = {
    "offset": "identify fits a constant term on columns it scales itself, so it needs no centring",
    "delay": "identify scores its candidates with input_delay={delay}",
    "fast": "identify keeps every sample (its derivative methods filter above the bandwidth); decimating by {k} "
            "would keep 20 and cut its cost",
}


def advice(X, y, *, dt, max_delay=20, max_order=50, within_identify=False):
    """Check a record before identification: delay, hold, offsets, drift, excitation, saturation, feedback, sampling.

    The report is logged (INFO, each problem also as a WARNING of this
    module's logger) and is ``str()`` of the result.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs) or None
        Inputs (None for an autonomous record).
    y : array-like of shape (n_samples, n_outputs) or (n_samples,)
    dt : float
        Sampling interval.
    max_delay : int, default=20
        Largest input delay (samples) considered.
    max_order : int, default=50
        Largest persistent-excitation order tested.
    within_identify : bool, default=False
        The advice runs inside :func:`~sindybench.identify.identify`: a
        finding that the search handles itself (an offset, an unresolved
        delay, fast sampling) says what ``identify`` does about it instead of
        what a user should set.

    Returns
    -------
    DataAdvice

    Examples
    --------
    A first-order process at 20 degrees, its input held for 5 samples and
    delayed by 2, its output clipped at 20.4:

    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.standard_normal(600), 5)[:, None]
    >>> y = np.zeros((3000, 1))
    >>> for t in range(3, 3000):
    ...     y[t] = 0.95 * y[t - 1] + 0.1 * u[t - 3]
    >>> y = 20.0 + np.minimum(y, 0.4) + 1e-4 * rng.standard_normal(y.shape)
    >>> report = advice(u, y, dt=0.1)
    >>> report.input_delay, report.input_hold, report.offsets
    (2, 'zoh', ['y0'])
    >>> print(report)
    data advice: 3000 samples, 1 input(s), 1 output(s), dt = 0.1
      input delay: 2 sample(s) (0.2 s)
      input hold: zoh
      output mean [19.87], std [0.5185]
      input mean [-0.02271], std [0.9968]
      persistent excitation order of the inputs: [50]
      outputs' 95 % bandwidth [0.53] Hz: [18.87] samples per period
      feedback: p = 0.0018 that the inputs' innovations do not predict the output
      (they explain 0.95 % of an ARX residual): open loop
      saturation: y0 upper level 20.4003 (27.7 % of the samples)
      proposed term: 1[20.33 <= y0 <= inf] (27.7 % of the samples at the upper level 20.4003)
      proposed term: sign(y0') (the velocity of y0 changes sign 140 times: friction)
      proposed term: sqrt(y0) (y0 stays positive (min 17.46): a power-law flow)
      warning: y0 has an offset (mean 19.87, std 0.519): centre it (normalize=True)
      warning: y0 saturates at its upper level 20.4003 (27.7 % of the samples)
    """
    X, y = _check(X, y, dt)
    max_order = check_integer(max_order, "max_order")  # also without inputs: a wrong setting is named, not ignored
    n, p, m = y.shape[0], X.shape[1], y.shape[1]
    result = DataAdvice(n_samples=n, n_inputs=p, n_outputs=m, dt=float(dt))
    result.input_holds = detect_input_hold(X)
    result.input_hold = result.input_holds[0] if p else "zoh"
    result.input_delay, result.delay_losses, result.delay_resolved = _estimate_delay(
        X, y, dt, max_delay, result.input_hold, 2, 3, 0.01)
    remedy = (lambda kind, **values: _IDENTIFY_REMEDIES[kind].format(**values)) if within_identify else None
    if not result.delay_resolved:
        result.warnings.append("the input delay is not resolved by this record (smooth input): " + (
            remedy("delay", delay=result.input_delay) if remedy else
            f"confirm input_delay={result.input_delay} on validation data"))
    result.output_mean, result.output_std = y.mean(axis=0), y.std(axis=0)
    result.input_mean, result.input_std = X.mean(axis=0), X.std(axis=0)
    warn = result.warnings
    for name, mean, std in [(f"y{j}", result.output_mean[j], result.output_std[j]) for j in range(m)] + \
            [(f"u{i}", result.input_mean[i], result.input_std[i]) for i in range(p)]:
        if abs(mean) > std:
            result.offsets.append(name)
            warn.append(f"{name} has an offset (mean {mean:.4g}, std {std:.3g}): "
                        + (remedy("offset") if remedy else "centre it (normalize=True)"))
    input_trend = max([_trend_share(u) for u in X.T], default=0.0)
    for j, v in enumerate(y.T):
        share = _trend_share(v)
        if share > 0.5 and input_trend < 0.25:
            result.drift.append(f"y{j}")
            warn.append(f"y{j} drifts (a straight line explains {100 * share:.0f} % of its variance; no input "
                        "does): detrend it or model the drift")
    result.excitation = excitation_order(X, max_order=max_order) if p else []
    for i, order in enumerate(result.excitation):
        if order < 4:
            warn.append(f"u{i} is persistently exciting of order {order} only: models with more than "
                        f"{max(order // 2, 0)} pole pair(s) cannot be told apart on this record")
    result.saturation = detect_saturation(y)
    for j, side, level, frac in result.saturation:
        warn.append(f"y{j} saturates at its {side} level {level:.6g} ({100 * frac:.1f} % of the samples)")
    if p and n > 200:
        p_value, effect = _feedback(X, y, result.input_delay + (result.input_hold == "zoh"))
        if p_value is None:
            result.feedback_note = effect
        else:
            result.feedback, result.feedback_effect = p_value, effect
            result.closed_loop = p_value < _FEEDBACK_P and effect > _FEEDBACK_EFFECT
        if result.closed_loop:
            warn.append(f"the inputs react to the output's noise (their innovations explain {100 * effect:.1f} % of "
                        f"an ARX model's residual, F test p = {p_value:.2g}): the record looks closed-loop (feedback) "
                        "or its output was filtered non-causally; open-loop fits may be biased")
    result.poles = _arx_poles(X, y, result.input_delay + (result.input_hold == "zoh")) if p else []
    result.unstable, result.integrating = _pole_findings(result.poles, dt, n * dt)
    for j in result.unstable:
        warn.append(f"y{j}: an ARX model of the record has a pole that grows within half the record (max |pole| "
                    f"{np.max(np.abs(result.poles[j])):.4f}): an open-loop unstable plant; free runs drift, so "
                    "candidates are better ranked by their k-step prediction (criterion='k_step')")
    for j in result.integrating:
        warn.append(f"y{j}: an ARX model of the record has a pole slower than half the record (an integrator or "
                    "nearly): free runs may drift, so k-step prediction may rank candidates better")
    result.bandwidth = _bandwidth(y, dt)
    with np.errstate(divide="ignore"):
        result.samples_per_period = 1.0 / (dt * result.bandwidth)
    for j, spp in enumerate(result.samples_per_period):
        if spp < _SAMPLES_PER_PERIOD[0]:
            warn.append(f"y{j} is sampled too slowly: {spp:.1f} samples per period of its 95 % bandwidth "
                        f"({result.bandwidth[j]:.4g} Hz); expected at least {_SAMPLES_PER_PERIOD[0]}")
        elif spp > _SAMPLES_PER_PERIOD[1]:
            warn.append(f"y{j} is sampled fast: {spp:.0f} samples per period of its 95 % bandwidth "
                        f"({result.bandwidth[j]:.4g} Hz); " + (remedy("fast", k=int(spp // 20)) if remedy else
                                                               f"decimating by {int(spp // 20)} keeps 20"))
    result.proposed_terms = _proposals(y, result.saturation, dt)
    for w in warn:
        logger.warning("data advice: %s", w)
    logger.info("%s", result)
    return result
