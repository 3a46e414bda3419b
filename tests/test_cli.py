"""The ``sindybench`` command and the experiment runner behind it.

A synthetic benchmark exercises the runner and the report writers quickly;
``sindybench run all --quick`` on the real records is the smoke test of the
whole study (files exist, every number and every figure is finite), and the
documentation is built from its output with warnings as errors.
"""

import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sklearn.utils import Bunch

from sindybench import load_model
from sindybench.cli import build_parser, main
from sindybench.experiments import (
    PUBLISHED,
    Benchmark,
    DataNotFoundError,
    ModelSpec,
    fit_from_r2,
    get_benchmark,
    run_benchmarks,
)
from sindybench.experiments._common import arx_model, arx_space, refinement, sindy_model, stls_space
from sindybench.experiments._runner import run_benchmark
from test_examples import NOTEBOOKS  # the notebooks, the figures and typeset models each must show
from sindybench.metrics import r2

ROOT = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- synthetic benchmark
def _record(rng, n, dt=0.1):
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20 + 1), 20)[:n, None]
    y = np.zeros((n, 1))
    for k in range(1, n):  # exact discretisation of y' = -0.5 y + u with u held
        y[k] = math.exp(-0.5 * dt) * y[k - 1] + 2.0 * (1.0 - math.exp(-0.5 * dt)) * u[k - 1]
    return Bunch(u=u, y=y, dt=dt, t=np.arange(n) * dt)


def _synthetic(fail_load=False):
    def load(*, data_home=None, download_if_missing=True):
        if fail_load:
            raise FileNotFoundError(f"toy/record.mat not found in {data_home}")
        rng = np.random.default_rng(0)
        return Bunch(train=_record(rng, 600), validation=_record(rng, 200), test=_record(rng, 300), n_init=2)

    def poly():
        from sindybench.libraries import PolynomialLibrary

        return PolynomialLibrary(degree=1)

    return Benchmark(
        name="toy", title="Toy first-order system", load=load, n_init=2,
        models=(
            ModelSpec("sindy_poly", "SINDy", sindy_model(poly, threshold=0.05),
                      stls_space(threshold=(1e-3, 1e-1)), n_trials=4, n_trials_quick=2),
            ModelSpec("arx", "ARX", arx_model({"na": 1, "nb": 1}), arx_space(2, 2), n_trials=3, n_trials_quick=2),
        ),
    )


