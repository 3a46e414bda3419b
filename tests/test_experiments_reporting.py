"""The designated row's extra reports: k-step prediction, smoothed start, standard errors, prediction band."""

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
