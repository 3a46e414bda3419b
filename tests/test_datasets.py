"""Tests of sindybench.datasets: the benchmark records against their raw files."""

import csv
import os
import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.io import loadmat
from scipy.signal import decimate

from sindybench.datasets import (
    DownloadError,
    as_input_output,
    get_data_home,
    load_bouc_wen,
    load_cascaded_tanks,
    load_emps,
    load_pick_and_place,
    load_silverbox,
)


def _read_csv_columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = [h.strip() for h in rows[0]]
    columns = {}
    for j, name in enumerate(header):
        if name:
            columns[name] = [float(r[j]) for r in rows[1:] if j < len(r) and r[j].strip() != ""]
    return {k: np.array(v) for k, v in columns.items()}


def _check_split(split, n, dt, t0):
    assert split.u.shape == (n, 1) and split.y.shape == (n, 1)
    assert split.u.dtype == float and split.y.dtype == float
    assert split.dt == pytest.approx(dt, rel=1e-12)
    assert split.t.shape == (n,)
    assert split.t[0] == pytest.approx(t0, abs=1e-9)
    np.testing.assert_allclose(np.diff(split.t), dt, rtol=1e-9)


# --- cascaded tanks ------------------------------------------------------------------------------


def test_cascaded_tanks_against_raw_csv(data_home):
    data = load_cascaded_tanks(data_home=data_home, download_if_missing=False)
    raw = _read_csv_columns(data_home / "cascaded_tanks" / "dataBenchmark.csv")
    assert data.dt == 4.0 and data.n_init == 5
    _check_split(data.train, 768, 4.0, 0.0)
    _check_split(data.validation, 256, 4.0, 768 * 4.0)
    _check_split(data.test, 1024, 4.0, 0.0)
    _check_split(data.estimation, 1024, 4.0, 0.0)
    # split boundaries and first/last values against the raw file, and its csv copy (5 digits)
    mat = loadmat(data_home / "cascaded_tanks" / "dataBenchmark.mat")
    assert data.train.u[0, 0] == mat["uEst"][0, 0] and data.train.y[-1, 0] == mat["yEst"][767, 0]
    assert data.validation.u[0, 0] == mat["uEst"][768, 0] and data.validation.y[-1, 0] == mat["yEst"][-1, 0]
    assert data.test.u[0, 0] == mat["uVal"][0, 0] and data.test.y[-1, 0] == mat["yVal"][-1, 0]
    assert data.train.u[0, 0] == pytest.approx(raw["uEst"][0], rel=1e-4)
    assert data.validation.u[0, 0] == pytest.approx(raw["uEst"][768], rel=1e-4)
    assert data.test.y[-1, 0] == pytest.approx(raw["yVal"][-1], rel=1e-4)
    np.testing.assert_allclose(np.vstack([data.train.y, data.validation.y])[:, 0], raw["yEst"], rtol=1e-4)
    np.testing.assert_allclose(data.test.u[:, 0], raw["uVal"], rtol=1e-4)
    assert data.test.y.max() <= 10.0 + 1e-9 and data.units.y == "V"
    assert "Ts = 4 s" in data.DESCR
    assert data.source[0].sha256.startswith("cb2f88d4")


# --- Bouc-Wen ------------------------------------------------------------------------------------


