"""The ``sindybench`` command and the experiment runner behind it.

A synthetic benchmark exercises the runner and the report writers quickly;
``sindybench run all --quick`` on the real records is the smoke test of the
whole study (files exist, every number and every figure is finite), and the
documentation is built from its output with warnings as errors.
"""

import base64
import contextlib
import dataclasses
import html
import io
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sklearn.utils import Bunch

from sindybench import load_model
from sindybench import _cli_args
from sindybench.cli import build_parser, main
from sindybench.experiments import (
    PUBLISHED,
    Benchmark,
    DataNotFoundError,
    ModelSpec,
    fit_from_r2,
    get_benchmark,
    results_markdown,
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
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["index.html", "report.md", "toy", "toy2"]
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
    page = (folder / "report.html").read_text()  # the HTML page embeds the very PNG of the run
    assert base64.b64encode((folder / "test_test.png").read_bytes()).decode() in page
    assert 'href="toy/report.html"' in (tmp_path / "out" / "index.html").read_text()
    assert "| SINDy |" in (folder / "results.md").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left


def test_a_protocol_scores_only_the_samples_after_those_that_set_the_state():
    """A test set with ``score_from`` (EMPS: 20) is scored from that sample on; without it, on all samples."""
    from sindybench.experiments import evaluate
    from sindybench.metrics import rmse

    y = np.arange(8.0)[:, None]

    class Shifted:  # a stand-in model whose simulation is 10 off on the first 3 samples, 1 off after them
        def predict(self, X, y_init):
            return y + np.r_[np.full(3, 10.0), np.ones(5)][:, None]

    test = Bunch(u=np.zeros((8, 1)), y=y, dt=1.0)
    _, all_samples = evaluate(Shifted(), test, 3)
    assert all_samples["rmse"] == pytest.approx(rmse(y, Shifted().predict(None, None)))
    _, after = evaluate(Shifted(), Bunch(**test, score_from=3), 3)
    assert after["rmse"] == pytest.approx(1.0) and after["status"] == "ok"
    assert after["r2"] == pytest.approx(r2(y[3:], y[3:] + 1))


def test_pick_and_place_neural_state_space_protocol(data_home):
    """Forgione et al. (2022): raw record scaled by its own mean and std, every 10th sample, split at raw 50,000."""
    from scipy.io import loadmat

    data = get_benchmark("pick-and-place-nss").load(data_home=data_home)
    raw = loadmat(data_home / "pick_and_place" / "headdata_1v6.mat")
    u, y = raw["u"][:, 0], raw["y"][:, 0]
    assert (len(data.train.y), len(data.validation.y), len(data.test.y)) == (4000, 1000, 1001)
    assert data.dt == pytest.approx(2.5e-3) and data.test.n_init == data.test.score_from == 20
    np.testing.assert_allclose(data.train.u[:, 0], ((u - u.mean()) / u.std())[:40000:10])
    np.testing.assert_allclose(data.validation.y[:, 0], ((y - y.mean()) / y.std())[40000:50000:10])
    np.testing.assert_allclose(data.test.y[:, 0], ((y - y.mean()) / y.std())[50000::10])
    assert data.test.t[0] == pytest.approx(12.5)  # the test part starts at 12.5 s


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
    # the report gives the refined row's time with the search it reuses
    assert refined["fit_time_with_search_s"] == pytest.approx(refined["fit_time_s"] + base["fit_time_s"])
    assert base["fit_time_s"] > 0 and "fit_time_with_search_s" not in base
    assert "s with the search of `sindy_poly`)" in results_markdown({**results, "wall_time_s": 1.0})


def _identify_row(key, families):
    def make(*, random_state, quick, dt, n_val, n_samples):
        from sindybench.identify import IdentifyCV

        return IdentifyCV(dt=dt, families=families, libraries=["linear"], derivatives=["finite_difference"],
                          n_refine=1, max_path=3, n_init=2, random_state=random_state, show_progress_bar=False)

    return ModelSpec(key, key, make)


def test_a_benchmarks_identify_rows_share_their_candidates():
    # as Silverbox's "identified" and "identified_equations": the second row's search reads back the candidates
    # the first computed, and scores what it scores alone
    rows = (_identify_row("with_lag", ["first_order", "lag"]), _identify_row("equations", ["first_order"]))
    bench = dataclasses.replace(_synthetic(), models=rows)
    both, fitted, _ = run_benchmark(bench, quick=True, seed=0)
    alone, fitted_alone, _ = run_benchmark(bench, quick=True, seed=0, models=["equations"])
    assert fitted["with_lag"].n_resumed_ == 0 and fitted_alone["equations"].n_resumed_ == 0
    assert fitted["equations"].n_resumed_ > 0
    shared, own = both["models"][1], alone["models"][0]
    assert shared["key"] == own["key"] == "equations" and shared["status"] == own["status"] == "ok"
    assert shared["scores"] == own["scores"] and shared["equations"] == own["equations"]


def test_refinement_row_without_its_model_fails_cleanly():
    toy = _synthetic(fail_load=False)
    rows = (ModelSpec("ghost_refined", "refined ghost", refinement(), refines="ghost"),)
    results, fitted, _ = run_benchmark(dataclasses.replace(toy, models=rows), quick=True)
    assert fitted["ghost_refined"] is None
    assert "'ghost', was not fitted" in results["models"][0]["status"]


def test_runner_failure_leaves_no_files(tmp_path, monkeypatch):
    import sindybench.experiments._parallel as runner

    real = runner.run_benchmark

    def second_fails(benchmark, **kwargs):
        if benchmark.name == "toy2":
            raise RuntimeError("boom in the second benchmark")
        return real(benchmark, **kwargs)

    monkeypatch.setattr(runner, "run_benchmark", second_fails)
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
    full, zoom, spectrum = fig.axes[:3]
    # the error-centred form: the output and each model's error; a model as wrong as the output is named, not drawn
    drawn = [line for line in full.get_lines() if not line.get_label().startswith("_")]
    assert [line.get_label() for line in drawn] == ["measured output", "error of GOOD (RMSE 0.1)"]
    np.testing.assert_allclose(drawn[1].get_ydata()[1:], -0.1)  # measured minus simulated, after n_init
    assert "WILD" in full.get_legend().get_title().get_text()
    assert [line.get_label() for line in spectrum.get_lines()] == ["measured output", "error of WILD", "error of GOOD"]
    assert fig.get_suptitle() == "Toy: open-loop simulation errors, test set 'test'"


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


def test_cli_lists_the_registrys_benchmarks(capsys):
    """The command's benchmark names are the registry's (one list), and ``all`` runs each of them."""
    import sindybench.cli
    from sindybench.experiments import BENCHMARKS

    assert "silverbox" in BENCHMARKS and not hasattr(sindybench.cli, "BENCHMARK_NAMES")
    for name in (*BENCHMARKS, "all"):
        assert build_parser().parse_args(["run", name]).benchmark == name
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "silverbox" in capsys.readouterr().out


def test_cli_runs_all_the_registrys_benchmarks(monkeypatch, tmp_path):
    from sindybench import experiments
    from sindybench.experiments import BENCHMARKS

    asked = []

    def run_benchmarks(benchmarks, out, **kwargs):  # writes what a run writes, trains nothing
        for name in asked:
            (out / name).mkdir(parents=True)
            (out / name / "results.json").write_text(json.dumps({"models": []}))
        (out / "report.md").write_text("report")
        return out / "report.md"

    monkeypatch.setattr(experiments, "get_benchmark", lambda name: asked.append(name) or name)
    monkeypatch.setattr(experiments, "run_benchmarks", run_benchmarks)
    assert main(["run", "all", "--no-progress", "-q", "--out", str(tmp_path / "out")]) == 0
    assert asked == list(BENCHMARKS)


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


# --------------------------------------------------------------------------- the output folder, exit status
@pytest.fixture
def toy_cli(monkeypatch):
    """``sindybench run cascaded-tanks`` runs the synthetic benchmark (named cascaded-tanks); counts its loads."""
    import sindybench.experiments as experiments

    loads = []
    toy = _synthetic()

    def load(**kwargs):
        loads.append(kwargs)
        return toy.load(**kwargs)

    bench = dataclasses.replace(toy, name="cascaded-tanks", load=load)
    monkeypatch.setattr(experiments, "get_benchmark", lambda name: bench)
    return bench, loads


def _run_toy(out, *extra):
    return main(["run", "cascaded-tanks", "--quick", "--no-progress", "-q", "--out", str(out), *extra])


def test_run_keeps_the_users_files_in_the_output_folder(toy_cli, tmp_path):
    # issue 18, case 1: the old benchmark folder was renamed away and removed, with the user's files in it
    out = tmp_path / "out"
    (out / "cascaded-tanks" / "models").mkdir(parents=True)
    mine = {out / "notes.txt": "top", out / "cascaded-tanks" / "my_notes.txt": "notes",
            out / "cascaded-tanks" / "models" / "my_model.json": "{}", out / "cascaded-tanks" / "results.md": "old"}
    for path, text in mine.items():
        path.write_text(text)
    for _ in range(2):  # a first run into the user's folder, then a second over the first
        assert _run_toy(out) == 0
        for path, text in mine.items():
            if path.name != "results.md":  # a file of the run's own name is the run's to replace
                assert path.read_text() == text, path
        assert "| SINDy |" in (out / "cascaded-tanks" / "results.md").read_text()
        assert (out / "cascaded-tanks" / "models" / "arx.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging folder left


@pytest.mark.parametrize("make, argv, message", [
    (lambda d: (d / "x.db").write_text("notes\n"), ["--storage", "{d}/x.db"], "is not an SQLite database"),
    (None, ["--storage", "foo://x"], "'foo' is not a database kind"),
    (None, ["--seed", str(2**32)], "expected an integer in [0, 2**32 - 1]"),
    (lambda d: (d / "out").write_text("a file"), [], "out is a file; expected a folder"),
    (lambda d: (d / "out" / "cascaded-tanks").mkdir(parents=True) or (d / "out" / "cascaded-tanks" / "models")
     .write_text("x"), [], "models is a file; the run writes a folder of that name"),
])
def test_run_refuses_bad_storage_seed_and_output_before_any_work(toy_cli, tmp_path, capsys, make, argv, message):
    # issue 18, cases 2 and 4: these ran the whole job (every model "failed to fit", exit 0, or a
    # FileExistsError traceback after the work); now they stop before the data are even loaded
    if make is not None:
        make(tmp_path)
    before = sorted(str(p) for p in tmp_path.rglob("*"))
    try:
        status = _run_toy(tmp_path / "out", *[a.format(d=tmp_path) for a in argv])
    except SystemExit as exc:  # refused by the argument parser
        status = exc.code
    assert status == 2
    assert message in capsys.readouterr().err
    assert toy_cli[1] == [] and sorted(str(p) for p in tmp_path.rglob("*")) == before


def test_run_with_models_that_fail_exits_1_and_names_them(toy_cli, tmp_path, capsys, monkeypatch):
    # issue 18, case 2: a run whose models could not be fitted exited 0
    import sindybench.experiments as experiments

    def broken(**kwargs):
        raise RuntimeError("no estimator today")

    bench = dataclasses.replace(toy_cli[0], models=(*toy_cli[0].models[:1], ModelSpec("broken", "Broken", broken)))
    monkeypatch.setattr(experiments, "get_benchmark", lambda name: bench)
    status = _run_toy(tmp_path / "out")
    err = capsys.readouterr().err
    assert status == 1
    assert "1 model(s) could not be fitted" in err and "cascaded-tanks/broken: fit failed: RuntimeError: no estimator" in err
    results = json.loads((tmp_path / "out" / "cascaded-tanks" / "results.json").read_text())
    assert [m["status"] for m in results["models"]] == ["ok", "fit failed: RuntimeError: no estimator today"]


def test_killed_run_leaves_a_staging_folder_the_next_run_removes(toy_cli, tmp_path):
    # issue 18, case 22: a SIGKILLed run left .out.tmp-* folders that no later run removed
    out = tmp_path / "out"
    script = ("import sys, time\nfrom sindybench.experiments import staged_output_dir\n"
              "with staged_output_dir(sys.argv[1]) as tmp:\n"
              "    (tmp / 'results.json').write_text('half')\n    print(tmp, flush=True)\n    time.sleep(60)\n")
    victim = subprocess.Popen([sys.executable, "-c", script, str(out)], stdout=subprocess.PIPE, text=True)
    staging = Path(victim.stdout.readline().strip())
    victim.kill()
    victim.wait()
    assert staging.is_dir() and staging.name.startswith(".out.tmp-")
    # not provably ours, or not stale: a folder without an owner record, one of a live process, one of another host
    other = {".out.tmp-user": None, ".out.tmp-live": {"host": socket.gethostname(), "pid": os.getppid()},
             ".out.tmp-remote": {"host": "elsewhere", "pid": 1}}
    for name, record in other.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "data.txt").write_text("keep")
        if record is not None:
            (tmp_path / name / ".sindybench-staging.json").write_text(json.dumps(record))
    assert _run_toy(out) == 0
    assert not staging.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["out", *other])
    assert (out / "cascaded-tanks" / "results.json").is_file()


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
    ARX(na=1, nb=1).fit(rec.u, rec.y).to_json(folder / "arx1.json")  # one input, no names
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


