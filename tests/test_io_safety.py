"""Model files are safe to load: bounded work, ValueError naming the field, no code run, safe writes.

The first part pins each defect of issue 18 (cases 9 to 13 and 19) with a test that failed before
the fix. The second part is a property-based (Hypothesis) fuzz suite over real saved files of every
estimator kind: a mutated file either loads into a model that simulates, or is refused with a
``ValueError`` that names the field, in bounded time and memory. A quick profile runs by default,
a longer one with ``--runslow``.
"""

import copy
import errno
import json
import math
import os
import re
import resource
import signal
import sys
import tempfile
import time
import tracemalloc
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import sindybench.io as sio
from sindybench import STLS, HiddenStateSINDy, SINDy, load_model
from sindybench._validation import check_bounds
from sindybench.baselines import ARX, NNARX
from sindybench.datasets import load_bouc_wen, load_cascaded_tanks, load_pick_and_place
from sindybench.hidden import BoucWenHiddenState, DerivativeHiddenState, ParametricHiddenState, TanksHiddenState
from sindybench.libraries import PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement

try:  # the fuzz suite needs Hypothesis (the test extra); the pinned cases below do not
    import hypothesis
    import hypothesis.strategies as st
except ImportError:
    hypothesis = None

needs_hypothesis = pytest.mark.skipif(hypothesis is None, reason="the test extra (hypothesis) is missing")


def upper_tank(xh, y, u, *, k1, k2):
    """A module-level ``rhs`` for ParametricHiddenState: the upper tank of the cascaded tanks."""
    return k1 * u - k2 * np.sqrt(np.clip(xh, 0.0, None))


def _record(load, data_home, n):
    data = load(data_home=data_home)
    return data["estimation"]["u"][:n], data["estimation"]["y"][:n], float(data["dt"])


@pytest.fixture(scope="module")
def files(data_home, tmp_path_factory):
    """``{kind: JSON text}``: one small model of every estimator kind, fitted on real records and saved."""
    u, y, dt = _record(load_cascaded_tanks, data_home, 300)
    models = {
        "SINDy": SINDy(library=PolynomialLibrary(degree=2) + SqrtLibrary(), optimizer=STLS(threshold=1e-3), dt=dt,
                       bounds=(0.0, 10.0), n_substeps=2, output_names=["level"], input_names=["pump"]).fit(u, y),
        "SINDy-refined": SINDy(library=PolynomialLibrary(degree=1) + SqrtLibrary(), optimizer=STLS(threshold=1e-3),
                               dt=dt, bounds=(0.0, 10.0), refine=OutputErrorRefinement(max_nfev=2)).fit(u, y),
        "ARX": ARX(na=2, nb=2).fit(u, y),
        "NNARX": NNARX(hidden_layer_sizes=(4,), max_iter=20, n_estimators=2, random_state=0).fit(u, y),
        "TanksHiddenState": HiddenStateSINDy(
            hidden=TanksHiddenState(k1=0.05, k_bounds=(0.02, 0.08), output_bounds=(0, 10), grid_size=5),
            dt=dt, n_substeps=2, n_trials=2, random_state=0).fit(u, y),
        "ParametricHiddenState": HiddenStateSINDy(
            hidden=ParametricHiddenState(upper_tank, params={"k1": 0.05, "k2": (0.02, 0.1)}, x0_bounds=(0.0, 10.0),
                                         bounds=(0.0, 10.0), grid_size=3, init_size=10),
            library=PolynomialLibrary(degree=1), dt=dt, n_trials=2, random_state=0).fit(u[:150], y[:150]),
    }
    theta = PolynomialLibrary(degree=2).fit_transform(np.hstack([y, u]))
    models["STLS"] = STLS(threshold=0.05).fit(theta, np.gradient(y[:, 0], dt))
    u, y, dt = _record(load_bouc_wen, data_home, 600)
    models["BoucWenHiddenState"] = HiddenStateSINDy(
        hidden=BoucWenHiddenState(m=2.0, c=10.0, k=5e4, trim=50), optimizer=STLS(threshold=1e5, normalize_columns=True),
        dt=dt, n_substeps=2).fit(u, y)
    u, y, dt = _record(load_pick_and_place, data_home, 300)
    models["DerivativeHiddenState"] = HiddenStateSINDy(
        hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
        optimizer=STLS(threshold=1e-3), dt=dt).fit(u, y)
    folder = tmp_path_factory.mktemp("safety")
    out = {}
    for kind, model in models.items():
        model.to_json(folder / f"{kind}.json")
        out[kind] = (folder / f"{kind}.json").read_text()
    return out


