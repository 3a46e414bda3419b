"""What ``identify`` costs, stage by stage, on a simulated record of one input and one output.

On a zoo system's estimation record (``sindybench.systems.get_system``; default ``duffing``, a
multisine-driven Duffing oscillator) of ``--samples`` samples (default 10,000 and 100,000), one
thread (numba, BLAS and OpenMP pinned: ``--threads``), after a warm-up search that compiles the
kernels: the CPU seconds of this process (``time.process_time``) of ``identify(u, y, dt=dt)``, split
into its stages by timing wrappers put around the library's stage functions for the run (the
library is not changed): the data settings (the advice, the linear base's order ``linear_order``
and its MOESP fits), each family's screening (the pruning path on the last fold), its candidates
on every fold (of which the simulation-error refinements and the subspace starts), the refined
candidates, and the final refit (everything outside those). Times are inclusive; a row indented
under another is part of it. As the reference, the same process times one default
``HiddenStateSINDy`` fit of the same record; the ratio says how many such fits ``identify`` costs.
The issue's targets: 60 s on 10,000 samples, 150 s on 100,000. Run::

    python benchmarks/bench_identify_cost.py [--system duffing] [--samples 10000,100000] [--seed 0]
    SINDYBENCH_DATA=../shared/data python benchmarks/bench_identify_cost.py --benchmark silverbox,emps

``--benchmark`` times a benchmark's identified row instead (as ``bench_identify.py`` fits it).
"""

import sys

from _threads import pin_threads

pin_threads(sys.argv)

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from collections import defaultdict  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from functools import wraps  # noqa: E402

import numpy as np  # noqa: E402

TARGET_S = {10_000: 60.0, 100_000: 150.0}


class StageClock:
    """Inclusive CPU seconds and calls per nested stage label, gathered by wrappers of the library's functions."""

    def __init__(self):
        self.stack = []
        self.seconds = defaultdict(float)
        self.calls = defaultdict(int)

    @contextmanager
    def stage(self, label):
        self.stack.append(label)
        key = tuple(self.stack)
        start = time.process_time()
        try:
            yield
        finally:
            self.seconds[key] += time.process_time() - start
            self.calls[key] += 1
            self.stack.pop()

    def wrap(self, func, label):
        """``func`` timed under ``label`` (a string, or a function of the call's arguments)."""
        @wraps(func)
        def timed(*args, **kwargs):
            with self.stage(label(*args, **kwargs) if callable(label) else label):
                return func(*args, **kwargs)
        return timed


@contextmanager
def instrumented(clock):
    """Patch the stage functions of ``identify`` with timed wrappers for the duration of the block."""
    from sindybench.hidden import _latent_starts
    from sindybench.identify import _estimator, _linear, _space
    from sindybench.refine import _settings

    def candidate(row, library, ctx, refinement):
        return f"{'refine' if refinement is not None else 'blocks'} {row['family']} ({row['library']})"

    patches = [
        (_estimator, "data_settings", "data settings"),
        (_space, "_advice", "advice"),
        (_space, "linear_order", "linear_order"),
        (_linear, "moesp_orders", "MOESP fits"),
        (_estimator, "structures", "structures"),
        (_estimator, "screen_structure", lambda struct, library, ctx: f"screen {struct['family']}"),
        (_estimator, "score_candidate", candidate),
        (_settings, "refine_simulation_error", "refinement"),
        (_settings, "refine_prediction_error", "prediction-error refinement"),
        (_latent_starts, "subspace_states", "subspace start"),
    ]

    def final_refit(make):  # the estimator the search refits on the whole record: its fit timed
        @wraps(make)
        def made(*args, **kwargs):
            estimator = make(*args, **kwargs)
            estimator.fit = clock.wrap(estimator.fit, "final refit")
            return estimator
        return made

    patches.append((_estimator, "make_estimator", final_refit))
    saved = [(module, name, getattr(module, name)) for module, name, _ in patches]
    try:
        for module, name, label in patches:
            func = getattr(module, name)
            setattr(module, name, label(func) if label is final_refit else clock.wrap(func, label))
        yield clock
    finally:
        for module, name, func in saved:
            setattr(module, name, func)


def _row(label, seconds, calls, total, indent):
    return f"{'  ' * indent}{label:<{58 - 2 * indent}} {seconds:8.2f} s {100 * seconds / total:5.1f} % {calls:6d}"