def _simulate_text(folder, model, text, tmp_path, *extra):
    """Exit status and output rows of ``simulate`` on an input file holding ``text`` (str or bytes)."""
    path = tmp_path / "u.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    output = tmp_path / "y.csv"
    output.unlink(missing_ok=True)
    status = main(["simulate", str(folder / model), "--input", str(path), "--output", str(output), "-q", *extra])
    rows = output.read_text().splitlines()[1:] if output.exists() else None
    return status, rows


@pytest.mark.parametrize("text, n_rows", [
    ("0.1\n0.2\n0.3\n0.4\n", 4),  # no header row: was read as a header, and 4 rows gave 3 outputs
    ("0.1\r\n0.2\r\n0.3\r\n0.4", 4),
    ("u\n0.1\n0.2\n0.3\n\n\n", 3),  # blank lines at the end are no samples
    ("\ufeffu\n0.1\n0.2\n", 2),  # a byte-order mark (spreadsheet exports)
])
def test_simulate_reads_every_sample(saved_models, tmp_path, text, n_rows):
    # issue 18, case 3: a CSV without a header row lost its first sample
    folder, u, y, models, inputs = saved_models
    status, rows = _simulate_text(folder, "arx1.json", text, tmp_path)
    assert status == 0 and len(rows) == n_rows
    values = np.array([float(v) for v in text.lstrip("\ufeffu\n").split()])[:, None]
    expected = load_model(folder / "arx1.json").predict(values)
    assert np.array_equal(np.array([float(r) for r in rows]), np.asarray(expected).ravel())