def _edited(files, kind, tmp_path, *edits):
    """Write ``files[kind]`` with each ``(path, value)`` set (``value`` a function of the old one if callable)."""
    data = json.loads(files[kind])
    for path, value in edits:
        d = data
        for key in path[:-1]:
            d = d[key]
        d[path[-1]] = value(d[path[-1]]) if callable(value) else value
    target = tmp_path / f"{kind}-edited.json"
    target.write_text(json.dumps(data))
    return target


def _refused(path, match, *, seconds=1.0, allow_import=True):
    start = time.perf_counter()
    with pytest.raises(ValueError, match=match):
        load_model(path, allow_import=allow_import)
    assert time.perf_counter() - start < seconds


_LIB = ["params", "library", "estimator", "params", "libraries", 0, "estimator", "params", "degree"]
_FITTED_LIB = ["fitted", "library", "library", "estimator", "params", "libraries", 0, "estimator", "params", "degree"]


# ------------------------------------------------------------- 9: bounded work
@pytest.mark.parametrize("degree", [100, 150, 10**15])
def test_a_huge_library_degree_is_refused_before_it_is_built(files, tmp_path, degree):
    """Before: degree=100 took 55 s and 2.5 GiB (every term built, then compared); now refused at once."""
    path = _edited(files, "SINDy", tmp_path, (_LIB, degree), (_FITTED_LIB, degree))
    _refused(path, rf"fitted.library.library: ConcatLibrary\(libraries=\[PolynomialLibrary\(degree={degree}\).* "
                   r"would build more than 1032 terms on 2 columns; the file stores 8")


def test_nested_products_are_refused_before_they_are_built(files, tmp_path):
    """A few hundred bytes of nested ProductLibrary would build 2**26 terms."""
    sqrt = {"estimator": {"class": "SqrtLibrary", "params": {}}}  # 2 terms on 2 columns
    lib = sqrt
    for _ in range(25):
        lib = {"estimator": {"class": "ProductLibrary", "params": {"left": lib, "right": sqrt}}}
    path = _edited(files, "SINDy", tmp_path, (["fitted", "library", "library"], lib))
    _refused(path, "fitted.library.library: ProductLibrary.* would build more than 1032 terms")


@pytest.mark.parametrize("kind, path, value, match", [
    ("SINDy", ["params", "n_substeps"], 10**9, "params.n_substeps = 1000000000; a model file may ask for at most 1000"),
    ("TanksHiddenState", ["params", "n_substeps"], 10**9, "params.n_substeps = 1000000000; a model file may ask"),
    ("TanksHiddenState", ["fitted", "hidden", "estimator", "params", "n_substeps"], 10**6,
     "fitted.hidden.estimator.params.n_substeps = 1000000; a model file may ask for at most 1000"),
    ("TanksHiddenState", ["fitted", "hidden", "estimator", "params", "grid_size"], 10**8,
     "fitted.hidden.estimator.params.grid_size = 100000000; a model file may ask for at most 10000"),
    ("SINDy", ["fitted", "n_states"], 10**12, "fitted.output_names: expected a list of 1000000000000 strings"),
    ("TanksHiddenState", ["fitted", "n_features_in"], 10**12,
     r"fitted.n_features_in: expected an integer in \[0, 100000\]"),
    ("TanksHiddenState", ["fitted", "structure", "n_states"], 10**12,
     "fitted.structure.state_names: expected a list of 1000000000000 strings"),
])
def test_settings_that_would_hang_or_exhaust_memory_are_refused(files, tmp_path, kind, path, value, match):
    """Before: n_substeps=10**9 loaded, then every simulation hung; the sizes allocated before they were checked."""
    _refused(_edited(files, kind, tmp_path, (path, value)), match)