def test_runner_writes_every_output(tmp_path):
    other = dataclasses.replace(_synthetic(), name="toy2")
    report = run_benchmarks([_synthetic(), other], tmp_path / "out", quick=True, seed=3)
    assert report == tmp_path / "out" / "report.md" and report.is_file()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["report.md", "toy", "toy2"]
    folder = tmp_path / "out" / "toy"
    results = json.loads((folder / "results.json").read_text())
    assert results["seed"] == 3 and results["quick"] is True
    test = _synthetic().load()["test"]
    for model in results["models"]:
        assert model["status"] == "ok" and model["n_trials"] == 2
        scores = model["scores"]["test"]
        assert scores["r2"] > 0.99, model  # the toy system is in both model classes
        assert 100 * (1 - math.sqrt(1 - scores["r2"])) == pytest.approx(scores["fit_index"], rel=1e-9)
        # the model file is a real model: it simulates the test set to the very score of the run
        loaded = load_model(folder / results["files"]["models"][model["key"]])
        assert r2(test.y, loaded.predict(test.u, y_init=test.y[:2])) == scores["r2"]
    assert (folder / "test_test.png").stat().st_size > 1000
    assert "| SINDy |" in (folder / "results.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left


def test_refinement_row_refines_the_fitted_model():
    toy = _synthetic()
    rows = (ModelSpec("sindy_poly_refined", "SINDy + refinement", refinement(), refines="sindy_poly"),)
    bench = dataclasses.replace(toy, models=toy.models[:1] + rows)
    # asking for the refinement row alone runs the model it refines first
    results, fitted, _ = run_benchmark(bench, quick=True, seed=0, models=["sindy_poly_refined"])
    base, refined = results["models"]
    assert [base["key"], refined["key"]] == ["sindy_poly", "sindy_poly_refined"]
    assert refined["status"] == "ok" and refined["n_trials"] == 0
    assert refined["best_params"] == {}  # SINDy has no inner search: its outer choice is in the clone
    assert fitted["sindy_poly_refined"].optimizer.threshold == fitted["sindy_poly"].optimizer.threshold
    record = refined["refinement"]
    assert record["jacobian"] == "sensitivity" and record["cost"] <= record["initial_cost"]
    assert fitted["sindy_poly"].refine is None and fitted["sindy_poly_refined"].refine is not None
    assert refined["scores"]["test"]["rmse"] <= 1.01 * base["scores"]["test"]["rmse"]


def test_refinement_row_without_its_model_fails_cleanly():
    toy = _synthetic(fail_load=False)
    rows = (ModelSpec("ghost_refined", "refined ghost", refinement(), refines="ghost"),)
    results, fitted, _ = run_benchmark(dataclasses.replace(toy, models=rows), quick=True)
    assert fitted["ghost_refined"] is None
    assert "'ghost', was not fitted" in results["models"][0]["status"]


def test_runner_failure_leaves_no_files(tmp_path, monkeypatch):
    import sindybench.experiments._registry as registry

    real = registry.run_benchmark

    def second_fails(benchmark, **kwargs):
        if benchmark.name == "toy2":
            raise RuntimeError("boom in the second benchmark")
        return real(benchmark, **kwargs)

    monkeypatch.setattr(registry, "run_benchmark", second_fails)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("user file")
    with pytest.raises(RuntimeError, match="boom"):
        run_benchmarks([_synthetic(), dataclasses.replace(_synthetic(), name="toy2")], tmp_path / "out", quick=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["keep.txt"]


def test_missing_data_is_reported_before_training(tmp_path):
    with pytest.raises(DataNotFoundError, match=r"(?s)toy/record\.mat.*SINDYBENCH_DATA"):
        run_benchmarks([_synthetic(), _synthetic(fail_load=True)], tmp_path / "out", data_home=tmp_path)
    assert not (tmp_path / "out").exists()


def test_bad_storage_is_reported_before_training(tmp_path):
    with pytest.raises(ValueError, match="storage 'study.csv' is not understood"):
        run_benchmarks([_synthetic()], tmp_path / "out", quick=True, storage="study.csv")
    assert list(tmp_path.iterdir()) == []


def test_report_figure_draws_every_model_with_the_public_plotting():
    from sindybench.experiments._report import _test_figure

    t = np.arange(200) * 0.1
    test = Bunch(u=np.sin(t)[:, None], y=np.cos(t)[:, None], dt=0.1)
    results = {"title": "Toy", "dt": 0.1, "output_label": "y", "input_label": "u", "models": [
        {"key": key, "label": key.upper(), "scores": {"test": {"r2": 0.5}}} for key in ("good", "wild", "lost")]}
    fig = _test_figure(results, "test", test, {"good": test.y + 0.1, "wild": 1e3 * t[:, None], "lost": None})
    ax, ax_u = fig.axes[:2]
    assert [line.get_label() for line in ax.get_lines()] == [
        "measured", "GOOD (R^2 0.98, fit 86.0 %)", "WILD (R^2 -259910631.28, fit -1612074.4 %), leaves the frame"]
    np.testing.assert_array_equal(ax_u.get_lines()[0].get_ydata(), test.u[:, 0])
    assert ax.get_title() == "Toy: open-loop simulation, test set 'test'"


def test_published_figures_name_existing_models():
    for name, models in PUBLISHED.items():
        keys = {m.key for m in get_benchmark(name).models}
        assert set(models) <= keys, name
    assert fit_from_r2(0.94) == pytest.approx(75.505, abs=1e-3)


# --------------------------------------------------------------------------- command line
@pytest.mark.parametrize(
    "argv, message",
    [
        (["run", "tanks"], "invalid choice: 'tanks'"),
        (["run", "all", "--trials", "-1"], "expected an integer >= 0"),
        (["run", "all", "--seed", "x"], "expected an integer >= 0"),
        (["run", "all", "--n-jobs", "0"], "positive integer or -1"),
        (["run", "all", "--storage", "study.csv"], "argument --storage: storage 'study.csv' is not understood"),
        (["run", "all", "--storage", "sqlite:///no_such_folder/s.db"], "'no_such_folder' does not exist"),
        ([], "the following arguments are required"),
    ],
)
def test_bad_arguments_exit_2(argv, message, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert message in capsys.readouterr().err


def test_parser_defaults():
    args = build_parser().parse_args(["run", "bouc-wen"])
    assert (args.trials, args.seed, args.n_jobs, args.quick, args.storage) == (None, 0, 1, False, None)


def test_missing_data_message_and_exit_status(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "sindybench.cli", "run", "cascaded-tanks", "--data-home", str(tmp_path / "empty"),
         "--no-download", "--out", str(out)],
        capture_output=True, text=True, timeout=120, env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    for text in ("dataBenchmark.mat", str(tmp_path / "empty"), "SINDYBENCH_DATA", "--data-home"):
        assert text in proc.stderr
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name != "empty"]


# --------------------------------------------------------------------------- simulate a saved model
def _write_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "".join(",".join(str(v) for v in row) + "\n" for row in rows))
    return path


@pytest.fixture(scope="module")
def saved_models(tmp_path_factory):
    """A toy record and two saved models of it: SINDy with named inputs, ARX without names."""
    from sindybench import SINDy
    from sindybench.baselines import ARX
    from sindybench.libraries import PolynomialLibrary

    folder = tmp_path_factory.mktemp("simulate")
    rec = _record(np.random.default_rng(1), 300)
    u = np.hstack([rec.u, 0.5 * rec.u**2])
    sindy = SINDy(library=PolynomialLibrary(degree=1), dt=rec.dt, input_names=["pump", "aux"]).fit(u, rec.y)
    arx = ARX(na=1, nb=1).fit(u, rec.y)
    sindy.to_json(folder / "sindy.json")
    arx.to_json(folder / "arx.json")
    inputs = _write_csv(folder / "u.csv", ["aux", "pump", "time"], np.column_stack([u[:, 1], u[:, 0], rec.t]))
    return folder, u, rec.y, {"sindy": sindy, "arx": arx}, inputs


@pytest.mark.parametrize("key, y_init", [("sindy", False), ("sindy", True), ("arx", True), ("arx", False)])
def test_simulate_command_writes_the_models_prediction(saved_models, tmp_path, key, y_init):
    folder, u, y, models, inputs = saved_models
    if key == "arx":  # no input names: the columns are taken in order
        inputs = _write_csv(tmp_path / "u.csv", ["a", "b"], u)
    argv = ["simulate", str(folder / f"{key}.json"), "--input", str(inputs), "--output", str(tmp_path / "y.csv"), "-q"]
    if y_init:
        argv += ["--y-init", str(_write_csv(tmp_path / "y0.csv", ["level"], y[:5]))]
    assert main(argv) == 0
    header, *rows = (tmp_path / "y.csv").read_text().splitlines()
    model = models[key]
    expected = model.predict(u, y_init=y[:5]) if y_init else (
        model.predict(u, x0=model.x0_) if key == "sindy" else model.predict(u))
    assert header == "y0" and np.array_equal(np.array([float(r) for r in rows]), np.asarray(expected).ravel())


@pytest.mark.parametrize("edit, message", [
    (lambda d: _write_csv(d / "u.csv", ["aux", "time"], [[0.1, 0.0], [0.2, 0.1]]), "no column 'pump'"),
    (lambda d: _write_csv(d / "u.csv", ["aux", "pump"], [[0.1, 0.0], [0.2, "nan"]]),
     "line 3, column 'pump': 'nan'; expected a finite number"),
    (lambda d: _write_csv(d / "u.csv", ["aux", "pump"], [[0.1, 0.0], [0.2, ""]]), "line 3, column 'pump': ''"),
    (lambda d: _write_csv(d / "u.csv", ["aux", "pump"], [[0.1, 0.0], [0.2]]), "line 3: 1 values; expected 2"),
    (lambda d: _write_csv(d / "u.csv", ["aux", "pump"], []), "has no samples"),
    (lambda d: _write_csv(d / "y0.csv", ["a", "b"], [[0.1, 0.0]]), "y_init has 2 columns; expected 1"),
    (lambda d: (d / "model.json").write_text('{"format": "sindybench-model", '), "is not valid JSON"),
    (lambda d: (d / "model.json").unlink(), "No such file"),
])
def test_simulate_command_errors_write_nothing(saved_models, tmp_path, capsys, edit, message):
    folder, u, y, models, inputs = saved_models
    shutil.copy(folder / "sindy.json", tmp_path / "model.json")
    shutil.copy(inputs, tmp_path / "u.csv")
    _write_csv(tmp_path / "y0.csv", ["level"], y[:3])
    edit(tmp_path)
    status = main(["simulate", str(tmp_path / "model.json"), "--input", str(tmp_path / "u.csv"),
                   "--y-init", str(tmp_path / "y0.csv"), "--output", str(tmp_path / "y.csv")])
    assert status == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "y.csv").exists() and not list(tmp_path.glob(".y.csv*"))


