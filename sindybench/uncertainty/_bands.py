"""Prediction bands: the ensemble's members simulated on new inputs."""

import hashlib
import warnings
from typing import NamedTuple

import numpy as np
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from .._divergence import DivergenceWarning
from .._limits import check_memory
from .._validation import check_alpha, check_signal
from ._bootstrap import BootstrapEnsemble, circular_block_indices

__all__ = ["PredictionBand", "prediction_band"]


class PredictionBand(NamedTuple):
    """Pointwise quantiles of an ensemble's simulations.

    Attributes
    ----------
    median, lower, upper : ndarray of shape (n_samples, n_columns)
        Median and the ``alpha / 2``, ``1 - alpha / 2`` quantiles over the
        members (NaN of diverged members ignored).
    samples : ndarray of shape (n_members, n_samples, n_columns)
    names : list of str
        Column names (outputs, or every state with ``states=True``).
    outputs : list of int
        The columns that are measured outputs.
    alpha : float
    n_diverged : int
        Members whose simulation diverged.
    ensemble_key : str
        A fingerprint of the ensemble that made the band (its residuals and
        block length): :meth:`with_noise` takes that ensemble only.
    """

    median: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    samples: np.ndarray
    names: list
    outputs: list
    alpha: float
    n_diverged: int
    ensemble_key: str = ""

    def coverage(self, y):
        """Fraction of the measured ``y`` (n_samples, n_outputs) inside the band's output columns.

        Raises
        ------
        ValueError
            When ``y`` is not one finite value per sample and output (a NaN is
            neither inside nor outside the band).
        """
        n, n_out = self.median.shape[0], len(self.outputs)
        y = check_signal(y, "y")
        if y.shape != (n, n_out):
            raise ValueError(f"y has shape {y.shape}; expected ({n}, {n_out}) (one row per sample of the band, one "
                             "column per output).")
        lo, hi = self.lower[:, self.outputs], self.upper[:, self.outputs]
        return float(np.mean((y >= lo) & (y <= hi)))

    def with_noise(self, ensemble, random_state=None):
        """This band with the measurement noise added: ``prediction_band(..., noise=True)`` without simulating again.

        Parameters
        ----------
        ensemble : BootstrapEnsemble
            The fitted ensemble whose members made ``samples`` (its training residuals are resampled).
        random_state : int, RandomState or None

        Returns
        -------
        PredictionBand

        Raises
        ------
        ValueError
            When ``ensemble`` is not the ensemble that made this band.
        """
        key = _check_ensemble(ensemble)
        if key != self.ensemble_key:
            raise ValueError("ensemble is not the BootstrapEnsemble that made this band (its residuals differ); "
                             "expected the ensemble passed to prediction_band.")
        samples = self.samples.copy()
        _add_residuals(samples, ensemble, self.outputs, random_state)
        return _quantile_band(samples, self.names, self.outputs, self.alpha, key)


def _check_ensemble(ensemble):
    """The fingerprint of a fitted :class:`BootstrapEnsemble`, or a ``ValueError`` for anything else."""
    if not isinstance(ensemble, BootstrapEnsemble):
        raise ValueError(f"ensemble must be a fitted BootstrapEnsemble; got {type(ensemble).__name__} (wrap a model "
                         "in BootstrapEnsemble(model).fit(X, y) for a band).")
    check_is_fitted(ensemble)
    digest = hashlib.sha256(np.ascontiguousarray(ensemble.residuals_, dtype=float).tobytes())
    digest.update(str(ensemble.block_length_).encode())
    return digest.hexdigest()[:16]


def _run(member, X, y_init, x0, states):
    """Outputs (or all states) of one member on ``X`` from ``x0`` or ``y_init``, NaN after a divergence.

    Each member starts as its own ``simulate`` does from ``y_init`` (a hidden-state
    model estimates its hidden states, SINDy starts from ``y_init[0]``).
    """
    x = member.simulate(X, y_init=None if x0 is not None else y_init, x0=x0, on_divergence="nan")
    index = list(member.output_index_)
    names = member.state_names_
    return (x, index, names) if states else (x[:, index], list(range(len(index))), [names[i] for i in index])