# ------------------------------------------------------- 10: ValueError, never a crash
def test_deeply_nested_json_is_refused_with_a_value_error(files, tmp_path):
    """Before: RecursionError (a traceback) from the parser and from the loader's own recursion."""
    path = tmp_path / "deep.json"
    path.write_text("[" * 5000 + "]" * 5000)
    _refused(path, "deep.json is not a model file: its JSON is nested thousands of levels deep")
    path = _edited(files, "SINDy", tmp_path, (["params", "max_abs"], "DEEP"))
    path.write_text(path.read_text().replace('"DEEP"', '{"tuple": [' * 3000 + "0.5" + "]}" * 3000))
    _refused(path, "is not a model file: its JSON is nested thousands of levels deep")
    data = json.loads(files["SINDy"])
    nested = 0.5
    for _ in range(3000):
        nested = {"tuple": [nested]}
    data["params"]["max_abs"] = nested  # the same as data: the loader reads it without recursion first
    with pytest.raises(ValueError, match=r"params.max_abs.tuple\[0\].*: nested more than 100 levels deep"):
        sio.model_from_dict(data)


@pytest.mark.parametrize("field", [["fitted", "dt"], ["params", "max_abs"], ["fitted", "coef", "data", 0],
                                   ["fitted", "n_states"], ["fitted", "coef", "shape", 0]])
def test_huge_integers_are_refused_with_a_value_error(files, tmp_path, field):
    """Before: a 4000-digit integer escaped as OverflowError (int too large to convert to float)."""
    name = ".".join(str(k) for k in field[:-1]) + (f"[{field[-1]}]" if isinstance(field[-1], int) else f".{field[-1]}")
    path = _edited(files, "SINDy", tmp_path, (field, "BIG"))
    text = path.read_text()
    path.write_text(text.replace('"BIG"', "7" * 4000))
    _refused(path, rf"{re.escape(name)}: an integer of 4000 digits; expected a 64-bit integer")
    path.write_text(text.replace('"BIG"', "7" * 5000))  # beyond Python's limit for reading integers
    _refused(path, "is not valid JSON: Exceeds the limit")


def test_bare_nan_constants_are_refused(files, tmp_path):
    path = tmp_path / "nan.json"
    path.write_text(files["SINDy"].replace('"dt": 4.0', '"dt": NaN', 1))
    _refused(path, "is not valid JSON: the bare constant NaN")


# -------------------------------------------------- 11: check first, import after
def test_a_function_where_none_is_allowed_is_refused_before_importing(files, tmp_path, capsys):
    """Before: naming the module `this` in input_names imported it (printing the Zen of Python), then refused."""
    sys.modules.pop("this", None)
    for field in (["params", "input_names"], ["fitted", "differentiation"],
                  ["params", "hidden", "estimator", "params", "params"]):
        kind = "ParametricHiddenState" if field[-1] == "params" else "SINDy"
        path = _edited(files, kind, tmp_path, (field, {"function": "this:s"}))
        where = ".".join(field)
        _refused(path, rf"{where} names the Python function 'this:s', which is not expected here; a model file may "
                       r"name a function only as one of \['ParametricHiddenState.rhs'\]", allow_import=True)
    path = _edited(files, "ParametricHiddenState", tmp_path,
                   (["params", "hidden", "estimator", "params", "params"], {"dict": {"k1": {"function": "this:s"}}}))
    _refused(path, r"params\['k1'\] names the Python function 'this:s'", allow_import=True)
    assert "this" not in sys.modules and capsys.readouterr().out == ""
    assert load_model(_edited(files, "ParametricHiddenState", tmp_path), allow_import=True).hidden.rhs is upper_tank


