"""The one search-space language of sindybench: dimension objects.

A search space is a dict ``{parameter name: dimension}``, the names being
``estimator.set_params`` keys (``"optimizer__threshold"``, ``"na"``) for
:func:`~sindybench.model_selection.tune` and ``HiddenStateSINDy(search_params=...)``,
or physical parameter names for a hidden-state strategy's ``bounds``. Each
dimension turns into one Optuna suggestion:

- :class:`Uniform`, :class:`LogUniform`: a float, uniform in the value or in its logarithm;
- :class:`IntRange`: an integer (model orders, polynomial degrees);
- :class:`Categorical`: one of a list of choices (any objects);
- :class:`Normal`, :class:`LogNormal`: a prior on a physical parameter. Optuna has no
  normal distribution, so the trial suggests the prior's *quantile* ``q``, uniform
  on ``[Phi(-n_sigma), Phi(n_sigma)]`` under the name ``"<name>:quantile"``, and the
  value is ``mean + sigma * Phi^-1(q)`` (exponentiated for the log-normal). Random
  sampling then follows the prior exactly (truncated at ``n_sigma``), and TPE models
  the quantile.

Optuna's own distributions (``optuna.distributions.FloatDistribution``,
``IntDistribution``, ``CategoricalDistribution``) are accepted too, so one
search space serves :func:`~sindybench.model_selection.tune` and
``optuna_integration.OptunaSearchCV``; each is suggested with the matching
``trial.suggest_*`` call.

The older spellings of ``search_params`` and of the strategies' ``bounds``,
``(low, high)``, ``(low, high, log)`` and a list of choices, are read by
:func:`as_dimension` (one place, with the messages), so that everything past
the constructors sees dimensions only.
"""

import math
import numbers
from dataclasses import dataclass, fields

import numpy as np

from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution
from scipy.special import ndtr, ndtri

from .._validation import check_integer
from ..io import register_model

__all__ = [
    "Categorical",
    "Dimension",
    "IntRange",
    "LogNormal",
    "LogUniform",
    "Normal",
    "Uniform",
    "as_dimension",
    "check_search_space",
    "sample_params",
]


def _real(value, name, owner):
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{owner}: {name} must be a finite number; got {value!r}.")
    return float(value)


def _check_range(owner, low, high, *, positive=False):
    if low >= high:
        raise ValueError(f"{owner}: low={low!r} >= high={high!r}; expected low < high.")
    if positive and low <= 0:
        raise ValueError(f"{owner}: low={low!r}; expected low > 0 on a log scale.")
    if not positive and not math.isfinite(high - low):  # the unit coordinate divides by the span
        raise ValueError(f"{owner}: the span high - low overflows a float; expected a range narrower than "
                         f"{np.finfo(float).max:.3g}.")
    _check_resolved(owner, low, high)


def _check_resolved(owner, low, high):
    """A range a float resolves: wider than ``RESOLUTION`` of its magnitude (else its unit coordinate is rounding)."""
    if not high - low > max(RESOLUTION * max(abs(low), abs(high)), np.finfo(float).tiny / RESOLUTION):
        raise ValueError(f"{owner}: the range [{low!r}, {high!r}] is narrower than floating point resolves "
                         f"(relative width {RESOLUTION:g}); expected a wider range, or a fixed value.")


RESOLUTION = 1e-12
"""Relative width below which a range counts as a single value (a few thousand float steps; and an absolute
width of at least ``tiny / RESOLUTION``, about 2e-296, away from subnormal numbers)."""
N_SIGMA_RANGE = (1e-6, 8.0)
"""``n_sigma`` of a :class:`Normal`: below, its quantile range is not resolved; above, ``ndtr`` rounds to 1."""


class Dimension:
    """Base class of a search-space dimension: ``suggest(trial, name) -> value``.

    The real-valued dimensions (:class:`Uniform`, :class:`LogUniform`,
    :class:`Normal`, :class:`LogNormal`) also map a value to a coordinate in
    ``[0, 1]`` and back (``to_unit``, ``from_unit``: the scale on which a local
    search moves) and give their ``support()``, the ``(low, high)`` their
    values lie in. Dimensions are stored in model files by their fields.
    """

    def suggest(self, trial, name):
        raise NotImplementedError

    @classmethod
    def _get_param_names(cls):
        return [f.name for f in fields(cls)]

    def get_params(self, deep=False):
        """The fields, as a scikit-learn estimator's parameters (for model files)."""
        return {name: getattr(self, name) for name in self._get_param_names()}


