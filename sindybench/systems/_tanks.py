"""Two cascaded water tanks with square-root outflow and overflow (known-truth generator).

    x1' = -k1 sqrt(x1) + k2 u
    x2' =  k3 sqrt(x1) - k4 sqrt(x2),     y = x2

Both levels are kept in ``[0, x_max]``: water above ``x_max`` overflows and is
lost (the state is clipped after every integration stage). The default
parameters were fitted by least squares (RK4, 10 substeps, y = x2, the upper
level's start free) to the estimation record of the cascaded-tanks benchmark
(volts, Ts = 4 s); the fit reaches an RMSE of about 0.53 V on that record and
0.62 V on its test record, a plausible stand-in for the real plant.
"""

import numpy as np
from numba import njit

from .._validation import check_dt, check_integer, check_positive, check_signal
from ._signals import check_rng

__all__ = ["CascadedTanks"]


@njit(cache=True)
def _tank_rates(x1, x2, u, k1, k2, k3, k4):
    s1 = np.sqrt(max(x1, 0.0))
    return -k1 * s1 + k2 * u, k3 * s1 - k4 * np.sqrt(max(x2, 0.0))


@njit(cache=True)
def _clip(x, upper):
    return min(max(x, 0.0), upper)


@njit(cache=True)
def integrate_tanks(u, dt, k1, k2, k3, k4, x_max, x0, n_substeps):
    """RK4 with the input held over each sample and the levels clipped to ``[0, x_max]``."""
    n = u.shape[0]
    out = np.empty((n, 2))
    x1, x2 = x0[0], x0[1]
    h = dt / n_substeps
    for i in range(n):
        out[i, 0] = x1
        out[i, 1] = x2
        ui = u[i]
        for _ in range(n_substeps):
            a1, a2 = _tank_rates(x1, x2, ui, k1, k2, k3, k4)
            b1, b2 = _tank_rates(_clip(x1 + 0.5 * h * a1, x_max), _clip(x2 + 0.5 * h * a2, x_max), ui, k1, k2, k3, k4)
            c1, c2 = _tank_rates(_clip(x1 + 0.5 * h * b1, x_max), _clip(x2 + 0.5 * h * b2, x_max), ui, k1, k2, k3, k4)
            d1, d2 = _tank_rates(_clip(x1 + h * c1, x_max), _clip(x2 + h * c2, x_max), ui, k1, k2, k3, k4)
            x1 = _clip(x1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1), x_max)
            x2 = _clip(x2 + h / 6.0 * (a2 + 2.0 * b2 + 2.0 * c2 + d2), x_max)
    return out


class CascadedTanks:
    """Simulator of two cascaded tanks with square-root outflow and overflow.

    Parameters
    ----------
    k1, k2, k3, k4 : float, default=0.0393, 0.0302, 0.0732, 0.0668
        Outflow coefficient of the upper tank, pump gain, inflow coefficient
        of the lower tank, outflow coefficient of the lower tank (volt units,
        per second).
    x_max : float, default=10.0
        Overflow level of both tanks (the benchmark's sensor range is 0-10 V).
    noise_std : float, default=0.02
        Standard deviation of the white output noise added when
        ``simulate(..., noise=True)``.
    n_substeps : int, default=10
        RK4 steps per sample.

    Examples
    --------
    >>> tanks = CascadedTanks()
    >>> x = tanks.simulate_states(np.full(500, 5.0), dt=4.0, x0=(0.0, 0.0))
    >>> x.shape, bool(np.all((x >= 0) & (x <= 10)))
    ((500, 2), True)
    >>> eq = tanks.equilibrium(5.0)
    >>> bool(np.allclose(x[-1], eq, rtol=1e-3))
    True
    """

    def __init__(self, *, k1=0.0393, k2=0.0302, k3=0.0732, k4=0.0668, x_max=10.0, noise_std=0.02, n_substeps=10):
        self.k1 = k1
        self.k2 = k2
        self.k3 = k3
        self.k4 = k4
        self.x_max = x_max
        self.noise_std = noise_std
        self.n_substeps = n_substeps

    def __repr__(self):
        return f"CascadedTanks(k1={self.k1!r}, k2={self.k2!r}, k3={self.k3!r}, k4={self.k4!r}, x_max={self.x_max!r})"

    def _check_params(self):
        for name in ("k1", "k2", "k3", "k4", "x_max"):
            check_positive(getattr(self, name), name)
        check_positive(self.noise_std, "noise_std", strict=False)
        check_integer(self.n_substeps, "n_substeps")

    def equilibrium(self, u):
        """Steady levels ``(x1, x2)`` for a constant input ``u`` (clipped to ``[0, x_max]``)."""
        self._check_params()
        x1 = (self.k2 * max(float(u), 0.0) / self.k1) ** 2
        x2 = (self.k3 / self.k4) ** 2 * x1
        return np.clip([x1, x2], 0.0, self.x_max)

    def simulate_states(self, u, *, dt=4.0, x0=None):
        """Simulate the levels ``(x1, x2)`` at the sample instants.

        Parameters
        ----------
        u : array-like of shape (n_samples,) or (n_samples, 1)
            Pump input (V), held constant over each sample interval.
        dt : float, default=4.0
            Sampling interval (s).
        x0 : array-like of shape (2,), optional
            Initial levels; default the equilibrium of ``u[0]``.

        Returns
        -------
        x : ndarray of shape (n_samples, 2)
        """
        self._check_params()
        dt = check_dt(dt)
        u = check_signal(u, "u")
        if u.shape[1] != 1:
            raise ValueError(f"u has {u.shape[1]} columns; expected 1 (the pump input).")
        if x0 is None:
            x0 = self.equilibrium(u[0, 0])
        x0 = np.asarray(x0, dtype=float).ravel()
        if x0.shape != (2,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must hold 2 finite levels (x1, x2); got {x0!r}.")
        x0 = np.clip(x0, 0.0, self.x_max)
        return integrate_tanks(
            u[:, 0], dt, float(self.k1), float(self.k2), float(self.k3), float(self.k4), float(self.x_max), x0,
            int(self.n_substeps),
        )

    def simulate(self, u, *, dt=4.0, x0=None, noise=False, random_state=None):
        """Simulate the measured output ``y = x2`` (plus white noise if ``noise``).

        Returns
        -------
        y : ndarray of shape (n_samples, 1)
        """
        y = self.simulate_states(u, dt=dt, x0=x0)[:, 1:2].copy()
        if noise and self.noise_std > 0:
            y += check_rng(random_state).standard_normal(y.shape) * self.noise_std
        return y
