"""The shared base of the estimators that fit continuous-time dynamics (``SINDy``, ``HiddenStateSINDy``).

A subclass fits, then keeps its model as a :class:`~sindybench.dynamics.Dynamics`
in ``dynamics_`` (built by :func:`~sindybench.dynamics.assemble` in its
``_rebuild_model``, after ``fit`` and after a model file is loaded alike) and
says how to start a simulation from measured outputs (``_initial_state``) and
what its equations are (``_equation_rows``). This base does the rest, the same
way for both: ``simulate``, ``predict`` (with a warning when the simulation
diverges), ``score``, ``equations``, ``estimate_initial_state``, the checks of
``X``, ``x0`` and ``y_init``, the refinement's skip-and-warn glue and the
scikit-learn tags.
"""

import numbers
import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from ._divergence import warn_divergence
from ._equations import EquationsDisplayMixin, format_equations
from ._params import Constraint, ParameterChecksMixin, SharedDefaultsMixin
from ._preprocessing import delay_inputs
from ._residual_tests import refinement_residual_test
from ._uncertainty_methods import ModelChecksMixin, UncertaintyMixin
from ._validation import (
    check_array_like,
    check_bool,
    check_estimator_param,
    check_inputs_outputs,
    check_integer,
    check_model_inputs,
    check_option,
    check_positive,
    check_signal,
    is_records,
)
from ._records import check_one_record, check_record_lists, check_records, count_records, in_record
from .io import SaveLoadMixin
from .metrics import make_simulation_scorer
from .simulate import _HOLDS, _METHODS, SimulationError

__all__ = ["DynamicsEstimator"]


def _per_record(value, n_records, name):
    if value is None:
        return [None] * n_records
    if name == "x0" and isinstance(value, np.ndarray) and value.ndim == 2 and value.shape[0] == n_records:
        return list(value)  # (n_records, n_states), as refine_simulation_error takes it
    if not isinstance(value, list) or len(value) != n_records:
        got = f"a list of {len(value)}" if isinstance(value, list) else type(value).__name__
        shape = f" of shape {value.shape}" if isinstance(value, np.ndarray) else ""
        raise ValueError(f"with {n_records} records, {name} must be a list of {n_records} entries (one per record) "
                         f"or None; got {got}{shape}.")
    return value


def check_refinement(value, name):
    """``refine``: an :class:`~sindybench.refine.OutputErrorRefinement`, a
    :class:`~sindybench.refine.PredictionErrorRefinement` (anything with ``run``) or None."""
    if value is not None and not hasattr(value, "run"):
        raise ValueError(f"{name} must be an OutputErrorRefinement, a PredictionErrorRefinement or None; got "
                         f"{type(value).__name__}.")
    return value


SHARED_CONSTRAINTS = {
    "n_substeps": Constraint(check_integer),
    "integrator": Constraint(check_option, options=_METHODS),
    "input_hold": Constraint(check_option, options=_HOLDS),
    "max_abs": Constraint(check_positive, allow_inf=True),
    "input_delay": Constraint(check_integer, low=0),
    "normalize": Constraint(check_bool),
    "optimizer": Constraint(check_estimator_param, expected="a regressor with coef_ such as STLS()"),
    "refine": Constraint(check_refinement),
}
"""The parameters both estimators share, with their checks (``bounds`` is checked in ``fit``: it needs the
number of states)."""


def _check_score_records(X, y):
    """The lists ``X`` and ``y`` of ``score``, each record checked (named ``X[i]``, ``y[i]``); one record a list of one."""
    if not (is_records(y) or is_records(X)):
        X, y = check_inputs_outputs(X, y)
        return [X], [y]
    if not is_records(y):
        raise ValueError(f"X is a list of {len(X)} records, so y must be a list of {len(X)} output arrays (one per "
                         f"record); got {type(y).__name__}.")
    X = _per_record(X, len(y), "X")
    pairs = [check_inputs_outputs(X_i, y_i, x_name=f"X[{i}]", y_name=f"y[{i}]")
             for i, (X_i, y_i) in enumerate(zip(X, y))]
    return [X_i for X_i, _ in pairs], [y_i for _, y_i in pairs]