@dataclass(frozen=True)
class Uniform(Dimension):
    """A float uniform in ``[low, high]``.

    Examples
    --------
    >>> Uniform(0.0, 1.0)
    Uniform(low=0.0, high=1.0)
    """

    low: float
    high: float

    def __post_init__(self):
        _check_range(self, _real(self.low, "low", self), _real(self.high, "high", self))

    def suggest(self, trial, name):
        return trial.suggest_float(name, self.low, self.high)

    def support(self):
        return self.low, self.high

    def to_unit(self, value):
        return (value - self.low) / (self.high - self.low)

    def from_unit(self, z):
        return float(min(max(self.low + z * (self.high - self.low), self.low), self.high))


@dataclass(frozen=True)
class LogUniform(Dimension):
    """A float whose logarithm is uniform in ``[log(low), log(high)]`` (thresholds, penalties).

    Examples
    --------
    >>> LogUniform(0.0, 1.0)
    Traceback (most recent call last):
    ...
    ValueError: LogUniform(low=0.0, high=1.0): low=0.0; expected low > 0 on a log scale.
    """

    low: float
    high: float

    def __post_init__(self):
        _check_range(self, _real(self.low, "low", self), _real(self.high, "high", self), positive=True)

    def suggest(self, trial, name):
        return trial.suggest_float(name, self.low, self.high, log=True)

    def support(self):
        return self.low, self.high

    def to_unit(self, value):
        return (np.log(value) - np.log(self.low)) / (np.log(self.high) - np.log(self.low))

    def from_unit(self, z):
        with np.errstate(over="ignore"):  # z far past 1: clipped to high below
            v = np.exp(np.log(self.low) + z * (np.log(self.high) - np.log(self.low)))
        return float(min(max(v, self.low), self.high))


@dataclass(frozen=True)
class IntRange(Dimension):
    """An integer in ``[low, high]`` (both included), optionally on a log scale.

    Examples
    --------
    >>> IntRange(1, 10)
    IntRange(low=1, high=10, step=1, log=False)
    """

    low: int
    high: int
    step: int = 1
    log: bool = False

    def __post_init__(self):
        for name in ("low", "high", "step"):
            check_integer(getattr(self, name), f"{self}: {name}", low=None)
        if self.step < 1:
            raise ValueError(f"{self}: step={self.step}; expected step >= 1.")
        if self.log and self.step != 1:
            raise ValueError(f"{self}: a log scale needs step=1; got step={self.step}.")
        _check_range(self, self.low, self.high, positive=self.log)

    def suggest(self, trial, name):
        return trial.suggest_int(name, int(self.low), int(self.high), step=int(self.step), log=self.log)


_PLAIN = (type(None), bool, int, float, str)


@dataclass(frozen=True)
class Categorical(Dimension):
    """One of ``choices``.

    Choices that are ``None``, bool, int, float or str are stored as they are;
    other objects (libraries, differentiation methods) are stored in the study
    under their ``repr``, which must then be distinct.

    Examples
    --------
    >>> Categorical(["tanh", "relu"])
    Categorical(choices=('tanh', 'relu'))
    """

    choices: tuple

    def __post_init__(self):
        if isinstance(self.choices, (str, bytes, dict)) or not hasattr(self.choices, "__iter__"):
            raise ValueError(f"Categorical: choices must be a list or tuple of choices; got {self.choices!r} (write "
                             f"[{self.choices!r}] for a single choice).")
        object.__setattr__(self, "choices", tuple(self.choices))
        if not self.choices:
            raise ValueError("Categorical: choices is empty; expected at least one choice.")
        labels = self._labels()
        if len(set(labels)) != len(labels):
            raise ValueError(f"{self}: two choices share the label; expected distinct choices (by repr).")

    def _plain(self):
        return all(isinstance(c, _PLAIN) for c in self.choices)

    def _labels(self):
        return list(self.choices) if self._plain() else [repr(c) for c in self.choices]

    def suggest(self, trial, name):
        labels = self._labels()
        return self.choices[labels.index(trial.suggest_categorical(name, labels))]