def test_a_function_is_saved_only_where_loading_accepts_one(tmp_path):
    model = STLS(threshold=0.1).fit(np.eye(3), np.ones(3))
    model.threshold = upper_tank  # a function in a parameter that takes none
    with pytest.raises(ValueError, match=r"params.threshold = <function upper_tank .*> cannot be stored: a Python "
                                         r"function is stored only as one of \['ParametricHiddenState.rhs'\]"):
        model.to_json(tmp_path / "m.json")
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------ 12: tampered values
@pytest.mark.parametrize("kind, path, value, match", [
    ("NNARX", ["fitted", "y_scale", "data", 0], 0.0, r"fitted.y_scale: expected finite values > 0; got 0.0 at index \[0\]"),
    ("NNARX", ["fitted", "u_scale", "data", 0], -1.0, "fitted.u_scale: expected finite values > 0; got -1.0"),
    ("NNARX", ["fitted", "networks", 0, "coefs", 0, "data", 0], "nan", r"fitted.networks\[0\].coefs\[0\]: expected finite"),
    ("TanksHiddenState", ["fitted", "hidden", "estimator", "params", "k1"], -0.05,
     "fitted.hidden: TanksHiddenState refused its parameters: k1 must be a finite number > 0 or None"),
    ("TanksHiddenState", ["fitted", "params", "dict", "k1"], -0.05,
     "fitted.params: the TanksHiddenState parameters .* are refused: k1 must be a finite number > 0"),
    ("TanksHiddenState", ["fitted", "params", "dict", "k2"], "fast", r"fitted.params\['k2'\]: expected a finite number"),
    ("BoucWenHiddenState", ["fitted", "params", "dict", "m"], -2.0, "fitted.params: the BoucWenHiddenState parameters"),
    ("TanksHiddenState", ["fitted", "states", "shape", 0], 0, "fitted.states.data: expected a list of 0 values"),
    ("ARX", ["fitted", "n_lags"], 3, r"fitted.n_lags: expected 2 \(na=2, nb=2, nk=1\); got 3"),
    ("NNARX", ["fitted", "n_lags"], 0, "fitted.n_lags: expected"),
    ("ARX", ["fitted", "y_ndim"], 7, r"fitted.y_ndim: expected an integer in \[1, 2\]"),
    ("SINDy", ["fitted", "optimizer"], {"class": "PolynomialLibrary", "params": {}},
     "fitted.optimizer: expected a fitted STLS .the class the parameters name.; got PolynomialLibrary"),
    ("TanksHiddenState", ["fitted", "optimizer"], {"class": "ConcatLibrary", "params": {}},
     "fitted.optimizer: expected a fitted STLS"),
    ("SINDy", ["fitted", "differentiation"], {"estimator": {"class": "STLS", "params": {}}},
     "fitted.differentiation: expected a differentiation method; got STLS"),
    ("SINDy", ["fitted", "differentiation"], {"estimator": {"class": "Spectral", "params": {}}},
     "fitted.differentiation: expected a fitted FiniteDifference"),
    ("SINDy", ["fitted", "coef", "data", 1], "inf", r"fitted.coef: expected finite values; got inf at index \[0, 1\]"),
    ("SINDy", ["fitted", "dt"], -4.0, "fitted.dt: expected a finite number > 0 or null; got -4.0"),
    ("SINDy", ["fitted", "coef", "shape"], [1] * 40, "fitted.coef.shape: expected a list of at most 32 integers"),
    # found by the fuzz suite below
    ("SINDy", ["params", "max_abs"], {"float": {"a": 1}}, r"params.max_abs.float: expected one of \['-inf', 'inf'"),
    ("SINDy", ["fitted", "x0", "data", 0], [1.0], r"fitted.x0.data: expected float64 values; got \['a list of 1'\]"),
    ("ParametricHiddenState", ["fitted", "params", "dict"], {"k1": 0.05},
     r"fitted.params: expected the ParametricHiddenState parameters \['k1', 'k2', 'x0'\]; got \['k1'\]"),
    ("NNARX", ["params", "hidden_layer_sizes"], "sindybench-model",
     r"params: hidden_layer_sizes = 'sindybench-model'; expected a non-empty tuple of integers"),
    ("TanksHiddenState", ["fitted", "library", "library", "estimator", "params", "libraries", 1, "estimator", "params",
                          "lower"], "", "fitted.library.library: ConcatLibrary.* refused its parameters on 3 columns"),
    ("TanksHiddenState", ["fitted", "structure", "bounds"], {"tuple": [0.0, 2.0]},
     r"fitted.x0: x0\[0\] = .* is outside fitted.structure.bounds \[0.0, 2.0\]"),
    ("TanksHiddenState", ["fitted", "structure", "bounds"], {"tuple": [0.0, "high"]},
     "fitted.structure.bounds: expected .lower, upper. of 2 states"),
    ("SINDy", ["params", "bounds"], {"tuple": [0.0, {"dict": {}}]}, "params: float.. argument must be"),
])
def test_tampered_values_are_refused_naming_the_field(files, tmp_path, kind, path, value, match):
    """Before: each of these loaded (y_scale=0 then predicted NaN everywhere)."""
    _refused(_edited(files, kind, tmp_path, (path, value)), match)


def test_a_trajectory_without_samples_is_refused(files, tmp_path):
    path = _edited(files, "TanksHiddenState", tmp_path, (["fitted", "states"], sio.encode_array(np.zeros((0, 2)))))
    _refused(path, "fitted.states: expected the training trajectory .at least one sample of 2 states.; got 0")