def test_bouc_wen_against_raw_files(data_home):
    data = load_bouc_wen(data_home=data_home, download_if_missing=False)
    dt = 1 / 750
    raw = _read_csv_columns(data_home / "bouc_wen" / "train_data.csv")
    _check_split(data.train, 40000, dt, 0.0)
    _check_split(data.validation, 960, dt, 40000 * dt)
    _check_split(data.estimation, 40960, dt, 0.0)
    assert data.train.u[0, 0] == raw["u"][0] and data.train.y[0, 0] == raw["y"][0]
    assert data.train.y[-1, 0] == raw["y"][39999] and data.validation.y[0, 0] == raw["y"][40000]
    assert data.validation.u[-1, 0] == raw["u"][40959]
    assert set(data.test) == {"multisine", "sinesweep", "sine"}
    for name, n in (("multisine", 8192), ("sinesweep", 153000)):
        u = loadmat(data_home / "bouc_wen" / f"uval_{name}.mat")[f"uval_{name}"].ravel()
        y = loadmat(data_home / "bouc_wen" / f"yval_{name}.mat")[f"yval_{name}"].ravel()
        test = data.test[name]
        _check_split(test, n, dt, 0.0)
        assert test.u[0, 0] == u[0] and test.u[-1, 0] == u[-1] and test.y[-1, 0] == y[-1]
    sine = data.test.sine
    _check_split(sine, 1000, dt, 0.0)
    np.testing.assert_allclose(sine.u[:, 0], 150 * np.sin(2 * np.pi * 0.75 * sine.t), atol=1e-9)
    assert abs(sine.y[0, 0]) < 1e-12  # from rest
    assert 5e-4 < np.abs(sine.y).max() < 5e-3  # about 1.4 mm at 150 N
    assert data.units.u == "N" and data.units.y == "m" and data.n_init == 10


# --- pick and place -------------------------------------------------------------------------------


