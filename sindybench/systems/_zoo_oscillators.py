"""Forced nonlinear oscillators and a bilinear system of the zoo (positions measured, velocities hidden)."""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, ode_plant

__all__ = ["SYSTEMS"]


def _duffing(x, u):
    return np.array([x[1], -0.2 * x[1] - x[0] - x[0] ** 3 + u[0]])


def _van_der_pol(x, u):
    return np.array([x[1], (1.0 - x[0] ** 2) * x[1] - x[0] + u[0]])


def _bilinear(x, u):
    return np.array([-0.5 * x[0] + u[0] + 0.5 * x[0] * u[0]])


def _pendulum(x, u):
    return np.array([x[1], -9.81 * np.sin(x[0]) - 0.3 * x[1] + 2.0 * u[0]])


def _chain_cubic(x, u):
    """Three unit masses in a chain (springs 2, dampers 0.5 to the wall), mass 1 on a hardening spring x1 + x1^3 to the
    wall and driven by the force u; states (x1, x1', x2, x2', x3, x3')."""
    x1, v1, x2, v2, x3, v3 = x
    return np.array([v1, -x1 - x1 ** 3 - 2.0 * (x1 - x2) - 0.5 * v1 + u[0],
                     v2, -2.0 * (x2 - x1) - 2.0 * (x2 - x3) - 0.5 * v2,
                     v3, -2.0 * (x3 - x2) - 0.5 * v3])


def _first(x):
    return x[:, :1]


SYSTEMS = [
    ZooSystem(
        "duffing",
        plant=ode_plant(_duffing, [0.0, 0.0], _first),
        equations=["y'' = -y - y^3 - 0.2 y' + u"],
        tags=["nonlinear", "oscillator", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.01, f_max=0.5, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.01, description="A forced Duffing oscillator (hardening cubic spring), position measured.",
    ),
    ZooSystem(
        "chain_cubic_spring",
        plant=ode_plant(_chain_cubic, np.zeros(6), _first),
        equations=["x1'' = -x1 - x1^3 - 2 (x1 - x2) - 0.5 x1' + u",
                   "x2'' = -2 (x2 - x1) - 2 (x2 - x3) - 0.5 x2'", "x3'' = -2 (x3 - x2) - 0.5 x3'", "y = x1"],
        tags=["nonlinear", "oscillator", "hidden_state", "lightly_damped"],
        excitation=Excitation("multisine", f_min=0.01, f_max=0.6, std=0.5), dt=0.05, n_samples=4000, n_test=2000,
        noise=0.01, description="A flexible structure with a cubic spring: three masses in a chain (six states, "
                                "three lightly damped modes), the driven, measured mass on a hardening spring.",
    ),
    ZooSystem(
        "van_der_pol",
        plant=ode_plant(_van_der_pol, [1.0, 0.0], _first),
        equations=["y'' = (1 - y^2) y' - y + u"],
        tags=["nonlinear", "oscillator", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.01, f_max=0.5, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.02, description="A forced Van der Pol oscillator (mu = 1, a limit cycle), position measured, "
                                "velocity hidden, 2 % noise.",
    ),
    ZooSystem(
        "bilinear",
        plant=ode_plant(_bilinear, [0.0], lambda x: x),
        equations=["y' = -0.5 y + u + 0.5 y u"],
        tags=["nonlinear"],
        excitation=Excitation("steps", low=-1.0, high=0.8, hold=20), dt=0.1, n_samples=2000, n_test=1000,
        noise=0.01, description="A bilinear system (the input also scales the decay rate: a heated body with "
                                "controlled ventilation).",
    ),
    ZooSystem(
        "pendulum",
        plant=ode_plant(_pendulum, [0.0, 0.0], _first),
        equations=["y'' = -9.81 sin(y) - 0.3 y' + 2.0 u"],
        tags=["nonlinear", "oscillator", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.05, f_max=0.4, std=0.8), dt=0.02, n_samples=3000, n_test=1500,
        noise=0.01, description="A forced pendulum with large swings, angle measured.",
    ),
]
