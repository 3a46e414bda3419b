"""Score identification methods on the zoo of simulated systems and write the docs table.

For every system of :mod:`sindybench.systems` (or ``--systems a,b``, or the ``--quick``
subset), one record at ``--seed`` (default 0): every method is fitted on the estimation
record (its inputs, outputs and ``dt`` only) and simulated in free run on the test record
from its first ``N_INIT`` measured samples; the scores cover the samples after those, against
the measured (noisy) test output:

- fit index ``100 (1 - ||y - yhat|| / ||y - mean y||)`` (averaged over outputs), RMSE, R^2;
- the number of terms (identify: its equation terms; ARX: its coefficients and intercepts;
  NN-ARX: its network and linear weights; fastcan: its selected terms and intercepts);
- CPU seconds of this process (``time.process_time``, one thread) for the whole method:
  its tuning, the final fit and the test simulation.

The methods (a dict ``METHODS`` of name -> function; add one there):

- ``identify``: ``sindybench.identify(u, y, dt=dt)`` with its defaults (seeded, no progress bar);
- ``arx``: ARX with orders ``na, nb`` in 1..10 and ``nk`` in {0, 1, 2, 5, 10}, chosen by the
  free-run RMSE on the last fifth of the estimation record (fitted on the first four fifths),
  then refitted on the whole estimation record;
- ``nnarx``: NN-ARX on the tuned ARX's orders (``na, nb`` at most 5), one hidden layer of 16
  tanh units, weight penalty 0.1 or 1 chosen on the same validation block, refitted;
- ``fastcan``: fastcan's polynomial NARX (``make_narx`` term selection, then multi-step
  fitting with ``coef_init="one_step_ahead"``, its documented settings), lags, degree and
  number of terms from a small grid chosen on the same validation block, refitted.
  fastcan is the ``bench`` extra (``pip install -e .[bench]``).

Run (the full zoo takes long: the long record alone has 100,000 samples)::

    nice -n 10 python benchmarks/bench_zoo.py [--quick | --systems a,b] [--methods identify,arx] \\
        [--seed 0] [--out docs/zoo_table.rst]
"""

import sys

from _threads import pin_threads

pin_threads(sys.argv)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from sindybench.metrics import fit_index, r2, rmse  # noqa: E402
from sindybench.systems import get_system, zoo_systems  # noqa: E402

N_INIT = 10  # measured samples that start every free run (validation and test)
QUICK = ("first_order", "second_order", "dead_time", "hammerstein", "hidden_saturation")
ARX_NA = range(1, 11)
ARX_NK = (0, 1, 2, 5, 10)
FASTCAN_GRID = ((3, 2, 10), (3, 3, 16), (6, 2, 16))  # (max_delay, poly_degree, n_terms_to_select)


def split(u, y):
    """The estimation record's first four fifths (fit) and last fifth (validation)."""
    cut = len(y) - len(y) // 5
    return (u[:cut], y[:cut]), (u[cut:], y[cut:])


