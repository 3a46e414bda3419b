"""Electro-Mechanical Positioning System, EMPS (Janot, Gautier, Brunot 2019)."""

import numpy as np
from scipy.io import loadmat
from sklearn.utils import Bunch

from ._base import RemoteFile, fetch_files
from ._common import make_dataset, make_split

__all__ = ["load_emps"]

REMOTES = (
    # the EMPS zip of nonlinearbenchmark.org is served through a file-sharing page, not a stable
    # download address, so the two records must be copied into the data home.
    RemoteFile("emps/DATA_EMPS.mat", None, "6cf6814ae14618795da0101aae2bb97ff0c6351b0501b5492751b02b07facf7e"),
    RemoteFile("emps/DATA_EMPS_PULSES.mat", None, "0eab75bb1f6b16228ee78791343a88bf9bfd9a51036ac9807d7b5fc11c0e1704"),
)

N_SAMPLES = 24841
#: one period of the reference trajectory (6.21 s) at the end of the estimation record
N_VALIDATION = 6210
N_TRAIN = N_SAMPLES - N_VALIDATION
#: the official protocol: the first 20 test samples may set the state, the RMSE is scored on the rest
N_INIT = 20
DT = 1e-3

DESCR = """Electro-Mechanical Positioning System, EMPS (nonlinearbenchmark.org).

A prismatic joint: a cart on a ball screw driven by a DC motor, with viscous
and Coulomb friction, measured in closed loop under a PD position controller
(``vir = kv (kp (qg - qm) - qm')``, kp = 160.18 1/s, kv = 243.45). Input
``u`` = ``vir`` (motor force command, V; the force on the load side is
``gtau * vir`` N, gtau = 35.15 N/V); output ``y`` = ``qm`` (measured
position, m). dt = 1 ms; two records of 24841 samples (24.84 s), each four
periods of the same reference trajectory ``qg``.

Official split (nonlinear_benchmarks' ``EMPS()``): estimate on DATA_EMPS
(``estimation``), test on DATA_EMPS_PULSES (``test``, open-loop simulation);
the first ``n_init`` = 20 test samples may set the initial state and the
RMSE is computed on the remaining ones (``test.score_from`` = 20). The test
record also holds ``pulses_N``, pulses applied during the test. Validation
block of this package: ``validation`` = the last 6210 samples (one period of
the reference) of the estimation record, ``train`` = the 18631 before it.
Each split also carries the reference ``qg``; ``controller`` holds ``kp``,
``kv`` and ``gtau``.

Reference model (IDIM-LS, the dataset's description):
M q'' = gtau vir - Fv q' - Fc sign(q') - offset, M = 95.11 kg,
Fv = 203.5 N s/m, Fc = 20.39 N, offset = -3.16 N.

Reference: A. Janot, M. Gautier, M. Brunot, "Data set and reference models
of EMPS", Workshop on Nonlinear System Identification Benchmarks, 2019.
"""


def _record(path):
    mat = loadmat(path)
    arrays = {k: np.asarray(mat[k], dtype=float).ravel() for k in ("t", "qm", "qg", "vir")}
    if any(a.shape[0] != N_SAMPLES for a in arrays.values()):
        shapes = {k: a.shape[0] for k, a in arrays.items()}
        raise ValueError(f"{path}: expected {N_SAMPLES} samples of t, qm, qg and vir; got {shapes}.")
    return mat, arrays


def load_emps(*, data_home=None, download_if_missing=True):
    """Load the EMPS benchmark: the official split plus a validation block.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder holding ``emps/DATA_EMPS.mat`` and ``emps/DATA_EMPS_PULSES.mat``
        (see :func:`sindybench.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Kept for a uniform interface: no stable public address is known for
        these records, so a missing file always raises FileNotFoundError.

    Returns
    -------
    data : Bunch
        ``estimation`` (DATA_EMPS, 24841 samples), ``train`` (its first
        18631), ``validation`` (its last 6210) and ``test`` (DATA_EMPS_PULSES,
        24841; with ``n_init`` = 20, ``score_from`` = 20, ``protocol`` and
        ``pulses``): each a Bunch with ``u`` = vir (V) and ``y`` = qm (m) of
        shape (n, 1), ``qg`` (m), ``t``, ``dt`` and ``name``. Also ``dt`` =
        1e-3, ``n_init`` = 20, ``controller`` (``kp``, ``kv``, ``gtau``),
        ``units``, ``official_split``, ``DESCR`` and ``source``.
    """
    paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    (est_mat, est), (test_mat, tst) = _record(paths[0]), _record(paths[1])
    test = make_split(tst["vir"], tst["qm"], DT, name="test")
    test.update(qg=tst["qg"], pulses=np.asarray(test_mat["pulses_N"], dtype=float).ravel(), n_init=N_INIT,
                score_from=N_INIT, protocol=f"official: {N_INIT} initial samples set the state, RMSE on the rest")
    data = make_dataset(
        est["vir"], est["qm"], DT, n_train=N_TRAIN, test=test, remotes=REMOTES, paths=paths,
        n_init=N_INIT,
        controller=Bunch(**{k: float(np.asarray(est_mat[k]).squeeze()) for k in ("kp", "kv", "gtau")}),
        units=Bunch(u="V", y="m", t="s"),
        official_split="estimation = DATA_EMPS, test = DATA_EMPS_PULSES (input vir, output qm)",
        DESCR=DESCR,
    )
    data.estimation.qg = est["qg"]
    data.train.qg, data.validation.qg = est["qg"][:N_TRAIN], est["qg"][N_TRAIN:]
    return data