def test_pick_and_place_against_raw_file(data_home):
    data = load_pick_and_place(data_home=data_home, download_if_missing=False)
    mat = loadmat(data_home / "pick_and_place" / "headdata_1v6.mat")
    u_dec = -100 * decimate(mat["u"][:, 0], 10)
    y_dec = decimate(mat["y"][:, 0], 10)
    assert u_dec.shape == (6001,)
    dt = 2.5e-3
    assert data.dt == dt
    _check_split(data.train, 3840, dt, 0.0)
    _check_split(data.validation, 960, dt, 3840 * dt)
    _check_split(data.test, 1201, dt, 4800 * dt)
    _check_split(data.estimation, 4800, dt, 0.0)
    u = np.vstack([data.train.u, data.validation.u, data.test.u])[:, 0]
    y = np.vstack([data.train.y, data.validation.y, data.test.y])[:, 0]
    assert u.mean() == pytest.approx(0, abs=1e-12) and u.std(ddof=1) == pytest.approx(1, rel=1e-12)
    assert y.mean() == pytest.approx(0, abs=1e-12) and y.std(ddof=1) == pytest.approx(1, rel=1e-12)
    # undo the standardisation and compare with the raw record decimated here
    np.testing.assert_allclose(u * data.scaling.u_std + data.scaling.u_mean, u_dec, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(y * data.scaling.y_std + data.scaling.y_mean, y_dec, rtol=1e-10, atol=1e-10)
    for split, first, last in ((data.train, 0, 3839), (data.validation, 3840, 4799), (data.test, 4800, 6000)):
        assert split.u[0, 0] == pytest.approx(u[first]) and split.y[-1, 0] == pytest.approx(y[last])


# --- EMPS -------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def emps_home(data_home):
    """The data home when it holds the EMPS records (skips without them, fails on CI)."""
    if not (data_home / "emps" / "DATA_EMPS.mat").is_file():
        msg = f"EMPS records not found in {data_home / 'emps'}"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return data_home


def test_emps_against_raw_files(emps_home):
    data = load_emps(data_home=emps_home, download_if_missing=False)
    est = loadmat(emps_home / "emps" / "DATA_EMPS.mat")
    tst = loadmat(emps_home / "emps" / "DATA_EMPS_PULSES.mat")
    dt = 1e-3
    assert data.dt == dt and data.n_init == 20
    np.testing.assert_allclose(np.diff(est["t"][:, 0]), dt, atol=1e-7)  # the records' own clock agrees
    _check_split(data.estimation, 24841, dt, 0.0)
    _check_split(data.train, 18631, dt, 0.0)
    _check_split(data.validation, 6210, dt, 18631 * dt)
    _check_split(data.test, 24841, dt, 0.0)
    # the validation block is the end of the estimation record: together they are the whole of it
    np.testing.assert_array_equal(np.vstack([data.train.u, data.validation.u]), est["vir"])
    np.testing.assert_array_equal(np.vstack([data.train.y, data.validation.y]), est["qm"])
    np.testing.assert_array_equal(data.test.u, tst["vir"])
    np.testing.assert_array_equal(data.test.y, tst["qm"])
    np.testing.assert_array_equal(data.test.pulses, tst["pulses_N"][:, 0])
    np.testing.assert_array_equal(data.validation.qg, est["qg"][18631:, 0])
    assert (data.test.n_init, data.test.score_from) == (20, 20)
    assert data.controller.kp == pytest.approx(160.18) and data.controller.gtau == pytest.approx(35.15, abs=1e-2)
    # the position stays within the 0.25 m stroke of the joint
    assert 0.24 < data.test.y.max() < 0.25 and abs(data.test.y.min()) < 1e-4


def test_emps_records_follow_the_pd_law_up_to_the_test_pulses(emps_home):
    """vir = kv (kp (qg - qm) - qm') on the estimation record; on the test record plus the pulses."""
    data = load_emps(data_home=emps_home)
    kp, kv = data.controller.kp, data.controller.kv
    for split, extra in ((data.estimation, 0.0), (data.test, data.test.pulses)):
        qm = split.y[:, 0]
        law = kv * (kp * (split.qg - qm) - np.gradient(qm, split.dt))
        assert np.median(np.abs(split.u[:, 0] - law - extra)) < 0.1  # V, against a median |vir| of 1.2 V
    # the pulses are in vir: without them the test record leaves the law by about their height (5)
    qm = data.test.y[:, 0]
    law = kv * (kp * (data.test.qg - qm) - np.gradient(qm, data.dt))
    assert np.median(np.abs(data.test.u[:, 0] - law)) > 4.0


def test_emps_matches_nonlinear_benchmarks_protocol(emps_home):
    """nonlinear_benchmarks.EMPS() reads the same files: same input, output, split and init window."""
    nlb = pytest.importorskip("nonlinear_benchmarks")
    data = load_emps(data_home=emps_home)
    # the package's loader downloads into its own folder: point it at ours instead (no network)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nlb.benchmarks, "cashed_download", lambda url, name, **kwargs: str(emps_home / "emps"))
        train_val, test = nlb.EMPS()
    np.testing.assert_array_equal(train_val.u, data.estimation.u[:, 0])
    np.testing.assert_array_equal(test.y, data.test.y[:, 0])
    assert test.state_initialization_window_length == data.test.n_init == data.test.score_from
    assert test.sampling_time == pytest.approx(data.dt, rel=1e-4)


# --- Silverbox ----------------------------------------------------------------------------------------


def test_silverbox_against_raw_file(data_home):
    """The official split of SNLS80mV: estimation, the three tests, the 50-sample window, volts and times."""
    raw = _read_csv_columns(data_home / "silverbox" / "SNLS80mV.csv")
    u, y = raw["V1"], raw["V2"]
    assert len(u) == len(y) == 131072
    data = load_silverbox(data_home=data_home, download_if_missing=False)
    dt = 2**14 / 1e7
    assert data.dt == pytest.approx(1.6384e-3, rel=1e-12) and data.n_init == 50
    _check_split(data.estimation, 65062, dt, 40650 * dt)
    _check_split(data.train, 52050, dt, 40650 * dt)
    _check_split(data.validation, 13012, dt, (40650 + 52050) * dt)
    np.testing.assert_array_equal(data.estimation.u[:, 0], u[40650:40650 + 65062])
    np.testing.assert_array_equal(np.vstack([data.train.y, data.validation.y]), data.estimation.y)
    tests = data.test
    assert list(tests) == ["multisine", "arrow_full", "arrow_no_extrapolation"]
    for name, start, n in (("multisine", 40650 + 65062, 21688), ("arrow_full", 100, 40475),
                           ("arrow_no_extrapolation", 100, 32000)):
        _check_split(tests[name], n, dt, start * dt)
        np.testing.assert_array_equal(tests[name].u[:, 0], u[start:start + n])
        np.testing.assert_array_equal(tests[name].y[:, 0], y[start:start + n])
        assert (tests[name].n_init, tests[name].score_from) == (50, 50) and "50 initial samples" in tests[name].protocol
    assert tests.multisine.t[-1] == pytest.approx(127399 * dt)  # the multisine block ends at all[127400]
    # the arrow grows beyond the estimation amplitudes after its first 32000 samples, not before
    peak = np.abs(data.estimation.y).max()
    assert np.abs(tests.arrow_no_extrapolation.y).max() < 1.1 * peak < np.abs(tests.arrow_full.y).max()
    assert data.units.y == "V" and data.source[0].sha256 == (
        "ae62d5a91230c10f76e6dd02c8a4fac3c9d4d8a95fbf50e87cb0c4885003e0f1")


def test_silverbox_matches_nonlinear_benchmarks_split(data_home, tmp_path):
    """nonlinear_benchmarks.Silverbox() cuts the same record into the same estimation and test sets."""
    nlb = pytest.importorskip("nonlinear_benchmarks")
    data = load_silverbox(data_home=data_home)
    record = {"V1": data.record.u[None, :], "V2": data.record.y[None, :]}
    with pytest.MonkeyPatch.context() as mp:  # the package reads SNLS80mV.mat: hand it our record, no network
        mp.setattr(nlb.benchmarks, "cashed_download", lambda url, name, **kwargs: str(tmp_path))
        mp.setattr(nlb.benchmarks, "loadmat", lambda path: record)
        train_val, tests = nlb.Silverbox()
    np.testing.assert_array_equal(train_val.u, data.estimation.u[:, 0])
    np.testing.assert_array_equal(train_val.y, data.estimation.y[:, 0])
    for theirs, name in zip(tests, ("multisine", "arrow_full", "arrow_no_extrapolation")):
        np.testing.assert_array_equal(theirs.y, data.test[name].y[:, 0])
        assert theirs.state_initialization_window_length == data.test[name].n_init == data.test[name].score_from


def test_silverbox_checksum_refuses_another_record(data_home, tmp_path):
    folder = tmp_path / "silverbox"
    folder.mkdir()
    text = (data_home / "silverbox" / "SNLS80mV.csv").read_text()
    (folder / "SNLS80mV.csv").write_text(text.replace("0.0057756", "0.0057757", 1))  # one digit of one sample
    with pytest.raises(DownloadError, match="not the published record"):
        load_silverbox(data_home=tmp_path)
    assert (folder / "SNLS80mV.csv").is_file()  # the user's file is kept


# --- data home and missing files --------------------------------------------------------------------


def test_get_data_home_honours_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("SINDYBENCH_DATA", str(tmp_path / "from_env"))
    assert get_data_home() == tmp_path / "from_env" and (tmp_path / "from_env").is_dir()
    assert get_data_home(tmp_path / "explicit") == tmp_path / "explicit"
    monkeypatch.delenv("SINDYBENCH_DATA")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert get_data_home() == tmp_path / "sindybench_data"


@pytest.mark.parametrize(
    ("loader", "filename"),
    [
        (load_cascaded_tanks, "cascaded_tanks/dataBenchmark.mat"),
        (load_bouc_wen, "bouc_wen/train_data.csv"),
        (load_pick_and_place, "pick_and_place/headdata_1v6.mat"),
        (load_emps, "emps/DATA_EMPS.mat"),
        (load_silverbox, "silverbox/SNLS80mV.csv"),
    ],
)
def test_missing_file_names_file_and_folder(loader, filename, tmp_path):
    with pytest.raises(FileNotFoundError, match=filename) as info:
        loader(data_home=tmp_path, download_if_missing=False)
    assert str(tmp_path) in str(info.value)
    assert not any(tmp_path.rglob("*.*"))


def test_record_without_public_source_says_where_to_copy_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="no public download address"):
        load_pick_and_place(data_home=tmp_path)


