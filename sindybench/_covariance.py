"""Covariance of refined parameters from the Jacobian at the simulation-error optimum.

Public as :func:`sindybench.uncertainty.parameter_covariance` and
:class:`sindybench.uncertainty.ParameterCovariance`. The module sits at the
bottom of the package (numpy and scipy only) because the refinement's record
(:class:`~sindybench.refine.RefinementResult`) computes the covariance that
a fit stores in its model file, and ``refine`` is below ``uncertainty``.

The refinement minimizes ``sum(r**2)`` with ``r = (y_sim(p) - y) / std(y) /
sqrt(m)`` (``m`` output samples times outputs). Near the optimum ``p*`` the
simulation is linear in ``p`` (``y_sim(p) ~ y_sim(p*) + J (p - p*)``), so the
least-squares estimate has the covariance

``(J^T J)^+ J^T Sigma J (J^T J)^+``

where ``Sigma`` is the covariance of the residuals. Two estimates of ``Sigma``:

``"white"``
    independent residuals, one variance per output, estimated from the residual
    sum of squares with ``m - p`` degrees of freedom (one output: the
    textbook ``s^2 (J^T J)^{-1}``, ``s^2 = SSE / (m - p)``);
``"hac"``
    a heteroskedasticity and autocorrelation consistent (Newey-West, Bartlett
    weights) estimate of the sum of the score contributions ``J_t^T r_t``
    over ``lags`` lags: residuals that are correlated in time (colored
    noise, a model error that drifts slowly) widen the intervals instead of
    making them falsely narrow.

``(J^T J)^+`` is a pseudo-inverse (singular values below ``rcond`` times the
largest are dropped): a rank-deficient Jacobian (two collinear terms, a
parameter the output does not see) gives a covariance whose ``rank`` is below
the number of parameters, and ``rank_deficient`` says so; the variance of the
unidentifiable directions is then not estimated (it is infinite), so those
standard errors are too small and must not be read as precise.
"""

from typing import NamedTuple

import numpy as np
from scipy import stats

__all__ = ["ParameterCovariance", "check_refinement_record", "parameter_covariance", "parameter_names"]


class ParameterCovariance(NamedTuple):
    """Covariance of the free parameters of a refinement.

    Attributes
    ----------
    parameters : tuple
        One entry per parameter: ``("physical", name)``, ``("coef", term,
        state)`` (an entry of the coefficient matrix ``C[term, state]``) or
        ``("x0", state)`` (the initial state).
    values : ndarray of shape (n_parameters,)
    matrix : ndarray of shape (n_parameters, n_parameters)
    kind : {"white", "hac"}
    dof : int
        Degrees of freedom of the residual variance (output samples minus
        the rank of the Jacobian).
    rank : int
        Numerical rank of the Jacobian.
    sigma : ndarray of shape (n_outputs,)
        Residual standard deviation of each output, in the residuals' units
        (a refinement's: output / its spread / sqrt(n_samples * n_outputs)).
    at_bound : ndarray of bool of shape (n_parameters,)
        Parameters that ended on a bound of the refinement (their interval
        is not valid: the optimum there is not a zero of the gradient).
    """

    parameters: tuple
    values: np.ndarray
    matrix: np.ndarray
    kind: str
    dof: int
    rank: int
    sigma: np.ndarray
    at_bound: np.ndarray

    @property
    def rank_deficient(self):
        """True when the Jacobian has fewer independent columns than parameters."""
        return self.rank < len(self.parameters)

    def standard_errors(self):
        """Standard errors, one per parameter (ndarray)."""
        return np.sqrt(np.clip(np.diag(self.matrix), 0.0, None))

    def confidence_intervals(self, alpha=0.05):
        """``(lower, upper)`` arrays of the two-sided ``1 - alpha`` intervals (Student t, ``dof``)."""
        alpha = float(alpha)
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must be in (0, 1) (0.05 gives 95 % intervals); got {alpha!r}.")
        half = stats.t.ppf(1.0 - alpha / 2.0, max(self.dof, 1)) * self.standard_errors()
        return self.values - half, self.values + half

    def to_dict(self):
        """JSON-able dict (lists); :meth:`from_dict` inverts it."""
        return {"parameters": [list(p) for p in self.parameters], "values": self.values.tolist(),
                "matrix": self.matrix.tolist(), "kind": self.kind, "dof": int(self.dof), "rank": int(self.rank),
                "sigma": self.sigma.tolist(), "at_bound": self.at_bound.tolist()}

    @classmethod
    def from_dict(cls, data):
        """Rebuild from :meth:`to_dict`'s output."""
        if not isinstance(data, dict) or not isinstance(data.get("parameters"), list) \
                or not all(isinstance(p, (list, tuple)) for p in data["parameters"]):
            raise ValueError("expected a dict with a list of parameters (each a list).")
        n = len(data["parameters"])
        for name in ("dof", "rank"):
            if isinstance(data.get(name), bool) or not isinstance(data.get(name), int):
                raise ValueError(f"{name} must be an integer; got {data.get(name)!r}.")
        try:
            return cls(parameters=tuple(tuple(p) for p in data["parameters"]),
                       values=np.asarray(data["values"], dtype=float).reshape(n),
                       matrix=np.asarray(data["matrix"], dtype=float).reshape(n, n), kind=str(data["kind"]),
                       dof=int(data["dof"]), rank=int(data["rank"]), sigma=np.asarray(data["sigma"], dtype=float),
                       at_bound=np.asarray(data["at_bound"], dtype=bool).reshape(n))
        except (TypeError, ValueError, KeyError) as exc:
            raise ValueError(f"values, matrix, sigma or at_bound do not fit {n} parameters ({exc}).") from exc


