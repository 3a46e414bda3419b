"""Linear systems of the zoo: orders 1 to 8, lightly damped modes, pure dead times, a short and a long record."""

import numpy as np
from scipy.linalg import block_diag
from scipy.signal import tf2ss

from ._zoo_base import Excitation, ZooSystem, linear_plant

__all__ = ["SYSTEMS", "modal_matrices", "tf_matrices"]


def tf_matrices(num, den):
    """State-space matrices ``(A, B, C, D)`` of the transfer function ``num(s) / den(s)``."""
    return tf2ss(num, den)


def modal_matrices(omegas, zetas, residues, *, output="position", feedthrough=0.0):
    """State-space matrices of a sum of second-order modes driven by one input.

    Mode ``i``: ``q_i'' = -2 zeta_i omega_i q_i' - omega_i^2 q_i + u``; the
    output is ``sum_i r_i q_i`` (``output="position"``) or ``sum_i r_i q_i''
    + feedthrough u`` (``"acceleration"``).
    """
    blocks = [np.array([[0.0, 1.0], [-w**2, -2 * z * w]]) for w, z in zip(omegas, zetas)]
    A = block_diag(*blocks)
    B = np.tile([[0.0], [1.0]], (len(omegas), 1))
    if output == "position":
        C = np.hstack([[[r, 0.0]] for r in residues])
        return A, B, C, np.zeros((1, 1))
    C = np.hstack([[r * blk[1]] for r, blk in zip(residues, blocks)])
    return A, B, C, np.array([[feedthrough + float(np.sum(residues))]])


def _dc_gain(A, B, C, D):
    return float((D - C @ np.linalg.solve(A, B))[0, 0])


def _system(name, matrices, *, delay=0, **kwargs):
    plant = linear_plant(*matrices, delay=delay)
    truth = {"dc_gain": _dc_gain(*matrices), "poles": np.linalg.eigvals(np.asarray(matrices[0], float)),
             "delay": delay}
    return ZooSystem(name, plant=plant, truth=truth, **kwargs)


_arm = modal_matrices([20.0, 55.0, 110.0], [0.02, 0.03, 0.05], [0.6, 0.3, 0.15], output="acceleration",
                      feedthrough=0.1)
_eight = modal_matrices([1.0, 2.5, 4.0, 7.0], [0.1, 0.05, 0.05, 0.02], [1.0, 0.5, -0.3, 0.2])