def report(clock, total):
    """The stage table: each stage under the one that called it, in the order they ran, family rows merged."""
    # merge the candidates of one family and stage (their libraries) into one row
    merged_s, merged_n, order = defaultdict(float), defaultdict(int), []
    for key, seconds in clock.seconds.items():
        short = tuple(k.split(" (")[0] for k in key)
        if short not in merged_s:
            order.append(short)
        merged_s[short] += seconds
        merged_n[short] += clock.calls[key]
    top = [k for k in order if len(k) == 1]
    lines = [f"{'stage':<58} {'CPU':>10} {'share':>7} {'calls':>6}"]
    accounted = 0.0

    def children(prefix, indent):
        kids = [k for k in order if len(k) == len(prefix) + 1 and k[:len(prefix)] == prefix]
        for k in sorted(kids, key=lambda k: -merged_s[k]):
            lines.append(_row(k[-1], merged_s[k], merged_n[k], total, indent))
            children(k, indent + 1)

    for k in top:
        accounted += merged_s[k]
        lines.append(_row(k[0], merged_s[k], merged_n[k], total, 0))
        children(k, 1)
    lines.append(_row("the rest (bookkeeping)", total - accounted, 1, total, 0))
    # the linear base and every family, all stages together
    families = defaultdict(float)
    for k in top:
        if k[0].split()[0] in ("screen", "blocks", "refine"):
            families[k[0].split()[1]] += merged_s[k]
    lines.append("per family (screen + blocks + refine): " + ", ".join(
        f"{f} {s:.1f} s" for f, s in sorted(families.items(), key=lambda kv: -kv[1])))
    return "\n".join(lines)


def run(system_name, n_samples, seed, families=None):
    from sindybench import HiddenStateSINDy
    from sindybench.identify import identify
    from sindybench.systems import get_system

    rec = get_system(system_name).record(seed, n_samples=n_samples, n_test=1000)
    u, y, dt = rec.u, rec.y, rec.dt
    clock = StageClock()
    kwargs = {} if families is None else {"families": families}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.process_time()
        HiddenStateSINDy(dt=dt, show_progress_bar=False).fit(u, y)
        ref_s = time.process_time() - start
        with instrumented(clock):
            start = time.process_time()
            model = identify(u, y, dt=dt, show_progress_bar=False, **kwargs)
            total = time.process_time() - start
    chosen = model.identification_["settings"]
    target = TARGET_S.get(n_samples)
    verdict = "" if target is None else f" (target {target:.0f} s: {'met' if total <= target else 'NOT met'})"
    print(f"== {system_name}: {n_samples} samples at dt={dt}, seed {seed}")
    print(f"   identify: CPU {total:.1f} s{verdict}; {total / ref_s:.0f}x one default HiddenStateSINDy fit "
          f"({ref_s:.2f} s)")
    base = model.identification_["data"].get("linear")
    print(f"   chosen: {chosen['family']} / {chosen['library']}, {chosen['n_terms']} terms; linear base: "
          + ("none" if base is None else f"order {base['order']}, {base['block_rows']} block rows"))
    print(report(clock, total), flush=True)
    return total


def run_benchmark(name):
    """The stages of a benchmark's identified row (``bench_identify.py``'s search on its estimation record)."""
    from bench_identify import _identified

    _, _, X, y, _, estimator = _identified(name)
    clock = StageClock()
    with warnings.catch_warnings(), instrumented(clock):
        warnings.simplefilter("ignore")
        start = time.process_time()
        search = estimator.fit(X, y)
        total = time.process_time() - start
    chosen = search.best_params_
    print(f"== {name}: {len(y)} samples; identified row CPU {total:.1f} s; chosen {chosen['family']} / "
          f"{chosen['library']}, {chosen['n_terms']} terms")
    print(report(clock, total), flush=True)
    return total


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", default="duffing", help="a zoo system (sindybench.systems.ZOO)")
    parser.add_argument("--samples", default="10000,100000", help="comma-separated record lengths")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--benchmark", default=None, help="comma-separated benchmarks (bench_identify.py's rows) "
                        "instead of a zoo record (needs SINDYBENCH_DATA)")
    parser.add_argument("--families", default=None, help="comma-separated families (default: identify's)")
    parser.add_argument("--threads", default="1", help="numba/BLAS threads (set before the import)")
    args = parser.parse_args(argv)
    from bench_identify import _warm_up  # the same warm-up search (the scripts' folder is on sys.path)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _warm_up()
    if args.benchmark:
        for name in args.benchmark.split(","):
            run_benchmark(name)
        return
    for n in (int(v) for v in args.samples.split(",")):
        run(args.system, n, args.seed, None if args.families is None else tuple(args.families.split(",")))


if __name__ == "__main__":
    main()
