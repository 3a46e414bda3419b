"""Integrating and open-loop unstable plants of the zoo, recorded under a stabilising controller.

The excitation is the controller's reference; the controller sees the noisy
measurement (and, as a tachometer would, the true velocity where it has a
derivative term); the record's ``u`` is the plant input it applied.
"""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, integrate_loop

__all__ = ["SYSTEMS"]

G = 9.81


def _loop(rhs, x0, *, measure, control, n_substeps=1):
    def loop(r, noise, dt):
        u, x = integrate_loop(rhs, x0, r, noise, dt, measure=measure, control=control, n_substeps=n_substeps)
        return u, np.atleast_2d(np.array([measure(xi) for xi in x])).reshape(len(x), -1)

    return loop


def _ball_and_beam(x, u):
    return np.array([x[1], 5.0 / 7.0 * G * np.sin(u[0])])


def _pendulum(x, u):
    return np.array([x[1], 4.0 * np.sin(x[0]) - 0.2 * x[1] + u[0]])


def _double_integrator(x, u):
    return np.array([x[1], (u[0] - 0.1 * x[1]) / 2.0])


def _integrator(x, u):
    return 0.5 * u


def _unstable_lag(x, u):
    return 0.5 * x + u


def _position(x):
    return x[:1]


SYSTEMS = [
    ZooSystem(
        "ball_and_beam",
        loop=_loop(_ball_and_beam, [0.0, 0.0], measure=_position,
                   control=lambda r, y, x: np.clip(0.14 * (r[0] - y[0]) - 0.2 * x[1], -0.5, 0.5)),
        equations=["p'' = (5/7) g sin(u)   (u: beam angle, p: ball position, measured)",
                   "u = clip(0.14 (r - y) - 0.2 p', -0.5, 0.5)   (the controller; r the reference)"],
        tags=["nonlinear", "integrating", "unstable", "closed_loop", "hidden_state"],
        excitation=Excitation("steps", low=-0.5, high=0.5, hold=30), dt=0.1, n_samples=1000, n_test=1000,
        noise=0.01, truth={"open_loop_poles": np.array([0.0, 0.0])},
        description="A ball rolling on a beam: a double integrator (open-loop unstable), the ball position "
                    "measured, the beam angle the recorded input, under a PD controller with a limited angle.",
    ),
    ZooSystem(
        "inverted_pendulum_pd",
        loop=_loop(_pendulum, [0.0, 0.0], measure=_position,
                   control=lambda r, y, x: 12.0 * (r[0] - y[0]) - 3.0 * x[1]),
        equations=["theta'' = 4.0 sin(theta) - 0.2 theta' + u", "u = 12 (r - y) - 3 theta'   (the controller)"],
        tags=["nonlinear", "unstable", "closed_loop", "hidden_state"],
        excitation=Excitation("filtered_noise", f_max=0.3, std=0.1), dt=0.02, n_samples=3000, n_test=1500,
        noise=0.005, truth={"open_loop_poles": np.roots([1.0, 0.2, -4.0])},
        description="An inverted pendulum (open-loop pole at +1.9 rad/s) balanced by PD feedback that tracks "
                    "small reference angles; the angle is measured.",
    ),
    ZooSystem(
        "double_integrator_cl",
        loop=_loop(_double_integrator, [0.0, 0.0], measure=_position,
                   control=lambda r, y, x: 8.0 * (r[0] - y[0]) - 4.0 * x[1]),
        equations=["p'' = 0.5 u - 0.05 p'", "u = 8 (r - y) - 4 p'   (the controller)"],
        tags=["linear", "integrating", "closed_loop", "hidden_state"],
        excitation=Excitation("steps", low=-1.0, high=1.0, hold=200), dt=0.01, n_samples=4000, n_test=2000,
        noise=0.002, truth={"open_loop_poles": np.array([0.0, -0.05])},
        description="A mass with little viscous friction (a double integrator, as a linear motor) under a PD "
                    "position controller.",
    ),
    ZooSystem(
        "integrator_p_control",
        loop=_loop(_integrator, [0.0], measure=_position, control=lambda r, y, x: 1.0 * (r[0] - y[0])),
        equations=["y' = 0.5 u", "u = r - y   (the controller)"],
        tags=["linear", "integrating", "closed_loop"],
        excitation=Excitation("steps", low=0.0, high=2.0, hold=25), dt=0.2, n_samples=1500, n_test=1000,
        noise=0.02, truth={"open_loop_poles": np.array([0.0])},
        description="A pure integrator (a level fed by a pump) under proportional control, 2 % noise in the loop.",
    ),
    ZooSystem(
        "unstable_first_order",
        loop=_loop(_unstable_lag, [0.0], measure=_position, control=lambda r, y, x: 2.0 * (r[0] - y[0])),
        equations=["y' = 0.5 y + u", "u = 2 (r - y)   (the controller)"],
        tags=["linear", "unstable", "closed_loop"],
        excitation=Excitation("prbs", amplitude=1.0, hold=40), dt=0.05, n_samples=2000, n_test=1000, noise=0.01,
        truth={"open_loop_poles": np.array([0.5])},
        description="An open-loop unstable first-order plant (pole +0.5) under proportional control.",
    ),
]
