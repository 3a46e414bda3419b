"""Simulators of benchmark systems with known truth: Bouc-Wen hysteresis, cascaded tanks."""

from ._bouc_wen import BoucWen
from ._resample import decimate_fir, upsample
from ._signals import low_frequency_sine, multisine
from ._tanks import CascadedTanks

__all__ = [
    "BoucWen",
    "CascadedTanks",
    "decimate_fir",
    "low_frequency_sine",
    "multisine",
    "upsample",
]
