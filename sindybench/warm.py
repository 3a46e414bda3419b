"""Compile the common numba kernels into numba's cache before a first call waits for them.

numba compiles each kernel on its first call and caches the machine code (``cache=True``:
``__pycache__`` beside the module, or ``NUMBA_CACHE_DIR``), so a new environment, CI run or
notebook kernel on a new machine pays the compilation once: the first ``estimate_noise``
about 10 s of CPU, the first refinement about 5 s. ``python -m sindybench.warm`` (or
:func:`warm`) pays it ahead, as the last step of the set-up: it runs every public entry point
that reaches a compiled kernel (fit, predict, the output- and prediction-error refinements,
the extended Kalman filter, the RTS smoother, ``estimate_noise``, the k-step prediction) once
on a model of a few samples, so that their kernels are compiled with the very types real
calls give them (a model built from built-in term operations, without compiled rows). Later
calls of any size load the machine code from the cache. A model with user operations
(``register_op``) or compiled rows compiles its own variant on its first call.

The groups of kernels compile side by side in ``n_jobs`` processes (numba compiles one kernel at
a time in a process; each group is one process's work, and the cache is shared through files).
"""

import argparse
import logging
import os
import tempfile
import time
import warnings

import numpy as np

from ._numba_cache import lock_numba_cache

__all__ = ["warm"]

logger = logging.getLogger(__name__)


def _record(n=60, dt=0.1):
    """A tank draining through a square root, driven by a square wave: its inputs and level."""
    u = 1.0 + 0.5 * np.sign(np.sin(0.3 * np.arange(n)))[:, None]
    y = np.empty((n, 1))
    y[0] = 1.0
    for k in range(n - 1):
        y[k + 1] = y[k] + dt * (u[k] - 0.8 * np.sqrt(y[k]))
    return u, y, dt


def _model(**kwargs):
    from ._sindy import SINDy
    from .libraries import ConcatLibrary, PolynomialLibrary, SqrtLibrary
    from .optimizers import STLS

    u, y, dt = _record()
    return SINDy(library=ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary()]), optimizer=STLS(threshold=1e-3),
                 dt=dt, bounds=(0.0, 10.0), **kwargs).fit(u, y), u, y


def _fit_predict_refine():
    """Features (the library's terms), the free run and its sensitivities (output-error refinement)."""
    from .refine import OutputErrorRefinement

    model, u, y = _model(refine=OutputErrorRefinement(max_nfev=2))
    model.predict(u, y_init=y[:1])


def _prediction_error():
    """The prediction-error refinement's predictor and its sensitivities."""
    from .refine import PredictionErrorRefinement

    _model(refine=PredictionErrorRefinement(max_nfev=2))


def _filter_noise_k_step():
    """The one-step map's Jacobian inside the extended Kalman filter, the RTS smoother, the k-step prediction."""
    from .estimation import estimate_noise, predict_k_step, rts_smoother

    model, u, y = _model()
    Q, R = estimate_noise(model, u, y, max_iter=2)
    rts_smoother(model, u, y, Q=Q, R=R)
    predict_k_step(model, u, y, 2, Q=Q, R=R)


GROUPS = {"filter, estimate_noise, smoother, k-step": _filter_noise_k_step,
          "fit, predict, output-error refinement": _fit_predict_refine,
          "prediction-error refinement": _prediction_error}
"""The kernel groups (most compilation first), each run once by :func:`warm`."""


def _run(name, lock_file=None):
    if lock_file is not None:  # processes compiling side by side save into numba's cache one at a time
        lock_numba_cache(lock_file)
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a model of 60 samples: convergence and advice warnings are no news
        GROUPS[name]()
    return time.process_time() - start


def warm(*, n_jobs=None):
    """Compile the kernels of the common entry points into numba's cache; return each group's CPU seconds.

    Parameters
    ----------
    n_jobs : int, optional
        Processes that compile side by side (joblib's convention: None is 1, -1 all cores).

    Returns
    -------
    dict
        ``{group: CPU seconds}`` of :data:`GROUPS` (compilation, or loading from the cache when
        it is warm already: about 0.1 s a group).

    Examples
    --------
    >>> seconds = warm()  # doctest: +SKIP
    >>> sorted(seconds) == sorted(GROUPS)  # doctest: +SKIP
    True
    """
    from joblib import Parallel, delayed

    names = list(GROUPS)
    if n_jobs in (None, 1):
        return {name: _run(name) for name in names}
    with tempfile.TemporaryDirectory(prefix="sindybench-warm-") as tmp:
        lock_file = os.path.join(tmp, "numba-cache.lock")
        seconds = Parallel(n_jobs=n_jobs)(delayed(_run)(name, lock_file) for name in names)
    return dict(zip(names, seconds))


def main(argv=None):
    """``python -m sindybench.warm [--jobs N]``: compile, then print what took how long."""
    parser = argparse.ArgumentParser(prog="python -m sindybench.warm", description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=-1, help="processes compiling side by side (default: every core)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    seconds = warm(n_jobs=args.jobs)
    for name, cpu in seconds.items():
        print(f"  {cpu:5.1f} s CPU  {name}")
    print(f"numba's cache holds the common kernels ({time.perf_counter() - start:.0f} s wall).")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
