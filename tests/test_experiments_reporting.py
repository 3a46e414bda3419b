"""The designated row's extra reports: k-step prediction, smoothed start, standard errors, prediction band."""

import json

import numpy as np
import pytest

from sindybench.experiments._best import best_model_markdown, smoothed_start_scores

def estimation_error():
    try:
        import sindybench.estimation  # noqa: F401
    except ImportError as exc:
        return str(exc)
    return None


def test_markdown_says_what_failed():
    best = {"key": "m", "label": "M", "choice": "designated", "status": "not fitted"}
    text = "\n".join(best_model_markdown(best))
    assert "Designated row `m`" in text and "not fitted" in text
    assert best_model_markdown(None) == []


def test_smoothed_start_reads_only_n_init_samples():
    """The smoothed start is the same whatever the test samples after n_init hold."""
    if estimation_error() is not None:
        pytest.skip(f"sindybench.estimation does not import in this tree: {estimation_error()}")
    from sindybench import SINDy, STLS
    from sindybench.libraries import PolynomialLibrary

    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, 30), 20)[:, None]
    y = np.zeros((600, 1))
    for k in range(599):
        y[k + 1] = y[k] + 0.05 * (-y[k] + 2 * u[k])
    model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.05).fit(u, y)
    clean, x0 = smoothed_start_scores(model, {"u": u, "y": y}, 10, Q=np.eye(1) * 1e-8, R=np.eye(1) * 1e-6)
    assert clean["status"] == "ok" and clean["rmse"] < 0.1 and abs(x0[0] - y[0, 0]) < 1e-2
    later = y.copy()
    later[10:] += 100.0  # what the smoother must not see
    moved, x0_later = smoothed_start_scores(model, {"u": u, "y": later}, 10, Q=np.eye(1) * 1e-8,
                                            R=np.eye(1) * 1e-6)
    np.testing.assert_array_equal(x0_later, x0)
    assert moved["rmse"] > 50.0  # scored against the moved samples, from the same start


# --------------------------------------------------------------------------- an output folder the run cannot write
def test_a_read_only_output_folder_is_named_before_any_work(tmp_path, monkeypatch):
    # issue 30, item 19: a read-only --out failed late, naming its staging folder '.out.tmp-xuoicjhw'
    import os

    from sindybench.experiments._report import check_output_dir

    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if str(p) == str(tmp_path) else real(p, mode))
    with pytest.raises(PermissionError, match=rf"output folder {tmp_path}/out: cannot write into {tmp_path} "
                                              r"\(not writable\); .*choose another --out"):
        check_output_dir(tmp_path / "out")


def test_a_staging_folder_that_cannot_be_made_names_the_output_folder(tmp_path, monkeypatch):
    import errno
    import tempfile

    from sindybench.experiments import staged_output_dir

    def read_only(**kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(tempfile, "mkdtemp", read_only)
    with pytest.raises(OSError, match=rf"output folder {tmp_path}/out: cannot write into {tmp_path} \(Read-only "
                                      r"file system\).*choose another --out") as info:
        with staged_output_dir(tmp_path / "out"):
            pass
    assert ".tmp-" not in str(info.value)
def test_conformal_band_is_calibrated_on_validation_data_only():
    """The band's half-width does not move when the test outputs do; the coverage and width are reported."""
    from sindybench.baselines import ARX
    from sindybench.experiments._best import _conformal

    rng = np.random.default_rng(0)
    u = rng.normal(size=(1500, 1))
    y = np.zeros((1500, 1))
    for t in range(1, 1500):
        y[t] = 0.9 * y[t - 1] + u[t - 1]
    y += 0.1 * rng.normal(size=y.shape)
    model = ARX(na=1, nb=1).fit(u[:800], y[:800])
    info = {"test": {"n_init": 5, "score_from": 0}}
    test = {"u": u[1000:], "y": y[1000:]}
    out = _conformal(model, u[800:1000], y[800:1000], {"test": test}, info)
    moved = _conformal(model, u[800:1000], y[800:1000], {"test": {"u": u[1000:], "y": y[1000:] + 1.0}}, info)
    entry = out["coverage"]["test"]
    assert out["name"] == "conformal 95 % free-run band" and entry["status"] == "ok"
    assert 0.9 <= entry["coverage"] <= 0.99 and entry["mean_width"] == pytest.approx(2 * entry["half_width"][0])
    shifted = moved["coverage"]["test"]
    assert shifted["half_width"] == entry["half_width"] and shifted["coverage"] < 0.5
    best = {"key": "m", "label": "M", "choice": "designated", "status": "ok", "noise": {"status": "-"}, "k_step": {},
            "standard_errors": {"a": 0.1}, "standard_errors_status": "warning: the residuals are not white",
            "residual_analysis": {"status": "ok", "message": "not white"}, "conformal_band": out}
    text = "\n".join(best_model_markdown(best))
    assert "**Warning**: the residuals are not white" in text and "residuals not white." in text
    assert "conformal 95 % free-run band (" in text and f"`test` {entry['coverage']:.3f} (mean width" in text
    # the test's inputs (normal draws) reach beyond the 200 validation samples': the entry and the report say so
    found = entry["extrapolation"]
    assert 0 < found["fraction_inputs"] <= found["fraction"] < 0.2 and "200 samples" in found["calibration"]
    assert json.loads(json.dumps(found)) == found
    assert f"**extrapolates**: {100 * found['fraction']:.1f} % of the test samples outside the calibration" in text
    inside = _conformal(model, u[800:1000], y[800:1000], {"test": {"u": u[1000:1005] * 0, "y": y[1000:1005] * 0}},
                        info)["coverage"]["test"]
    assert inside["extrapolation"]["fraction"] == 0.0


def test_held_out_band_takes_its_half_width_from_a_refit_without_the_validation_block():
    from sindybench.baselines import ARX
    from sindybench.experiments._best import HELD_OUT_NAME, _held_out
    from sindybench.uncertainty import conformal_calibration

    rng = np.random.default_rng(1)
    u = rng.normal(size=(1200, 1))
    y = np.zeros((1200, 1))
    for t in range(1, 1200):
        y[t] = 0.9 * y[t - 1] + u[t - 1] + 0.05 * y[t - 1] ** 2 / (1 + y[t - 1] ** 2)
    y += 0.1 * rng.normal(size=y.shape)
    row = ARX(na=1, nb=1).fit(u[:1000], y[:1000])  # the row, fitted on training and validation blocks
    info = {"test": {"n_init": 5, "score_from": 0}}
    out = _held_out(row, u[:1000], y[:1000], 200, {"test": {"u": u[1000:], "y": y[1000:]}}, info, None)
    held = ARX(na=1, nb=1).fit(u[:800], y[:800])
    expected = conformal_calibration(held, u[800:1000], y[800:1000], n_init=5).half_width
    assert out["name"] == HELD_OUT_NAME and out["status"] == "ok" and out["time_s"] > 0
    assert out["coverage"]["test"]["half_width"] == expected.tolist()
    text = "\n".join(best_model_markdown({"key": "m", "label": "M", "choice": "c", "status": "ok", "noise": {},
                                          "k_step": {}, "conformal_band_held_out": out}))
    assert f"{HELD_OUT_NAME} (the same band" in text
