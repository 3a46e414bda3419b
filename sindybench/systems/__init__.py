"""Simulators of systems with known truth: the benchmarks' (Bouc-Wen hysteresis, cascaded tanks) and the zoo."""

from ._bouc_wen import BoucWen
from ._resample import decimate_fir, upsample
from ._signals import low_frequency_sine, multisine
from ._tanks import CascadedTanks
from ._zoo import ZOO, get_system, zoo_systems
from ._zoo_base import TAGS, Excitation, ZooSystem

__all__ = [
    "TAGS",
    "ZOO",
    "BoucWen",
    "CascadedTanks",
    "Excitation",
    "ZooSystem",
    "decimate_fir",
    "get_system",
    "low_frequency_sine",
    "multisine",
    "upsample",
    "zoo_systems",
]
