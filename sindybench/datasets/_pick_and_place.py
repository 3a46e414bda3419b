"""Pick-and-place machine (Juloski, Heemels, Ferrari-Trecate 2004)."""

from scipy.io import loadmat
from scipy.signal import decimate
from sklearn.utils import Bunch

from ._base import RemoteFile, fetch_files
from ._common import make_dataset, make_split

__all__ = ["load_pick_and_place"]

REMOTES = (
    # the record ships with the benchmarking study's code; no stable public
    # download address is known, so the file must be copied into the data home.
    RemoteFile(
        "pick_and_place/headdata_1v6.mat", None, "63f43427579125940bfed469433800cac814d0547f843a2b91fb12dc3da2e113"
    ),
)

DECIMATION = 10
N_SAMPLES = 6001
N_TRAIN = 3840
N_VALIDATION = 960
N_TEST = 1201
N_INIT = 5

DESCR = """Pick-and-place machine (Juloski, Heemels, Ferrari-Trecate 2004).

The mounting head of a component placement machine, driven by a motor
(input u: motor voltage) and measured in position (output y). The head moves
freely, hits the component (impact) and saturates at an upper and a lower
stop: four modes, a piecewise-affine benchmark. Raw record: 60001 samples at
4 kHz (15 s).

Preprocessing (Bemporad et al. 2018, used by the study): both signals are
decimated by 10 (order-8 Chebyshev type I, zero phase:
``scipy.signal.decimate(x, 10)``), then ``u = -100 * u_dec``, and u and y
are standardised over the whole decimated record (mean 0, sample std 1):
6001 samples at 400 Hz (dt = 2.5 ms). The standardisation constants are in
``scaling`` (of ``-100 * u_dec`` and ``y_dec``).

Split: ``estimation`` = first 4800 samples (the estimation record of
Bemporad et al.), of which ``train`` = first 3840 and ``validation`` = next
960; ``test`` = the last 1201 samples. ``t`` counts seconds from the start of
the record. ``n_init``: initial test samples a model may use to set its state.

Reference: A.L. Juloski, W.P.M.H. Heemels, G. Ferrari-Trecate, "Data-based
hybrid modelling of the component placement process in pick-and-place
machines", Control Engineering Practice 12(10), 2004.
"""


def load_pick_and_place(*, data_home=None, download_if_missing=True):
    """Load the pick-and-place record, decimated and standardised, with the study's split.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder holding ``pick_and_place/headdata_1v6.mat``.
    download_if_missing : bool, default=True
        Kept for a uniform interface: no public address is known for this
        record, so a missing file always raises FileNotFoundError.

    Returns
    -------
    data : Bunch
        ``train`` (3840 samples), ``validation`` (960), ``test`` (1201) and
        ``estimation`` (4800); each a Bunch with ``u``, ``y`` of shape (n, 1),
        ``t``, ``dt`` and ``name``. Also ``dt`` = 2.5e-3, ``n_init`` = 5,
        ``scaling`` (``u_mean``, ``u_std``, ``y_mean``, ``y_std``), ``units``,
        ``official_split``, ``DESCR``, ``source``.
    """
    (path,) = paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    mat = loadmat(path)
    t_raw = mat["t"].ravel()
    u_dec = -100.0 * decimate(mat["u"].ravel(), DECIMATION)
    y_dec = decimate(mat["y"].ravel(), DECIMATION)
    if u_dec.shape[0] != N_SAMPLES or y_dec.shape[0] != N_SAMPLES:
        raise ValueError(
            f"decimating {path} by {DECIMATION} gave {u_dec.shape[0]} samples; expected {N_SAMPLES}."
        )
    # sampling interval from the time vector, rounded to 1e-12 s (0.25 ms raw, 2.5 ms decimated)
    dt = round(DECIMATION * float(t_raw[-1] - t_raw[0]) / (t_raw.shape[0] - 1), 12)
    scaling = Bunch(
        u_mean=float(u_dec.mean()), u_std=float(u_dec.std(ddof=1)), y_mean=float(y_dec.mean()), y_std=float(y_dec.std(ddof=1))
    )
    u = (u_dec - scaling.u_mean) / scaling.u_std
    y = (y_dec - scaling.y_mean) / scaling.y_std
    n_est = N_TRAIN + N_VALIDATION
    return make_dataset(
        u[:n_est], y[:n_est], dt, n_train=N_TRAIN, remotes=REMOTES, paths=paths,
        test=make_split(u[n_est:], y[n_est:], dt, start=n_est, name="test"),
        n_init=N_INIT,
        scaling=scaling,
        units=Bunch(u="standardised motor voltage", y="standardised head position", t="s"),
        official_split="no official split; estimation = first 4800 samples, test = last 1201 (Bemporad et al.)",
        DESCR=DESCR,
    )