def test_simulate_command_wrong_number_of_inputs(saved_models, tmp_path, capsys):
    folder, u, y, models, inputs = saved_models
    _write_csv(tmp_path / "u.csv", ["a"], u[:, :1])
    assert main(["simulate", str(folder / "arx.json"), "--input", str(tmp_path / "u.csv"), "--output",
                 str(tmp_path / "y.csv")]) == 2
    assert "has 1 column(s) ['a']; the model has 2 input(s)" in capsys.readouterr().err
    assert not (tmp_path / "y.csv").exists()


# --------------------------------------------------------------------------- smoke run of the study
@pytest.fixture(scope="module")
def quick_run(tmp_path_factory, data_home):
    out = tmp_path_factory.mktemp("quick") / "results"
    status = main(["run", "all", "--quick", "--no-progress", "-q", "--out", str(out), "--data-home", str(data_home),
                   "--no-download"])
    assert status == 0
    return out


def _numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _numbers(v)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield obj


@pytest.mark.parametrize("name", ["pick-and-place", "bouc-wen", "cascaded-tanks"])
def test_quick_run_outputs(quick_run, name):
    import matplotlib.image

    folder = quick_run / name
    results = json.loads((folder / "results.json").read_text())
    benchmark = get_benchmark(name)
    assert [m["key"] for m in results["models"]] == [m.key for m in benchmark.models]
    assert all(math.isfinite(x) for x in _numbers(results))
    for model in results["models"]:
        assert model["status"] == "ok", model["status"]
        loaded = load_model(folder / results["files"]["models"][model["key"]])
        assert getattr(loaded, "equations", list)() == model["equations"]
        for test_name, scores in model["scores"].items():
            assert scores["status"] == "ok", (model["key"], test_name, scores["status"])
            assert scores["rmse"] > 0 and scores["fit_index"] < 100
    assert set(results["files"]["figures"]) >= set(results["test_sets"])
    if benchmark.hysteresis_test:
        assert "hysteresis" in results["files"]["figures"]
    for figure in results["files"]["figures"].values():
        image = matplotlib.image.imread(folder / figure)
        assert image.ndim == 3 and image.shape[0] > 100 and np.all(np.isfinite(image))
        assert image.std() > 0.01  # not a blank canvas
    text = (folder / "results.md").read_text()
    assert results["title"] in text and "R^2 (study)" in text


