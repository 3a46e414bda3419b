"""Property-based tests of the size limits and of simulate's output path (Hypothesis; issue 30).

* Sizes: an argument or a model-file setting whose product of sizes passes a limit is
  refused at once with a ``ValueError`` that names the product; one within the limits is
  accepted and does what it says (a block of any length gives the indices of a block cut
  at the record's length; an initial-state grid has ``grid_size ** n_hidden`` points).
* Paths: ``sindybench simulate`` given an ``--output`` spelled any way (relative, with
  ``.`` and ``..``, doubled slashes, through a symbolic or hard link) that names one of
  its inputs exits 2 and leaves every input byte for byte; any other output is written.

By default each property runs a fixed, derandomized set of examples; ``pytest --runslow``
runs many more, freshly drawn.
"""

import os
import time

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sindybench import SINDy  # noqa: E402
from sindybench._limits import MAX_BYTES, check_memory, check_size  # noqa: E402
from sindybench.baselines import ARX  # noqa: E402
from sindybench.cli import main  # noqa: E402
from sindybench.hidden import LatentHiddenState, ParametricHiddenState  # noqa: E402
from sindybench.hidden._parametric import MAX_GRID_POINTS  # noqa: E402
from sindybench.uncertainty import BootstrapEnsemble, circular_block_indices  # noqa: E402

QUICK_EXAMPLES, SLOW_EXAMPLES = 40, 1000


def _settings(runslow, **kwargs):
    return settings(max_examples=SLOW_EXAMPLES if runslow else QUICK_EXAMPLES, derandomize=not runslow,
                    deadline=None, database=None, suppress_health_check=list(HealthCheck), **kwargs)


# --------------------------------------------------------------------------- sizes
sizes = st.one_of(st.integers(0, 100), st.integers(0, 10**6), st.integers(0, 10**13))


def test_products_of_sizes_are_bounded(runslow):
    @_settings(runslow)
    @given(factors=st.lists(sizes, min_size=1, max_size=4), limit=st.integers(1, 10**12))
    def check(factors, limit):
        named = {f"f{i}": v for i, v in enumerate(factors)}
        try:
            check_size("it", named, limit=limit, unit="units")
            assert int(np.prod(factors, dtype=object)) <= limit
        except ValueError as exc:
            assert int(np.prod(factors, dtype=object)) > limit
            assert " x ".join(f"{v:,} f{i}" for i, v in enumerate(factors)) in str(exc)
        try:
            check_memory("it", factors)
            assert 8 * int(np.prod(factors, dtype=object)) <= MAX_BYTES
        except ValueError as exc:
            assert 8 * int(np.prod(factors, dtype=object)) > MAX_BYTES and "expected at most" in str(exc)

    check()


def test_a_block_of_any_length_is_cut_at_the_record(runslow):
    @_settings(runslow)
    @given(n=st.integers(1, 500), block=st.one_of(st.integers(1, 600), st.integers(1, 10**15)),
           seed=st.integers(0, 2**32 - 1))
    def check(n, block, seed):
        idx = circular_block_indices(n, block, np.random.default_rng(seed))
        assert idx.shape == (n,) and idx.min() >= 0 and idx.max() < n
        assert np.array_equal(idx, circular_block_indices(n, min(block, n), np.random.default_rng(seed)))

    check()


def two_tanks(xh, y, u, *, k):
    return np.array([-k * xh[0] + u[0], k * (xh[0] - xh[1])])


def test_an_initial_state_grid_is_bounded_over_all_hidden_states(runslow):
    @_settings(runslow)
    @given(grid_size=st.one_of(st.integers(2, 200), st.integers(2, 10**12)), n_hidden=st.integers(1, 3))
    def check(grid_size, n_hidden):
        hidden = ParametricHiddenState(two_tanks, params={"k": 0.5}, x0_bounds=[(0.0, 1.0)] * n_hidden,
                                       grid_size=grid_size)
        start = time.perf_counter()
        try:
            hidden._validate()
            assert hidden._grid_points() == grid_size**n_hidden <= MAX_GRID_POINTS
        except ValueError as exc:
            assert grid_size**n_hidden > MAX_GRID_POINTS
            assert f"{grid_size:,} points of hidden state {n_hidden - 1}" in str(exc)
        assert time.perf_counter() - start < 1.0

    check()