def test_existing_file_with_wrong_checksum_is_refused(data_home, tmp_path):
    folder = tmp_path / "cascaded_tanks"
    folder.mkdir()
    shutil.copy(data_home / "cascaded_tanks" / "dataBenchmark.mat", folder / "dataBenchmark.mat")
    with open(folder / "dataBenchmark.mat", "ab") as f:
        f.write(b"\0")
    with pytest.raises(DownloadError, match="not the published record"):
        load_cascaded_tanks(data_home=tmp_path)


# --- interop with nonlinear_benchmarks ---------------------------------------------------------------


def test_as_input_output_with_stand_in_record():
    rec = SimpleNamespace(u=np.arange(6.0), y=np.ones((6, 1)), sampling_time=0.25, state_initialization_window_length=3)
    b = as_input_output(rec)
    assert b.u.shape == (6, 1) and b.y.shape == (6, 1) and b.dt == 0.25 and b.n_init == 3
    np.testing.assert_allclose(b.t, 0.25 * np.arange(6))
    assert as_input_output(rec, dt=0.5).dt == 0.5
    pair = as_input_output((np.zeros((4, 2)), np.zeros(4)), dt=1.0)
    assert pair.u.shape == (4, 2) and pair.n_init is None
    with pytest.raises(ValueError, match="no sampling interval"):
        as_input_output(SimpleNamespace(u=np.zeros(3), y=np.zeros(3), sampling_time=None))
    with pytest.raises(ValueError, match="expected the same number of samples"):
        as_input_output(SimpleNamespace(u=np.zeros(3), y=np.zeros(4), sampling_time=1.0))
    with pytest.raises(ValueError, match="expected an object with u and y"):
        as_input_output(np.zeros(3))


