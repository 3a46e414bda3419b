"""Cost of uncertainty: the covariance of a refinement, and a 50-member ensemble of the refined cascaded tanks.

The model is the study's refined cascaded-tanks row (``hidden_tanks_refined``: the hidden upper
tank with the searched ``k1, k2`` and start level held, the default library, refined by
simulation error), rebuilt from the model file of a ``run all`` (``--model``, default
``sindybench_results/cascaded-tanks/models/hidden_tanks_refined.json``, the command's default
output folder) and fitted on the
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

4. (``--conformal RESULTS``, a ``sindybench run all`` output folder) for each benchmark's
   designated row, loaded from ``RESULTS/<benchmark>/models/<row>.json``: the time of its
   conformal 95 % free-run band as ``run all`` makes it (calibration on the validation block,
   one per test protocol, and the band around the runner's simulation of every test set)
   against a refit of the row (its refinement on the estimation record, what ``run all`` times
   as the row's fit), and the coverage of every test set; the same for the band whose
   half-width comes from the row refitted without the validation block (one more fit); then
   the residual analysis (free run, 25 lags) of the row on its longest test record and the
   residual test alone on 100,000 samples.

Numba, BLAS and OpenMP run on one thread per process (as the other scripts here; many
threads on small matrices on a loaded machine cost more than they give). Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_uncertainty.py [--repeat 3] [--members 50]
    SINDYBENCH_DATA=../shared/data python benchmarks/bench_uncertainty.py --conformal sindybench_results
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
from sindybench.refine import Shooting  # noqa: E402
from sindybench.uncertainty import BootstrapEnsemble  # noqa: E402

MODEL = os.path.join("sindybench_results", "cascaded-tanks", "models", "hidden_tanks_refined.json")


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
    kwargs = {**kwargs, "shooting": Shooting(n_segments, kwargs["shooting"].continuity_weight)}
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


def conformal_cost(results, repeat):
    """Part 4: the conformal band's cost against a refit of each designated row; the residual test's time."""
    from sindybench.experiments import get_benchmark
    from sindybench.experiments._best import _conformal, _held_out, test_record
    from sindybench.experiments._runner import _test_info, _training_record, load_data, test_sets
    from sindybench.uncertainty import residual_analysis, residual_test

    for name in ("cascaded-tanks", "pick-and-place", "pick-and-place-nss", "emps", "bouc-wen"):
        bench = get_benchmark(name)
        data = load_data(bench)
        X, y, n_train, n_val = _training_record(bench, data, False)
        model = load_model(os.path.join(results, name, "models", f"{bench.reported_model}.json"))
        keep = bench.model(bench.reported_model).train_rows(quick=False, n_train=n_train, n_samples=len(y))
        tests = test_sets(data)
        info = {k: _test_info(bench, data, t) for k, t in tests.items()}
        t_fit, _ = best_time(lambda: clone(model).fit(X[keep], y[keep]), repeat)
        sims = {}  # the runner's test simulations, which the band reuses
        for k, t in tests.items():
            u, yt = test_record(t)
            sims[k] = np.asarray(model.predict(u, y_init=yt[:info[k]["n_init"]]), float).reshape(yt.shape)
        t_band, out = best_time(lambda: _conformal(model, X[-n_val:], y[-n_val:], tests, info, sims), repeat)
        cover = ", ".join(f"{k} {v['coverage']:.3f} (width {v['mean_width']:.3g})" for k, v in out["coverage"].items())
        print(f"{name}: conformal band {t_band:.3f} s = {100 * t_band / t_fit:.1f} % of the row's refit "
              f"({t_fit:.2f} s); coverage {cover}")
        t_held, held = best_time(lambda: _held_out(model, X[keep], y[keep], n_val, tests, info, sims), 1)
        cover = ", ".join(f"{k} {v['coverage']:.3f} (width {v['mean_width']:.3g})" for k, v in held["coverage"].items())
        print(f"  held-out refit band {t_held:.3f} s = {100 * t_held / t_fit:.0f} % of the row's refit; "
              f"coverage {cover}")
    u, yt = max((test_record(t) for t in tests.values()), key=lambda r: len(r[1]))
    t_ra, _ = best_time(lambda: residual_analysis(model, u, yt), repeat)
    rng = np.random.default_rng(0)
    e, x = rng.normal(size=(100_000, 1)), rng.normal(size=(100_000, 1))
    t_test, _ = best_time(lambda: residual_test(e, x), repeat)
    print(f"residual analysis of the Bouc-Wen row on {len(yt)} samples (free run included): {t_ra:.3f} s; "
          f"residual test alone on 100,000 samples: {t_test:.3f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default=MODEL)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--members", type=int, default=50)
    parser.add_argument("--conformal", metavar="RESULTS", help="part 4 only, on a run-all output folder")
    a = parser.parse_args()
    warnings.simplefilter("ignore")
    if a.conformal:
        conformal_cost(a.conformal, a.repeat)
        return
    if not os.path.isfile(a.model):
        parser.error(f"no model file {a.model}: run 'sindybench run cascaded-tanks' first, or pass --model FILE "
                     "(the hidden_tanks_refined.json of a run's models/ folder)")
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
