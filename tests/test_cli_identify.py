"""``sindybench identify`` and ``sindybench report``: the real command on a small simulated CSV record.

The searches use cheap budgets (one family, two libraries, one derivative
method): each costs a few seconds. The ``--report`` and ``report`` tests run
once the HTML report module (``sindybench.report``) is installed.
"""

import json
import os
import subprocess
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from sindybench import load_model
from sindybench.cli import main
from sindybench.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
DT = 0.01
CHEAP = ["--families", "first_order", "--libraries", "linear,poly2", "--derivatives", "finite_difference",
         "--n-refine", "0"]


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """``data.csv`` (1200 samples) and ``test.csv`` (400) of ``y' = -2 y + u1 + 0.5 u2``, with a time column."""
    folder = tmp_path_factory.mktemp("identify")
    t = np.arange(1600) * DT
    U = np.c_[np.sin(t) + np.sin(2.3 * t), np.cos(0.7 * t) + 0.3 * np.sin(3.1 * t)]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0] + 0.5 * u[1]]), [0.0], U, dt=DT, input_hold="linear")
    table = np.c_[t, U, y]
    for name, rows in (("data.csv", slice(0, 1200)), ("test.csv", slice(1200, None))):
        np.savetxt(folder / name, table[rows], delimiter=",", header="time,u1,u2,y", comments="", fmt="%.17g")
    return folder


def _identify(folder, *extra, cheap=True):
    return ["identify", str(folder / "data.csv"), "--dt", str(DT), "--inputs", "u1,u2", "--outputs", "y",
            *(CHEAP if cheap else []), *extra]


def _env():
    env = dict(os.environ)
    env.pop("SINDYBENCH_PROGRESS", None)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    return env