SYSTEMS = [
    _system(
        "first_order", tf_matrices([0.5], [1.0, 0.5]),
        equations=["y' = -0.5 y + 0.5 u"], tags=["linear"],
        excitation=Excitation("prbs", amplitude=1.0, hold=20), dt=0.1, n_samples=2000, n_test=1000, noise=0.01,
        description="A first-order lag (time constant 2 s, unit gain) under a PRBS.",
    ),
    _system(
        "first_order_short", tf_matrices([2.0], [1.0, 1.0]),
        equations=["y' = -1.0 y + 2.0 u"], tags=["linear", "short_record"],
        excitation=Excitation("steps", low=-1.0, high=1.0, hold=15), dt=0.05, n_samples=300, n_test=300,
        noise=0.005, description="A first-order lag on a record of only 300 samples (random steps).",
    ),
    _system(
        "second_order", tf_matrices([4.0], [1.0, 0.8, 4.0]),
        equations=["y'' = -4.0 y - 0.8 y' + 4.0 u"], tags=["linear", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=2000, n_test=1000,
        noise=0.01, description="A mass-spring-damper (natural frequency 2 rad/s, damping 0.2), position measured.",
    ),
    _system(
        "second_order_long", tf_matrices([25.0], [1.0, 0.5, 25.0]),
        equations=["y'' = -25.0 y - 0.5 y' + 25.0 u"], tags=["linear", "hidden_state", "lightly_damped",
                                                              "long_record"],
        excitation=Excitation("filtered_noise", f_max=2.0, std=1.0), dt=0.02, n_samples=100_000, n_test=5000,
        noise=0.005, noise_colour="coloured",
        description="A lightly damped resonance (5 rad/s, damping 0.05) on a long record of 100,000 samples, "
                    "coloured noise.",
    ),
    _system(
        "third_order", tf_matrices([1.0], [1.0, 3.5, 3.5, 1.0]),
        equations=["y''' = -3.5 y'' - 3.5 y' - 1.0 y + 1.0 u"], tags=["linear", "hidden_state"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=1.0), dt=0.1, n_samples=2000, n_test=1000,
        noise=0.01, description="Three real poles (-0.5, -1, -2), unit gain, under low-pass noise.",
    ),
    _system(
        "fourth_order_two_modes", modal_matrices([1.0, 3.0], [0.05, 0.03], [1.0, 2.0]),
        equations=["q1'' = -1.0 q1 - 0.1 q1' + u", "q2'' = -9.0 q2 - 0.18 q2' + u", "y = q1 + 2.0 q2"],
        tags=["linear", "hidden_state", "lightly_damped"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.01, description="Two lightly damped modes (1 and 3 rad/s) in one output.",
    ),
    _system(
        "fifth_order_nonminimum_phase", tf_matrices([-24.0, 24.0], np.polymul([1.0, 6.0, 11.0, 6.0],
                                                                             [1.0, 0.4, 4.0])),
        equations=["Y(s) / U(s) = 24 (1 - s) / ((s + 1)(s + 2)(s + 3)(s^2 + 0.4 s + 4))"],
        tags=["linear", "hidden_state"],
        excitation=Excitation("prbs", amplitude=1.0, hold=10), dt=0.05, n_samples=3000, n_test=1500, noise=0.01,
        description="Five poles (three real, one lightly damped pair) and a right-half-plane zero (an inverse "
                    "response), unit gain.",
    ),
    _system(
        "flexible_arm", _arm,
        equations=["q_i'' = -2 zeta_i omega_i q_i' - omega_i^2 q_i + u, omega = (20, 55, 110) rad/s, "
                   "zeta = (0.02, 0.03, 0.05)",
                   "y = 0.1 u + 0.6 q1'' + 0.3 q2'' + 0.15 q3''"],
        tags=["linear", "hidden_state", "lightly_damped"],
        excitation=Excitation("multisine", f_min=0.5, f_max=40.0, std=1.0), dt=0.005, n_samples=1024, n_test=1024,
        noise=0.02,
        description="A flexible robot arm: torque in, acceleration out (a direct feedthrough), three lightly damped "
                    "modes (six states), 1024 samples.",
    ),
    _system(
        "eighth_order", _eight,
        equations=["q_i'' = -2 zeta_i omega_i q_i' - omega_i^2 q_i + u, omega = (1, 2.5, 4, 7) rad/s, "
                   "zeta = (0.1, 0.05, 0.05, 0.02)", "y = q1 + 0.5 q2 - 0.3 q3 + 0.2 q4"],
        tags=["linear", "hidden_state", "lightly_damped"],
        excitation=Excitation("multisine", f_min=0.01, f_max=1.5, std=1.0), dt=0.05, n_samples=4000, n_test=2000,
        noise=0.005, description="Four modes, eight states, position of a flexible structure measured.",
    ),
    _system(
        "dead_time", tf_matrices([1.0], [1.0, 1.0]), delay=10,
        equations=["y'(t) = -1.0 y(t) + 1.0 u(t - 1.0)"], tags=["linear", "dead_time"],
        excitation=Excitation("prbs", amplitude=1.0, hold=15), dt=0.1, n_samples=2000, n_test=1000, noise=0.01,
        description="A first-order lag behind a pure dead time of 10 samples (1 s).",
    ),
    _system(
        "second_order_dead_time", tf_matrices([2.25], [1.0, 0.9, 2.25]), delay=8,
        equations=["y''(t) = -2.25 y(t) - 0.9 y'(t) + 2.25 u(t - 0.4)"],
        tags=["linear", "dead_time", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=2000, n_test=1000,
        noise=0.02, noise_colour="coloured",
        description="An oscillator (1.5 rad/s, damping 0.3) behind a dead time of 8 samples, 2 % coloured noise.",
    ),
]
