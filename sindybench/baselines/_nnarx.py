"""NN-ARX: the ARX lags feeding multilayer perceptrons, simulated in free run."""

import numbers

import numpy as np
from scipy.linalg import block_diag
from sklearn.neural_network import MLPRegressor
from sklearn.utils import check_random_state
from threadpoolctl import threadpool_limits

from .._validation import check_bool, check_integer, check_option
from ..io import SaveLoadMixin, register_model
from ._arx import least_squares
from ._base import LagModel
from ._lags import free_run, input_lags
from ._persist import nnarx_from_dict, nnarx_to_dict

__all__ = ["NNARX"]

_MAX_UNITS = 100_000  # units per hidden layer: far beyond any NARX model, short of an out-of-memory error
_ACTIVATIONS = {
    "identity": lambda h: h,
    "logistic": lambda h: 0.5 * (1.0 + np.tanh(0.5 * h)),
    "tanh": np.tanh,
    "relu": lambda h: np.maximum(h, 0.0),
}


def _scale(a):
    std = a.std(axis=0)
    return np.where(std > 0, std, 1.0)


def _stack_networks(networks):
    """One wide network whose output is the mean of the outputs of ``networks``.

    The first layers side by side, the hidden layers block-diagonal, the
    output layers stacked and divided by their number: one matrix product
    per layer and step of the free run, whatever the ensemble size.
    """
    k = len(networks)
    weights = [np.hstack([net.coefs_[0] for net in networks])]
    weights += [block_diag(*(net.coefs_[i] for net in networks)) for i in range(1, len(networks[0].coefs_) - 1)]
    weights.append(np.vstack([net.coefs_[-1] for net in networks]) / k)
    biases = [np.concatenate([net.intercepts_[i] for net in networks]) for i in range(len(networks[0].coefs_) - 1)]
    biases.append(np.mean([net.intercepts_[-1] for net in networks], axis=0))
    return weights, biases