def insignificant_lag(R):
    """The first lag from which every column's autocorrelation is insignificant (``< 2 / sqrt(n)``)."""
    n = R.shape[0]
    z = R - R.mean(axis=0)
    var = np.sum(z**2, axis=0)
    lag = 1
    while lag < n // 4:
        acf = np.sum(z[lag:] * z[:-lag], axis=0) / np.where(var > 0, var, 1.0)
        if np.all(np.abs(acf) < 2.0 / np.sqrt(n)):
            break
        lag += 1
    return lag


def _default_lags(R):
    """The longer of Newey-West's ``floor(4 (n / 100)^(2/9))`` and twice :func:`insignificant_lag`."""
    return int(max(np.floor(4.0 * (R.shape[0] / 100.0) ** (2.0 / 9.0)), 2 * insignificant_lag(R)))


def _block_lags(g, R, blocks, lags):
    """The lagged terms of the Newey-West sum, within each record block of the rows of ``g`` and ``R``."""
    edges = np.concatenate([[0], np.cumsum(np.asarray(blocks, dtype=int))])
    if edges[-1] != g.shape[0]:
        raise ValueError(f"blocks {list(blocks)} sum to {edges[-1]} samples; expected {g.shape[0]}.")
    parts = [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]
    if lags is None:
        lags = max(_default_lags(R[part]) for part in parts)
    lags = int(lags)
    out = np.zeros((g.shape[1], g.shape[1]))
    for part in parts:
        gb = g[part]
        for lag in range(1, min(lags, gb.shape[0] - 1) + 1):
            w = 1.0 - lag / (lags + 1.0)
            cross = gb[lag:].T @ gb[:-lag]
            out += w * (cross + cross.T)
    return out


