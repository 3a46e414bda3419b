"""Silverbox, an electronic Duffing oscillator (Wigren & Schoukens 2013)."""

import numpy as np
from sklearn.utils import Bunch

from ._base import RemoteFile, fetch_files
from ._common import make_dataset, make_split

__all__ = ["load_silverbox"]

REMOTES = (
    # the record is SNLS80mV.mat in SilverboxFiles.zip of nonlinearbenchmark.org; this CSV copy of it
    # (columns V1, V2) has no stable public address, so it must be copied into the data home.
    RemoteFile("silverbox/SNLS80mV.csv", None, "ae62d5a91230c10f76e6dd02c8a4fac3c9d4d8a95fbf50e87cb0c4885003e0f1"),
)

N_SAMPLES = 131072
#: fs = 10 MHz / 2**14 = 610.35 Hz
DT = 2.0**14 / 1e7
#: the official protocol (nonlinear_benchmarks' ``Silverbox()``): the multisine block of the record ...
MULTISINE = slice(40650, 127400)
#: ... of which the first 75 % estimate and the rest is the ``multisine`` test
N_ESTIMATION = int(0.75 * (MULTISINE.stop - MULTISINE.start))
#: the Gaussian-noise "arrow" of growing amplitude, and its part within the estimation data's amplitude
ARROW = slice(100, 40575)
N_ARROW_NO_EXTRAPOLATION = 32000
#: the first 50 samples of each test may set the state; the RMSE is computed on the rest
N_INIT = 50
#: validation block of this package: the last 20 % of the estimation record
N_VALIDATION = 13012
N_TRAIN = N_ESTIMATION - N_VALIDATION

DESCR = """Silverbox, an electronic Duffing oscillator (nonlinearbenchmark.org).

An electronic circuit implementing a forced Duffing oscillator,
m y'' + d y' + k y + k3 y^3 = u: a second-order linear system with a cubic
static nonlinearity in feedback; the velocity is not measured. Input ``u``:
voltage V1 (V); output ``y``: voltage V2 (V). One record (SNLS80mV) of
131072 samples at fs = 10 MHz / 2^14 = 610.35 Hz (dt = 1.6384 ms): a
Gaussian noise "arrow" of growing amplitude (samples 0 to about 40500),
then a block of odd random-phase multisine realizations.

Official protocol (nonlinear_benchmarks' ``Silverbox()``): the multisine
block is all[40650:127400]; ``estimation`` = its first 75 % (65062
samples). Tests (``test``, open-loop simulation): ``multisine`` = the rest
of the block (21688 samples), ``arrow_full`` = all[100:40575] (40475
samples; its end exceeds the amplitude of the estimation data) and
``arrow_no_extrapolation`` = arrow_full[:32000]. On each test the first
``n_init`` = 50 samples may set the initial state and the RMSE is computed
on the samples after them (``score_from`` = 50); it is usually reported in
millivolts. Validation block of this package: ``validation`` = the last
13012 samples (20 %) of the estimation record, ``train`` = the 52050
before it. ``t`` counts seconds from the start of the whole record.

Reference: T. Wigren, J. Schoukens, "Three free data sets for development
and benchmarking in nonlinear system identification", European Control
Conference, 2013.
"""


def _read(path):
    # each line ends with a comma: read the two named columns only
    record = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1), ndmin=2)
    if record.shape != (N_SAMPLES, 2):
        raise ValueError(f"{path}: expected {N_SAMPLES} rows of V1, V2; got an array of shape {record.shape}.")
    return record[:, 0], record[:, 1]


def _test(u, y, part, name):
    test = make_split(u[part], y[part], DT, start=part.start, name=name)
    test.update(n_init=N_INIT, score_from=N_INIT,
                protocol=f"official: {N_INIT} initial samples set the state, RMSE on the rest")
    return test


def load_silverbox(*, data_home=None, download_if_missing=True):
    """Load the Silverbox benchmark: the official split plus a validation block.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder holding ``silverbox/SNLS80mV.csv`` (see
        :func:`sindybench.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Kept for a uniform interface: no stable public address is known for
        this copy of the record, so a missing file always raises
        FileNotFoundError.

    Returns
    -------
    data : Bunch
        ``estimation`` (65062 samples), ``train`` (its first 52050),
        ``validation`` (its last 13012) and ``test``, a Bunch of the official
        tests ``multisine`` (21688), ``arrow_full`` (40475) and
        ``arrow_no_extrapolation`` (32000), each with ``n_init`` = 50,
        ``score_from`` = 50 and ``protocol``. Every split is a Bunch with
        ``u`` = V1 and ``y`` = V2 (volts) of shape (n, 1), ``t`` (seconds
        from the start of the record), ``dt`` and ``name``. Also ``dt`` =
        1.6384e-3, ``n_init`` = 50, ``record`` (the whole record: ``u``,
        ``y``), ``units``, ``official_split``, ``DESCR`` and ``source``.

    Examples
    --------
    >>> data = load_silverbox()  # doctest: +SKIP
    >>> len(data.estimation.y), len(data.test.multisine.y)  # doctest: +SKIP
    (65062, 21688)
    """
    paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    u, y = _read(paths[0])
    arrow = _test(u, y, ARROW, "arrow_full")
    no_extrapolation = _test(u, y, slice(ARROW.start, ARROW.start + N_ARROW_NO_EXTRAPOLATION),
                             "arrow_no_extrapolation")
    end = MULTISINE.start + N_ESTIMATION
    tests = Bunch(
        multisine=_test(u, y, slice(end, MULTISINE.stop), "multisine"),
        arrow_full=arrow,
        arrow_no_extrapolation=no_extrapolation,
    )
    data = make_dataset(
        u[MULTISINE.start:end], y[MULTISINE.start:end], DT, n_train=N_TRAIN, test=tests, remotes=REMOTES,
        paths=paths, n_init=N_INIT,
        record=Bunch(u=u, y=y),
        units=Bunch(u="V", y="V", t="s"),
        official_split="estimation = the first 75 % of all[40650:127400]; tests multisine = the rest of it, "
                       "arrow_full = all[100:40575], arrow_no_extrapolation = arrow_full[:32000]",
        DESCR=DESCR,
    )
    for split in (data.train, data.validation, data.estimation):  # times since the start of the record
        split.t = split.t + MULTISINE.start * DT
    return data
