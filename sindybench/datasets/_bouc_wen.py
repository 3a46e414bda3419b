"""Bouc-Wen hysteretic system (Noel & Schoukens 2016)."""

import numpy as np
from scipy.io import loadmat
from sklearn.utils import Bunch

from ..systems import BoucWen, low_frequency_sine
from ._base import RemoteFile, fetch_files
from ._common import make_dataset, make_split

__all__ = ["load_bouc_wen"]

# "Hysteretic Benchmark with a Dynamic Nonlinearity" on the 4TU data repository
# (doi:10.4121/12967592): the item archive holds BoucWenFiles.zip, whose
# "BoucWenFiles/Test signals/Validation signals/" folder has the test records.
_URL = "https://data.4tu.nl/ndownloader/items/7060f9bc-8289-411e-8d32-57bef2740d32/versions/1"
_FOLDER = "BoucWenFiles/Test signals/Validation signals/"

_TESTS = {
    "uval_multisine": "3eb9abc0aef66b97beaf003fbcb45b43a4e28d7e82db5bf8abc1c931b92106ed",
    "yval_multisine": "05e462f7c508c26c8e69549e2b80ff5acea2828b399175c8bdd3fa70eb9905bc",
    "uval_sinesweep": "fefd6c08bbf3b27f13f61a15ea0dd8c63211c5924e99f6ca43760d1f25ce9ed3",
    "yval_sinesweep": "52b49f7ff62487bf75efbed95bf759b06d8bad1127a8e63bc242e119d72bc57b",
}

REMOTES = (
    # the study's training record (5 periods of a random-phase multisine with
    # measurement noise); no public download address is known for this copy.
    RemoteFile("bouc_wen/train_data.csv", None, "679d5e474405103984c31784e962142a374aec3d8a6615d4ccab8a2b6b662324"),
) + tuple(
    RemoteFile(f"bouc_wen/{key}.mat", _URL, digest, ("BoucWenFiles.zip", _FOLDER + f"{key}.mat"))
    for key, digest in _TESTS.items()
)

FS = 750.0
N_TRAIN = 40000
N_VALIDATION = 960
N_INIT = 10

DESCR = """Bouc-Wen hysteretic system (nonlinearbenchmark.org).

A mass-spring-damper with a hysteretic restoring force z (Bouc-Wen law):
    m y'' + c y' + k y + z = u,
    z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu),
m = 2, c = 10, k = 5e4, alpha = 5e4, beta = 1e3, gamma = 0.8, delta = -1.1,
nu = 1. Input u: force (N); output y: displacement (m); fs = 750 Hz.

Estimation record (``estimation``): 40960 samples, 5 periods of an
8192-sample random-phase multisine (5-150 Hz, 50 N rms) with band-limited
measurement noise. Study split: ``train`` = first 40000 samples,
``validation`` = next 960. Tests (``test``, noise-free, open loop):
``multisine`` (official, 8192 samples, periodic steady state),
``sinesweep`` (official, 153000 samples, from rest) and ``sine`` (150 N,
0.75 Hz, one period = 1000 samples from rest, generated with
:class:`sindybench.systems.BoucWen`; it shows the hysteresis loop).
``t`` counts seconds from the start of each record. ``n_init``: initial test
samples a model may use to set its state.

Reference: J.P. Noel, M. Schoukens, "Hysteretic benchmark with a dynamic
nonlinearity", Workshop on Nonlinear System Identification Benchmarks, 2016.
"""


def load_bouc_wen(*, data_home=None, download_if_missing=True):
    """Load the Bouc-Wen benchmark with the study's split and three tests.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder holding ``bouc_wen/`` (see :func:`sindybench.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Download missing files (the four official test files; the training
        record has no known public address and must be present).

    Returns
    -------
    data : Bunch
        ``train`` (40000 samples), ``validation`` (960), ``estimation`` (40960)
        and ``test``, a Bunch of named tests ``multisine`` (8192),
        ``sinesweep`` (153000) and ``sine`` (1000); each a Bunch with ``u``,
        ``y`` of shape (n, 1), ``t``, ``dt`` and ``name``. Also ``dt`` = 1/750,
        ``n_init`` = 10, ``units``, ``official_split``, ``DESCR``, ``source``.
    """
    paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    train_path, *test_paths = paths
    dt = 1.0 / FS
    record = np.loadtxt(train_path, delimiter=",", skiprows=1, ndmin=2)
    y_est, u_est = record[:, 0], record[:, 1]
    mats = {key: loadmat(p)[key].ravel() for key, p in zip(_TESTS, test_paths)}
    u_sine = low_frequency_sine(fs=FS)
    y_sine = BoucWen(fs=FS).simulate(u_sine)
    tests = Bunch(
        multisine=make_split(mats["uval_multisine"], mats["yval_multisine"], dt, name="multisine"),
        sinesweep=make_split(mats["uval_sinesweep"], mats["yval_sinesweep"], dt, name="sinesweep"),
        sine=make_split(u_sine, y_sine, dt, name="sine"),
    )
    end_val = N_TRAIN + N_VALIDATION
    return make_dataset(
        u_est[:end_val], y_est[:end_val], dt, n_train=N_TRAIN, test=tests, remotes=REMOTES, paths=paths,
        n_init=N_INIT,
        units=Bunch(u="N", y="m", t="s"),
        official_split="estimation = user-generated multisine record; tests = uval/yval multisine and sinesweep",
        DESCR=DESCR,
    )