@dataclass(frozen=True)
class Normal(Dimension):
    """A normal prior ``N(mean, sigma^2)`` truncated at ``n_sigma`` standard deviations.

    Suggested through its quantile (see the module notes); the trial's Optuna
    parameter is ``"<name>:quantile"``.

    Examples
    --------
    >>> Normal(1.0, 0.1)
    Normal(mean=1.0, sigma=0.1, n_sigma=4.0)
    """

    mean: float
    sigma: float
    n_sigma: float = 4.0
    _positive = False  # the values are positive (LogNormal): not a field

    def __post_init__(self):
        _real(self.mean, "mean", self)
        for name in ("sigma", "n_sigma"):
            if _real(getattr(self, name), name, self) <= 0:
                raise ValueError(f"{self}: {name} must be > 0; got {getattr(self, name)!r}.")
        if not N_SIGMA_RANGE[0] <= self.n_sigma <= N_SIGMA_RANGE[1]:
            low, high = self._quantiles()  # ndtr rounds to 0.5 (tiny n_sigma) or to 1.0 (n_sigma past 8)
            raise ValueError(f"{self}: n_sigma={self.n_sigma!r} gives the quantile range [{low!r}, {high!r}] in "
                             f"floating point; expected n_sigma in [{N_SIGMA_RANGE[0]:g}, {N_SIGMA_RANGE[1]:g}].")
        with np.errstate(over="ignore"):
            try:
                support = self.support()
            except OverflowError:
                support = (-math.inf, math.inf)
        if not (math.isfinite(support[0]) and math.isfinite(support[1]) and support[0] < support[1]) \
                or (self._positive and not support[0] > 0):
            raise ValueError(f"{self}: its support at +-n_sigma is {support}; expected finite values with low < high"
                             f"{' and low > 0' if self._positive else ''} (another mean, sigma or n_sigma).")
        _check_resolved(self, *support)

    def _quantiles(self):
        bound = float(ndtr(self.n_sigma))
        return 1.0 - bound, bound

    def _normal(self, trial, name):
        q = trial.suggest_float(f"{name}:quantile", *self._quantiles())
        return self._value(q)

    def _value(self, q):
        """The value at the prior's quantile ``q``."""
        return self.mean + self.sigma * float(ndtri(q))

    def _z(self, value):
        return (value - self.mean) / self.sigma

    def suggest(self, trial, name):
        return self._normal(trial, name)

    def support(self):
        """``(low, high)``: the values at ``-n_sigma`` and ``+n_sigma``."""
        return tuple(self._value(q) for q in self._quantiles())

    def to_unit(self, value):
        """The value's quantile, scaled from the suggested quantile range to ``[0, 1]``."""
        low, high = self._quantiles()
        return (float(ndtr(self._z(value))) - low) / (high - low)

    def from_unit(self, z):
        low, high = self._quantiles()
        return self._value(min(max(low + z * (high - low), low), high))


@dataclass(frozen=True)
class LogNormal(Normal):
    """A log-normal prior: ``log(value) ~ N(mean, sigma^2)`` (numpy's convention).

    For a physical parameter with nominal value ``k0`` known to a factor of
    about ``exp(sigma)``, write ``LogNormal(math.log(k0), sigma)``; the median
    is ``exp(mean)``. Truncated at ``n_sigma``; suggested through its quantile
    (Optuna parameter ``"<name>:quantile"``).

    Examples
    --------
    >>> import math, optuna
    >>> prior = LogNormal(math.log(5e4), 0.5)
    >>> prior.suggest(optuna.trial.FixedTrial({"k:quantile": 0.5}), "k")
    50000.0...
    """

    _positive = True

    def _value(self, q):
        return math.exp(super()._value(q))

    def _z(self, value):
        return (math.log(value) - self.mean) / self.sigma


_OPTUNA = (FloatDistribution, IntDistribution, CategoricalDistribution)


