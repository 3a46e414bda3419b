"""Friction and hysteresis of the zoo: Coulomb and Stribeck friction, a Bouc-Wen hysteretic oscillator.

The sign of the velocity is smoothed, ``sign(v) ~ tanh(v / v_eps)`` with a
small ``v_eps``, so that the fixed-step integration does not chatter at
rest; the equations say so.
"""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, ode_plant

__all__ = ["SYSTEMS"]


def _coulomb(x, u):
    v = x[0]
    return np.array([u[0] - 0.5 * v - 1.0 * np.tanh(v / 0.01)])


def _stribeck(x, u):
    v = x[0]
    friction = (0.5 + 0.3 * np.exp(-((v / 0.1) ** 2))) * np.tanh(v / 0.005) + 0.3 * v
    return np.array([u[0] - friction])


def _bouc_wen(x, u):
    p, v, z = x
    return np.array([v, u[0] - 0.2 * v - p - 0.5 * z, v - 0.6 * abs(v) * z - 0.2 * v * abs(z)])


def _first(x):
    return x[:, :1]


SYSTEMS = [
    ZooSystem(
        "coulomb_friction",
        plant=ode_plant(_coulomb, [0.0], _first, n_substeps=2),
        equations=["v' = u - 0.5 v - 1.0 sign(v)   (sign(v) = tanh(v / 0.01)); y = v"],
        tags=["nonlinear", "hard_nonlinearity", "friction"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=2.0), dt=0.02, n_samples=3000, n_test=1500,
        noise=0.01, description="A mass driven by a force against viscous and Coulomb friction, velocity measured.",
    ),
    ZooSystem(
        "stribeck_friction",
        plant=ode_plant(_stribeck, [0.0], _first, n_substeps=2),
        equations=["v' = u - F(v); y = v",
                   "F(v) = (0.5 + 0.3 exp(-(v / 0.1)^2)) sign(v) + 0.3 v   (sign(v) = tanh(v / 0.005))"],
        tags=["nonlinear", "hard_nonlinearity", "friction"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=1.0), dt=0.01, n_samples=4000, n_test=2000,
        noise=0.005, description="A mass against Stribeck friction (static 0.8, Coulomb 0.5, Stribeck velocity "
                                 "0.1, viscous 0.3), velocity measured.",
    ),
    ZooSystem(
        "bouc_wen_hysteresis",
        plant=ode_plant(_bouc_wen, [0.0, 0.0, 0.0], _first),
        equations=["p'' = u - 0.2 p' - p - 0.5 z; y = p", "z' = p' - 0.6 |p'| z - 0.2 p' |z|"],
        tags=["nonlinear", "hysteresis", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=4000, n_test=2000,
        noise=0.005, description="An oscillator with a hysteretic Bouc-Wen restoring force (position measured; "
                                 "velocity and hysteretic force hidden).",
    ),
]