class NNARX(SaveLoadMixin, LagModel):
    """Neural ARX model: ``MLPRegressor`` networks trained one step ahead, simulated free-run.

    The networks map the standardised lags ``[y[t-1], ..., y[t-na], u[t-nk], ...,
    u[t-nk-nb+1]]`` to the standardised ``y[t]`` (inputs and outputs are scaled
    by their training mean and standard deviation). Training minimises the
    one-step-ahead error; :meth:`simulate` feeds the model its own outputs.

    With ``residual=True`` (the default) the model is a linear ARX part plus the
    networks, ``y[t] = ARX(lags) + mean_j MLP_j(lags)``, like the linear term of
    the sigmoid-network nonlinearity of MATLAB's ``nlarx``: the ARX part is fitted
    first by least squares and the networks learn its one-step residual. The
    networks then only correct a model that already simulates sensibly; on
    small records this generalises better than a network that has to learn
    the whole (near-identity) one-step map, which can fit a validation block
    and still drift on new data. With ``n_estimators > 1`` several
    networks, trained from different random initialisations, are averaged at
    every step of the free run (a cheap ensemble that reduces the variance of
    the simulation from one seed to another).

    Parameters
    ----------
    na, nb : int, default=2
        Number of past outputs and of input samples.
    nk : int, default=1
        Input delay in samples.
    hidden_layer_sizes : tuple of int, default=(32,)
    activation : {"tanh", "relu", "logistic", "identity"}, default="tanh"
    solver : {"lbfgs", "adam", "sgd"}, default="lbfgs"
    alpha : float, default=0.1
        L2 penalty of the network weights (``MLPRegressor``'s default is
        1e-4). The networks fit standardised data, with ``residual=True``
        only a small residual: a strong penalty keeps them a smooth
        correction (tuned on the cascaded tanks: 0.1 to 1).
    learning_rate_init : float, default=1e-3
        Step size of "adam" and "sgd".
    max_iter : int, default=500
    tol : float, default=1e-6
    residual : bool, default=True
        Fit a linear ARX part first and train the networks on its residual;
        ``False`` gives the plain network ``y[t] = MLP(lags)``.
    n_estimators : int, default=1
        Number of networks averaged in the free run (each trained from its
        own seed; the fit time grows in proportion).
    dtype : {"float64", "float32"}, default="float64"
        Precision of the training data given to the networks. Single
        precision, as neural networks are usually trained, makes a fit two to
        four times faster; on long records (pick-and-place, Bouc-Wen) it
        reaches the same validation error, on short ones fitted for many
        iterations (the cascaded tanks) it can stop short of the double
        precision optimum. The simulation always runs in double precision.
    random_state : int, RandomState instance or None, default=None
        Seeds the weight initialisations.

    Attributes
    ----------
    estimators_ : list of MLPRegressor
        The fitted networks (on standardised data).
    mlp_ : MLPRegressor
        The first network, ``estimators_[0]``.
    linear_coef_ : ndarray of shape (na * n_outputs + nb * n_inputs, n_outputs)
        Coefficients of the linear part on the standardised lags (zeros
        with ``residual=False``).
    linear_intercept_ : ndarray of shape (n_outputs,)
    n_iter_ : int
        Most training iterations run by a network.
    n_lags_ : int
        Samples taken from ``y_init`` to start a simulation.
    n_features_in_ : int
    n_outputs_ : int
    u_mean_, u_scale_, y_mean_, y_scale_ : ndarray
        Standardisation of the inputs and outputs.

    See Also
    --------
    ARX : the linear model on the same lags.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, (400, 1))
    >>> y = np.zeros((400, 1))
    >>> for t in range(1, 400):
    ...     y[t] = 0.7 * y[t - 1] + np.tanh(2 * u[t - 1])
    >>> model = NNARX(na=1, nb=1, hidden_layer_sizes=(8,), random_state=0).fit(u, y)
    >>> model.score(u, y) > 0.95
    True
    >>> ensemble = NNARX(na=1, nb=1, hidden_layer_sizes=(8,), n_estimators=3, random_state=0).fit(u, y)
    >>> len(ensemble.estimators_), ensemble.score(u, y) > 0.95
    (3, True)
    """

    def __init__(
        self,
        *,
        na=2,
        nb=2,
        nk=1,
        hidden_layer_sizes=(32,),
        activation="tanh",
        solver="lbfgs",
        alpha=0.1,
        learning_rate_init=1e-3,
        max_iter=500,
        tol=1e-6,
        residual=True,
        n_estimators=1,
        dtype="float64",
        random_state=None,
    ):
        self.na = na
        self.nb = nb
        self.nk = nk
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.solver = solver
        self.alpha = alpha
        self.learning_rate_init = learning_rate_init
        self.max_iter = max_iter
        self.tol = tol
        self.residual = residual
        self.n_estimators = n_estimators
        self.dtype = dtype
        self.random_state = random_state

    def _check_settings(self):
        """Check the settings; return the hidden layer sizes as a tuple."""
        sizes = self.hidden_layer_sizes
        if isinstance(sizes, numbers.Integral) and not isinstance(sizes, bool):
            sizes = (sizes,)
        try:
            sizes = tuple(sizes)
        except TypeError:
            sizes = None
        if not sizes or not all(isinstance(k, numbers.Integral) and not isinstance(k, bool) and 1 <= k <= _MAX_UNITS
                                for k in sizes):
            raise ValueError(
                f"hidden_layer_sizes = {self.hidden_layer_sizes!r}; expected a non-empty tuple of integers in "
                f"[1, {_MAX_UNITS}] (one size per hidden layer; for a model without hidden layer use ARX)."
            )
        check_option(self.activation, "activation", sorted(_ACTIVATIONS))
        check_bool(self.residual, "residual")
        check_integer(self.n_estimators, "n_estimators")
        check_option(self.dtype, "dtype", ["float32", "float64"])
        return sizes

    def fit(self, X, y):
        """Train the networks on the one-step-ahead regressors.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
            Inputs.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.

        Returns
        -------
        self
        """
        self._check_settings()
        phi, target = self._fit_lags(X, y)
        u = np.asarray(X, dtype=float)
        self.u_mean_, self.u_scale_ = u.mean(axis=0), _scale(u)
        self.y_scale_ = _scale(target)
        # the lag columns repeat the output and input channels: scale them alike
        shift = np.concatenate([np.tile(self.y_mean_, int(self.na)), np.tile(self.u_mean_, int(self.nb))])
        scale = np.concatenate([np.tile(self.y_scale_, int(self.na)), np.tile(self.u_scale_, int(self.nb))])
        features = (phi - shift) / scale
        z = (target - self.y_mean_) / self.y_scale_
        if self.residual:
            self.linear_coef_, self.linear_intercept_, z = least_squares(features, z)
        else:
            self.linear_coef_ = np.zeros((features.shape[1], z.shape[1]))
            self.linear_intercept_ = np.zeros(z.shape[1])
        try:
            rng = check_random_state(self.random_state)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"random_state = {self.random_state!r}: {exc}; expected None, an integer in "
                             "[0, 2**32 - 1] or a numpy RandomState.") from exc
        seeds = rng.randint(np.iinfo(np.int32).max, size=int(self.n_estimators))
        # one BLAS thread: the products are (n_samples x a few dozen), where threads only add overhead (tens of
        # times slower on a busy machine), and a thread count would change the rounding, hence the networks
        features, z = features.astype(self.dtype), z.astype(self.dtype)
        with threadpool_limits(limits=1, user_api="blas"):
            self.estimators_ = [self._network(seed).fit(features, z if z.shape[1] > 1 else z[:, 0]) for seed in seeds]
        self.mlp_ = self.estimators_[0]
        self.n_iter_ = max(net.n_iter_ for net in self.estimators_)
        return self

    def _network(self, seed):
        """One unfitted network with this model's settings (also rebuilt by a loaded model)."""
        return MLPRegressor(
            hidden_layer_sizes=self.hidden_layer_sizes,
            activation=self.activation,
            solver=self.solver,
            alpha=self.alpha,
            learning_rate_init=self.learning_rate_init,
            max_iter=self.max_iter,
            tol=self.tol,
            random_state=int(seed),
        )

    def _one_step(self, phi):
        na, nb = int(self.na), int(self.nb)
        shift = np.concatenate([np.tile(self.y_mean_, na), np.tile(self.u_mean_, nb)])
        scale = np.concatenate([np.tile(self.y_scale_, na), np.tile(self.u_scale_, nb)])
        features = (phi - shift) / scale
        z = np.mean([net.predict(features).reshape(len(phi), -1) for net in self.estimators_], axis=0)
        z = z + features @ self.linear_coef_ + self.linear_intercept_
        return z * self.y_scale_ + self.y_mean_

    def _simulate(self, u, y_start):
        na, nb, nk = int(self.na), int(self.nb), int(self.nk)
        n_y = na * self.n_outputs_
        weights, biases = _stack_networks(self.estimators_)
        act = _ACTIVATIONS[self.activation]
        # the inputs' share of the first layer and of the linear part is known in advance
        inputs = input_lags((u - self.u_mean_) / self.u_scale_, nb, nk, y_start.shape[0])
        drive = inputs @ weights[0][n_y:] + biases[0]
        linear = inputs @ self.linear_coef_[n_y:] + self.linear_intercept_ + biases[-1]
        w_past, lin_past = weights[0][:n_y], self.linear_coef_[:n_y]

        def step(past, i):
            h = act(drive[i] + past @ w_past)
            for w, b in zip(weights[1:-1], biases[1:-1]):
                h = act(h @ w + b)
            return h @ weights[-1] + linear[i] + past @ lin_past

        z = free_run(step, u, (y_start - self.y_mean_) / self.y_scale_, na, nb, nk)
        return z * self.y_scale_ + self.y_mean_


register_model(NNARX, to_dict=nnarx_to_dict, from_dict=nnarx_from_dict)
