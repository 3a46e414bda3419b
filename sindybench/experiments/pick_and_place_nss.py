"""Pick-and-place machine under the neural state-space protocol (Forgione, Mejari and Piga, 2022).

"Learning neural state-space models: do we need a state estimator?" uses the
raw 4 kHz record scaled by its own mean and standard deviation, split at raw
sample 50,000 (12.5 s), every 10th sample kept (no anti-alias filter):
training on the first part (5,000 samples at 400 Hz), testing on the rest
(1,001 samples), whose first 20 samples go to the state estimator and whose
fit index is computed on the remaining 981. Their best fit index is 93.6 %.

The models are those of :mod:`sindybench.experiments.pick_and_place`, tuned
on a validation block of the training part (its last 1,000 samples).
"""

import numpy as np

from .pick_and_place import BENCHMARK as _STUDY
from ._common import IDENTIFIED, identified
from ._spec import Benchmark

__all__ = []  # the module's BENCHMARK is read through experiments.get_benchmark (every set-up has one)

SPLIT = 50_000  # raw samples of the training part
DECIMATION = 10
N_VALIDATION = 1000
N_INIT = 20


def _load(*, data_home=None, download_if_missing=True):
    from scipy.io import loadmat
    from sklearn.utils import Bunch

    from ..datasets import fetch_files
    from ..datasets._common import make_dataset, make_split
    from ..datasets._pick_and_place import REMOTES

    (path,) = paths = fetch_files(REMOTES, data_home=data_home, download_if_missing=download_if_missing)
    mat = loadmat(path)
    u_raw, y_raw, t_raw = (np.asarray(mat[k], dtype=float).ravel() for k in ("u", "y", "t"))
    u = (u_raw - u_raw.mean()) / u_raw.std()  # population std of the whole raw record, as their loader
    y = (y_raw - y_raw.mean()) / y_raw.std()
    dt = round(DECIMATION * float(t_raw[-1] - t_raw[0]) / (t_raw.shape[0] - 1), 12)
    u_tr, y_tr = u[:SPLIT:DECIMATION], y[:SPLIT:DECIMATION]
    u_te, y_te = u[SPLIT::DECIMATION], y[SPLIT::DECIMATION]
    test = make_split(u_te, y_te, dt, start=len(y_tr), name="test")
    test.update(n_init=N_INIT, score_from=N_INIT,
                protocol=f"Forgione et al. 2022: {N_INIT} initial samples set the state, scored on the rest")
    return make_dataset(
        u_tr, y_tr, dt, n_train=len(y_tr) - N_VALIDATION, test=test, remotes=REMOTES, paths=paths, n_init=N_INIT,
        scaling=Bunch(u_mean=float(u_raw.mean()), u_std=float(u_raw.std()), y_mean=float(y_raw.mean()),
                      y_std=float(y_raw.std())),
    )


BENCHMARK = Benchmark(
    name="pick-and-place-nss",
    cost=37,  # CPU seconds of run all (seed 0, fresh clone, after its warm-up); orders a parallel run
    title="Pick-and-place machine, neural state-space protocol",
    load=_load,
    output_label="head position y (scaled)",
    input_label="motor voltage u (scaled)",
    n_init=N_INIT,
    reported_model="sindy_friction_refined",  # the richest physical structure, refined (fixed before any test score)
    # the study's models; the identified row starts its validation blocks from this protocol's N_INIT samples
    models=tuple(m for m in _STUDY.models if m.key != IDENTIFIED) + (identified(N_INIT),),
)
