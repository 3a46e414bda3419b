"""Cost of uncertainty: the covariance of a refinement, and a 50-member ensemble of the refined cascaded tanks.

The model is the study's refined cascaded-tanks row (``hidden_tanks_refined``: the hidden upper
tank with the searched ``k1, k2`` and start level held, the default library, refined by
simulation error), rebuilt from the baseline model file (``--model``, default
``/work/baseline_results/cascaded-tanks/models/hidden_tanks_refined.json``) and fitted on the
benchmark's estimation record (1024 samples). Printed side by side in one process:

1. the wall time of its refinement (:func:`~sindybench.refine.refine_simulation_error` with the
   arguments the estimator passes), single shooting and with 5 shooting segments, against the
   time the covariance adds: the open-loop output Jacobian of multiple shooting (computed inside
   the refinement) and the two covariances of the record's summary (``"white"``, ``"hac"``);
   best of ``--repeat`` runs each;
2. the refit equals the baseline model file bit for bit (the covariance changes no number);
3. the wall time of a :class:`~sindybench.uncertainty.BootstrapEnsemble` of ``--members`` members
   (each a clone refitted: design, least squares, refinement), serially and with
   ``n_jobs=2`` (joblib processes: their start-up and numba's compilation in each worker are
   included); the CPU time of the serial one is what it would take on an idle core.

Numba, BLAS and OpenMP run on one thread per process (as the other scripts here; many
threads on small matrices on a loaded machine cost more than they give). Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_uncertainty.py [--repeat 3] [--members 50]
"""

import argparse
import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # before numpy and numba are imported (joblib's workers inherit it)

import time  # noqa: E402
import timeit  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from sklearn.base import clone  # noqa: E402

import sindybench.refine._core as core  # noqa: E402
import sindybench.refine._settings as settings_module  # noqa: E402
from sindybench import load_model  # noqa: E402
from sindybench.datasets import load_cascaded_tanks  # noqa: E402
from sindybench.uncertainty import BootstrapEnsemble  # noqa: E402

MODEL = "/work/baseline_results/cascaded-tanks/models/hidden_tanks_refined.json"


def best_time(func, repeat):
    """Best wall time of ``repeat`` calls (after one that warms up and gives the result)."""
    out = func()
    return min(timeit.repeat(func, number=1, repeat=repeat)), out


def captured_refinement(model, u, y):
    """The arguments the estimator passes to ``refine_simulation_error`` during a fit."""
    calls = []
    original = settings_module.refine_simulation_error

    def capture(*args, **kwargs):
        calls.append((args, kwargs))
        return original(*args, **kwargs)

    settings_module.refine_simulation_error = capture
    try:
        fitted = clone(model).fit(u, y)
    finally:
        settings_module.refine_simulation_error = original
    return fitted, calls[0]


def covariance_cost(args, kwargs, repeat, n_segments):
    kwargs = {**kwargs, "n_segments": n_segments}
    extra = []
    original = core._output_jacobian

    def timed(problem, fit):
        start = time.perf_counter()
        out = original(problem, fit)
        extra.append(time.perf_counter() - start)
        return out

    core._output_jacobian = timed
    try:
        t_refine, res = best_time(lambda: core.refine_simulation_error(*args, **kwargs), repeat)
    finally:
        core._output_jacobian = original
    t_cov, _ = best_time(lambda: (res.covariance("white"), res.covariance("hac")), repeat)
    t_jac = min(extra)
    print(f"  n_segments={n_segments}: refinement {t_refine:.3f} s ({res.nfev} simulations, {res.message})")
    print(f"    output Jacobian at the optimum {t_jac * 1e3:.2f} ms, covariances (white + hac) {t_cov * 1e3:.2f} ms"
          f" -> the covariance adds {100 * (t_jac + t_cov) / (t_refine - t_jac):.1f} % to the refinement")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default=MODEL)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--members", type=int, default=50)
    a = parser.parse_args()
    warnings.simplefilter("ignore")
    saved = load_model(a.model)
    data = load_cascaded_tanks().estimation
    u, y = data.u.reshape(len(data.u), -1), data.y.reshape(len(data.y), -1)
    print(f"cascaded tanks, refined hidden-tank model, {len(y)} estimation samples; load {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    fitted, (args, kwargs) = captured_refinement(saved, u, y)
    same = np.array_equal(fitted.coef_, saved.coef_) and fitted.params_ == saved.params_
    print(f"refit equals the baseline model file bit for bit: {same}")
    print("standard errors:", {k: f"{v:.3g}" for k, v in fitted.standard_errors().items()})
    for n_segments in (1, 5):
        covariance_cost(args, kwargs, a.repeat, n_segments)
    t_fit, _ = best_time(lambda: clone(saved).fit(u, y), a.repeat)
    print(f"one refit of the model: {t_fit:.3f} s")
    for n_jobs in (1, 2):
        start, cpu = time.perf_counter(), time.process_time()
        ens = BootstrapEnsemble(clone(saved), n_members=a.members, n_jobs=n_jobs, random_state=0).fit(u, y)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        k = ens.parameter_intervals()
        print(f"ensemble of {a.members}, n_jobs={n_jobs}: {wall:.1f} s wall, {cpu:.1f} s CPU of this process "
              f"(block {ens.block_length_}, "
              f"{ens.n_failed_} failed); k1 in [{k['k1'][0]:.4f}, {k['k1'][1]:.4f}], "
              f"k2 in [{k['k2'][0]:.4f}, {k['k2'][1]:.4f}]; load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