def test_state_counts_and_ensemble_sizes_are_refused_before_any_work(runslow):
    rng = np.random.default_rng(0)
    u = rng.standard_normal((50, 1))
    y = np.cumsum(u, axis=0) * 0.01

    @_settings(runslow)
    @given(n_latent=st.integers(1, 10**12), n_members=st.integers(2, 10**12))
    def check(n_latent, n_members):
        start = time.perf_counter()
        try:
            LatentHiddenState(n_latent=n_latent)._validate()
            assert 8 * (n_latent + 1) * n_latent <= MAX_BYTES
        except ValueError as exc:
            assert 8 * (n_latent + 1) * n_latent > MAX_BYTES and "lag chain's coefficients" in str(exc)
        if 8 * n_members * 50 > MAX_BYTES:  # refused before the first fit (a fit of the members would be long)
            with pytest.raises(ValueError, match=rf"BootstrapEnsemble\(n_members={n_members}\): the members' "):
                BootstrapEnsemble(SINDy(dt=0.1), n_members=n_members).fit(u, y)
        assert time.perf_counter() - start < 1.0

    check()


# --------------------------------------------------------------------------- paths that alias
@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A model, an input and a y-init file, a sub-folder, and links to each file."""
    root = tmp_path_factory.mktemp("alias")
    rng = np.random.default_rng(0)
    u = rng.standard_normal((40, 1))
    ARX(na=1, nb=1).fit(u, np.cumsum(u, axis=0) * 0.1).to_json(root / "model.json")
    (root / "u.csv").write_text("u\n" + "".join(f"{v!r}\n" for v in u[:, 0]))
    (root / "y0.csv").write_text("y\n0.0\n")
    (root / "sub").mkdir()
    for name in ("model.json", "u.csv", "y0.csv"):
        os.symlink(root / name, root / f"soft-{name}")
        os.link(root / name, root / f"hard-{name}")
    os.symlink(root, root / "sub" / "up")
    return root


def _spelling(draw, root, name):
    """``name`` in ``root``, written one of many ways (from the current folder ``root / "sub"``)."""
    form = draw(st.sampled_from(["absolute", "relative", "dot", "dotdot", "slashes", "soft", "hard", "dir-link"]))
    if form in ("soft", "hard") and name != "new.csv":
        return str(root / f"{form}-{name}"), True
    return {
        "absolute": str(root / name),
        "relative": os.path.join("..", name),
        "dot": os.path.join(".", "..", ".", name),
        "dotdot": os.path.join("..", "sub", "..", name),
        "slashes": str(root).replace(os.sep, os.sep * 2) + os.sep * 2 + name,
        "dir-link": os.path.join("up", name),
    }.get(form, str(root / name)), name != "new.csv"


def test_simulate_refuses_every_spelling_of_an_input_as_its_output(folder, runslow, monkeypatch, capsys):
    monkeypatch.chdir(folder / "sub")
    inputs = ("model.json", "u.csv", "y0.csv")
    before = {name: (folder / name).read_bytes() for name in inputs}

    @_settings(runslow)
    @given(data=st.data())
    def check(data):
        target = data.draw(st.sampled_from([*inputs, "new.csv"]))
        output, alias = _spelling(data.draw, folder, target)
        argv = ["simulate", _spelling(data.draw, folder, "model.json")[0], "--input",
                _spelling(data.draw, folder, "u.csv")[0], "--y-init", _spelling(data.draw, folder, "y0.csv")[0],
                "--output", output, "-q"]
        (folder / "new.csv").unlink(missing_ok=True)
        status = main(argv)
        err = capsys.readouterr().err
        if alias:
            assert status == 2 and "simulate never writes over what it reads" in err, (argv, err)
        else:
            assert status == 0 and (folder / "new.csv").read_text().startswith("y0\n"), (argv, err)
        assert {name: (folder / name).read_bytes() for name in inputs} == before, argv

    check()