def parameter_covariance(jac, residuals, parameters, values, *, n_outputs=1, kind="white", lags=None, rcond=1e-9,
                         at_bound=None, blocks=None):
    """Covariance of least-squares parameters from the Jacobian and residuals at the optimum.

    Parameters
    ----------
    jac : ndarray of shape (m, n_parameters)
        Jacobian of the residuals, rows ordered sample by sample
        (``n_outputs`` rows per sample).
    residuals : ndarray of shape (m,)
    parameters : sequence
        Parameter descriptions (see :class:`ParameterCovariance`).
    values : array-like of shape (n_parameters,)
    n_outputs : int, default=1
    kind : {"white", "hac"}, default="white"
        See the module's description.
    lags : int, optional
        Lags of the ``"hac"`` estimate; default the longer of Newey-West's
        ``floor(4 (n / 100)^(2/9))`` (``n`` samples) and twice the lag from
        which the residuals' autocorrelation is insignificant.
    rcond : float, default=1e-9
        Relative cut-off of the singular values of ``jac``.
    at_bound : array-like of bool, optional
    blocks : sequence of int, optional
        Samples of each record when the rows stack several records (in
        order): the ``"hac"`` estimate sums lagged products within a record
        only, and its default ``lags`` is the longest of the records'.

    Returns
    -------
    ParameterCovariance

    Examples
    --------
    A straight line ``y = a + b t`` with unit noise: the textbook covariance.

    >>> t = np.linspace(0, 1, 50)
    >>> J = np.column_stack([np.ones(50), t])
    >>> r = np.random.default_rng(0).normal(size=50)
    >>> cov = parameter_covariance(J, r, [("coef", 0, 0), ("coef", 1, 0)], [0.0, 0.0])
    >>> s2 = r @ r / 48
    >>> bool(np.allclose(cov.matrix, s2 * np.linalg.inv(J.T @ J))), cov.rank, cov.dof
    (True, 2, 48)
    """
    if kind not in ("white", "hac"):
        raise ValueError(f"kind must be 'white' or 'hac'; got {kind!r}.")
    jac = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float).reshape(-1)
    m, p = jac.shape
    if r.shape[0] != m or m % n_outputs:
        raise ValueError(f"jac has {m} rows and residuals {r.shape[0]}; expected equal, a multiple of {n_outputs}.")
    values = np.asarray(values, dtype=float).reshape(p)
    U, s, Vt = np.linalg.svd(jac, full_matrices=False)
    keep = s > rcond * (s[0] if s.size else 0.0)
    rank = int(keep.sum())
    # (J^T J)^+ J^T = V S^-1 U^T on the kept singular directions
    pinv_t = Vt[keep].T / s[keep]  # (p, rank)
    dof = max(m - rank, 1)
    n = m // n_outputs
    R = r.reshape(n, n_outputs)
    sigma2 = np.sum(R**2, axis=0) / max(n - rank / n_outputs, 1.0)
    if kind == "white":
        Uk = U[:, keep].reshape(n, n_outputs, rank)
        meat = np.einsum("o,nok,nol->kl", sigma2, Uk, Uk)
    else:
        g = (U[:, keep] * r[:, None]).reshape(n, n_outputs, rank).sum(axis=1)  # score contributions per sample
        g = g * np.sqrt(m / dof)
        meat = g.T @ g
        if blocks is None or len(blocks) == 1:
            lags = _default_lags(R) if lags is None else int(lags)
            for lag in range(1, min(lags, n - 1) + 1):
                w = 1.0 - lag / (lags + 1.0)
                cross = g[lag:].T @ g[:-lag]
                meat += w * (cross + cross.T)
        else:
            meat += _block_lags(g, R, blocks, lags)
    matrix = pinv_t @ meat @ pinv_t.T
    matrix = 0.5 * (matrix + matrix.T)
    at_bound = np.zeros(p, dtype=bool) if at_bound is None else np.asarray(at_bound, dtype=bool).reshape(p)
    return ParameterCovariance(parameters=tuple(tuple(q) for q in parameters), values=values, matrix=matrix,
                               kind=kind, dof=int(dof), rank=rank, sigma=np.sqrt(sigma2), at_bound=at_bound)


def _index(value, high, what):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < high:
        raise ValueError(f"{what} must be an integer in [0, {high - 1}]; got {value!r}.")
    return int(value)