def _suggest(dim, trial, name):
    """Suggest ``name`` on ``trial`` from a dimension or an Optuna distribution."""
    if isinstance(dim, FloatDistribution):
        return trial.suggest_float(name, dim.low, dim.high, step=dim.step, log=dim.log)
    if isinstance(dim, IntDistribution):
        return trial.suggest_int(name, dim.low, dim.high, step=dim.step, log=dim.log)
    if isinstance(dim, CategoricalDistribution):
        return trial.suggest_categorical(name, dim.choices)
    return dim.suggest(trial, name)


_REAL = (Uniform, LogUniform, Normal)  # LogNormal is a Normal
_EXPECTED = ("Uniform, LogUniform, IntRange, Categorical, Normal, LogNormal or optuna's FloatDistribution, "
             "IntDistribution, CategoricalDistribution")


def _number(v):
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def as_dimension(spec, *, name="dimension", real=False, log=None):
    """One dimension of a search space, from a dimension object or an older spelling.

    The one reader of the spellings that ``HiddenStateSINDy(search_params=...)``
    and the hidden-state strategies' ``bounds`` accepted before the dimension
    objects: ``(low, high)`` and ``(low, high, log)`` become :class:`Uniform`
    or :class:`LogUniform` (:class:`IntRange` when both ends are ``int``), a
    list becomes :class:`Categorical`. Dimension objects and Optuna's
    distributions are returned as they are.

    Parameters
    ----------
    spec : Dimension, optuna distribution, tuple or list
    name : str, default="dimension"
        Where ``spec`` was given (``"search_params['optimizer__threshold']"``),
        for messages.
    real : bool, default=False
        A physical parameter's range: ``(low, high[, log])`` is always a float
        range (also for ``int`` ends), a list is read as that tuple, and the
        dimension must be real-valued (:class:`Uniform`, :class:`LogUniform`,
        :class:`Normal` or :class:`LogNormal`).
    log : bool or None, default=None
        The scale of a ``(low, high)`` range; None takes it from the third
        entry (default linear). ``True`` or ``False`` fix it for ranges that a
        strategy always searches on one scale (a third entry is then ignored,
        as it always was).

    Returns
    -------
    Dimension or optuna distribution

    Examples
    --------
    >>> as_dimension((1e-3, 1.0, True))
    LogUniform(low=0.001, high=1.0)
    >>> as_dimension((5, 41)), as_dimension([7, 11, 15])
    (IntRange(low=5, high=41, step=1, log=False), Categorical(choices=(7, 11, 15)))
    >>> as_dimension((1, 10), real=True)
    Uniform(low=1.0, high=10.0)
    >>> as_dimension((2.0, 1.0), name="search_params['a']")
    Traceback (most recent call last):
    ...
    ValueError: search_params['a'] = (2.0, 1.0); expected low < high.
    >>> as_dimension("wide", name="bounds['k']", real=True)
    Traceback (most recent call last):
    ...
    ValueError: bounds['k'] = 'wide'; expected (low, high), (low, high, log) or Uniform, LogUniform, Normal, LogNormal.
    """
    if real:
        if isinstance(spec, _REAL):
            return spec
        expected = "(low, high), (low, high, log) or Uniform, LogUniform, Normal, LogNormal"
        if isinstance(spec, (list, np.ndarray)):
            spec = tuple(spec)
    else:
        if isinstance(spec, (Dimension, *_OPTUNA)):
            return spec
        expected = f"(low, high), (low, high, log), a list of choices or {_EXPECTED}"
        if isinstance(spec, list):
            if not spec:
                raise ValueError(f"{name} is an empty list; expected at least one choice.")
            try:
                return Categorical(spec)
            except ValueError as exc:
                raise ValueError(f"{name} = {spec!r}: {exc}") from None
    if not isinstance(spec, tuple) or len(spec) not in (2, 3):
        raise ValueError(f"{name} = {spec!r}; expected {expected}.")
    low, high = spec[0], spec[1]
    if not (_number(low) and _number(high)):
        raise ValueError(f"{name} = {spec!r}; expected numeric low and high.")
    if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
        raise ValueError(f"{name} = {spec!r}; expected low < high.")
    if log is None:
        log = bool(spec[2]) if len(spec) == 3 else False
    if log and low <= 0:
        raise ValueError(f"{name} = {spec!r} is log-scaled; expected low > 0.")
    if not real and isinstance(low, numbers.Integral) and isinstance(high, numbers.Integral):
        return IntRange(int(low), int(high), log=log)
    return LogUniform(float(low), float(high)) if log else Uniform(float(low), float(high))


