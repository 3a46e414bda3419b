"""NN-ARX: the ARX lags feeding a multilayer perceptron, simulated in free run."""

import numpy as np
from sklearn.neural_network import MLPRegressor

from ._base import LagModel
from ._lags import free_run, input_lags

__all__ = ["NNARX"]

_ACTIVATIONS = {
    "identity": lambda h: h,
    "logistic": lambda h: 0.5 * (1.0 + np.tanh(0.5 * h)),
    "tanh": np.tanh,
    "relu": lambda h: np.maximum(h, 0.0),
}


def _scale(a):
    std = a.std(axis=0)
    return np.where(std > 0, std, 1.0)


class NNARX(LagModel):
    """Neural ARX model: an ``MLPRegressor`` trained one step ahead, simulated free-run.

    The network maps the standardised lags ``[y[t-1], ..., y[t-na], u[t-nk], ...,
    u[t-nk-nb+1]]`` to the standardised ``y[t]`` (inputs and outputs are scaled
    by their training mean and standard deviation). Training minimises the
    one-step-ahead error; :meth:`simulate` feeds the network its own outputs.

    Parameters
    ----------
    na, nb : int, default=2
        Number of past outputs and of input samples.
    nk : int, default=1
        Input delay in samples.
    hidden_layer_sizes : tuple of int, default=(32,)
    activation : {"tanh", "relu", "logistic", "identity"}, default="tanh"
    solver : {"lbfgs", "adam", "sgd"}, default="lbfgs"
    alpha : float, default=1e-4
        L2 penalty of the network weights.
    learning_rate_init : float, default=1e-3
        Step size of "adam" and "sgd".
    max_iter : int, default=500
    tol : float, default=1e-6
    random_state : int, RandomState instance or None, default=None
        Seeds the weight initialisation.

    Attributes
    ----------
    mlp_ : MLPRegressor
        The fitted network (on standardised data).
    n_iter_ : int
        Training iterations run.
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
        alpha=1e-4,
        learning_rate_init=1e-3,
        max_iter=500,
        tol=1e-6,
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
        self.random_state = random_state

    def fit(self, X, y):
        """Train the network on the one-step-ahead regressors.

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
        if self.activation not in _ACTIVATIONS:
            raise ValueError(f"activation must be one of {sorted(_ACTIVATIONS)}; got {self.activation!r}.")
        phi, target = self._fit_lags(X, y)
        u = np.asarray(X, dtype=float)
        self.u_mean_, self.u_scale_ = u.mean(axis=0), _scale(u)
        self.y_scale_ = _scale(target)
        # the lag columns repeat the output and input channels: scale them alike
        shift = np.concatenate([np.tile(self.y_mean_, int(self.na)), np.tile(self.u_mean_, int(self.nb))])
        scale = np.concatenate([np.tile(self.y_scale_, int(self.na)), np.tile(self.u_scale_, int(self.nb))])
        self.mlp_ = MLPRegressor(
            hidden_layer_sizes=self.hidden_layer_sizes,
            activation=self.activation,
            solver=self.solver,
            alpha=self.alpha,
            learning_rate_init=self.learning_rate_init,
            max_iter=self.max_iter,
            tol=self.tol,
            random_state=self.random_state,
        )
        z = (target - self.y_mean_) / self.y_scale_
        self.mlp_.fit((phi - shift) / scale, z if z.shape[1] > 1 else z[:, 0])
        self.n_iter_ = self.mlp_.n_iter_
        return self

    def _simulate(self, u, y_start):
        na, nb, nk = int(self.na), int(self.nb), int(self.nk)
        n_y = na * self.n_outputs_
        weights, biases = self.mlp_.coefs_, self.mlp_.intercepts_
        act = _ACTIVATIONS[self.activation]
        # the inputs' share of the first layer is known in advance
        drive = input_lags((u - self.u_mean_) / self.u_scale_, nb, nk, y_start.shape[0]) @ weights[0][n_y:]
        drive += biases[0]
        w_past = weights[0][:n_y]

        def step(past, i):
            h = act(drive[i] + past @ w_past)
            for w, b in zip(weights[1:-1], biases[1:-1]):
                h = act(h @ w + b)
            return h @ weights[-1] + biases[-1]

        z = free_run(step, u, (y_start - self.y_mean_) / self.y_scale_, na, nb, nk)
        return z * self.y_scale_ + self.y_mean_