def _add_residuals(samples, ensemble, outputs, random_state):
    """Add to each member's outputs a circular-block resample of the training residuals (in place)."""
    rng = check_random_state(random_state)
    e = ensemble.residuals_
    for k in range(samples.shape[0]):
        idx = circular_block_indices(samples.shape[1], ensemble.block_length_, rng, n_source=e.shape[0])
        samples[k][:, outputs] += e[idx]


def _quantile_band(samples, names, outputs, alpha, key):
    """The band of ``samples`` (n_members, n_samples, n_columns); diverged members left out of the quantiles.

    A diverged member's output lies outside every finite band, so the band of
    the others is a ``1 - alpha`` band of the ensemble only while the diverged
    share is at most ``alpha``: past that (or with fewer than two members left)
    it is refused, below it a :class:`~sindybench.DivergenceWarning` says how
    many diverged.
    """
    diverged = ~np.all(np.isfinite(samples), axis=(1, 2))
    n, n_div = samples.shape[0], int(diverged.sum())
    if n_div:
        what = (f"{n_div} of {n} ensemble members diverged on these inputs (their simulation left max_abs or became "
                "NaN)")
        if n - n_div < 2 or n_div > alpha * n:
            raise ValueError(f"{what}: a {1 - alpha:.0%} band may leave out at most {int(np.floor(alpha * n))} of "
                             f"{n} members and needs at least 2 to remain. Expected fewer diverging members: start "
                             "from other initial states (y_init / x0), use a larger alpha or check the model.")
        warnings.warn(f"{what}; the band is over the {n - n_div} others.", DivergenceWarning, stacklevel=3)
    lower, median, upper = np.quantile(samples[~diverged], [alpha / 2, 0.5, 1 - alpha / 2], axis=0)
    return PredictionBand(median=median, lower=lower, upper=upper, samples=samples, names=names, outputs=outputs,
                          alpha=alpha, n_diverged=n_div, ensemble_key=key)


def prediction_band(ensemble, X, *, y_init=None, x0=None, alpha=0.05, states=False, noise=False, random_state=None):
    """Simulate every member of a fitted ensemble on new inputs; pointwise quantiles.

    Parameters
    ----------
    ensemble : BootstrapEnsemble
        Fitted.
    X : array-like of shape (n_samples, n_inputs)
    y_init : array-like of shape (n_init, n_outputs), optional
        First measured outputs of the new record; each member estimates its
        initial state from them (its own strategy's way).
    x0 : array-like of shape (n_states,), optional
        The initial state instead (the same for every member).
    alpha : float, default=0.05
        ``1 - alpha`` bands.
    states : bool, default=False
        Bands on every state (hidden ones included), not only the outputs.
    noise : bool, default=False
        Add to each member's outputs a circular-block resample of the
        training residuals: a band for new *measurements* (model and noise),
        not only for the model's output.
    random_state : int, RandomState or None
        For ``noise``.

    Returns
    -------
    PredictionBand

    Raises
    ------
    ValueError
        When ``ensemble`` is not a fitted ``BootstrapEnsemble``, or when more
        than an ``alpha`` share of the members diverge (or fewer than two
        remain); fewer diverging members give a
        :class:`~sindybench.DivergenceWarning` naming how many.
    """
    key = _check_ensemble(ensemble)
    alpha = check_alpha(alpha, "bands")
    if (x0 is None) == (y_init is None):
        raise ValueError("give exactly one of x0 and y_init.")
    if y_init is not None:
        y_init = check_signal(y_init, "y_init")
    n_columns = ensemble.estimator_.n_states_ if states else len(ensemble.estimator_.output_index_)
    if X is not None and np.ndim(X) >= 1:
        check_memory("prediction_band: the members' simulations", (len(ensemble.members_), len(X), n_columns))
    runs = [_run(m, X, y_init, x0, states) for m in ensemble.members_]
    samples = np.array([r[0] for r in runs])
    outputs, names = runs[0][1], runs[0][2]
    if noise:
        _add_residuals(samples, ensemble, outputs, random_state)
    return _quantile_band(samples, names, outputs, alpha, key)