# ------------------------------------------------------------ 13: safe writes
def test_saving_over_a_file_keeps_its_permissions(files, tmp_path):
    """Before: a file with mode 600 became 644 when a model was saved over it."""
    model = load_model(_edited(files, "ARX", tmp_path))
    path = tmp_path / "private.json"
    path.write_text("old")
    path.chmod(0o600)
    model.to_json(path)
    assert path.stat().st_mode & 0o777 == 0o600 and json.loads(path.read_text())["class"] == "ARX"
    path.chmod(0o640)
    model.to_json(path)
    assert path.stat().st_mode & 0o777 == 0o640


def test_write_errors_name_the_target_not_the_temporary_file(files, tmp_path, monkeypatch):
    """Before: FileNotFoundError: '.../missing/.m.json.abc123.tmp'."""
    model = load_model(_edited(files, "ARX", tmp_path))
    target = tmp_path / "missing" / "m.json"
    with pytest.raises(FileNotFoundError, match=re.escape(f"cannot write the file (No such file or directory): "
                                                          f"'{target}'")) as info:
        model.to_json(target)
    assert ".tmp" not in str(info.value)

    def read_only(*args, **kwargs):  # as mkstemp fails in a read-only folder (root may write anywhere)
        raise PermissionError(errno.EACCES, "Permission denied", str(tmp_path / ".m.json.x1y2.tmp"))

    monkeypatch.setattr(sio._files.tempfile, "mkstemp", read_only)
    with pytest.raises(PermissionError, match=re.escape(f"cannot write the file (Permission denied): "
                                                        f"'{tmp_path / 'm.json'}'")) as info:
        model.to_json(tmp_path / "m.json")
    assert ".tmp" not in str(info.value) and not (tmp_path / "m.json").exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_named(files, tmp_path):
    model = load_model(_edited(files, "ARX", tmp_path))
    folder = tmp_path / "ro"
    folder.mkdir(mode=0o500)
    with pytest.raises(PermissionError, match=re.escape(str(folder / "m.json"))):
        model.to_json(folder / "m.json")


# ------------------------------------------------------ 19: pysindy parts
def test_pysindy_parts_are_named_with_their_sindybench_equivalent(tmp_path):
    ps = pytest.importorskip("pysindy")
    y = np.c_[np.sin(np.arange(100) * 0.05), np.cos(np.arange(100) * 0.05)]
    model = SINDy(library=ps.PolynomialLibrary(degree=2), dt=0.05).fit(None, y)
    with pytest.raises(ValueError, match=r"params.library = PolynomialLibrary\(\) cannot be stored as JSON: it is "
                                         r"pysindy's PolynomialLibrary .*; use sindybench.libraries.PolynomialLibrary"):
        model.to_json(tmp_path / "m.json")
    model = SINDy(library=ps.FourierLibrary(), dt=0.05).fit(None, y)
    with pytest.raises(ValueError, match="it is pysindy's FourierLibrary .*sindybench has no equivalent to store"):
        model.to_json(tmp_path / "m.json")
    with pytest.raises(ValueError, match=r"library pysindy.*CustomLibrary cannot be used: its get_params\(\) fails .*"
                                         r"use sindybench.libraries.CustomLibrary\(functions=\[...\]\)"):
        SINDy(library=ps.CustomLibrary(library_functions=[np.tanh]), dt=0.05).fit(None, y)
    assert list(tmp_path.iterdir()) == []


# ================================================================= fuzz suite
KINDS = ["SINDy", "SINDy-refined", "STLS", "ARX", "NNARX", "TanksHiddenState", "ParametricHiddenState",
         "BoucWenHiddenState", "DerivativeHiddenState"]
SECONDS = 5.0  # one load and one simulation; a small file loads in well under a second
MEBIBYTES = 200  # peak allocation of one load and one simulation (the files are a few kB)
_TOP = re.compile(r"^(\S*\.json |format|format_version|sindybench_version|class|params|fitted)\b")


def _paths(data, prefix=()):
    """Every place in ``data`` (long lists: their first two and last entries)."""
    out = [prefix]
    if isinstance(data, dict):
        for k, v in data.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(data, list):
        for i in sorted({0, 1, len(data) - 1} & set(range(len(data)))):
            out += _paths(data[i], (*prefix, i))
    return out