class DynamicsEstimator(ModelChecksMixin, UncertaintyMixin, EquationsDisplayMixin, SaveLoadMixin, SharedDefaultsMixin,
                        ParameterChecksMixin, RegressorMixin, BaseEstimator):
    """Base class: ``simulate``, ``predict``, ``score`` and ``equations`` of a fitted ``dynamics_``.

    Subclasses set ``dynamics_``, ``x0_``, ``n_features_in_`` and ``_y_1d``
    at the end of a successful ``fit`` and implement ``_initial_state(X, y_init)``
    and ``_equation_rows()``.

    The fitted attributes ``n_states_``, ``state_names_``, ``output_index_``
    and ``n_outputs_`` are read from ``dynamics_``.

    Both subclasses take the parameters of ``SHARED_CONSTRAINTS`` (checked
    by ``_validate_params`` at the start of ``fit``), among them
    ``input_delay``: ``fit``, ``simulate``, ``predict`` and
    ``estimate_initial_state`` feed the model ``X`` delayed by that many
    samples (:meth:`delayed_inputs`), so ``dynamics_`` itself is driven by
    the delayed inputs. Every function of :mod:`sindybench.estimation` and
    :mod:`sindybench.uncertainty` given the model and the user's ``X`` (the
    filter, the smoother, the k-step prediction, the noise estimate, the
    residual analysis, the bands) applies the delay itself: pass the inputs
    as measured, never ``model.delayed_inputs(X)`` (that would delay twice).
    """

    _parameter_constraints = SHARED_CONSTRAINTS
    # what sindybench.estimation asks (it imports no estimator class): a fitted model has a state-space ``dynamics_``
    _has_dynamics = True

    # ------------------------------------------------------- fitted attributes
    @property
    def n_states_(self):
        """Number of states of the fitted model."""
        return self.dynamics_.n_states

    @property
    def state_names_(self):
        """Names of the states (list of str)."""
        return list(self.dynamics_.state_names)

    @property
    def output_index_(self):
        """The states that are the measured outputs, in the column order of ``y`` (tuple of int)."""
        return self.dynamics_.output_index

    @property
    def n_outputs_(self):
        """Number of measured outputs (columns of ``y``)."""
        return len(self.dynamics_.output_index)

    # ------------------------------------------------------------------ checks
    def _check_X(self, X, n_samples=None):
        return check_model_inputs(X, self.n_features_in_, type(self).__name__, n_samples=n_samples)

    def _check_y_init(self, y_init):
        y_init = check_signal(y_init, "y_init")
        if y_init.shape[1] != self.n_outputs_:
            raise ValueError(f"y_init has {y_init.shape[1]} columns; expected {self.n_outputs_} (one per output).")
        return y_init

    def _check_x0(self, x0):
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape[0] != self.n_states_:
            raise ValueError(f"x0 has {x0.shape[0]} entries; expected {self.n_states_} (one per state).")
        return x0

    def _check_fit_records(self, X, y, *, y_kind):
        """The input check of ``fit``: ``(Xs, ys, y_1d, several)``, one record turned into a list of one.

        ``Xs`` and ``ys`` are lists of checked 2-D arrays, one per record;
        ``y_1d`` says whether every ``y`` was 1-D; ``several`` whether the user
        gave a list of records (only the messages name ``y[i]`` then, and the
        shapes the user sees are kept for one array). ``y_kind`` names the
        columns of ``y`` (``"states"`` or ``"outputs"``). Records in ``X``
        with one array ``y`` raise.
        """
        if y is None:
            expected = "the measured states" if y_kind == "states" else "the outputs"
            raise ValueError(f"{type(self).__name__} requires y to be passed, but the target y is None; expected "
                             f"{expected}.")
        if count_records(X) and not is_records(y):
            check_record_lists(X, y)  # says that y must be a list of records too
        if is_records(y):
            Xs, ys = check_records(X, y, y_kind=y_kind)
            self._check_delay(Xs)
            return Xs, ys, all(y_r.ndim == 1 for y_r in y), True
        check_array_like(X, "X")
        check_array_like(y, "y")
        y_1d = np.asarray(y).ndim == 1
        X, y = check_inputs_outputs(X, y)
        self._check_delay([X])
        return [X], [y], y_1d, False

    def _check_delay(self, Xs):
        """Refuse an ``input_delay`` as long as a training record: its delayed inputs would be one sample held."""
        delay = getattr(self, "input_delay", 0)
        if not isinstance(delay, numbers.Integral) or isinstance(delay, bool) or not Xs[0].shape[1]:
            return  # a bad value is named by the parameter check; no input, nothing delayed
        shortest = min(X_r.shape[0] for X_r in Xs)
        if delay >= shortest:
            raise ValueError(f"input_delay={delay} samples is not shorter than the training record ({shortest} "
                             "samples): the delayed inputs would hold their first sample throughout. Expected a "
                             "delay of fewer samples than the record.")

    def delayed_inputs(self, X):
        """The inputs the model sees: ``X`` delayed by ``input_delay`` samples (the first row held before it).

        What ``fit``, ``simulate`` and the estimation functions apply to the
        user's inputs; code that drives ``dynamics_`` directly (the
        :mod:`sindybench.dynamics` simulator) calls it, code that takes the
        model does not.

        Parameters
        ----------
        X : ndarray of shape (n_samples, n_inputs)
            Checked inputs of one record.

        Returns
        -------
        ndarray of shape (n_samples, n_inputs)
        """
        return delay_inputs(X, getattr(self, "input_delay", 0))

    # -------------------------------------------------------------- simulation
    def estimate_initial_state(self, X, y_init):
        """Initial state for simulating ``X``, from the first samples ``y_init`` of its output.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
            Inputs of the run to simulate (a strategy may use the first ones).
        y_init : array-like of shape (n_init, n_outputs)
            First measured output samples of that run.

        Returns
        -------
        ndarray of shape (n_states,)
        """
        check_is_fitted(self)
        self._check_one_record("estimate_initial_state", X, y_init)
        y_init = self._check_y_init(y_init)
        X = self._check_X(X, y_init.shape[0])
        return self._initial_state(self.delayed_inputs(X), y_init)

    def _check_one_record(self, method, *args):
        """Refuse lists of records in a method that takes one record."""
        check_one_record(f"{type(self).__name__}.{method}", *args,
                         advice="call it once per record, or predict, which takes lists")

    def _initial_state(self, X, y_init):
        raise NotImplementedError

    def simulate(self, X, *, y_init=None, x0=None, on_divergence="raise"):
        """Open-loop simulation of the full state, driven by the inputs ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
            Inputs (None for an autonomous model started from ``y_init``).
        y_init : array-like of shape (n_init, n_outputs), optional
            First measured output samples; the initial state is estimated
            from them (:meth:`estimate_initial_state`).
        x0 : array-like of shape (n_states,), optional
            The initial state, instead of ``y_init`` (returned as the first row).
        on_divergence : {"raise", "nan"}, default="raise"
            Raise :class:`sindybench.SimulationError`, or fill NaN from the
            diverged sample on.

        Returns
        -------
        ndarray of shape (n_samples, n_states)
        """
        return self._simulate(X, y_init, x0, on_divergence)

    def _simulate(self, X, y_init, x0, on_divergence, *, dt=None, t=None):
        check_is_fitted(self)
        self._check_one_record("simulate", X, y_init)
        if (x0 is None) == (y_init is None):
            raise ValueError("give exactly one of x0 and y_init.")
        n_samples = len(t) if t is not None else None
        if y_init is not None:
            y_init = self._check_y_init(y_init)
            if n_samples is None and X is None:  # an autonomous model: as many samples as y_init
                n_samples = y_init.shape[0]
        X = self.delayed_inputs(self._check_X(X, n_samples))
        if y_init is not None:
            x0 = self._initial_state(X, y_init)
        dt, t = self._time(X.shape[0], dt, t)
        return self.dynamics_.simulate(X, self._check_x0(x0), dt=dt, t=t, on_divergence=on_divergence)

    def _time(self, n_samples, dt, t):
        """``(dt, t)`` of a simulation of ``n_samples`` (default: the fitted ``dynamics_.dt``)."""
        return dt, t

    def predict(self, X, *, y_init=None, x0=None):
        """Simulated outputs for the inputs ``X``; NaN after a divergence, with a warning.

        The simulation starts from the state estimated from ``y_init`` (the
        first samples of the measured output, as the scorers of
        :mod:`sindybench.metrics` pass it) or from ``x0``; without either from
        the first training state ``x0_``, with a warning (right only when
        ``X`` starts where the training data started).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), None, or list of ndarray
            A list of input arrays predicts several records (``y_init`` or
            ``x0`` then a list too, one entry per record) and returns a list.
        y_init : array-like of shape (n_init, n_outputs), or list, optional
        x0 : array-like of shape (n_states,), or list, optional
            With several records, a list or an array of shape
            (n_records, n_states) (as ``refinement_["initial_states"]``).

        Returns
        -------
        ndarray of shape (n_samples, n_outputs), or (n_samples,) when ``fit`` got a 1-D ``y``
            A list of such arrays, one per record, when ``X`` is a list.

        Warns
        -----
        DivergenceWarning
            When the simulation diverged; the message says from which sample.
        """
        check_is_fitted(self)
        if x0 is not None and y_init is not None:
            raise ValueError("give x0 or y_init, not both.")
        several = is_records(X) or is_records(y_init) or (X is None and is_records(x0))
        if x0 is None and y_init is None:
            if several:
                raise ValueError("predict on several records needs y_init or x0, a list with one entry per record; "
                                 "x0_ is only the first training record's state.")
            warnings.warn(
                "predict without y_init or x0 starts from the first training state x0_; "
                "pass y_init (the first samples of the measured y) for new data.",
                UserWarning,
                stacklevel=2,
            )
            x0 = self.x0_
        key = "y_init" if x0 is None else "x0"
        start = y_init if x0 is None else x0
        if several:  # one record is a list of one from here on
            n_records = len(next(a for a in (X, y_init, x0) if isinstance(a, list)))
            Xs, starts = _per_record(X, n_records, "X"), _per_record(start, n_records, key)
        else:
            Xs, starts = [X], [start]
        y_pred = []
        for i, (X_i, s) in enumerate(zip(Xs, starts)):
            with in_record(i, several):
                if s is None:
                    raise ValueError(f"{key}[{i}] is None; expected the start of every record.")
                states = self.simulate(X_i, **{key: s}, on_divergence="nan")
            y_i = warn_divergence(states[:, list(self.output_index_)], type(self).__name__)
            y_pred.append(y_i[:, 0] if getattr(self, "_y_1d", False) else y_i)
        return y_pred if several else y_pred[0]

    def score(self, X, y, sample_weight=None):
        """R^2 of the open-loop simulation started from the start of ``y``.

        A diverged simulation scores ``-inf`` (ranked last by scikit-learn
        searches, as by :func:`sindybench.metrics.make_simulation_scorer`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), None, or list
        y : array-like of shape (n_samples, n_outputs), or list of ndarray
            With lists (several records), each record is simulated from its
            own start and the R^2 pools the samples of all records.
        sample_weight : None
            Not supported; must be None.

        Returns
        -------
        float
        """
        if sample_weight is not None:
            raise ValueError(f"sample_weight is not supported by {type(self).__name__}.score; expected None.")
        X, y = _check_score_records(X, y)
        # the scorer simulates each record from its own start and pools the samples (one record: a list of one)
        return make_simulation_scorer("r2")(self, X, y)

    # ----------------------------------------------------------------- display
    def equations(self, precision=3, *, latex=False, errors=False):
        r"""Readable model equations, one line per state (fixed rows included).

        Lines look like ``y0' = -4.822 y0 + 0.740 y0 u0 + 1.742 u0^2``; a
        constant term shows as its number, an all-zero row as ``0``, a row
        fixed by a Python function as ``(fixed: <strategy>)``. A model with
        latent states ends with one line per latent state saying how its scale
        is fixed (``gauge: z0: the coefficient of u0 in z0' is 1 ...``). In a
        notebook a fitted model displays them typeset (``_repr_latex_``).

        Parameters
        ----------
        precision : int, default=3
            Decimals of the coefficients; coefficients that would show fewer
            than two significant digits, or ``|c| >= 1e6``, use ``precision``
            significant digits (``%.3g``) instead.
        latex : bool, default=False
            LaTeX lines instead (``\dot{y}_0 = -2.00 \, y_0``), the terms
            written from the library's symbolic terms (``\sqrt{x_1}``, ``|v| z``).
        errors : bool, default=False
            Write each refined coefficient with its standard error,
            ``(4.822 ± 0.012)`` (needs ``refine``; see :meth:`standard_errors`).

        Returns
        -------
        list of str

        Examples
        --------
        >>> import numpy as np
        >>> from sindybench import STLS, SINDy
        >>> from sindybench.libraries import PolynomialLibrary
        >>> t = np.arange(0, 3, 0.01)
        >>> y = np.column_stack([np.exp(-2 * t), 1 + np.exp(-t)])
        >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01)
        >>> model.fit(None, y).equations(precision=2)
        ["y0' = -2.00 y0", "y1' = 1.00 - 1.00 y1"]
        >>> model.equations(precision=2, latex=True)[0]
        '\\dot{y}_0 = -2.00 \\, y_0'
        """
        lines = format_equations(self._equation_rows(), precision=precision, latex=latex,
                                 errors=self._coef_errors() if errors else None)
        notes = [f"gauge: {note}" for note in self._equation_notes()]
        delay = getattr(self, "input_delay", 0)
        if delay:
            notes.append(f"input delay: {delay} samples; u stands for u(t - {delay} dt)")
        return lines + ([rf"\text{{{note}}}" for note in notes] if latex else notes)

    def _equation_notes(self):
        """Lines that ``equations()`` adds after the rows (none by default)."""
        return []

    # -------------------------------------------------------------- refinement
    def _check_refine_records(self, n_records):
        """Refuse multiple shooting with several records at the start of ``fit`` (not after a search)."""
        n_segments = getattr(self.refine, "n_segments", 1)
        if self.refine is not None and n_records > 1 and n_segments > 1:
            raise ValueError(f"refine has n_segments={n_segments} (multiple shooting), which takes one record; got "
                             f"{n_records} records. Expected n_segments=1 with several records.")

    def _run_refinement(self, dynamics, u, y, *, x0, free=None, refine=None):
        """Refine ``dynamics`` on ``(u, y)`` with ``refine`` (default ``self.refine``); ``(result, None)`` or ``(None, record)``.

        ``free``: what is free (a :class:`~sindybench.refine.FreeParameters`;
        see :meth:`OutputErrorRefinement.run <sindybench.refine.OutputErrorRefinement.run>`).
        A model whose simulation of the training record diverges cannot be
        refined: it is kept as fitted by equation error, with a warning, and
        the record says so.
        """
        refine = refine or self.refine
        try:
            result = refine.run(dynamics, u, y, x0=x0, free=free)
        except SimulationError as exc:
            warnings.warn(f"refinement skipped, the equation-error model is kept: {exc}", UserWarning, stacklevel=4)
            return None, {"status": -1, "message": f"skipped: {exc}"}
        if result.residuals is not None:  # recorded for standard_errors to warn on (see uncertainty)
            used = [refine._head(u_r) for u_r in u]  # the samples refined (max_samples)
            result = result._replace(residual_test=refinement_residual_test(result.residuals, result.n_outputs, used))
        return result, None

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.regressor_tags.poor_score = True
        tags.input_tags.allow_nan = False
        return tags