def parameter_names(parameters, rows):
    """Readable names of covariance parameters, given the estimator's equation rows.

    Raises
    ------
    ValueError
        For an entry that names no parameter of these rows (a tampered record).
    """
    out = []
    for j, q in enumerate(parameters):
        where = f"parameters[{j}] = {list(q)!r}"
        kind = q[0] if len(q) else None
        if kind == "physical" and len(q) == 2 and isinstance(q[1], str):
            out.append(q[1])
        elif kind == "coef" and len(q) == 3:
            row = rows[_index(q[2], len(rows), f"{where}: the row")]
            if row.coef is None:
                raise ValueError(f"{where}: row {row.name!r} is fixed by a function; it has no coefficients.")
            out.append(f"{row.name}': {row.features[_index(q[1], len(row.features), f'{where}: the term')]}")
        elif kind == "x0" and len(q) in (2, 3):
            name = rows[_index(q[1], len(rows), f"{where}: the state")].name
            out.append(f"{name}(0)" if len(q) == 2 else f"{name}(0) [record {_index(q[2], 2**31, where)}]")
        elif kind == "gain" and len(q) == 3:  # prediction error: ("gain", state, output) of the observer gain K
            name = rows[_index(q[1], len(rows), f"{where}: the state")].name
            out.append(f"K[{name}, {_index(q[2], 2**31, where)}]")
        else:
            raise ValueError(f"{where}: expected ('physical', name), ('coef', term, row), ('x0', state[, record]) "
                             "or ('gain', state, output).")
    return out


def check_refinement_record(model, where="fitted.refinement"):
    """Check a loaded estimator's refinement record against the estimator (a model file's ``refinement``).

    Each covariance must name parameters this model has (by its equation
    rows), each once, with finite values, a symmetric finite matrix with a
    nonnegative diagonal (variances), ``1 <= dof`` and ``0 <= rank <= n``.
    (Its values are not compared with the model's: a refined model whose
    coefficients were edited after the fit saves and loads.)

    Raises
    ------
    ValueError
        Naming the field and what was wrong.
    """
    record = getattr(model, "refinement_", None)
    if not record or "covariance" not in record:
        return
    covariances = record["covariance"]
    if not isinstance(covariances, dict):
        raise ValueError(f"{where}.covariance: expected a dict kind -> covariance; got {type(covariances).__name__}.")
    rows = model._equation_rows()
    for kind, data in covariances.items():
        field = f"{where}.covariance.{kind}"
        try:
            cov = ParameterCovariance.from_dict(data)
            names = parameter_names(cov.parameters, rows)
        except (ValueError, TypeError, KeyError, IndexError) as exc:
            raise ValueError(f"{field}: {exc}") from exc
        n = len(names)
        problem = None
        if cov.kind != kind:
            problem = f"kind is {cov.kind!r} under the key {kind!r}"
        elif not (np.all(np.isfinite(cov.values)) and np.all(np.isfinite(cov.matrix)) and np.all(np.isfinite(cov.sigma))):
            problem = "values, matrix and sigma must be finite"
        elif np.any(np.diag(cov.matrix) < 0) or not np.allclose(cov.matrix, cov.matrix.T, rtol=1e-9, atol=0.0):
            problem = "the matrix must be symmetric with a nonnegative diagonal (variances)"
        elif cov.dof < 1 or not 0 <= cov.rank <= n or np.any(cov.sigma < 0):
            problem = f"dof = {cov.dof} (expected >= 1), rank = {cov.rank} (expected in [0, {n}]), sigma >= 0"
        elif len(set(names)) != n:
            problem = "a parameter is listed twice"
        elif any(q[0] == "physical" and q[1] not in (getattr(model, "params_", None) or {}) for q in cov.parameters):
            problem = f"a physical parameter is not one of the model's {sorted(getattr(model, 'params_', None) or {})}"
        if problem:
            raise ValueError(f"{field}: {problem}; expected the record of this model's refinement.")
