"""Speed of user-defined terms against built-in ones, side by side in one process.

1. A DC-servo style model (angle and speed measured, 2 states, 2000 samples,
   ``w' = -a w + b u - c sign(w)``) fitted by ``SINDy`` with the simulation-error
   refinement (``OutputErrorRefinement()``), its library ``[1, x, w, u]`` plus
   a friction term given three ways: the built-in ``SIGN`` term (the reference),
   ``CustomLibrary(functions=[np.sign])`` and ``CustomLibrary(functions=[lambda
   v: np.tanh(v / 0.02)])`` (both compiled by numba as user operations). The
   refinement's wall time (fit with refinement minus fit without) and one
   ``predict`` of the 2000 samples, with the ratios to the reference.
2. A ``HiddenStateSINDy`` search of 40 trials on 3000 samples with a
   ``ParametricHiddenState`` whose hidden law ``h' = -a h + b u`` is a NumPy
   function (compiled by numba as rows of the simulator), against the same search
   with that law written as built-in terms (the reference): wall time and ratio.

``--python`` adds the Python path (``CustomLibrary(..., compile=False)``, and the
hidden law wrapped in an object numba cannot compile) for the old cost; it is
slow (minutes). Compilation happens once per process and is excluded by a warm-up
run (its time is printed). Numba, BLAS and OpenMP run on one thread. Run::

    python benchmarks/bench_user_terms.py [--repeat 3] [--python]
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from sindybench import STLS, SINDy, HiddenStateSINDy  # noqa: E402
from sindybench.differentiation import SavitzkyGolay  # noqa: E402
from sindybench.hidden import ParametricHiddenState  # noqa: E402
from sindybench.libraries import POW, SIGN, ConcatLibrary, CustomLibrary, PolynomialLibrary, TermsLibrary  # noqa: E402
from sindybench.refine import OutputErrorRefinement  # noqa: E402
from sindybench.simulate import TermsRHS, simulate  # noqa: E402

DT = 0.01


def servo_data(n=2000, seed=0):
    """Angle and speed of ``x' = w, w' = -2 w + 8 u - 1.5 sign(w)`` under a random-phase multisine."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    u = sum(np.sin(f * t + rng.uniform(0, 2 * np.pi)) for f in (0.7, 1.9, 4.3, 9.1))[:, None] * 0.4
    w_, u_, sgn = ((1, POW, 1, 0),), ((2, POW, 1, 0),), ((1, SIGN, 0, 0),)
    truth = TermsRHS.from_equations([{w_: 1.0}, {w_: -2.0, u_: 8.0, sgn: -1.5}])
    x = simulate(truth, [0.0, 0.1], u, DT, n_substeps=4)
    return u, x + rng.normal(scale=1e-3, size=x.shape)


def servo_model(friction, refine):
    library = ConcatLibrary([PolynomialLibrary(degree=1), friction])
    return SINDy(library=library, optimizer=STLS(threshold=0.05), dt=DT, refine=refine)


def best_time(f, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - start)
    return min(times), out


def lag(xh, y, u, *, a, b):
    """The hidden law ``h' = -a h + b u`` written with NumPy."""
    return -a * xh + b * u[:1]


class _Opaque:
    """``lag`` behind an object numba cannot compile (the Python path)."""

    def __call__(self, xh, y, u, *, a, b):
        return lag(xh, y, u, a=a, b=b)


class LagInTerms(ParametricHiddenState):
    """The same strategy with the hidden law as built-in terms (the compiled reference)."""

    def structure(self, params, *, n_outputs, n_inputs):
        s = super().structure(params, n_outputs=n_outputs, n_inputs=n_inputs)
        phys, _ = self._split(params)
        p = n_outputs
        coef = np.zeros((2, p + 1))
        coef[:, p] = -phys["a"], phys["b"]
        return dataclasses.replace(s, fixed_terms=[((p, POW, 1, 0),), ((p + 1, POW, 1, 0),)], fixed_coef=coef,
                                   fixed_rhs=None)

    def _simulate_hidden(self, u, y, dt, params):
        phys, x0 = self._split(params)
        rhs = TermsRHS([[-phys["a"]], [phys["b"]]], [((0, POW, 1, 0),), ((1, POW, 1, 0),)], 1)
        return simulate(rhs, x0, np.hstack([u, y]), dt, n_substeps=self.n_substeps, input_hold="linear",
                        bounds=self._hidden_bounds(1))