def _nested(depth):
    value = []
    for _ in range(depth):
        value = [value]
    return value


if hypothesis is not None:
    _NAMES = ["STLS", "SINDy", "PolynomialLibrary", "ConcatLibrary", "ProductLibrary", "TanksHiddenState", "Spectral",
              "FiniteDifference", "OutputErrorRefinement", "os.system", "TermsLibrary"]
    SPECIAL = st.sampled_from([
        None, True, 0, -1, 1, 2, 10**9, 2**63, -(2**63) - 1, int("9" * 400), 1e308, -1e-320, 0.5, float("inf"), "nan",
        "inf", "", "x" * 10_000, [], {}, [0] * 1000, {"float": "nan"}, {"float": "inf"}, {"tuple": []},
        {"dict": {}}, {"function": "this:s"}, {"function": "os:system"}, {"array": sio.encode_array(np.ones((2, 2)))},
        {"array": {"dtype": "float64", "shape": [0, 2**40], "data": []}}, _nested(150),
        {"estimator": {"class": "PolynomialLibrary", "params": {"degree": 10**6}}},
    ])
    JSON = st.recursive(
        st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats(allow_nan=False) | st.text(max_size=8),
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
        max_leaves=8,
    ) | SPECIAL | st.builds(lambda name: {"estimator": {"class": name, "params": {}}}, st.sampled_from(_NAMES))


def _mutate(data, draw):
    """One random change of a real file: a value, a type, a shape, a size, a nesting, a deletion."""
    path = draw(st.sampled_from(_paths(data)[1:]))
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    key, old = path[-1], parent[path[-1]]
    how = draw(st.sampled_from(["replace", "delete", "number", "list", "wrap", "swap"]))
    if how == "delete":
        del parent[key]
    elif how == "number" and isinstance(old, (int, float)) and not isinstance(old, bool):
        parent[key] = draw(st.sampled_from([lambda v: -v, lambda v: 0 * v, lambda v: v + 1, lambda v: v - 1,
                                            lambda v: v * 10**6, lambda v: float(v), lambda v: str(v)]))(old)
    elif how == "list" and isinstance(old, list):
        parent[key] = draw(st.sampled_from([old[:-1], old + old[-1:], old * 3, [], list(reversed(old))]))
    elif how == "wrap":
        parent[key] = draw(st.sampled_from([[old], {"tuple": [old]}, {"dict": {"x": old}}, {"array": old}]))
    elif how == "swap":
        other = draw(st.sampled_from(_paths(data)[1:]))
        value = data
        for k in other:
            value = value[k]
        parent[key] = json.loads(json.dumps(value))
    else:
        parent[key] = copy.deepcopy(draw(JSON))  # a copy: later changes must not edit the shared examples
    return ".".join(map(str, path)), how


def _use(model, rng):
    """What a user does with a loaded model: simulate it (NaN after a divergence is a result)."""
    n = 30
    if isinstance(model, STLS):
        return model.predict(rng.normal(size=(n, model.n_features_in_)))
    X = rng.uniform(0.0, 1.0, size=(n, model.n_features_in_))
    if isinstance(model, SINDy):  # a model fitted on sample times (dt_ None) simulates on sample times
        x0 = np.clip(model.x0_, *check_bounds(model.bounds, model.n_states_))  # x0_ is a training sample only
        return model.simulate(X, x0, t=np.arange(n) * 0.1 if model.dt_ is None else None, on_divergence="nan")
    if isinstance(model, HiddenStateSINDy):
        return model.simulate(X, x0=model.x0_, on_divergence="nan")
    return model.simulate(X)


class _Timeout(Exception):
    pass


