"""Hard nonlinearities of hidden states (issue 35): overflow, saturation, friction and impacts behind a measurement.

In each system the non-smooth term acts on a state that is not measured, so
no term of the measured output can express it directly: the upper tank that
overflows, a saturating state that feeds the measured one, the velocity that
sets the sign of the friction, the position beyond a wall seen only through
the bounce.
"""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, ode_plant

__all__ = ["SYSTEMS"]

_X_MAX = 10.0


def _hidden_tanks(x, u):
    x1, x2 = max(x[0], 0.0), max(x[1], 0.0)
    q = x1**0.7
    return np.array([-0.05 * q + 0.04 * u[0], 0.03 * q - 0.08 * np.sqrt(x2)])


def _hidden_saturation(x, u):
    return np.array([-x[0] + 2.0 * u[0], -0.5 * x[1] + 0.5 * x[0]])


def _friction(x, u):
    p, v = x
    return np.array([v, u[0] - 2.0 * p - 0.2 * v - 0.6 * np.tanh(v / 0.01)])


def _impact(x, u):
    p, v = x
    contact = 1000.0 * max(p - 0.5, 0.0) ** 1.5 + (20.0 * v if p > 0.5 else 0.0)
    return np.array([v, u[0] - p - 0.1 * v - contact])


def _second(x):
    return x[:, 1:2]


def _first(x):
    return x[:, :1]


SYSTEMS = [
    ZooSystem(
        "hidden_tank_overflow",
        plant=ode_plant(_hidden_tanks, [0.0, 0.0], _second, project=lambda x: np.clip(x, 0.0, _X_MAX)),
        equations=["x' = -0.05 x^0.7 + 0.04 u,   x in [0, 10] (the hidden upper tank overflows at 10)",
                   "y' = 0.03 x^0.7 - 0.08 sqrt(y)   (the lower tank, measured)"],
        tags=["nonlinear", "hidden_state", "hard_nonlinearity", "flow"],
        excitation=Excitation("steps", low=2.0, high=8.0, hold=60), dt=2.0, n_samples=2000, n_test=1000,
        noise=0.01, description="Cascaded tanks whose upper tank is hidden, with power-law outflow, and overflows "
                                "for pump levels above about 7 (a third of the time here); the lower level is measured; step input.",
    ),
    ZooSystem(
        "hidden_saturation",
        plant=ode_plant(_hidden_saturation, [0.0, 0.0], _second, project=lambda x: np.array(
            [min(max(x[0], -1.0), 1.0), x[1]])),
        equations=["x' = -x + 2.0 u,   x in [-1, 1] (the hidden state saturates)", "y' = -0.5 y + 0.5 x"],
        tags=["nonlinear", "hidden_state", "hard_nonlinearity"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.01, description="A fast hidden state held in [-1, 1] (a current limit) feeding a measured "
                                "first-order state.",
    ),
    ZooSystem(
        "friction_hidden_velocity",
        plant=ode_plant(_friction, [0.0, 0.0], _first, n_substeps=2),
        equations=["y'' = u - 2.0 y - 0.2 y' - 0.6 sign(y')   (sign(v) = tanh(v / 0.01))"],
        tags=["nonlinear", "hidden_state", "hard_nonlinearity", "friction"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=2.0), dt=0.02, n_samples=3000, n_test=1500,
        noise=0.005, description="A mass on a spring with Coulomb friction; the position is measured, the velocity "
                                 "that sets the friction's sign is hidden.",
    ),
    ZooSystem(
        "impacts",
        plant=ode_plant(_impact, [0.0, 0.0], _first, n_substeps=10),
        equations=["y'' = u - y - 0.1 y' - F_c",
                   "F_c = 1000 max(y - 0.5, 0)^1.5 + 20 y' [y > 0.5]   (a stiff, damped wall at y = 0.5)"],
        tags=["nonlinear", "hidden_state", "hard_nonlinearity"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.02, n_samples=3000, n_test=1500,
        noise=0.005, description="A mass on a spring that hits a stiff damped wall (Hertzian contact); position "
                                 "measured, velocity hidden.",
    ),
]
