"""Tanks of the zoo: square-root and power-law outflow of one measured level."""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, ode_plant

__all__ = ["SYSTEMS"]


def _sqrt_tank(x, u):
    return np.array([-0.2 * np.sqrt(max(x[0], 0.0)) + 0.1 * u[0]])


def _power_tank(x, u):
    return np.array([-0.15 * max(x[0], 0.0) ** 0.75 + 0.1 * u[0]])


def _nonnegative(x):
    return np.maximum(x, 0.0)


SYSTEMS = [
    ZooSystem(
        "single_tank",
        plant=ode_plant(_sqrt_tank, [1.0], lambda x: x, project=_nonnegative),
        equations=["y' = -0.2 sqrt(y) + 0.1 u"],
        tags=["nonlinear", "flow"],
        excitation=Excitation("steps", low=1.0, high=5.0, hold=60), dt=1.0, n_samples=2000, n_test=1000,
        noise=0.01, description="A tank with square-root (Torricelli) outflow fed by a pump; the level is measured.",
    ),
    ZooSystem(
        "tank_power_law",
        plant=ode_plant(_power_tank, [1.0], lambda x: x, project=_nonnegative),
        equations=["y' = -0.15 y^0.75 + 0.1 u"],
        tags=["nonlinear", "flow"],
        excitation=Excitation("prbs", amplitude=1.5, offset=2.5, hold=40), dt=1.0, n_samples=3000, n_test=1500,
        noise=0.005, noise_colour="coloured",
        description="A tank whose outflow grows as the level to the power 0.75, coloured noise.",
    ),
]