def test_as_input_output_accepts_split_bunch(data_home):
    split = load_cascaded_tanks(data_home=data_home).test
    b = as_input_output(split)
    np.testing.assert_array_equal(b.y, split.y)
    assert b.dt == 4.0


def test_cascaded_tanks_protocol_of_nonlinear_benchmarks(data_home, tmp_path):
    """The installed nonlinear_benchmarks sets the initial window that the cascaded-tanks benchmark scores after."""
    nlb = pytest.importorskip("nonlinear_benchmarks")
    from sindybench.experiments import cascaded_tanks

    folder = tmp_path / "CascadedTanksFiles"
    folder.mkdir()
    shutil.copy(data_home / "cascaded_tanks" / "dataBenchmark.mat", folder)
    with pytest.MonkeyPatch.context() as mp:  # read our copy instead of downloading
        mp.setattr(nlb.benchmarks, "cashed_download", lambda urls, name, **kwargs: str(tmp_path))
        _, test = nlb.Cascaded_Tanks()
    window = test.state_initialization_window_length
    assert window == cascaded_tanks.NONLINEAR_BENCHMARKS_N_INIT, (
        f"nonlinear_benchmarks now starts its cascaded-tanks test from {window} samples; update the benchmark")
    ours = cascaded_tanks.BENCHMARK.load(data_home=data_home).test
    np.testing.assert_array_equal(ours.test_nonlinear_benchmarks.y[:, 0], test.y)
    assert ours.test_nonlinear_benchmarks.n_init == ours.test_nonlinear_benchmarks.score_from == window
    assert "score_from" not in ours.test and ours.test.y.shape == (1024, 1)


def test_as_input_output_with_nonlinear_benchmarks():
    nlb = pytest.importorskip("nonlinear_benchmarks")
    rec = nlb.Input_output_data(u=np.arange(5.0), y=np.arange(5.0) ** 2, sampling_time=0.1)
    b = as_input_output(rec)
    assert b.u.shape == (5, 1) and b.dt == 0.1
    np.testing.assert_allclose(b.y[:, 0], np.arange(5.0) ** 2)