@contextmanager
def _time_limit(seconds):
    def stop(signum, frame):
        raise _Timeout(f"took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _check_case(text, tmp_path, what, allow_import=True):
    """Load ``text`` as a model file: a model that simulates, or a ValueError naming the field, in bounded time."""
    path = tmp_path / "fuzz.json"
    path.write_text(text)
    start = time.perf_counter()
    tracemalloc.start()  # numpy reports its arrays to tracemalloc too
    with _time_limit(4 * SECONDS), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # divergence and convergence warnings are results too
        try:
            model = load_model(path, allow_import=allow_import)
        except (ValueError, OSError) as exc:
            message = str(exc)
            assert _TOP.match(message), f"{what}: the message names no field: {message[:300]}"
        else:
            out = np.asarray(_use(model, np.random.default_rng(0)))
            assert out.shape[0] == 30, what
        finally:
            peak = tracemalloc.get_traced_memory()[1] / 2**20
            tracemalloc.stop()
    assert time.perf_counter() - start < SECONDS, f"{what}: took {time.perf_counter() - start:.1f} s"
    assert peak < MEBIBYTES, f"{what}: allocated {peak:.0f} MiB"


def _max_rss_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux


@needs_hypothesis
@pytest.mark.parametrize("kind", KINDS)
def test_fuzz_mutated_model_files(files, tmp_path, runslow, kind):
    """Every mutated file: a loaded model that simulates, or a ValueError naming the field, fast and small."""
    rss = _max_rss_mib()
    allow_import = kind == "ParametricHiddenState"  # the one file that names a function where one is declared
    sys.modules.pop("this", None)

    @hypothesis.settings(max_examples=500 if runslow else 30, deadline=None, derandomize=not runslow,
                         database=None, suppress_health_check=list(hypothesis.HealthCheck))
    @hypothesis.given(st.data())
    def run(data):
        content = json.loads(files[kind])
        changes = [_mutate(content, data.draw) for _ in range(data.draw(st.integers(1, 3)))]
        _check_case(json.dumps(content), tmp_path, f"{kind} {changes}", allow_import)

    run()
    assert _max_rss_mib() - rss < 500, "loading mutated files took more than 500 MiB"
    assert allow_import or "this" not in sys.modules, "a file ran code: it imported the module 'this'"


@needs_hypothesis
@pytest.mark.parametrize("kind", KINDS)
def test_fuzz_truncated_and_garbled_text(files, tmp_path, runslow, kind):
    """Cut or garbled JSON text is refused as invalid JSON or by field, never with a traceback."""
    text = files[kind]

    @hypothesis.settings(max_examples=200 if runslow else 10, deadline=None, derandomize=not runslow, database=None,
                         suppress_health_check=list(hypothesis.HealthCheck))
    @hypothesis.given(st.integers(0, len(text)), st.integers(0, len(text)), st.text(max_size=5))
    def run(start, stop, insert):
        _check_case(text[:start] + insert + text[max(start, stop):], tmp_path, f"{kind} text[{start}:{stop}]")

    run()


def test_fuzz_suite_finds_the_old_defects():
    """The checks of the fuzz suite are real: a message without a field, or a slow load, fails a case."""
    assert _TOP.match("fitted.coef: expected ...") and _TOP.match("/x/m.json is not valid JSON")
    assert not _TOP.match("int too large to convert to float") and not _TOP.match("maximum recursion depth")
    with pytest.raises(_Timeout), _time_limit(0.05):
        time.sleep(1)
    with pytest.raises(AssertionError, match="allocated"), pytest.MonkeyPatch.context() as patch:
        patch.setattr(sys.modules[__name__], "MEBIBYTES", 0)
        _check_case("{}", Path(tempfile.mkdtemp()), "an empty object")
    assert math.isfinite(_max_rss_mib())


# ------------------------------------------------------ issue 30, item 19: clear messages
@pytest.mark.parametrize("path", ["../../etc:passwd", "a/b:leak", "os:path/x", ":leak", "my_tank:", "leak",
                                  "my tank:leak", "os.:path"])
def test_a_function_path_of_no_python_names_is_a_value_error(files, tmp_path, path):
    # '../../etc:passwd' raised a TypeError from importlib instead of the documented ValueError
    file = _edited(files, "ParametricHiddenState", tmp_path,
                   (["params", "hidden", "estimator", "params", "rhs"], {"function": path}))
    _refused(file, rf"expected a function path 'module:name' of dotted Python names \('my_models.laws:leak'\); "
                   rf"got {re.escape(repr(path))}\.", allow_import=True)


@pytest.mark.parametrize("field", [["class"], ["format_version"], ["params", "dt"]])
def test_a_huge_value_is_quoted_in_part(files, field):
    # a 10 MB class name was echoed into a 10,000,116-character message
    data = json.loads(files["SINDy"])
    where = data
    for key in field[:-1]:
        where = where[key]
    where[field[-1]] = "A" * 10**7
    with pytest.raises(ValueError) as info:
        sio.model_from_dict(data)
    assert len(str(info.value)) < 1000 and "10,000,002 characters" in str(info.value), str(info.value)[:2000]