def test_quick_run_report(quick_run):
    text = (quick_run / "report.md").read_text()
    for title in ("Pick-and-place machine", "Bouc-Wen oscillator", "Cascaded tanks"):
        assert title in text
    assert "Total wall time" in text
    # the fit time of each model family and its share of the wall time, the NN-ARX baselines among them
    assert re.search(r"Fit times: .*nnarx \d+\.\d s \(\d+ %", text)


def test_docs_build_with_generated_figures(quick_run, notebooks, tmp_path):
    """The docs build (warnings as errors) with the run's figures, the notebooks' outputs and the API figures."""
    sphinx = pytest.importorskip("sphinx.cmd.build", reason="the docs extra (sphinx, numpydoc, myst-nb) is missing")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_nb")
    shutil.copytree(ROOT / "docs", tmp_path / "docs",
                    ignore=shutil.ignore_patterns("_build", "_generated", "generated", "notebooks", "jupyter_execute"))
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    shutil.copytree(quick_run, tmp_path / "docs" / "_generated")
    executed = tmp_path / "docs" / "_generated" / "notebooks"
    executed.mkdir()
    for name in NOTEBOOKS:  # executed once, by the notebook tests' runner: the build only renders them
        notebooks.run(name)
        shutil.copy(notebooks.folder / f"{name}.ipynb", executed)
    status = sphinx.build_main(["-W", "-q", "-b", "html", str(tmp_path / "docs"), str(tmp_path / "html")])
    assert status == 0
    html = tmp_path / "html"
    page = (html / "case_studies" / "bouc_wen.html").read_text()
    assert "hysteresis_sine.png" in page and "Hidden SINDy" in page and "notebooks/bouc_wen.html" in page
    for name, (_, n_figures, latex) in NOTEBOOKS.items():
        page = (html / "notebooks" / f"{name}.html").read_text()
        assert page.count("<img") >= n_figures, name  # the figures the notebook test counted
        assert ("\\begin{aligned}" in page) == latex, name  # fitted models typeset as math
        assert "Traceback" not in page
    api = (html / "api.html").read_text()
    images = re.findall(r'src="(_images/api-\d+\.png)"', api)  # the plotting module's figures
    assert len(images) == 5 and all((html / src).is_file() for src in images)