def check_search_space(search_space, estimator=None, *, name="search_space", convert=False):
    """Check a search space; with ``estimator``, also check the parameter names.

    Parameters
    ----------
    search_space : dict or callable
        ``{name: Dimension or Optuna distribution}``, or a callable
        ``search_space(trial) -> dict of parameter values`` for conditional
        spaces (not checked further).
    estimator : object with ``get_params``, optional
    name : str, default="search_space"
        The argument's name, for messages.
    convert : bool, default=False
        Also read the older spellings with :func:`as_dimension` (as
        ``HiddenStateSINDy(search_params=...)`` does); without it, only
        dimensions and Optuna distributions are accepted (as in ``tune``).

    Returns
    -------
    dict or callable
        ``{name: dimension}`` (a new dict with ``convert``), or the callable.

    Examples
    --------
    >>> from sindybench.baselines import ARX
    >>> check_search_space({"na": IntRange(1, 5), "order": IntRange(1, 5)}, ARX())
    Traceback (most recent call last):
    ...
    ValueError: search_space names 'order', which ARX has not; expected names from ARX().get_params(deep=True): fit_intercept, na, nb, nk.
    >>> check_search_space({"na": (1, 5)}, convert=True)
    {'na': IntRange(low=1, high=5, step=1, log=False)}
    """
    if callable(search_space) and not isinstance(search_space, dict):
        return search_space
    if not isinstance(search_space, dict) or not search_space:
        raise ValueError(
            f"{name} must be a non-empty dict {{name: dimension}} or a callable(trial); got {search_space!r}."
        )
    for key, dim in search_space.items():
        if not isinstance(key, str) or ":" in key:
            raise ValueError(f"{name} key {key!r} must be a parameter name (str, no ':').")
        if not convert and not isinstance(dim, (Dimension, *_OPTUNA)):
            raise ValueError(f"{name}[{key!r}] is {dim!r}; expected {_EXPECTED}.")
    if convert:
        search_space = {key: as_dimension(dim, name=f"{name}[{key!r}]") for key, dim in search_space.items()}
    if estimator is not None:
        valid = estimator.get_params(deep=True)
        unknown = [key for key in search_space if key not in valid]
        if unknown:
            cls = type(estimator).__name__
            raise ValueError(
                f"{name} names {', '.join(map(repr, unknown))}, which {cls} has not; expected names from "
                f"{cls}().get_params(deep=True): {', '.join(sorted(valid))}."
            )
    return search_space


def sample_params(search_space, trial):
    """Suggest every dimension of ``search_space`` on ``trial``; return ``{name: value}``.

    Works with an ``optuna.trial.FixedTrial`` too, which rebuilds the values
    of a finished trial from its ``params``.

    Parameters
    ----------
    search_space : dict or callable
        ``{name: dimension}`` (see :func:`check_search_space`), or a callable
        ``trial -> {name: value}`` that suggests the values itself.
    trial : optuna.trial.BaseTrial

    Returns
    -------
    dict
        ``{name: value}``, in the order of ``search_space``.

    Examples
    --------
    >>> import optuna
    >>> sample_params({"na": IntRange(1, 5)}, optuna.trial.FixedTrial({"na": 3}))
    {'na': 3}
    >>> space = {"alpha": optuna.distributions.FloatDistribution(1e-3, 1.0, log=True)}
    >>> sample_params(space, optuna.trial.FixedTrial({"alpha": 0.01}))
    {'alpha': 0.01}
    """
    if callable(search_space) and not isinstance(search_space, dict):
        params = search_space(trial)
        if not isinstance(params, dict):
            raise ValueError(f"the search_space callable returned {type(params).__name__}; expected a dict.")
        return params
    return {name: _suggest(dim, trial, name) for name, dim in search_space.items()}


for _cls in (Uniform, LogUniform, IntRange, Categorical, Normal, LogNormal):  # storable in model files
    register_model(_cls)
