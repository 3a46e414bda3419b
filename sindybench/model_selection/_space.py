"""Declarative search spaces for :func:`~sindybench.model_selection.tune`.

A search space is a dict ``{parameter name: dimension}``, the names being
``estimator.set_params`` keys (``"optimizer__threshold"``, ``"na"``). Each
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
"""

import math
import numbers
from dataclasses import dataclass

from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution
from scipy.special import ndtr, ndtri

from .._validation import check_integer

__all__ = [
    "Categorical",
    "IntRange",
    "LogNormal",
    "LogUniform",
    "Normal",
    "Uniform",
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


class Dimension:
    """Base class of a search-space dimension: ``suggest(trial, name) -> value``."""

    def suggest(self, trial, name):
        raise NotImplementedError


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

    def __post_init__(self):
        _real(self.mean, "mean", self)
        for name in ("sigma", "n_sigma"):
            if _real(getattr(self, name), name, self) <= 0:
                raise ValueError(f"{self}: {name} must be > 0; got {getattr(self, name)!r}.")

    def _normal(self, trial, name):
        bound = float(ndtr(self.n_sigma))
        q = trial.suggest_float(f"{name}:quantile", 1.0 - bound, bound)
        return self.mean + self.sigma * float(ndtri(q))

    def suggest(self, trial, name):
        return self._normal(trial, name)


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

    def suggest(self, trial, name):
        return math.exp(self._normal(trial, name))


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


def check_search_space(search_space, estimator=None):
    """Check a search space; with ``estimator``, also check the parameter names.

    Parameters
    ----------
    search_space : dict or callable
        ``{name: Dimension or Optuna distribution}``, or a callable
        ``search_space(trial) -> dict of parameter values`` for conditional
        spaces (not checked further).
    estimator : object with ``get_params``, optional

    Examples
    --------
    >>> from sindybench.baselines import ARX
    >>> check_search_space({"na": IntRange(1, 5), "order": IntRange(1, 5)}, ARX())
    Traceback (most recent call last):
    ...
    ValueError: search_space names 'order', which ARX has not; expected names from ARX().get_params(deep=True): fit_intercept, na, nb, nk.
    """
    if callable(search_space) and not isinstance(search_space, dict):
        return search_space
    if not isinstance(search_space, dict) or not search_space:
        raise ValueError(
            f"search_space must be a non-empty dict {{name: dimension}} or a callable(trial); got {search_space!r}."
        )
    for name, dim in search_space.items():
        if not isinstance(name, str) or ":" in name:
            raise ValueError(f"search_space key {name!r} must be a parameter name (str, no ':').")
        if not isinstance(dim, (Dimension, *_OPTUNA)):
            raise ValueError(
                f"search_space[{name!r}] is {dim!r}; expected Uniform, LogUniform, IntRange, "
                "Categorical, Normal, LogNormal or optuna's FloatDistribution, IntDistribution, "
                "CategoricalDistribution."
            )
    if estimator is not None:
        valid = estimator.get_params(deep=True)
        unknown = [name for name in search_space if name not in valid]
        if unknown:
            cls = type(estimator).__name__
            raise ValueError(
                f"search_space names {', '.join(map(repr, unknown))}, which {cls} has not; expected names from "
                f"{cls}().get_params(deep=True): {', '.join(sorted(valid))}."
            )
    return search_space


def sample_params(search_space, trial):
    """Suggest every dimension of ``search_space`` on ``trial``; return ``{name: value}``.

    Works with an ``optuna.trial.FixedTrial`` too, which rebuilds the values
    of a finished trial from its ``params``.

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
