"""Speed of the compiled extended Kalman filter against the same filter written with filterpy.

The model: the Bouc-Wen hidden-force model of the study (``HiddenStateSINDy`` with
``BoucWenHiddenState`` and the true ``m, c, k``; 3 states ``y, v, z``; RK4 with 2
sub-steps and a linearly interpolated force), fitted on the benchmark's 40,000 training
samples. The record: the sine-sweep test (153,000 samples), its displacement measured.
Printed side by side in one process:

1. :func:`sindybench.estimation.extended_kalman_filter` over the whole record: first
   call (compilation or cache load) and best steady-state time of ``--repeat`` runs;
2. filterpy's ``ExtendedKalmanFilter`` (the reference) with the same model: a subclass
   whose ``predict_x`` advances the state by one sample and sets ``F`` to the step's
   Jacobian, then filterpy's ``predict`` (``P = F P F' + Q``) and ``update`` (``H`` the
   measured-state selection). Two versions of the step: (a) the public API, as a user
   writes it (``sindybench.refine.simulate_sensitivity`` over two samples, the final
   state's sensitivity to the initial one), the reference of the target; (b) the same
   compiled one-step map as ours (``sindybench.dynamics.step_jacobian_kernel``) called
   from Python (each call converts the model's flattened arrays into numba's types, the
   cost that dominates it). Each step is called once before timing (compilation or cache
   load), then runs on the first ``--filterpy-samples`` samples and its time is scaled
   linearly (per sample) to the whole record;
3. the largest difference between the two filters' states over the samples both ran
   (filterpy's update is the plain ``(I - K H) P`` form, ours Joseph's: equal to rounding).

Wall and CPU (``time.process_time``) times are printed: on a loaded machine the CPU time is
what one free core would take. Numba, BLAS and OpenMP run on one thread. Needs the benchmark data (``SINDYBENCH_DATA``)::

    python benchmarks/bench_ekf.py [--repeat 3] [--filterpy-samples 5000]
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from sindybench import STLS, HiddenStateSINDy  # noqa: E402
from sindybench.datasets import load_bouc_wen  # noqa: E402
from sindybench.differentiation import Spectral  # noqa: E402
from sindybench.dynamics import step_jacobian_kernel  # noqa: E402
from sindybench.estimation import extended_kalman_filter, model_step  # noqa: E402
from sindybench.hidden import BoucWenHiddenState  # noqa: E402
from sindybench.refine import simulate_sensitivity  # noqa: E402


def fit_model(u, y):
    threshold = 0.1 * 1.3e4 * np.sqrt(len(u))  # as the study's Bouc-Wen experiment
    return HiddenStateSINDy(hidden=BoucWenHiddenState(m=2.0, c=10.0, k=5e4),
                            optimizer=STLS(threshold=threshold, normalize_columns=True),
                            differentiation=Spectral(cutoff=150.0), dt=1.0 / 750.0, n_substeps=2,
                            input_hold="linear").fit(u, y)


def compiled_step(m):
    """The model's step and Jacobian through the public compiled one-step map (``step_jacobian_kernel``,
    called from Python)."""
    sm = m.step_model()

    def step(x, u2):
        x_next, jac, _, bad = step_jacobian_kernel(sm, x, u2[0], u2[1], m.dt)
        if bad:
            raise RuntimeError("the model's step diverged")
        return x_next, jac

    return step


def public_step(m):
    """The model's step and Jacobian as a user writes it with the public API: a two-sample simulation
    with the sensitivities of the final state to the initial one."""
    free = list(range(m.n_states))
    settings = dict(n_substeps=m.n_substeps, method=m.method, input_hold=m.input_hold, bounds=(m.lower, m.upper))

    def step(x, u2):
        x_sim, _, jac = simulate_sensitivity(m.rhs, x, u2, m.dt, free_x0=free, output_index=[], **settings)
        return x_sim[-1], jac

    return step


def filterpy_ekf(m, step, u, y, Q, R, x0, P0):
    """The same filter with filterpy's ExtendedKalmanFilter; returns the filtered states."""
    from filterpy.kalman import ExtendedKalmanFilter

    n, oidx = m.n_states, list(m.output_index)
    H = np.zeros((len(oidx), n))
    H[np.arange(len(oidx)), oidx] = 1.0

    class ModelEKF(ExtendedKalmanFilter):
        def predict_x(self, u2):
            x_next, self.F = step(self.x[:, 0].copy(), u2)
            self.x = x_next[:, None]

    ekf = ModelEKF(dim_x=n, dim_z=len(oidx))
    ekf.x, ekf.P, ekf.Q, ekf.R = x0[:, None].copy(), P0.copy(), Q.copy(), R.copy()
    out = np.empty((len(y), n))
    for k in range(len(y)):
        if k > 0:
            ekf.predict(u[k - 1:k + 1])
        ekf.update(y[k], HJacobian=lambda x: H, Hx=lambda x: H @ x)
        out[k] = ekf.x[:, 0]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--filterpy-samples", type=int, default=5000)
    args = parser.parse_args()

    data = load_bouc_wen()
    model = fit_model(data.train.u, data.train.y)
    test = data.test.sinesweep
    u, y = np.ascontiguousarray(test.u), np.ascontiguousarray(test.y)
    m = model_step(model)
    n = m.n_states
    Q = np.diag((1e-4 * m.state_scale) ** 2)
    R = np.array([[1e-6 ** 2]])  # 1 um of measurement noise
    x0, P0 = np.zeros(n), np.diag(m.state_scale ** 2)
    print(f"Bouc-Wen sine sweep: {len(y)} samples, {n} states, model {model.equations(precision=3)[-1]}")

    with threadpool_limits(1):
        start = time.perf_counter()
        res = extended_kalman_filter(model, u, y, Q=Q, R=R, x0=x0, P0=P0)
        first = time.perf_counter() - start
        best, best_cpu = np.inf, np.inf
        for _ in range(args.repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            res = extended_kalman_filter(model, u, y, Q=Q, R=R, x0=x0, P0=P0)
            best = min(best, time.perf_counter() - start)
            best_cpu = min(best_cpu, time.process_time() - start_cpu)

        n_ref = min(args.filterpy_samples, len(y))
        refs = {}
        for label, step in (("public API step", public_step(m)), ("compiled step", compiled_step(m))):
            step(x0.copy(), u[:2])  # compilation (or cache load) is not part of the per-sample cost
            start, start_cpu = time.perf_counter(), time.process_time()
            states = filterpy_ekf(m, step, u[:n_ref], y[:n_ref], Q, R, x0, P0)
            scale = len(y) / n_ref
            refs[label] = ((time.perf_counter() - start) * scale, (time.process_time() - start_cpu) * scale, states)

    rms = np.sqrt(np.mean(res.innovations ** 2))
    print(f"sindybench EKF                 : first call {first:6.3f} s, best of {args.repeat} {best:6.3f} s wall, "
          f"{best_cpu:6.3f} s CPU ({1e6 * best_cpu / len(y):.2f} us per sample; target <= 1 s; "
          f"innovation RMS {rms:.3g} m)")
    for label, (t_ref, t_cpu, states) in refs.items():
        diff = np.max(np.abs(states - res.states[:n_ref]) / m.state_scale)
        print(f"filterpy EKF, {label:<17}: {t_ref:6.2f} s wall, {t_cpu:6.2f} s CPU ({1e6 * t_cpu / len(y):5.1f} us "
              f"per sample, ran {n_ref} samples, scaled); ours is {t_ref / best:5.1f}x faster (wall), "
              f"{t_cpu / best_cpu:5.1f}x (CPU); max |x - ours| / std(x) = {diff:.1e}")


if __name__ == "__main__":
    main()
