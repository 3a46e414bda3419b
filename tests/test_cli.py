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
from sindybench.experiments._common import arx_model, arx_space, sindy_model, stls_space

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
    for model in results["models"]:
        assert model["status"] == "ok" and model["n_trials"] == 2
        scores = model["scores"]["test"]
        assert scores["r2"] > 0.99, model  # the toy system is in both model classes
        assert 100 * (1 - math.sqrt(1 - scores["r2"])) == pytest.approx(scores["fit_index"], rel=1e-9)
        assert (folder / "models" / f"{model['key']}.json").is_file()
    assert (folder / "test_test.png").stat().st_size > 1000
    assert "| SINDy |" in (folder / "results.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left


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


def test_figure_keeps_the_frame_on_the_measurement():
    from sindybench.experiments._report import plot_test

    t = np.arange(200) * 0.1
    test = Bunch(u=np.sin(t)[:, None], y=np.cos(t)[:, None], dt=0.1)
    results = {"title": "Toy", "dt": 0.1, "output_label": "y", "input_label": "u", "models": [
        {"key": key, "label": key, "scores": {"test": {"r2": 0.5}}} for key in ("good", "wild")]}
    close = test.y + 0.1
    fig = plot_test(results, "test", test, {"good": close, "wild": close})
    assert fig.axes[0].get_ylim()[1] < 1.5  # no model leaves the frame: matplotlib's own limits
    fig = plot_test(results, "test", test, {"good": close, "wild": 1e3 * t[:, None]})
    assert fig.axes[0].get_ylim() == pytest.approx((-2.0, 2.0), abs=1e-3)
    assert fig.axes[0].get_legend().get_texts()[2].get_text() == "wild (R^2 0.50), leaves the frame"


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
        assert json.loads((folder / results["files"]["models"][model["key"]]).read_text())
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


def test_docs_build_with_generated_figures(quick_run, tmp_path):
    sphinx = pytest.importorskip("sphinx.cmd.build", reason="the docs extra (sphinx, numpydoc) is not installed")
    pytest.importorskip("numpydoc")
    shutil.copytree(ROOT / "docs", tmp_path / "docs", ignore=shutil.ignore_patterns("_build", "_generated", "generated"))
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    shutil.copytree(quick_run, tmp_path / "docs" / "_generated")
    status = sphinx.build_main(["-W", "-q", "-b", "html", str(tmp_path / "docs"), str(tmp_path / "html")])
    assert status == 0
    page = (tmp_path / "html" / "case_studies" / "bouc_wen.html").read_text()
    assert "hysteresis_sine.png" in page and "Hidden SINDy" in page


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
