"""The Bouc-Wen hysteretic benchmark system (Noel & Schoukens 2016), true model.

    m y'' + c y' + k y + z = u
    z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu)

Integration follows the benchmark: the input is interpolated (band-limited) to
``upsampling * fs``, the equations are integrated with the Newmark
average-acceleration (trapezoidal) scheme, the hysteretic force ``z`` with the
same trapezoidal rule, the implicit step being solved by Newton's method on
``(y'', z)``; the displacement is brought back to ``fs`` by FIR decimation.
"""

import logging
import numbers

import numpy as np
from numba import njit

from .._validation import check_integer, check_positive, check_signal
from ._resample import decimate_fir, upsample
from ._signals import check_rng

__all__ = ["BoucWen"]

logger = logging.getLogger(__name__)


@njit(cache=True)
def _z_rate(v, z, alpha, beta, gamma, delta, nu):
    """Return z' and its partial derivatives with respect to v and z."""
    az = abs(z)
    sv = 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
    sz = 1.0 if z > 0.0 else (-1.0 if z < 0.0 else 0.0)
    if nu == 1.0:
        rate = alpha * v - beta * (gamma * abs(v) * z + delta * v * az)
        d_v = alpha - beta * (gamma * sv * z + delta * az)
        d_z = -beta * (gamma * abs(v) + delta * v * sz)
    else:
        p = az ** (nu - 1.0)
        rate = alpha * v - beta * (gamma * abs(v) * p * z + delta * v * p * az)
        d_v = alpha - beta * (gamma * sv * p * z + delta * p * az)
        d_z = -beta * nu * p * (gamma * abs(v) + delta * v * sz)
    return rate, d_v, d_z


