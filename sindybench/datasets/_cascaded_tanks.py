"""Cascaded tanks with overflow (Schoukens, Mattsson, Wigren, Noel 2016)."""

import numpy as np
from scipy.io import loadmat
from sklearn.utils import Bunch

from ._base import RemoteFile, fetch_files
from ._common import make_dataset, make_split

__all__ = ["load_cascaded_tanks"]

# CascadedTanksFiles.zip of nonlinearbenchmark.org on the 4TU data repository
# (doi:10.4121/12960104); the archive holds CascadedTanksFiles/dataBenchmark.mat.
_URL = "https://data.4tu.nl/file/d4810b78-6cdd-48fe-8950-9bd601e5f47f/3b697e42-01a4-4979-a370-813a456c36f5"

REMOTES = (
    RemoteFile(
        "cascaded_tanks/dataBenchmark.mat",
        _URL,
        "cb2f88d4388be4d3f2a24c6402fba804976aac5f2e1f26cda59ea0a38d016eab",
        "CascadedTanksFiles/dataBenchmark.mat",
    ),
)

N_TRAIN = 768
N_INIT = 5

DESCR = """Cascaded tanks with overflow (nonlinearbenchmark.org).

A pump (input u, volts) fills an upper tank that drains through a small
opening into a lower tank; the water level of the lower tank is measured
(output y, volts). Outflows follow the square-root law of Torricelli; the
tanks overflow when too full and the level sensor saturates at 10 V.
Ts = 4 s; two records of 1024 samples.

Official split: estimate on uEst/yEst (``estimation``), test on uVal/yVal
(``test``, open-loop simulation). Study split: ``train`` = first 768 samples
of the estimation record, ``validation`` = its last 256, ``test`` = the 1024
samples of the test record. ``t`` counts seconds from the start of each
record. ``n_init``: initial test samples a model may use to set its state.

Reference: M. Schoukens, P. Mattsson, T. Wigren, J.P. Noel, "Cascaded tanks
benchmark combining soft and hard nonlinearities", Workshop on Nonlinear
System Identification Benchmarks, 2016.
"""


def load_cascaded_tanks(*, data_home=None, download_if_missing=True):
    """Load the cascaded-tanks benchmark with the study's split.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder holding ``cascaded_tanks/dataBenchmark.mat`` (see
        :func:`sindybench.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Download the file if it is missing; otherwise raise FileNotFoundError.

    Returns
    -------
    data : Bunch
        ``train`` (768 samples), ``validation`` (256), ``test`` (1024) and
        ``estimation`` (the whole official estimation record, 1024): each a
        Bunch with ``u``, ``y`` of shape (n, 1), ``t``, ``dt`` and ``name``;
        plus ``dt`` = 4.0, ``n_init`` = 5, ``units``, ``official_split``,
        ``DESCR`` and ``source``.
    """
    (path,) = paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    mat = loadmat(path)
    dt = float(np.asarray(mat["Ts"]).squeeze())
    u_est, y_est = mat["uEst"].ravel(), mat["yEst"].ravel()
    u_val, y_val = mat["uVal"].ravel(), mat["yVal"].ravel()
    return make_dataset(
        u_est, y_est, dt, n_train=N_TRAIN, test=make_split(u_val, y_val, dt, name="test"), remotes=REMOTES, paths=paths,
        n_init=N_INIT,
        units=Bunch(u="V", y="V", t="s"),
        official_split="estimation = uEst/yEst, test = uVal/yVal",
        DESCR=DESCR,
    )