# --------------------------------------------------------------------------- workers sharing a PostgreSQL study
def _cli_worker(out, storage, data_home, trials):
    return subprocess.Popen(
        [sys.executable, "-m", "sindybench.cli", "run", "cascaded-tanks", "--quick", "--trials", str(trials),
         "--storage", storage, "--out", str(out), "--data-home", str(data_home), "--no-download", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "MPLBACKEND": "Agg"},
    )


def _finished(trials):
    return {t.number: (t.params, t.value) for t in trials if t.state.name in ("COMPLETE", "PRUNED")}


def test_cli_workers_share_a_postgresql_study_and_survive_a_kill(postgres_url, data_home, tmp_path):
    """Two ``sindybench run --storage postgresql+psycopg://...`` share the searches; one is SIGKILLed.

    The killed run is started again (same command) while the other still runs. The
    trial in flight at the kill stays RUNNING until a worker on this host sees that
    its process is gone (the survivor after its next trial, or the rerun when it
    starts) and marks it FAIL, which gives its place in the budget back. Every search
    ends with exactly ``--trials`` finished trials and no trial finished before the
    kill is lost; the killed run wrote nothing.
    """
    import optuna

    from sindybench.model_selection._storage import make_storage

    trials, first = 8, "cascaded-tanks.sindy_poly.seed0"
    searched = [m.key for m in get_benchmark("cascaded-tanks").models if m.search_space is not None]
    storage = make_storage(postgres_url)
    victim, survivor = (_cli_worker(tmp_path / name, postgres_url, data_home, trials) for name in "ab")
    deadline = time.monotonic() + 60
    while True:  # kill the victim in the middle of the first search, after a few trials finished
        assert time.monotonic() < deadline and victim.poll() is None, "the run ended before it could be killed"
        try:
            done = _finished(optuna.load_study(study_name=first, storage=storage).get_trials(deepcopy=False))
        except KeyError:  # the study does not exist yet
            done = {}
        if len(done) >= 3:
            break
        time.sleep(0.02)
    os.kill(victim.pid, signal.SIGKILL)
    victim.wait()
    before = _finished(optuna.load_study(study_name=first, storage=storage).get_trials(deepcopy=False))
    assert not (tmp_path / "a").exists()  # a killed run leaves no output folder

    rerun = _cli_worker(tmp_path / "a", postgres_url, data_home, trials)
    for proc in (survivor, rerun):
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err
    names = set(optuna.get_all_study_names(storage=storage))
    assert names == {f"cascaded-tanks.{key}.seed0" for key in searched}
    for name in names:
        study_trials = optuna.load_study(study_name=name, storage=storage).get_trials(deepcopy=False)
        assert len(_finished(study_trials)) == trials, name
        assert not [t for t in study_trials if t.state.name in ("RUNNING", "WAITING")], name
        # a FAIL trial is the one the kill interrupted, or one that stood down because the budget was full
        failed = [t for t in study_trials if t.state.name == "FAIL"]
        assert len([t for t in failed if t.user_attrs.get("worker", "").endswith(f":{victim.pid}")]) <= 1
        assert all(t.user_attrs.get("worker", "").endswith(f":{victim.pid}")
                   or "budget" in t.user_attrs.get("fail_reason", "") for t in failed), name
    after = _finished(optuna.load_study(study_name=first, storage=storage).get_trials(deepcopy=False))
    assert {n: after[n] for n in before} == before
    for out in (tmp_path / "a", tmp_path / "b"):
        results = json.loads((out / "cascaded-tanks" / "results.json").read_text())
        assert results["storage"] == postgres_url  # no password in this URL: shown as given
        assert all(m["status"] == "ok" for m in results["models"])