@njit(cache=True)
def newmark_bouc_wen(u, h, m, c, k, alpha, beta, gamma, delta, nu, x0, stride, tol, max_iter):
    """Integrate the Bouc-Wen equations on the fine grid ``u`` (step ``h``).

    Returns the displacement at every step, the states ``(y, y', z)`` every
    ``stride`` steps (starting at step 0) and the number of steps whose Newton
    iteration stopped at ``max_iter`` without meeting ``tol``.
    """
    n = u.shape[0]
    y_out = np.empty(n)
    states = np.empty(((n + stride - 1) // stride, 3))
    y, v, z = x0[0], x0[1], x0[2]
    a = (u[0] - c * v - k * y - z) / m
    k_eff = m + 0.5 * h * c + 0.25 * h * h * k
    n_fail = 0
    for i in range(n):
        if i > 0:
            zd0, _, _ = _z_rate(v, z, alpha, beta, gamma, delta, nu)
            a1 = a
            z1 = z + h * zd0
            converged = False
            for _ in range(max_iter):
                v1 = v + 0.5 * h * (a + a1)
                y1 = y + h * v + 0.25 * h * h * (a + a1)
                zd1, dzd_v, dzd_z = _z_rate(v1, z1, alpha, beta, gamma, delta, nu)
                r1 = m * a1 + c * v1 + k * y1 + z1 - u[i]
                r2 = z1 - z - 0.5 * h * (zd0 + zd1)
                j21 = -0.25 * h * h * dzd_v
                j22 = 1.0 - 0.5 * h * dzd_z
                det = k_eff * j22 - j21
                da = (r1 * j22 - r2) / det
                dz = (k_eff * r2 - j21 * r1) / det
                a1 -= da
                z1 -= dz
                # scales that stay positive when a or z cross zero within the step
                a_scale = abs(a) + abs(a1) + (abs(u[i]) + abs(z1)) / m
                z_scale = abs(z) + abs(z1) + h * abs(zd0)
                if abs(da) <= tol * a_scale and abs(dz) <= tol * z_scale:
                    converged = True
                    break
            if not converged:
                n_fail += 1
            y = y + h * v + 0.25 * h * h * (a + a1)
            v = v + 0.5 * h * (a + a1)
            a = a1
            z = z1
        y_out[i] = y
        if i % stride == 0:
            j = i // stride
            states[j, 0] = y
            states[j, 1] = v
            states[j, 2] = z
    return y_out, states, n_fail


class BoucWen:
    """Simulator of the Bouc-Wen hysteretic benchmark (true model).

    Parameters
    ----------
    m, c, k : float, default=2.0, 10.0, 5e4
        Mass (kg), viscous damping (N s/m) and linear stiffness (N/m).
    alpha, beta, gamma, delta, nu : float, default=5e4, 1e3, 0.8, -1.1, 1.0
        Bouc-Wen hysteresis parameters (``nu >= 1``).
    fs : float, default=750.0
        Sampling frequency of inputs and outputs (Hz).
    upsampling : int, default=20
        Integration steps per sample (15 kHz with the defaults).
    decimation : tuple of int, default=(2, 2, 5)
        Stages of the FIR decimation back to ``fs``; their product must equal
        ``upsampling``. ``(2, 2, 5)`` is the benchmark's documented chain and
        reproduces the official multisine test and the training record;
        ``(20,)`` (one stage) reproduces the official sine-sweep test.
    noise_std : float, default=8e-6
        Standard deviation (m) of the band-limited measurement noise added
        when ``simulate(..., noise=True)``: white at ``fs``, interpolated and
        added before the decimation filter, as in the benchmark's training
        data (after the filter its standard deviation is about 0.92 times this).
    newton_tol : float, default=1e-12
        Relative tolerance of the Newton iteration of each implicit step.
    max_newton : int, default=50
        Maximum Newton iterations per step (non-converged steps are logged).

    Examples
    --------
    >>> from sindybench.systems import multisine
    >>> u = multisine(1024, random_state=0)
    >>> y = BoucWen().simulate(u, periodic=True)
    >>> y.shape
    (1024, 1)
    """

    def __init__(
        self,
        *,
        m=2.0,
        c=10.0,
        k=5e4,
        alpha=5e4,
        beta=1e3,
        gamma=0.8,
        delta=-1.1,
        nu=1.0,
        fs=750.0,
        upsampling=20,
        decimation=(2, 2, 5),
        noise_std=8e-6,
        newton_tol=1e-12,
        max_newton=50,
    ):
        self.m = m
        self.c = c
        self.k = k
        self.alpha = alpha
        self.beta = beta
        self.gamma = gamma
        self.delta = delta
        self.nu = nu
        self.fs = fs
        self.upsampling = upsampling
        self.decimation = decimation
        self.noise_std = noise_std
        self.newton_tol = newton_tol
        self.max_newton = max_newton

    def __repr__(self):
        return f"BoucWen(m={self.m!r}, c={self.c!r}, k={self.k!r}, alpha={self.alpha!r}, beta={self.beta!r}, " \
            f"gamma={self.gamma!r}, delta={self.delta!r}, nu={self.nu!r}, fs={self.fs!r})"

    def _check_params(self):
        for name in ("m", "k", "fs", "newton_tol"):
            check_positive(getattr(self, name), name)
        for name in ("c", "alpha", "beta", "noise_std"):
            check_positive(getattr(self, name), name, strict=False)
        for name in ("gamma", "delta"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
                raise ValueError(f"{name} must be a finite number; got {value!r}.")
        nu = self.nu
        if isinstance(nu, bool) or not isinstance(nu, numbers.Real) or not (np.isfinite(nu) and nu >= 1):
            raise ValueError(f"nu must be a finite number >= 1 (the hysteresis law is not differentiable below); got {nu!r}.")
        up = check_integer(self.upsampling, "upsampling", low=1)
        check_integer(self.max_newton, "max_newton", low=1)
        try:
            stages = tuple(check_integer(r, "each decimation stage", low=1) for r in self.decimation)
        except TypeError as exc:
            raise ValueError(f"decimation must be a tuple of integer factors; got {self.decimation!r}.") from exc
        if int(np.prod(stages)) != up:
            raise ValueError(f"the decimation stages {stages} multiply to {int(np.prod(stages))}; expected upsampling = {up}.")
        return up, stages

    def _check_x0(self, x0):
        if x0 is None:
            return np.zeros(3)
        x0 = np.asarray(x0, dtype=float).ravel()
        if x0.shape != (3,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must hold 3 finite values (y, dy/dt, z); got {x0!r}.")
        return x0

    def _integrate(self, u, x0, periodic, n_periods, up):
        """Return the fine-grid displacement and the sampled states of the returned record."""
        u = check_signal(u, "u")
        if u.shape[1] != 1:
            raise ValueError(f"u has {u.shape[1]} columns; expected 1 (the force).")
        u = u[:, 0]
        x0 = self._check_x0(x0)
        if periodic:
            n_periods = check_integer(n_periods, "n_periods", low=2)
        fine = upsample(u, up, periodic=periodic)
        if periodic:
            fine = np.tile(fine, n_periods)
        h = 1.0 / (self.fs * up)
        y_fine, states, n_fail = newmark_bouc_wen(
            fine, h, float(self.m), float(self.c), float(self.k), float(self.alpha), float(self.beta),
            float(self.gamma), float(self.delta), float(self.nu), x0, up, float(self.newton_tol), int(self.max_newton),
        )
        if n_fail:
            logger.warning("Newton iteration did not converge to tol=%g in %d of %d steps", self.newton_tol, n_fail, fine.size)
        n = u.shape[0]
        return y_fine[-n * up :], states[-n:]

    def simulate(self, u, *, x0=None, periodic=False, n_periods=2, noise=False, random_state=None):
        """Simulate the displacement for a force input sampled at ``fs``.

        Parameters
        ----------
        u : array-like of shape (n_samples,) or (n_samples, 1)
            Force (N).
        x0 : array-like of shape (3,), optional
            Initial state ``(y, dy/dt, z)``; default at rest.
        periodic : bool, default=False
            ``u`` is one period of a periodic input: simulate ``n_periods``
            periods and return the last one (periodic steady state, decimated
            circularly). Otherwise simulate ``u`` once from ``x0``.
        n_periods : int, default=2
            Periods simulated when ``periodic`` (>= 2).
        noise : bool, default=False
            Add band-limited measurement noise of standard deviation ``noise_std``.
        random_state : int, RandomState, Generator or None
            Seed of the noise.

        Returns
        -------
        y : ndarray of shape (n_samples, 1)
            Displacement (m).
        """
        up, stages = self._check_params()
        y_fine, _ = self._integrate(u, x0, periodic, n_periods, up)
        if noise and self.noise_std > 0:
            rng = check_rng(random_state)
            white = rng.standard_normal(y_fine.size // up) * self.noise_std
            y_fine = y_fine + upsample(white, up, periodic=periodic)
        for r in stages:
            y_fine = decimate_fir(y_fine, r, periodic=periodic)
        return y_fine.reshape(-1, 1)

    def simulate_states(self, u, *, x0=None, periodic=False, n_periods=2):
        """Simulate the true states ``(y, dy/dt, z)`` at the sample instants (no filter, no noise).

        Parameters are those of :meth:`simulate`.

        Returns
        -------
        x : ndarray of shape (n_samples, 3)
            Displacement (m), velocity (m/s) and hysteretic force ``z`` (N).

        Examples
        --------
        >>> from sindybench.systems import low_frequency_sine
        >>> x = BoucWen().simulate_states(low_frequency_sine())
        >>> x.shape, x[0].tolist()
        ((1000, 3), [0.0, 0.0, 0.0])
        """
        up, _ = self._check_params()
        _, states = self._integrate(u, x0, periodic, n_periods, up)
        return states.copy()
