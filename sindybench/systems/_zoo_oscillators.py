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