def test_identify_command_writes_a_model_that_loads_and_simulates(records, tmp_path):
    model_path = tmp_path / "model.json"
    # the console script's entry point (sindybench_launcher), stderr a pipe: no progress bar drawn
    argv = [sys.executable, "-c", "import sys, sindybench_launcher; sys.exit(sindybench_launcher.main())",
            *_identify(records, "--test", str(records / "test.csv"), "-o", str(model_path))]
    done = subprocess.run(argv, capture_output=True, text=True, env=_env(), timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and "\r" not in done.stderr and "data advice" in done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("identified (") and "first_order" in lines[0] and "3 terms" in lines[0]
    assert lines[1].strip() == "y0' = -2.000 y0 + 1.000 u0 + 0.500 u1"
    assert lines[2].strip() == "where u0 is 'u1', u1 is 'u2', y0 is 'y' (the columns of DATA)"
    test_line = lines[3]
    for text in ("RMSE", "R^2 1.0000", "fit index", "n_init = 20", "scored samples: all 400"):
        assert text in test_line
    rmse = float(test_line.split("RMSE ")[1].split(",")[0])
    assert rmse < 1e-4
    # the session docs/identify.rst quotes is this one
    page = (ROOT / "docs" / "identify.rst").read_text().splitlines()
    start = next(i for i, line in enumerate(page) if line.strip().startswith("$ sindybench identify data.csv"))
    quoted = [line.strip() for line in page[start + 1:start + 5]]
    assert quoted[0].split("):")[1].split(", validation")[0] == lines[0].split("):")[1].split(", validation")[0]
    assert quoted[1:3] == [line.strip() for line in lines[1:3]]
    assert quoted[3].startswith("test (test.csv, 400 samples): RMSE") and "400 samples): RMSE" in test_line
    assert quoted[3].split(", R^2")[1] == test_line.split(", R^2")[1]
    assert float(quoted[3].split("RMSE ")[1].split(",")[0]) == pytest.approx(rmse, rel=0.01)
    model = load_model(model_path)  # the file keeps the search's record, and the columns it was given
    record = model.identification_
    assert record["settings"]["family"] == "first_order"
    assert record["cli"]["inputs"] == ["u1", "u2"] and record["cli"]["outputs"] == ["y"]
    assert record["cli"]["test_scores"]["rmse"] == pytest.approx(rmse, rel=1e-5)
    assert len(record["cv_results"]["status"]) == int(lines[0].split("(")[1].split()[0])
    # and the file runs with 'sindybench simulate': on the test file itself, its input columns taken by name
    test = np.loadtxt(records / "test.csv", delimiter=",", skiprows=1)
    np.savetxt(tmp_path / "y0.csv", test[:20, 3:], delimiter=",", fmt="%.17g")
    assert main(["simulate", str(model_path), "--input", str(records / "test.csv"), "--output",
                 str(tmp_path / "y.csv"), "--y-init", str(tmp_path / "y0.csv"), "-q"]) == 0
    assert (tmp_path / "y.csv").read_text().startswith("y\n")  # the output column's name
    y_sim = np.loadtxt(tmp_path / "y.csv", delimiter=",", skiprows=1)
    assert np.max(np.abs(y_sim - test[:, 3])) < 1e-4
    # the same inputs in another order, or without one of them, by name
    np.savetxt(tmp_path / "u.csv", test[:, [2, 1]], delimiter=",", header="u2,u1", comments="", fmt="%.17g")
    assert main(["simulate", str(model_path), "--input", str(tmp_path / "u.csv"), "--output",
                 str(tmp_path / "y2.csv"), "--y-init", str(tmp_path / "y0.csv"), "-q"]) == 0
    assert np.array_equal(np.loadtxt(tmp_path / "y2.csv", delimiter=",", skiprows=1), y_sim)
    np.savetxt(tmp_path / "u1.csv", test[:, [1]], delimiter=",", header="u1", comments="", fmt="%.17g")
    assert main(["simulate", str(model_path), "--input", str(tmp_path / "u1.csv"), "--output",
                 str(tmp_path / "y3.csv"), "-q"]) == 2


def test_identify_resumes_from_storage_and_never_overwrites_without_force(records, tmp_path, capsys):
    storage = f"sqlite:///{tmp_path / 'search.db'}"
    model_path = tmp_path / "model.json"
    assert main(_identify(records, "--storage", storage, "-o", str(model_path), "-q")) == 0
    first = capsys.readouterr().out
    before = model_path.read_text()
    # an existing -o is refused before any work, and left as it was
    assert main(_identify(records, "--storage", storage, "-o", str(model_path), "-q")) == 2
    err = capsys.readouterr().err
    assert "exists; pass --force" in err and len(err.strip().splitlines()) == 1
    assert model_path.read_text() == before
    # with --force the same search is read back from the storage: the same model, no candidate fitted again
    assert main(_identify(records, "--storage", storage, "-o", str(model_path), "--force", "-q")) == 0
    second = capsys.readouterr().out
    n_candidates = int(first.split("(")[1].split()[0])
    assert f"{n_candidates} read back from --storage" in second.splitlines()[0]
    assert first.splitlines()[1:] == second.splitlines()[1:]


def test_identify_interrupted_exits_130_and_writes_nothing(records, tmp_path, capsys, monkeypatch):
    from sindybench.identify import IdentifyCV

    def interrupted(self, X, y, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(IdentifyCV, "fit", interrupted)
    storage = f"sqlite:///{tmp_path / 'search.db'}"
    assert main(_identify(records, "-o", str(tmp_path / "model.json"), "--storage", storage, "-q")) == 130
    err = capsys.readouterr().err
    assert "interrupted; no output written" in err and "run the same command to resume" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # not even the storage was created by a fit


def test_an_interrupt_that_ends_as_a_cleanup_error_is_an_interrupt(records, tmp_path, capsys, monkeypatch):
    """A Ctrl-C while Optuna holds its journal file's lock surfaced as the lock's FileNotFoundError (exit 2)."""
    from sindybench.identify import IdentifyCV

    def fit(self, X, y, **kwargs):
        try:
            raise KeyboardInterrupt
        finally:
            open(tmp_path / "search.log.lock.rename")  # noqa: SIM115 - the lock file a cleanup no longer finds

    monkeypatch.setattr(IdentifyCV, "fit", fit)
    argv = _identify(records, "-o", str(tmp_path / "model.json"), "--storage", str(tmp_path / "search.log"), "-q")
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "interrupted; no output written" in err and "run the same command to resume" in err
    assert "No such file" not in err and sorted(tmp_path.iterdir()) == []


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("case, match", [
    ("missing column", "has no column 'v'"),
    ("non-numeric cell", "line 3, column 'u1': 'abc'; expected a finite number"),
    ("NaN", "line 2, column 'y': 'nan'; expected a finite number"),
    ("index out of range", "column index 7 is out of range"),
    ("names without header", "has no header row, so no column is named 'u1'"),
    ("input is output", "both take column 3"),
    ("test lacks a column", r"t\.csv has no column 'u2'"),
    ("short rows", "line 4: 3 values; expected 4"),
    ("no dt", "--dt missing"),
    ("no outputs", "--outputs missing"),
    ("no such file", "no such file; expected a CSV file or a dataset's name"),
])
def test_identify_bad_input_is_one_line_and_exit_2(records, tmp_path, capsys, case, match):
    good = (records / "data.csv").read_text().splitlines()
    data, inputs, outputs, extra = records / "data.csv", "u1,u2", "y", ["--dt", str(DT)]
    if case == "missing column":
        outputs = "v"
    elif case == "non-numeric cell":
        data = _write(tmp_path / "d.csv", "\n".join(good[:2] + ["0.01,abc,1,2"] + good[3:]))
    elif case == "NaN":
        data = _write(tmp_path / "d.csv", "\n".join(good[:1] + ["0,1,1,nan"] + good[2:]))
    elif case == "index out of range":
        inputs = "1,7"
    elif case == "names without header":
        data = _write(tmp_path / "d.csv", "\n".join(good[1:]))
    elif case == "input is output":
        inputs = "u1,3"
    elif case == "test lacks a column":
        extra += ["--test", str(_write(tmp_path / "t.csv", "time,u1,y\n0,1,2\n" * 1))]
    elif case == "short rows":
        data = _write(tmp_path / "d.csv", "\n".join(good[:3] + ["0.03,1,2"] + good[4:]))
    elif case == "no dt":
        extra = []
    elif case == "no outputs":
        outputs = None
    elif case == "no such file":
        data = tmp_path / "absent.csv"
    argv = ["identify", str(data), "--inputs", inputs, *(["--outputs", outputs] if outputs else []), *extra,
            *CHEAP, "-o", str(tmp_path / "model.json"), "-q"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("sindybench: error: ")
    assert re.search(match, err), err
    assert not (tmp_path / "model.json").exists()


@pytest.mark.parametrize("value", ["0", "-0.01", "nan", "x"])
def test_identify_refuses_a_dt_that_is_not_positive(records, capsys, value):
    with pytest.raises(SystemExit) as exc:
        main(["identify", str(records / "data.csv"), "--dt", value, "--inputs", "u1", "--outputs", "y"])
    assert exc.value.code == 2
    assert "argument --dt: expected a" in capsys.readouterr().err


def test_identify_help_says_what_the_data_decides(capsys):
    with pytest.raises(SystemExit):
        main(["identify", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for phrase in ("default: the data advice's estimate, confirmed on validation", "default: both searched",
                   "--storage", "--n-jobs", "--random-state", "--time-budget", "--force", "cascaded-tanks"):
        assert phrase in text


def test_identify_a_dataset_by_name(data_home, tmp_path, capsys):
    argv = ["identify", "cascaded-tanks", "--data-home", str(data_home), *CHEAP, "--libraries", "linear",
            "-o", str(tmp_path / "tanks.json"), "-q"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    # the dataset's own dt (4 s), protocol (n_init = 5) and test set (the 1024 samples of uVal/yVal)
    assert "test (test, 1024 samples)" in out and "n_init = 5" in out and "scored samples: all 1024" in out
    model = load_model(tmp_path / "tanks.json")
    assert model.dt_ == 4.0 and model.identification_["cli"]["data"] == "cascaded-tanks"


def test_identify_report_and_the_report_command(records, tmp_path, capsys):
    pytest.importorskip("sindybench.report")
    model_path, page = tmp_path / "model.json", tmp_path / "report.html"
    test = str(records / "test.csv")
    assert main(_identify(records, "--test", test, "-o", str(model_path), "--report", str(page), "-q")) == 0
    html = page.read_text()
    assert html.lstrip().lower().startswith("<!doctype html") and "first_order" in html
    # later, from the file: the columns come from the model file's record
    later = tmp_path / "later.html"
    assert main(["report", str(model_path), str(records / "data.csv"), "--test", test, "-o", str(later), "-q"]) == 0
    assert "first_order" in later.read_text()
    assert main(["report", str(model_path), str(records / "data.csv"), "-o", str(later), "-q"]) == 2
    assert "exists; pass --force" in capsys.readouterr().err


def test_a_report_that_cannot_be_written_is_said_before_the_search(records, tmp_path, capsys, monkeypatch):
    from sindybench.identify import IdentifyCV

    monkeypatch.setitem(sys.modules, "sindybench.report", None)  # as an installation without the report module
    monkeypatch.setattr(IdentifyCV, "fit", lambda *args, **kwargs: pytest.fail("the search ran"))
    assert main(_identify(records, "-o", str(tmp_path / "m.json"), "--report", str(tmp_path / "r.html"))) == 2
    assert "the HTML report (sindybench.report) is not available" in capsys.readouterr().err
    assert sorted(tmp_path.iterdir()) == []


def test_identify_passes_the_criterion_where_identifycv_has_it(records, tmp_path, capsys, monkeypatch):
    from sindybench.identify import IdentifyCV

    seen = {}

    def fit(self, X, y, **kwargs):
        seen.update(self.get_params())
        raise KeyboardInterrupt  # what is given to the search is all this test needs

    monkeypatch.setattr(IdentifyCV, "fit", fit)
    status = main(_identify(records, "--criterion", "k_step", "--horizon", "7", "--time-budget", "30", "-q"))
    if "criterion" in IdentifyCV._get_param_names():
        assert status == 130 and seen["criterion"] == "k_step" and seen["horizon"] == 7
    else:
        assert status == 2 and "--criterion: this version's IdentifyCV has no criterion" in capsys.readouterr().err
    assert seen.get("time_budget", 30) == 30


def test_identify_ctrl_c_during_the_search_exits_130_and_writes_nothing(records, tmp_path):
    import signal

    code = "import sys, sindybench_launcher; sys.exit(sindybench_launcher.main())"
    storage = tmp_path / "search.log"
    # the default search (all families) runs for tens of seconds: the interrupt comes in the middle of it
    proc = subprocess.Popen([sys.executable, "-c", code, *_identify(records, cheap=False), "--storage", str(storage),
                             "-o", str(tmp_path / "model.json")],
                            cwd=tmp_path, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as on a terminal
    lines = []
    for line in proc.stderr:  # the data advice is logged once the search has its settings
        lines.append(line)
        if line.startswith("data advice:"):
            break
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    err = "".join(lines) + err
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted; no output written." in err
    assert "run the same command to resume" in err
    assert out == ""
    assert {p.name for p in tmp_path.iterdir()} <= {"search.log"}  # the storage at most: no model file, no temporary