def lag_data(n=3000):
    """h' = -2 h + u (hidden), y' = -0.5 y - y^3 + 1.5 h (measured), as tests/test_hidden_parametric.py."""
    dt = 0.02
    t = np.arange(n) * dt
    u = (2.0 * np.sin(1.7 * t + 1.0) + 1.5 * np.sin(4.1 * t) + np.sin(0.6 * t))[:, None]
    y_, h_, u_, y3 = ((0, POW, 1, 0),), ((1, POW, 1, 0),), ((2, POW, 1, 0),), ((0, POW, 3, 0),)
    truth = TermsRHS.from_equations([{y_: -0.5, y3: -1.0, h_: 1.5}, {h_: -2.0, u_: 1.0}])
    return u, simulate(truth, [0.0, 0.6], u, dt=dt, n_substeps=4, input_hold="linear")[:, :1], dt


def search_model(strategy_cls, rhs, dt, n_trials):
    hidden = strategy_cls(rhs, params={"a": (0.5, 8.0, True), "b": 1.0}, x0_bounds=(-2.0, 2.0), n_substeps=1,
                          grid_size=7, init_size=30)
    return HiddenStateSINDy(hidden=hidden, library=PolynomialLibrary(degree=3), optimizer=STLS(threshold=0.05),
                            dt=dt, differentiation=SavitzkyGolay(window_length=9), input_hold="linear",
                            n_trials=n_trials, random_state=0, validation_size=300)


def servo_part(repeat, python):
    u, y = servo_data()
    variants = [("built-in SIGN", TermsLibrary(terms=[[[1, SIGN, 0.0, 0.0]]])),
                ("CustomLibrary np.sign", CustomLibrary(functions=[np.sign], variables=[1])),
                ("CustomLibrary tanh(v/0.02)", CustomLibrary(functions=[lambda v: np.tanh(v / 0.02)], variables=[1]))]
    if python:
        variants.append(("np.sign, Python path", CustomLibrary(functions=[np.sign], variables=[1], compile=False)))
    print(f"1. DC servo, {len(u)} samples, SINDy + OutputErrorRefinement(); best of {repeat}")
    print(f"   {'friction term':28s} {'warm-up s':>9s} {'refine s':>9s} {'ratio':>7s} {'predict ms':>10s} {'ratio':>7s}"
          f" {'R2 (train)':>10s}")
    ref = None
    for name, friction in variants:
        start = time.perf_counter()
        servo_model(friction, OutputErrorRefinement()).fit(u, y)  # compiles what this variant needs
        warm = time.perf_counter() - start
        n_rep = 1 if "Python" in name else repeat
        plain, _ = best_time(lambda: servo_model(friction, None).fit(u, y), n_rep)
        full, model = best_time(lambda: servo_model(friction, OutputErrorRefinement()).fit(u, y), n_rep)
        pred, _ = best_time(lambda: model.predict(u, y_init=y[:1]), max(n_rep, 5))
        refine = max(full - plain, 1e-9)
        ref = ref or (refine, pred)
        print(f"   {name:28s} {warm:9.2f} {refine:9.3f} {refine / ref[0]:7.2f} {pred * 1e3:10.2f} "
              f"{pred / ref[1]:7.2f} {model.score(u, y):10.5f}")


def search_part(n_trials, python):
    u, y, dt = lag_data()
    variants = [("hidden law as built-in terms", LagInTerms, None), ("NumPy hidden law (compiled)",
                                                                     ParametricHiddenState, lag)]
    if python:
        variants.append(("NumPy hidden law, Python path", ParametricHiddenState, _Opaque()))
    print(f"\n2. ParametricHiddenState search, {n_trials} trials on {len(u)} samples")
    print(f"   {'hidden law':30s} {'warm-up s':>9s} {'search s':>9s} {'ratio':>7s} {'a found':>8s}")
    ref = None
    for name, cls, rhs in variants:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the Python path's warning
            start = time.perf_counter()
            search_model(cls, rhs or lag, dt, 2).fit(u, y)
            warm = time.perf_counter() - start
            seconds, model = best_time(lambda: search_model(cls, rhs or lag, dt, n_trials).fit(u, y), 1)
        ref = ref or seconds
        print(f"   {name:30s} {warm:9.2f} {seconds:9.2f} {seconds / ref:7.2f} {model.params_['a']:8.4f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--python", action="store_true", help="also time the Python path (slow)")
    args = parser.parse_args()
    servo_part(args.repeat, args.python)
    search_part(args.trials, args.python)


if __name__ == "__main__":
    main()