@pytest.mark.parametrize("model, text, message", [
    # a blank line in a one-column file is a missing sample: it was dropped, and the output one sample short
    ("arx1.json", "u\n0.1\n\n0.3\n0.4\n", "line 3, column 'u': ''; expected a finite number"),
    ("arx1.json", "0.1\n\n0.3\n", "line 2, column 1: ''; expected a finite number"),
    # the line numbers count every line of the file: they were row numbers, wrong after a blank line ...
    ("arx.json", "a,b\n0.1,0.0\n\n0.2,x\n", "line 3: 0 values; expected 2"),
    # ... or after a quoted cell that spans two lines
    ("arx.json", 'a,b\n"0.1\n",0.0\n0.2,x\n', "line 4, column 'b': 'x'"),
    ("arx.json", "0.1,0.0\n0.2\n", "line 2: 1 values; expected 2 (one per column of the first row)"),
    ("arx.json", "0.1,0.0,1.0\n", "has 3 column(s) and no header row; the model has 2 input(s)"),
    ("arx1.json", b"u\n0.1\n\xff\xfe\n", "is not UTF-8 text"),
    ("arx1.json", "\nu\n0.1\n", "line 1 is blank"),
    ("arx1.json", "", "is empty"),
    ("arx1.json", " \n0.1\n", "line 1: [' '] is neither a header row (names, no numbers) nor a sample"),
    ("arx.json", ",0.5\n0.1,0.2\n", "line 1: ['', '0.5'] is neither a header row"),  # not a header: a bad sample
    ("arx1.json", "u\n0.1\n0\x002\n", "line 3, column 'u'"),
])
def test_simulate_csv_errors_name_the_file_and_line(saved_models, tmp_path, capsys, model, text, message):
    folder = saved_models[0]
    status, rows = _simulate_text(folder, model, text, tmp_path)
    err = capsys.readouterr().err
    assert status == 2 and rows is None
    assert str(tmp_path / "u.csv") in err and message in err, err


