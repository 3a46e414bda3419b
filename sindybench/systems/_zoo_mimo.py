"""Systems of the zoo with several inputs, and 2x2 systems with two measured outputs."""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, linear_plant, ode_plant

__all__ = ["SYSTEMS"]

# two masses, each driven by its own force, coupled by a spring; positions measured
_K1, _K2, _KC, _C = 1.0, 2.0, 0.5, 0.3
_A = np.array([[0.0, 1.0, 0.0, 0.0],
               [-(_K1 + _KC), -_C, _KC, 0.0],
               [0.0, 0.0, 0.0, 1.0],
               [_KC, 0.0, -(_K2 + _KC), -_C]])
_B = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
_C_OUT = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])


def _coupled_tanks(x, u):
    h1, h2 = max(x[0], 0.0), max(x[1], 0.0)
    between = 0.1 * np.sign(h1 - h2) * np.sqrt(abs(h1 - h2))
    return np.array([0.1 * u[0] - 0.15 * np.sqrt(h1) - between, 0.1 * u[1] - 0.15 * np.sqrt(h2) + between])


SYSTEMS = [
    ZooSystem(
        "two_input_first_order",
        plant=linear_plant([[-0.8]], [[1.0, -0.5]], [[1.0]]),
        equations=["y' = -0.8 y + 1.0 u0 - 0.5 u1"],
        tags=["linear", "multi_input"], n_inputs=2,
        excitation=Excitation("prbs", amplitude=1.0, hold=12), dt=0.1, n_samples=2000, n_test=1000, noise=0.01,
        description="One output driven by two independent PRBS inputs.",
        truth={"dc_gain": np.array([1.25, -0.625])},
    ),
    ZooSystem(
        "two_mass_2x2",
        plant=linear_plant(_A, _B, _C_OUT),
        equations=["y0'' = -1.5 y0 + 0.5 y1 - 0.3 y0' + u0", "y1'' = 0.5 y0 - 2.5 y1 - 0.3 y1' + u1"],
        tags=["linear", "multi_input", "multi_output", "hidden_state"], n_inputs=2, n_outputs=2,
        excitation=Excitation("filtered_noise", f_max=0.5, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.005, description="Two masses coupled by a spring, a force on each, both positions measured "
                                 "(a 2x2 system with hidden velocities).",
    ),
    ZooSystem(
        "coupled_tanks_2x2",
        plant=ode_plant(_coupled_tanks, [1.0, 1.0], lambda x: x, project=lambda x: np.maximum(x, 0.0)),
        equations=["y0' = 0.1 u0 - 0.15 sqrt(y0) - 0.1 sign(y0 - y1) sqrt(|y0 - y1|)",
                   "y1' = 0.1 u1 - 0.15 sqrt(y1) + 0.1 sign(y0 - y1) sqrt(|y0 - y1|)"],
        tags=["nonlinear", "flow", "multi_input", "multi_output"], n_inputs=2, n_outputs=2,
        excitation=Excitation("steps", low=1.0, high=5.0, hold=50), dt=1.0, n_samples=2000, n_test=1000,
        noise=0.01, description="Two tanks side by side joined by a pipe, each fed by its own pump, both levels "
                                "measured.",
    ),
]
