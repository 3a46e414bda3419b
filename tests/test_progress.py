"""Progress bars: in a terminal or a notebook, off by a parameter or SINDYBENCH_PROGRESS, never in a log."""

import functools
import io
import os
import subprocess
import sys
import types

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench._progress import ENV_VAR, progress_bar, show_progress
from sindybench.baselines import ARX
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.model_selection import IntRange, tune


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def _terminal(monkeypatch):
    """Standard error replaced by a terminal that records what is written to it.

    Called in the test body: pytest's capture puts its own stderr back between setup and call.
    """
    monkeypatch.delenv(ENV_VAR, raising=False)
    stream = _Terminal()
    monkeypatch.setattr(sys, "stderr", stream)
    return stream


def test_bars_only_where_they_can_be_drawn(monkeypatch):
    terminal = _terminal(monkeypatch)
    assert show_progress(True) is True
    assert show_progress(False) is False
    for off in ("0", "false", "Off", "no"):
        monkeypatch.setenv(ENV_VAR, off)
        assert show_progress(True) is False
    monkeypatch.setenv(ENV_VAR, "1")
    assert show_progress(True) is True
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # a pipe or a log file
    assert show_progress(True) is False


def test_bars_in_a_notebook_kernel(monkeypatch):
    monkeypatch.delenv(ENV_VAR, raising=False)
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # a kernel's stderr is no terminal
    shell = types.SimpleNamespace(config={"IPKernelApp": {}})
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: shell))
    assert show_progress(True) is True
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: None))  # a plain script
    assert show_progress(True) is False


def test_bad_switch():
    with pytest.raises(ValueError, match="show_progress_bar must be True or False; got 1"):
        show_progress(1)
    with pytest.raises(ValueError, match="show_progress_bar must be True or False; got 'no'"):
        HiddenStateSINDy(dt=0.1, show_progress_bar="no").fit(np.zeros((50, 1)), np.zeros((50, 1)))


def test_disabled_bar_writes_nothing(monkeypatch):
    terminal = _terminal(monkeypatch)
    bar = progress_bar(3, desc="x", show=False)
    bar.update(3)
    bar.close()
    assert terminal.getvalue() == ""


def _searched(show):
    t = np.arange(600) * 0.01
    u = np.sin(t)[:, None]
    y = np.cos(t)[:, None]
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=1), library=PolynomialLibrary(degree=1),
                            optimizer=STLS(), search_params={"optimizer__threshold": (1e-3, 1.0, True)}, n_trials=5,
                            random_state=0, dt=0.01, show_progress_bar=show, input_hold="zoh", refine=None), u, y


def test_inner_search_bar(monkeypatch):
    import tqdm.auto

    terminal = _terminal(monkeypatch)
    # redraw on every update (by default tqdm waits 0.1 s between redraws; these trials are faster)
    monkeypatch.setattr(tqdm.auto.tqdm, "__init__", functools.partialmethod(tqdm.auto.tqdm.__init__, mininterval=0))
    model, u, y = _searched(True)
    model.fit(u, y)
    text = terminal.getvalue()
    assert "inner search" in text and "5/5 [" in text and ", best 0." in text
    terminal.seek(0)
    terminal.truncate()
    model.set_params(show_progress_bar=False).fit(u, y)
    assert terminal.getvalue() == ""


def test_tune_bar_follows_the_switch_and_the_environment(monkeypatch):
    terminal = _terminal(monkeypatch)
    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    y = np.cumsum(u, axis=0) * 0.1
    space = {"na": IntRange(1, 3)}
    tune(ARX(), space, u, y, n_trials=3, random_state=0)
    assert "3/3" in terminal.getvalue()
    terminal.seek(0)
    terminal.truncate()
    monkeypatch.setenv(ENV_VAR, "0")
    tune(ARX(), space, u, y, n_trials=3, random_state=0)
    assert terminal.getvalue() == ""


def test_piped_cli_run_writes_no_carriage_returns(data_home, tmp_path):
    """A run whose output goes to a log (not a terminal) writes whole lines, no progress updates."""
    env = {k: v for k, v in os.environ.items() if k != ENV_VAR}
    proc = subprocess.run(
        [sys.executable, "-m", "sindybench.cli", "run", "pick-and-place", "--quick", "--trials", "2",
         "--out", str(tmp_path / "out"), "--data-home", str(data_home), "--no-download"],
        capture_output=True, timeout=600, env=env,
    )
    assert proc.returncode == 0, proc.stderr.decode()[-3000:]
    assert b"pick-and-place: SINDy, 1st order" in proc.stderr  # the log is there ...
    assert b"\r" not in proc.stderr and b"\r" not in proc.stdout  # ... without carriage-return updates
    assert b"it/s" not in proc.stderr