def test_simulate_y_init_errors_name_the_file(saved_models, tmp_path, capsys):
    # issue 18, case 16 (command line): the estimator's message about y_init did not say which file it was
    folder, u, y, models, inputs = saved_models
    y0 = _write_csv(tmp_path / "y0.csv", ["a", "b"], [[0.1, 0.0]])
    status, _ = _simulate_text(folder, "arx1.json", "u\n0.1\n0.2\n", tmp_path, "--y-init", str(y0))
    err = capsys.readouterr().err
    assert status == 2 and f"--y-init {y0} (1 row(s) of 2 value(s)): y_init has 2 " in err


@pytest.mark.parametrize("cell", ["1_000", "\u0663", "\uff13", "1\u0660", " \uff11.5 ", "\u0661e3"])
def test_simulate_reads_only_ascii_numbers(saved_models, tmp_path, capsys, cell):
    # issue 30, item 10: '1_000', Arabic-Indic and full-width digits were read as 1000.0, 3.0 and 3.0
    status, rows = _simulate_text(saved_models[0], "arx1.json", f"u\n0.1\n{cell}\n", tmp_path)
    err = capsys.readouterr().err
    assert status == 2 and rows is None
    assert f"line 3, column 'u': {cell.strip()!r}; expected a finite number in ASCII digits" in err, err


@pytest.mark.parametrize("source", ["/dev/zero", "long line", "big file"])
def test_simulate_refuses_an_endless_or_huge_input_within_a_second(saved_models, tmp_path, capsys, monkeypatch,
                                                                     source):
    # issue 30, item 16: --input /dev/zero ended in a MemoryError traceback
    if source == "/dev/zero" and not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    path = tmp_path / "u.csv"
    if source == "long line":
        path.write_text("u\n" + "1" * (_cli_args.MAX_CSV_LINE + 5) + "\n")
    elif source == "big file":
        monkeypatch.setattr(_cli_args, "MAX_CSV_BYTES", 4000)  # the same check as at 64 MiB, on a small file
        path.write_text("u\n" + "0.125\n" * 1000)
    start = time.perf_counter()
    status = main(["simulate", str(saved_models[0] / "arx1.json"), "--input",
                   source if source == "/dev/zero" else str(path), "--output", str(tmp_path / "y.csv")])
    err = capsys.readouterr().err
    assert time.perf_counter() - start < 1.0
    expected = "is longer than 0 MiB" if source == "big file" else "has a line longer than 1 MiB"
    assert status == 2 and expected in err and "Traceback" not in err, err
    assert not (tmp_path / "y.csv").exists()


