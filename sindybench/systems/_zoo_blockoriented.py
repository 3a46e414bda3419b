"""Block-oriented systems of the zoo: Wiener, Hammerstein, Wiener-Hammerstein; saturation, dead zone, backlash."""

import numpy as np

from ._zoo_base import Excitation, ZooSystem, linear_plant
from ._zoo_linear import tf_matrices

__all__ = ["SYSTEMS", "backlash", "dead_zone"]


def dead_zone(u, width):
    """``sign(u) max(|u| - width, 0)``."""
    return np.sign(u) * np.maximum(np.abs(u) - width, 0.0)


def backlash(x, width, y0=0.0):
    """The play operator: the output follows ``x`` only once ``x`` leaves ``[y - width, y + width]``.

    Examples
    --------
    >>> backlash(np.array([0.0, 0.5, 1.0, 0.8, 0.0]), 0.25).tolist()
    [0.0, 0.25, 0.75, 0.75, 0.25]
    """
    y = np.empty_like(x, dtype=float)
    last = y0
    for i, xi in enumerate(x):
        last = min(max(last, xi - width), xi + width)
        y[i] = last
    return y


def _chain(*blocks):
    """``plant(u, dt)`` of blocks applied in order; a block is a static map ``f(v)`` or a linear plant."""
    def plant(u, dt):
        v = u
        for block in blocks:
            v = block(v, dt) if getattr(block, "matrices", None) is not None else block(v)
        return v

    return plant


def _backlash_plant(servo, width):
    def plant(u, dt):
        x = servo(u, dt)
        return backlash(x[:, 0], width).reshape(-1, 1)

    return plant


SYSTEMS = [
    ZooSystem(
        "wiener",
        plant=_chain(linear_plant(*tf_matrices([4.0], [1.0, 1.2, 4.0])), np.tanh),
        equations=["x'' = -4.0 x - 1.2 x' + 4.0 u", "y = tanh(x)"],
        tags=["nonlinear", "block_oriented", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.01, description="A second-order linear block followed by a static tanh (a Wiener system).",
    ),
    ZooSystem(
        "hammerstein",
        plant=_chain(lambda u: u + 0.5 * u**2, linear_plant(*tf_matrices([1.0], [1.0, 1.0]))),
        equations=["y' = -1.0 y + u + 0.5 u^2"],
        tags=["nonlinear", "block_oriented"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=1.0), dt=0.05, n_samples=2000, n_test=1000,
        noise=0.01, description="A static polynomial of the input followed by a first-order lag (a Hammerstein "
                                "system).",
    ),
    ZooSystem(
        "wiener_hammerstein",
        plant=_chain(linear_plant(*tf_matrices([9.0], [1.0, 3.0, 9.0])), lambda x: np.tanh(1.2 * x) + 0.2 * x**2,
                     linear_plant(*tf_matrices([2.0], [1.0, 2.0]))),
        equations=["x'' = -9.0 x - 3.0 x' + 9.0 u", "y' = -2.0 y + 2.0 (tanh(1.2 x) + 0.2 x^2)"],
        tags=["nonlinear", "block_oriented", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.05, f_max=2.0, std=1.0), dt=0.02, n_samples=4000, n_test=2000,
        noise=0.005, noise_colour="coloured",
        description="A linear block, an asymmetric static nonlinearity and a second linear block "
                    "(Wiener-Hammerstein, three states), coloured noise.",
    ),
    ZooSystem(
        "actuator_saturation",
        plant=_chain(lambda u: np.clip(u, -1.0, 1.0), linear_plant(*tf_matrices([2.25], [1.0, 1.2, 2.25]))),
        equations=["y'' = -2.25 y - 1.2 y' + 2.25 sat(u)", "sat(u) = min(max(u, -1), 1)"],
        tags=["nonlinear", "hard_nonlinearity", "block_oriented", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=1.0, std=1.2), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.01, description="An actuator that saturates at +-1 in front of a second-order plant; the input "
                                "exceeds the limit a third of the time.",
    ),
    ZooSystem(
        "dead_zone",
        plant=_chain(lambda u: dead_zone(u, 0.3), linear_plant(*tf_matrices([1.25], [1.0, 1.25]))),
        equations=["y' = -1.25 y + 1.25 dz(u)", "dz(u) = sign(u) max(|u| - 0.3, 0)"],
        tags=["nonlinear", "hard_nonlinearity", "block_oriented"],
        excitation=Excitation("filtered_noise", f_max=0.5, std=1.0), dt=0.05, n_samples=2000, n_test=1000,
        noise=0.01, description="A dead zone of width 0.3 in front of a first-order lag (a valve with stiction-free "
                                "play, an amplifier's crossover).",
    ),
    ZooSystem(
        "backlash",
        plant=_backlash_plant(linear_plant(*tf_matrices([4.0], [1.0, 2.8, 4.0])), 0.1),
        equations=["x'' = -4.0 x - 2.8 x' + 4.0 u   (motor position)",
                   "y = play(x, 0.1): y stays while |x - y| < 0.1, else follows x at distance 0.1"],
        tags=["nonlinear", "hard_nonlinearity", "hysteresis", "hidden_state"],
        excitation=Excitation("multisine", f_min=0.02, f_max=0.5, std=1.0), dt=0.05, n_samples=3000, n_test=1500,
        noise=0.005, description="A servo whose load follows the motor through a gear with backlash (play 0.1).",
    ),
]