def free_run_rmse(predict, u, y):
    """RMSE of a free run from the first ``N_INIT`` samples of ``y`` (inf if it failed or diverged)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            y_hat = np.asarray(predict(u, y[:N_INIT]), float).reshape(y.shape)
    except Exception:  # a candidate that cannot simulate loses the comparison
        return np.inf
    return float(rmse(y, y_hat, skip=N_INIT)) if np.all(np.isfinite(y_hat)) else np.inf


def choose(candidates, fit, predict, u, y):
    """The candidate whose model, fitted on the first four fifths, free-runs best on the last fifth."""
    (u_fit, y_fit), (u_val, y_val) = split(u, y)
    best, best_err = None, np.inf
    for cand in candidates:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = fit(cand, u_fit, y_fit)
        except Exception:
            continue
        err = free_run_rmse(lambda uu, yy, m=model: predict(m, uu, yy), u_val, y_val)
        if err < best_err:
            best, best_err = cand, err
    if best is None:
        raise RuntimeError("no candidate could be fitted")
    return best


# ---------------------------------------------------------------------------------------------- methods
def run_identify(rec, **kwargs):
    from sindybench import identify

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = identify(rec.u, rec.y, dt=rec.dt, show_progress_bar=False, random_state=0, **kwargs)
    y_hat = model.predict(rec.u_test, y_init=rec.y_test[:N_INIT])
    settings = model.identification_["settings"]
    return y_hat, settings.get("n_terms"), str(settings.get("family"))


def _arx_fit(orders, u, y):
    from sindybench.baselines import ARX

    na, nb, nk = orders
    return ARX(na=na, nb=nb, nk=nk).fit(u, y)


def _lag_predict(model, u, y):
    return model.predict(u, y_init=y)


def _tuned_arx_orders(rec):
    nk_max = len(rec.y) // 20
    grid = [(na, nb, nk) for na in ARX_NA for nb in ARX_NA for nk in ARX_NK if nk <= nk_max]
    return choose(grid, _arx_fit, _lag_predict, rec.u, rec.y)


def run_arx(rec):
    orders = _tuned_arx_orders(rec)
    model = _arx_fit(orders, rec.u, rec.y)
    y_hat = model.predict(rec.u_test, y_init=rec.y_test[:N_INIT])
    return y_hat, int(np.count_nonzero(model.coef_) + np.count_nonzero(model.intercept_)), "na={}, nb={}, nk={}".format(
        *orders)


def run_nnarx(rec):
    from sindybench.baselines import NNARX

    na, nb, nk = _tuned_arx_orders(rec)
    na, nb = min(na, 5), min(nb, 5)

    def fit(alpha, u, y):
        return NNARX(na=na, nb=nb, nk=nk, hidden_layer_sizes=(16,), alpha=alpha, max_iter=300,
                     random_state=0).fit(u, y)

    alpha = choose((0.1, 1.0), fit, _lag_predict, rec.u, rec.y)
    model = fit(alpha, rec.u, rec.y)
    n_weights = sum(c.size + b.size for net in model.estimators_ for c, b in zip(net.coefs_, net.intercepts_))
    y_hat = model.predict(rec.u_test, y_init=rec.y_test[:N_INIT])
    return y_hat, int(n_weights + model.linear_coef_.size), f"na={na}, nb={nb}, nk={nk}, alpha={alpha:g}"


def _fastcan():
    try:
        from fastcan.narx import make_narx
    except ImportError as exc:
        raise ImportError("the fastcan method needs fastcan: pip install -e .[bench] (or pip install fastcan)") \
            from exc
    return make_narx


def _fastcan_fit(settings, u, y):
    make_narx = _fastcan()
    max_delay, degree, n_terms = settings
    model = make_narx(u, y, n_terms_to_select=n_terms, max_delay=max_delay, poly_degree=degree, refine_verbose=0,
                      verbose=0)
    return model.fit(u, y, coef_init="one_step_ahead")


def _fastcan_predict(model, u, y):
    y_init = y[:N_INIT] if y.shape[1] > 1 else y[:N_INIT, 0]
    return model.predict(u, y_init=y_init)


def run_fastcan(rec):
    settings = choose(FASTCAN_GRID, _fastcan_fit, _fastcan_predict, rec.u, rec.y)
    model = _fastcan_fit(settings, rec.u, rec.y)
    y_hat = _fastcan_predict(model, rec.u_test, rec.y_test)
    n_terms = int(np.count_nonzero(model.coef_) + np.count_nonzero(model.intercept_))
    return y_hat, n_terms, "lags={}, degree={}, terms={}".format(*settings)


def run_linear(rec):
    """The linear base alone: ``identify(..., families=["linear_ss"])``."""
    return run_identify(rec, families=["linear_ss"])


def run_identify_nl(rec):
    """``identify`` with the default families and the opt-in nonlinear family on the linear base."""
    from sindybench.identify._space import FAMILIES

    return run_identify(rec, families=[*FAMILIES, "linear_ss+nl"])


METHODS = {"identify": run_identify, "arx": run_arx, "nnarx": run_nnarx, "fastcan": run_fastcan,
           "linear": run_linear, "identify_nl": run_identify_nl}


# ---------------------------------------------------------------------------------------------- scoring
def score(system, method, rec):
    start = time.process_time()
    try:
        y_hat, n_terms, chosen = METHODS[method](rec)
    except ImportError:
        raise
    except Exception as exc:  # a failed method is a result of the table, not a crash of the script
        return {"system": system.name, "method": method, "status": f"failed: {type(exc).__name__}: {exc}"[:200],
                "cpu_s": time.process_time() - start}
    cpu = time.process_time() - start
    y = rec.y_test
    y_hat = np.asarray(y_hat, float).reshape(y.shape)
    row = {"system": system.name, "method": method, "cpu_s": cpu, "n_terms": n_terms, "chosen": chosen}
    if not np.all(np.isfinite(y_hat)):
        return row | {"status": "diverged"}
    return row | {"status": "ok", "fit_index": float(fit_index(y, y_hat, skip=N_INIT)),
                  "rmse": float(rmse(y, y_hat, skip=N_INIT)), "r2": float(r2(y, y_hat, skip=N_INIT)),
                  "fit_index_true": float(fit_index(rec.y_test_true, y_hat, skip=N_INIT))}


def _cell(row, key, fmt):
    value = row.get(key)
    if row.get("status") != "ok" and key in ("fit_index", "rmse", "r2"):
        return row.get("status", "")[:30]
    if key in ("fit_index", "r2") and value is not None and value < -999:
        return "< -999"  # drifted far away: the digits say nothing more
    return "" if value is None else format(value, fmt)


def _list_table(header, body, widths=None):
    lines = [".. list-table::", "   :header-rows: 1"]
    if widths:
        lines.append(f"   :widths: {widths}")
    lines.append("")
    for cells in [header] + body:
        lines.append(f"   * - {cells[0]}")
        lines += [f"     - {c}" for c in cells[1:]]
    return lines + [""]


def write_table(rows, path, *, subset, seed):
    """The results in rst: the fit index per system and method (best in bold), then every score."""
    methods = [m for m in METHODS if any(r["method"] == m for r in rows)]
    systems = list(dict.fromkeys(r["system"] for r in rows))
    by_key = {(r["system"], r["method"]): r for r in rows}
    summary = []
    for name in systems:
        fits = {m: by_key[name, m].get("fit_index") for m in methods if (name, m) in by_key}
        best = max((v for v in fits.values() if v is not None), default=None)
        cells = [name]
        for m in methods:
            row = by_key.get((name, m))
            text = "" if row is None else _cell(row, "fit_index", ".1f")
            cells.append(f"**{text}**" if row is not None and fits.get(m) is not None and fits[m] == best else text)
        summary.append(cells)
    medians = ["median"]
    for m in methods:
        values = [by_key[name, m]["fit_index"] if by_key[name, m].get("fit_index") is not None else -np.inf
                  for name in systems if (name, m) in by_key]
        medians.append(f"{np.median(values):.1f}" if values else "")
    summary.append(medians)
    detail = [[r["system"], r["method"], _cell(r, "fit_index", ".1f"), _cell(r, "rmse", ".4g"), _cell(r, "r2", ".4f"),
               _cell(r, "n_terms", "d"), _cell(r, "cpu_s", ".1f"), str(r.get("chosen", "")).replace("*", "\\*")]
              for r in rows]
    lines = [
        ".. This file is written by benchmarks/bench_zoo.py; do not edit by hand.",
        "",
        f"Seed {seed}; systems: {subset}. Free run on the test record from its first {N_INIT} measured samples, "
        "scored on the rest against the measured output. Fit index in percent (a failed or diverged "
        "simulation counts as minus infinity in the median):",
        "",
    ]
    lines += _list_table(["system"] + methods, summary)
    lines += ["Every score; CPU seconds of one thread for the whole method (tuning, fit, test simulation):", ""]
    lines += _list_table(["system", "method", "fit index (%)", "RMSE", "R\\ :sup:`2`", "terms", "CPU (s)", "chosen"],
                         detail)
    Path(path).write_text("\n".join(lines))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--systems", help="comma-separated names (default: every system)")
    parser.add_argument("--quick", action="store_true", help=f"the quick subset: {', '.join(QUICK)}")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated, from " + ", ".join(METHODS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="rst table to write (e.g. docs/zoo_table.rst)")
    parser.add_argument("--json", default=None, help="also write the rows as JSON (after every system)")
    parser.add_argument("--merge", default=None, help="rows of an earlier run (its --json) to keep where this run "
                                                      "has none; the table then holds both")
    parser.add_argument("--subset-text", default=None, help="how the table names its systems (default: from the "
                                                            "options)")
    parser.add_argument("--threads", default="1", help="threads of numba and BLAS (default 1)")
    args = parser.parse_args(argv)
    if args.systems:
        systems = [get_system(name) for name in args.systems.split(",")]
        subset = ", ".join(s.name for s in systems)
    elif args.quick:
        systems = [get_system(name) for name in QUICK]
        subset = "the quick subset (" + ", ".join(QUICK) + ")"
    else:
        systems, subset = zoo_systems(), "every system of the zoo"
    methods = args.methods.split(",")
    unknown = sorted(set(methods) - set(METHODS))
    if unknown:
        parser.error(f"unknown methods {unknown}; expected some of {list(METHODS)}")
    if "fastcan" in methods:
        _fastcan()  # a clear message before any work if it is missing
    earlier = json.loads(Path(args.merge).read_text()) if args.merge else []
    rows = []
    for system in systems:
        rec = system.record(args.seed)
        for method in methods:
            row = score(system, method, rec)
            rows.append(row)
            print(f"{row['system']:30s} {method:9s} fit {_cell(row, 'fit_index', '.1f'):>8s}  "
                  f"rmse {_cell(row, 'rmse', '.4g'):>10s}  terms {_cell(row, 'n_terms', 'd'):>5s}  "
                  f"cpu {row['cpu_s']:6.1f} s  {row.get('chosen', '')}", flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    new = {(r["system"], r["method"]) for r in rows}
    order = {name: i for i, name in enumerate(s.name for s in zoo_systems())}
    rows = sorted([r for r in earlier if (r["system"], r["method"]) not in new] + rows,
                  key=lambda r: (order.get(r["system"], len(order)), list(METHODS).index(r["method"])))
    if args.out:
        write_table(rows, args.out, subset=args.subset_text or subset, seed=args.seed)


if __name__ == "__main__":
    main()