@pytest.mark.parametrize("delay", [0.0, 0.3, 1.0])
def test_ctrl_c_while_the_command_starts_exits_130_without_a_traceback(tmp_path, delay):
    # issue 30, item 17: a Ctrl-C in the first seconds of `sindybench run` (importing the package) printed a
    # KeyboardInterrupt traceback and the process died of the signal (-2); the console script now starts in
    # sindybench_launcher, outside the package, and guards that import too
    import sindybench

    root = os.path.dirname(os.path.dirname(sindybench.__file__))
    env = {**os.environ, "PYTHONPATH": root}
    # Python's own start-up and the console script's first line (finding the launcher: milliseconds) are no place
    # for this test: start the clock once the launcher is imported, as the package import begins
    code = "import sys, sindybench_launcher; print('started', flush=True); sys.exit(sindybench_launcher.main())"
    proc = subprocess.Popen([sys.executable, "-c", code, "run", "cascaded-tanks", "--quick", "--out",
                             str(tmp_path / "out")], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as on a terminal
    assert proc.stdout.readline().strip() == "started"
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().endswith("sindybench: interrupted; no output written."), err
    assert not (tmp_path / "out").exists()


def _aliases(tmp_path, folder):
    """``{name: (argv, the file --output must not replace)}``: outputs that are one of simulate's inputs."""
    model, inputs, y0 = tmp_path / "model.json", tmp_path / "u.csv", tmp_path / "y0.csv"
    shutil.copy(folder / "arx1.json", model)
    inputs.write_text("u\n0.1\n0.2\n0.3\n")
    y0.write_text("y\n0.0\n")
    os.link(inputs, tmp_path / "hard.csv")
    os.symlink(inputs, tmp_path / "soft.csv")
    base = ["simulate", str(model), "--input", str(inputs), "--y-init", str(y0), "--output"]
    return {
        "input": (base + [str(inputs)], inputs),
        "model": (base + [str(model)], model),
        "y-init": (base + [str(y0)], y0),
        "relative": (base + [os.path.relpath(inputs)], inputs),
        "dot-dot": (base + [str(tmp_path / "sub" / ".." / "u.csv")], inputs),
        "hard link": (base + [str(tmp_path / "hard.csv")], inputs),
        "symbolic link": (base + [str(tmp_path / "soft.csv")], inputs),
    }


@pytest.mark.parametrize("case", ["input", "model", "y-init", "relative", "dot-dot", "hard link", "symbolic link"])
def test_simulate_never_writes_over_its_inputs(saved_models, tmp_path, capsys, monkeypatch, case):
    # issue 30, item 2: --input u.csv --output u.csv replaced the input with the outputs (exit 0)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    argv, target = _aliases(tmp_path, saved_models[0])[case]
    before = target.read_bytes()
    assert main(argv) == 2
    err = capsys.readouterr().err
    option = {"model": "MODEL.json", "y-init": "--y-init"}.get(case, "--input")
    assert f"is the file of {option} (" in err and "simulate never writes over what it reads" in err, err
    assert target.read_bytes() == before


RHS_MODULE = """
import numpy as np


def leak(xh, y, u, *, a):
    return -a * xh + u
"""

CLI_SCRIPT = "import sys\nfrom sindybench.cli import main\nsys.exit(main())\n"


def test_simulate_allow_import_finds_a_module_in_the_current_folder(tmp_path, monkeypatch, capsys):
    # issue 18, case 20: the console script's sys.path holds its own folder, not the current one, so
    # --allow-import could not import the user's module next to the model; without the flag, the message
    # spelled the option the Python way (allow_import=True)
    from sindybench import HiddenStateSINDy
    from sindybench.hidden import ParametricHiddenState
    from sindybench.libraries import PolynomialLibrary

    work, bin_dir = tmp_path / "work", tmp_path / "bin"
    work.mkdir()
    bin_dir.mkdir()
    (work / "my_tank_rhs.py").write_text(RHS_MODULE)
    monkeypatch.syspath_prepend(str(work))
    import my_tank_rhs

    t = np.arange(80) * 0.05
    u, y = np.sin(t)[:, None], np.cos(t)[:, None]
    hidden = ParametricHiddenState(my_tank_rhs.leak, params={"a": 0.5}, x0_bounds=(0.0, 1.0), grid_size=2,
                                   init_size=5)
    model = HiddenStateSINDy(hidden=hidden, library=PolynomialLibrary(degree=1), dt=0.05, n_trials=2,
                             random_state=0).fit(u, y)
    model.to_json(work / "model.json")
    _write_csv(work / "u.csv", ["u"], u)
    _write_csv(work / "y0.csv", ["y"], y[:5])
    (bin_dir / "sindybench_cli.py").write_text(CLI_SCRIPT)  # run as the console script is: from another folder
    argv = [sys.executable, str(bin_dir / "sindybench_cli.py"), "simulate", "model.json", "--input", "u.csv",
            "--y-init", "y0.csv", "--output", "y.csv", "-q"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONSAFEPATH"}
    proc = subprocess.run([*argv, "--allow-import"], cwd=work, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    simulated = np.array([float(r) for r in (work / "y.csv").read_text().splitlines()[1:]])
    assert np.array_equal(simulated, np.asarray(model.predict(u, y_init=y[:5])).ravel())
    (work / "y.csv").unlink()
    monkeypatch.chdir(work)
    assert main(argv[2:]) == 2
    err = capsys.readouterr().err
    assert "'my_tank_rhs:leak'" in err and "pass --allow-import" in err and "allow_import=True" not in err


# --------------------------------------------------------------------------- fuzzing simulate's CSV reading
def _cell(draw, st, valid):
    if valid:
        value = draw(st.one_of(st.floats(allow_nan=False, allow_infinity=False, width=32),
                               st.integers(-10**6, 10**6)))
        text = repr(value) if isinstance(value, float) else str(value)
        return draw(st.sampled_from(["{}", " {} ", '"{}"'])).format(text)
    return draw(st.sampled_from(["", " ", "nan", "NaN", "inf", "-inf", "1e999", "abc", "0x10", "1,5", '"1\n2"']))


def _is_float(text):
    try:
        float(text.strip().strip('"'))
    except ValueError:
        return False
    return True


def _csv_case(draw, st):
    """``(n_columns, text, n_rows, clean)``: a generated CSV file, its number of samples, whether it is clean."""
    n_columns = draw(st.sampled_from([1, 2]))
    n_rows = draw(st.integers(0, 12))
    header = draw(st.booleans())
    file_columns = draw(st.sampled_from([n_columns, n_columns, n_columns + 1, max(n_columns - 1, 1)]))
    bad_cells = draw(st.booleans())
    rows = []
    for _ in range(n_rows):
        width = file_columns if draw(st.integers(0, 9)) else draw(st.integers(0, 3))
        rows.append([_cell(draw, st, not (bad_cells and draw(st.integers(0, 4)) == 0)) for _ in range(width)])
    lines = [(",".join(row), True) for row in rows]  # (text, is a sample row)
    blank_at = draw(st.lists(st.integers(0, max(len(lines) - 1, 0)), max_size=2)) if lines else []
    for i in sorted(blank_at, reverse=True):
        lines.insert(i, ("", False))
    if header:
        names = [draw(st.sampled_from(["u", "pump", "a b", '"x,y"', "time"])) for _ in range(file_columns)]
        lines.insert(0, (",".join(names), False))
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    text = newline.join(t for t, _ in lines) + draw(st.sampled_from(["", newline, newline * 3]))
    clean = (
        n_rows > 0 and file_columns == n_columns and not blank_at
        and all(len(r) == n_columns for r in rows)
        and not any(c.strip(' "') in ("", "nan", "NaN", "inf", "-inf", "1e999", "abc", "0x10", "1,5", "1\n2")
                    for r in rows for c in r)
    )
    while lines and lines[-1][0] == "":  # empty lines at the end (an empty last row too) are no samples
        n_rows -= lines.pop()[1]
    if not header and rows and not any(_is_float(c) for c in rows[0]) and any(c.strip() for c in rows[0]):
        n_rows -= 1  # a first row of words is a header row
    return n_columns, text, n_rows, clean


def test_simulate_csv_fuzz(saved_models, tmp_path, capsys, runslow):
    """Every generated CSV gives an output of the input's length, or exit 2 with a message naming the file.

    A clean file (a number in every cell, as many columns as the model has inputs, no blank line
    inside, with or without a header row) must simulate; anything else may be refused, but only
    with a message naming the input file, never a traceback, and without writing the output. A
    quick profile by default; ``--runslow`` tries many more files.
    """
    hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
    st = hypothesis.strategies
    folder = saved_models[0]
    models = {1: "arx1.json", 2: "arx.json"}

    @hypothesis.settings(max_examples=1500 if runslow else 100, deadline=None, database=None,
                         suppress_health_check=list(hypothesis.HealthCheck))
    @hypothesis.given(data=st.data(), raw=st.one_of(st.none(), st.binary(max_size=60)))
    def check(data, raw):
        n_columns, text, n_rows, clean = _csv_case(data.draw, st)
        start = time.perf_counter()
        status, rows = _simulate_text(folder, models[n_columns], raw if raw is not None else text, tmp_path)
        err = capsys.readouterr().err
        assert time.perf_counter() - start < 10.0
        assert status in (0, 2), err
        if status == 0:
            assert rows is not None and "error" not in err
            if raw is None:
                assert len(rows) == n_rows, (text, rows)
        else:
            assert rows is None and str(tmp_path / "u.csv") in err, err
            assert raw is not None or not clean, (text, err)

    check()


# --------------------------------------------------------------------------- smoke run of the study
@pytest.fixture(scope="module")
def quick_run(tmp_path_factory, data_home):
    out = tmp_path_factory.mktemp("quick") / "results"
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr):
        status = main(["run", "all", "--quick", "--no-progress", "-q", "--out", str(out), "--data-home",
                       str(data_home), "--no-download"])
    assert status == 0
    (out.parent / "stderr.txt").write_text(stderr.getvalue())
    return out


def test_quick_run_is_quiet_and_its_report_keeps_the_warnings(quick_run):
    """-q prints nothing on stderr: the small budgets' ConvergenceWarnings and the advice go into the report."""
    assert (quick_run.parent / "stderr.txt").read_text() == ""
    results = json.loads((quick_run / "cascaded-tanks" / "results.json").read_text())
    said = {(w["kind"], w["category"]) for w in results["warnings"]}
    assert ("warning", "ConvergenceWarning") in said and ("log", "WARNING") in said
    assert all(w["count"] >= 1 for w in results["warnings"])
    assert "## Warnings" in (quick_run / "cascaded-tanks" / "results.md").read_text()
    assert "identify fits a constant term" in (quick_run / "report.md").read_text()


def _numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _numbers(v)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield obj


@pytest.mark.parametrize("name", ["pick-and-place", "pick-and-place-nss", "bouc-wen", "cascaded-tanks", "emps",
                                  "silverbox"])
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
    page = (folder / results["files"]["report"]).read_text()  # the HTML page embeds every figure of the run
    assert page.count("data:image/png;base64,") == len(results["files"]["figures"])
    assert all(html.escape(eq) in page for m in results["models"] for eq in m["equations"])


def _estimation_error():
    try:
        import sindybench.estimation  # noqa: F401
    except ImportError as exc:
        return str(exc)
    return None


@pytest.mark.parametrize("name", ["pick-and-place", "pick-and-place-nss", "bouc-wen", "cascaded-tanks", "emps",
                                  "silverbox"])
def test_quick_run_best_model(quick_run, name):
    from sindybench.experiments._best import HORIZONS

    results = json.loads((quick_run / name / "results.json").read_text())
    best = results["best_model"]
    benchmark = get_benchmark(name)
    assert best["key"] == benchmark.reported_model and best["status"] == "ok"
    errors = best["standard_errors"]
    assert errors and all(math.isfinite(v) and v > 0 for v in errors.values())
    band = best["band"]
    if benchmark.band_members_quick:
        assert band["status"] == "ok" and band["n_members"] == benchmark.band_members_quick
        assert set(band["coverage"]) == set(results["test_sets"])
        for cov in band["coverage"].values():
            assert cov["status"] == "ok" and 0.0 <= cov["coverage"] <= 1.0 and cov["mean_width"] > 0
            assert cov["measurement_coverage"] >= cov["coverage"] - 0.05  # the residuals widen the band
    else:
        assert band["status"].startswith("skipped: ") and benchmark.band_skip_reason in band["status"]
    text = (quick_run / name / "results.md").read_text()
    assert f"Designated row `{best['key']}`" in text and "95 % prediction band" in text
    if _estimation_error() is not None:
        assert "failed" in best["noise"]["status"]  # said in the report, not a crash
        pytest.skip(f"sindybench.estimation does not import in this tree: {_estimation_error()}")
    assert len(best["noise"]["Q_diag"]) >= 1 and all(r > 0 for r in best["noise"]["R_diag"])
    assert set(best["k_step"]) == set(best["smoothed_start"]) == set(results["test_sets"])
    for name_, rows in best["k_step"].items():
        assert [int(k) for k in rows] == list(HORIZONS)
        values = [rows[str(k)]["rmse"] for k in HORIZONS]
        assert all(v is not None and math.isfinite(v) and v > 0 for v in values), rows
        assert values[0] <= values[-1] * 3  # one step ahead is not far worse than a long horizon
        smoothed = best["smoothed_start"][name_]
        assert smoothed["status"] == "ok" and smoothed["rmse"] > 0


def test_quick_run_silverbox(quick_run):
    """The quick Silverbox run: the refined second-order rows beat the published GRU and every baseline."""
    results = json.loads((quick_run / "silverbox" / "results.json").read_text())
    rmse = {m["key"]: {t: s["rmse"] for t, s in m["scores"].items()} for m in results["models"]}
    assert set(results["test_sets"]) == {"multisine", "arrow_full"}  # the quick run's test sets
    for test, gru in (("multisine", 1.49), ("arrow_full", 2.80)):  # mV
        for key in ("sindy_duffing_refined", "sindy_second_order_refined"):
            assert rmse[key][test] < gru, (key, test)
            assert rmse[key][test] < min(rmse[k][test] for k in ("arx", "nnarx", "sindy_poly")), (key, test)
    text = (quick_run / "silverbox" / "results.md").read_text()
    assert "GRU (Champneys et al., 2024) RMSE 1.49" in text


def test_quick_run_report(quick_run):
    text = (quick_run / "report.md").read_text()
    for title in ("Pick-and-place machine", "neural state-space protocol", "Bouc-Wen oscillator", "Cascaded tanks",
                  "Electro-Mechanical Positioning", "test_nonlinear_benchmarks", "Silverbox"):
        assert title in text
    assert "Total wall time" in text
    index = (quick_run / "index.html").read_text()
    assert all(f'href="{name}/report.html"' in index for name in ("pick-and-place", "bouc-wen", "silverbox"))
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
    # the pages include source lines of the package (literalinclude ../sindybench/...)
    shutil.copytree(ROOT / "sindybench", tmp_path / "sindybench", ignore=shutil.ignore_patterns("__pycache__"))
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


@pytest.mark.slow  # known race, see below; the quick versions: tests/test_tune_processes.py (killed workers)
def test_cli_workers_share_a_postgresql_study_and_survive_a_kill(postgres_url, data_home, tmp_path):
    """Two ``sindybench run --storage postgresql+psycopg://...`` share the searches; one is SIGKILLed.

    Known race (about 1 run in 5 here): a kill that lands after Optuna created a trial and before
    sindybench tagged it with its worker leaves an untagged RUNNING trial, which holds its place in
    the budget until the database heartbeat fails it; the search then ends one trial short.

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


@pytest.mark.parametrize("catch", ["except BaseException: pass", "except KeyboardInterrupt: raise ImportError('x')"])
def test_a_ctrl_c_during_the_import_is_neither_swallowed_nor_turned_into_another_error(tmp_path, catch):
    """A Ctrl-C while the package imports, inside a library that swallows the interrupt (the run went on: the lost
    Ctrl-C 0.3 s into a cold start) or turns it into another error (NumPy's 'PyCapsule_Import could not import module
    "datetime"' when the interrupt comes during its C initialization, with a traceback): exit 130 at once."""
    import sindybench

    root = os.path.dirname(os.path.dirname(sindybench.__file__))
    code = ("import os, signal, sindybench_launcher\n"
            "restore = sindybench_launcher._exit_on_interrupt()\n"
            "os.kill(os.getpid(), signal.SIGINT)\n"
            f"try:\n    sum(range(10**6))\n{catch}\n"
            "restore()\nprint('the run goes on', flush=True)\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env={**os.environ, "PYTHONPATH": root},
                          capture_output=True, text=True, timeout=60,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.returncode == 130 and "the run goes on" not in proc.stdout, (proc.stdout, proc.stderr)
    assert proc.stderr.strip() == "sindybench: interrupted; no output written.", proc.stderr
    # restored: outside the import, a Ctrl-C is the command's KeyboardInterrupt again (its files unwound)
    code = ("import os, signal, sindybench_launcher\nsindybench_launcher._exit_on_interrupt()()\n"
            "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env={**os.environ, "PYTHONPATH": root},
                         capture_output=True, text=True, timeout=60).stdout
    assert out.strip() == "True"


def test_an_interrupted_extension_import_exits_130(monkeypatch, capsys):
    # an interrupt inside a C extension's initialization surfaced as "ImportError: initialization failed" (its
    # cause a KeyboardInterrupt): the launcher ended with status 1 and a traceback instead of 130
    import builtins

    import sindybench_launcher

    real_import = builtins.__import__

    def interrupted(name, *args, **kwargs):
        if name == "sindybench.cli":
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as exc:
                raise ImportError("initialization failed") from exc
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted)
    assert sindybench_launcher.main(["--version"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_an_import_error_without_an_interrupt_is_raised(monkeypatch):
    import builtins

    import sindybench_launcher

    real_import = builtins.__import__

    def broken(name, *args, **kwargs):
        if name == "sindybench.cli":
            raise ImportError("no module named foo")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", broken)
    with pytest.raises(ImportError, match="no module named foo"):
        sindybench_launcher.main(["--version"])
