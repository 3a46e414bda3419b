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

This module holds the report (:class:`DataAdvice`, :class:`ProposedTerm`,
:func:`advice`); the checks live beside it, each group in its own module:
``_advice_signals`` (the record's magnitude, the input hold, excitation,
saturation, trend, bandwidth), ``_advice_delay`` (the input delay) and
``_advice_feedback`` (feedback and the poles of an ARX model). The public
checks stay importable from here.
"""

import logging
from dataclasses import dataclass, field

import numpy as np

from .._validation import check_integer
from ..dynamics import SIGN, SQRT, STEP
from ._advice_delay import estimate_delay, estimate_delay_details
from ._advice_feedback import arx_poles, feedback_test, pole_findings
from ._advice_signals import (MAX_MAGNITUDE, check_magnitude, check_record, detect_input_hold,  # noqa: F401
                              detect_saturation, excitation_order, noise_std, output_bandwidth, trend_share)

__all__ = ["DataAdvice", "ProposedTerm", "advice", "detect_input_hold", "detect_saturation", "estimate_delay",
           "excitation_order"]

logger = logging.getLogger(__name__)

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


def _proposals(y, saturation, dt):
    terms = []
    for j, side, level, frac in saturation:
        tol = max(1e-3 * np.ptp(y[:, j]), 3 * noise_std(y[:, j]))
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
    X, y = check_record(X, y, dt)
    max_order = check_integer(max_order, "max_order")  # also without inputs: a wrong setting is named, not ignored
    n, p, m = y.shape[0], X.shape[1], y.shape[1]
    result = DataAdvice(n_samples=n, n_inputs=p, n_outputs=m, dt=float(dt))
    result.input_holds = detect_input_hold(X)
    result.input_hold = result.input_holds[0] if p else "zoh"
    result.input_delay, result.delay_losses, result.delay_resolved = estimate_delay_details(
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
    input_trend = max([trend_share(u) for u in X.T], default=0.0)
    for j, v in enumerate(y.T):
        share = trend_share(v)
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
        p_value, effect = feedback_test(X, y, result.input_delay + (result.input_hold == "zoh"))
        if p_value is None:
            result.feedback_note = effect
        else:
            result.feedback, result.feedback_effect = p_value, effect
            result.closed_loop = p_value < _FEEDBACK_P and effect > _FEEDBACK_EFFECT
        if result.closed_loop:
            warn.append(f"the inputs react to the output's noise (their innovations explain {100 * effect:.1f} % of "
                        f"an ARX model's residual, F test p = {p_value:.2g}): the record looks closed-loop (feedback) "
                        "or its output was filtered non-causally; open-loop fits may be biased")
    result.poles = arx_poles(X, y, result.input_delay + (result.input_hold == "zoh")) if p else []
    result.unstable, result.integrating = pole_findings(result.poles, dt, n * dt)
    for j in result.unstable:
        warn.append(f"y{j}: an ARX model of the record has a pole that grows within half the record (max |pole| "
                    f"{np.max(np.abs(result.poles[j])):.4f}): an open-loop unstable plant; free runs drift, so "
                    "candidates are better ranked by their k-step prediction (criterion='k_step')")
    for j in result.integrating:
        warn.append(f"y{j}: an ARX model of the record has a pole slower than half the record (an integrator or "
                    "nearly): free runs may drift, so k-step prediction may rank candidates better")
    result.bandwidth = output_bandwidth(y, dt)
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
