"""sindybench.plotting: the artists carry the data they were given, and bad input is refused clearly."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from sindybench import STLS, HiddenStateSINDy, SINDy  # noqa: E402
from sindybench.baselines import ARX  # noqa: E402
from sindybench.hidden import DerivativeHiddenState  # noqa: E402
from sindybench.libraries import PolynomialLibrary  # noqa: E402
from sindybench.metrics import fit_index, r2  # noqa: E402
from sindybench.plotting import (  # noqa: E402
    coefficient_table,
    envelope,
    error_spectrum,
    plot_coefficients,
    plot_error_spectrum,
    plot_hidden_states,
    plot_hysteresis,
    plot_output_error,
    plot_search_history,
    plot_simulation,
    zoom_window,
)
from sindybench.simulate import TermsRHS, simulate  # noqa: E402

DT = 0.01


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def oscillator():
    """Inputs and measured position of a forced damped oscillator (velocity hidden)."""
    t = np.arange(1500) * DT
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    truth = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0},
                                     {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.5, ((2, 0, 1, 0),): 2.0}])
    return u, simulate(truth, [0.0, 0.0], u, dt=DT, n_substeps=4)[:, :1]


@pytest.fixture(scope="module")
def hidden_model(oscillator):
    u, y = oscillator
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
                            dt=DT).fit(u, y)


@pytest.fixture(scope="module")
def searched_model(oscillator):
    u, y = oscillator
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
                            optimizer=STLS(), search_params={"optimizer__threshold": (1e-3, 10.0, True)},
                            n_trials=8, random_state=0, dt=DT).fit(u, y)


@pytest.fixture(scope="module")
def sindy_model():
    t = np.arange(0, 3, DT)
    y = np.column_stack([np.exp(-2 * t), 1 + np.exp(-t)])
    return SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=DT).fit(None, y)


# ------------------------------------------------------------------ simulation
def test_simulation_lines_hold_the_given_arrays(oscillator):
    u, y = oscillator
    a, b = 1.1 * y, y + 0.05
    out_ax, in_ax = plot_simulation(u, y, {"a": a, "b": b}, dt=DT, output_label="position")
    lines = out_ax.get_lines()
    assert len(lines) == 3
    t = np.arange(len(y)) * DT
    for line, expected in zip(lines, (y, a, b)):
        np.testing.assert_array_equal(line.get_xdata(), t)
        np.testing.assert_array_equal(line.get_ydata(), expected[:, 0])
    labels = [line.get_label() for line in lines]
    assert labels == ["measured", f"a (R^2 {r2(y, a):.2f}, fit {fit_index(y, a):.1f} %)",
                      f"b (R^2 {r2(y, b):.2f}, fit {fit_index(y, b):.1f} %)"]
    assert [t.get_text() for t in out_ax.get_legend().get_texts()] == labels
    np.testing.assert_array_equal(in_ax.get_lines()[0].get_ydata(), u[:, 0])
    assert out_ax.get_ylabel() == "position" and in_ax.get_xlabel() == "time [s]"


def test_simulation_label_tells_close_fits_apart(oscillator):
    # before: R^2 to two decimals only, "1.00" for both (every refined model read 1.00; issue 18, case 23)
    u, y = oscillator
    noise = np.random.default_rng(0).normal(size=y.shape) * y.std()
    close, closer = y + 0.03 * noise, y + 0.01 * noise
    out_ax, _ = plot_simulation(u, y, {"close": close, "closer": closer})
    labels = [line.get_label() for line in out_ax.get_lines()[1:]]
    assert labels[0].startswith("close (R^2 1.00, fit 97.") and labels[1].startswith("closer (R^2 1.00, fit 99.")


def test_simulation_of_a_fitted_model_is_its_prediction(oscillator, hidden_model):
    u, y = oscillator
    (out_ax, _) = plot_simulation(u, y, hidden_model, n_init=20)
    expected = hidden_model.predict(u, y_init=y[:20])
    np.testing.assert_allclose(out_ax.get_lines()[1].get_ydata(), expected[:, 0])
    assert out_ax.get_lines()[1].get_label().startswith("HiddenStateSINDy (R^2 ")
    np.testing.assert_array_equal(out_ax.get_lines()[0].get_xdata(), np.arange(len(y)))  # no dt: samples


def test_simulation_on_given_axes(oscillator):
    u, y = oscillator
    fig, ax = plt.subplots()
    (got,) = plot_simulation(u, y, [1.1 * y], ax=ax)
    assert got is ax and len(fig.axes) == 1 and [line.get_label() for line in ax.get_lines()][1].startswith("model 0")
    fig, axes = plt.subplots(2, 1)
    got = plot_simulation(u, y, None, ax=axes)
    assert list(got) == list(axes) and len(axes[0].get_lines()) == 1 and len(axes[1].get_lines()) == 1


def test_simulation_keeps_the_frame_on_the_measurement():
    t = np.arange(200) * 0.1
    u, y = np.sin(t)[:, None], np.cos(t)[:, None]
    close = y + 0.1
    (ax, _) = plot_simulation(u, y, {"good": close, "wild": close})
    assert ax.get_ylim()[1] < 1.5  # nothing leaves the frame: matplotlib's own limits
    (ax, _) = plot_simulation(u, y, {"good": close, "wild": 1e3 * t[:, None]})
    assert ax.get_ylim() == pytest.approx((-2.0, 2.0), abs=1e-3)
    assert ax.get_legend().get_texts()[2].get_text().endswith(", leaves the frame")


def test_diverged_simulation_is_labelled():
    y = np.cos(np.arange(50.0))[:, None]
    bad = y.copy()
    bad[30:] = np.nan
    (ax,) = plot_simulation(None, y, {"m": bad})
    assert ax.get_lines()[1].get_label() == "m (diverged)"


def test_long_records_are_strided(oscillator):
    u, y = oscillator
    (ax, _) = plot_simulation(u, y, max_points=500)
    np.testing.assert_array_equal(ax.get_lines()[0].get_ydata(), y[::3, 0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"models": {"m": np.zeros((10, 1))}}, r"simulation of model 'm' has shape \(10, 1\); expected \(1500, 1\)"),
        ({"models": {"m": "abc"}}, "neither a fitted estimator nor an array"),
        ({"models": {"m": 3.0}}, r"simulation of model 'm' has shape \(\); expected \(1500, 1\)"),
        ({"output": 1}, r"output=1 but there are 1 column\(s\)"),
        ({"dt": -1.0}, "dt must be a number > 0"),
        ({"ax": "axes"}, "ax must be one matplotlib Axes"),
        ({"n_init": 0}, "n_init"),
    ],
)
def test_simulation_bad_input(oscillator, kwargs, match):
    u, y = oscillator
    with pytest.raises(ValueError, match=match):
        plot_simulation(u, y, **kwargs)


def test_simulation_of_an_estimator_needs_inputs(oscillator, hidden_model):
    with pytest.raises(ValueError, match="is an estimator; pass its inputs X"):
        plot_simulation(None, oscillator[1], {"m": hidden_model})
    with pytest.raises(ValueError, match="X has 3 samples|expected 1500"):
        plot_simulation(oscillator[0][:3], oscillator[1])


# ------------------------------------------------------------------ hysteresis
def test_hysteresis_loops_are_output_against_input(oscillator):
    u, y = oscillator
    ax = plot_hysteresis(u, y, {"m": 0.9 * y}, output_label="y [m]", input_label="u [N]")
    measured, model = ax.get_lines()
    np.testing.assert_array_equal(measured.get_xdata(), y[:, 0])
    np.testing.assert_array_equal(measured.get_ydata(), u[:, 0])
    np.testing.assert_array_equal(model.get_xdata(), 0.9 * y[:, 0])
    assert (ax.get_xlabel(), ax.get_ylabel(), model.get_label()) == ("y [m]", "u [N]", "m")


def test_hysteresis_against_a_hidden_state(oscillator, hidden_model):
    u, y = oscillator
    ax = plot_hysteresis(u, y, {"hidden": hidden_model}, hidden="y0'", n_init=20)
    states = hidden_model.simulate(u, y_init=y[:20])
    (line,) = ax.get_lines()
    np.testing.assert_allclose(line.get_xdata(), states[:, 0])
    np.testing.assert_allclose(line.get_ydata(), states[:, 1])
    assert ax.get_ylabel() == "y0'"


def test_hysteresis_bad_input(oscillator, hidden_model, sindy_model):
    u, y = oscillator
    with pytest.raises(ValueError, match=r"'z' is not a hidden state of the model; expected one of \[\"y0'\"\]"):
        plot_hysteresis(u, y, hidden_model, hidden="z")
    with pytest.raises(ValueError, match="hidden=1 but the model has 1 hidden state"):
        plot_hysteresis(u, y, hidden_model, hidden=1)
    with pytest.raises(ValueError, match="SINDy has no hidden states"):
        plot_hysteresis(u, y, sindy_model, hidden=0)
    with pytest.raises(ValueError, match="needs the inputs X"):
        plot_hysteresis(None, y)


# --------------------------------------------------------------- hidden states
def test_hidden_states_of_the_training_reconstruction(hidden_model):
    (ax,) = plot_hidden_states(hidden_model)
    (line,) = ax.get_lines()
    np.testing.assert_array_equal(line.get_ydata(), hidden_model.hidden_states_[:, 0])
    np.testing.assert_allclose(line.get_xdata(), np.arange(len(hidden_model.states_)) * DT)
    assert ax.get_ylabel() == "y0'" and "reconstructed" in line.get_label()


def test_hidden_states_of_a_simulation(oscillator, hidden_model):
    u, y = oscillator
    fig, ax = plt.subplots()
    (got,) = plot_hidden_states(hidden_model, u[:300], y[:300], n_init=20, states="y0'", ax=ax)
    assert got is ax
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), hidden_model.simulate(u[:300], y_init=y[:20])[:, 1])


def test_hidden_states_labels_and_units(hidden_model):
    # before: plot_hidden_states took no labels or units
    assert plot_hidden_states(hidden_model, labels=["velocity"], units=["m/s"])[0].get_ylabel() == "velocity [m/s]"
    assert plot_hidden_states(hidden_model, units={"y0'": "m/s"})[0].get_ylabel() == "y0' [m/s]"
    assert plot_hidden_states(hidden_model, labels="speed")[0].get_ylabel() == "speed"
    with pytest.raises(ValueError, match="labels has 2 entries; expected 1, one per drawn state"):
        plot_hidden_states(hidden_model, labels=["a", "b"])
    with pytest.raises(ValueError, match=r"units names \['h0'\], not drawn states"):
        plot_hidden_states(hidden_model, units={"h0": "N"})
    with pytest.raises(ValueError, match="units = .*expected strings"):
        plot_hidden_states(hidden_model, units=[3])


def test_hidden_states_bad_input(oscillator, hidden_model, sindy_model):
    with pytest.raises(ValueError, match="SINDy has no hidden states"):
        plot_hidden_states(sindy_model)
    with pytest.raises(ValueError, match="give both X and y"):
        plot_hidden_states(hidden_model, oscillator[0])
    with pytest.raises(ValueError, match=r"'y0' is not a hidden state"):
        plot_hidden_states(hidden_model, states=["y0"])


# ---------------------------------------------------------------- coefficients
def test_coefficient_table_across_models(sindy_model, hidden_model):
    rows, terms, values = coefficient_table({"plain": sindy_model, "hidden": hidden_model})
    assert rows == ["plain: y0'", "plain: y1'", "hidden: y0''"]
    assert terms == ["1", "y0", "y1", "y0'", "u0"]
    np.testing.assert_array_equal(values[:2, :3], sindy_model.coef_)
    np.testing.assert_array_equal(values[:2, 3:], 0.0)
    np.testing.assert_array_equal(values[2, [0, 1, 3, 4]], hidden_model.coef_[0])
    assert values[2, 2] == 0.0  # y1 is not a term of the hidden model
    rows, _, _ = coefficient_table(hidden_model, learned_only=False)
    assert rows == ["HiddenStateSINDy: y0'", "HiddenStateSINDy: y0''"]


def test_coefficient_heatmap(sindy_model, hidden_model):
    ax = plot_coefficients({"plain": sindy_model, "hidden": hidden_model})
    _, _, values = coefficient_table({"plain": sindy_model, "hidden": hidden_model})
    keep = np.any(values != 0, axis=0)
    image = ax.get_images()[0].get_array()
    np.testing.assert_array_equal(image.filled(0.0), values[:, keep])
    assert np.array_equal(image.mask, values[:, keep] == 0)
    assert len(ax.texts) == np.count_nonzero(values)
    assert [t.get_text() for t in ax.get_yticklabels()] == ["plain: y0'", "plain: y1'", "hidden: y0''"]


def test_coefficients_bad_input(oscillator):
    arx = ARX().fit(*oscillator)
    with pytest.raises(ValueError, match=r"model 'ARX' \(ARX\) has no equations; expected a fitted SINDy"):
        coefficient_table(arx)
    with pytest.raises(ValueError, match="no equations to draw"):
        plot_coefficients({})


# --------------------------------------------------------------------- search
def test_search_history_of_the_inner_search(searched_model):
    ax = plot_search_history(searched_model, label="inner")
    scores = np.array([s for _, s in searched_model.search_results_])
    best, trials = ax.get_lines()[:2]
    np.testing.assert_array_equal(trials.get_ydata(), scores)
    np.testing.assert_array_equal(best.get_ydata(), np.minimum.accumulate(scores))
    assert best.get_label() == "inner" and "lower is better" in ax.get_ylabel()


def test_search_history_of_tune(oscillator):
    from sindybench.model_selection import IntRange, tune

    u, y = oscillator
    _, study = tune(ARX(), {"na": IntRange(1, 4), "nb": IntRange(1, 3)}, u[::5], y[::5], n_trials=6,
                    random_state=0, scoring="r2", show_progress_bar=False)
    ax = plot_search_history(study)
    values = [t.value for t in study.trials]
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), np.maximum.accumulate(values))
    assert "higher is better" in ax.get_ylabel()


def test_search_history_marks_failed_trials():
    history = [({}, 0.5), ({}, 1e3), ({}, 0.2), ({}, float("nan"))]
    ax = plot_search_history(history)
    failed = ax.get_lines()[2]
    assert failed.get_label() == "failed (2)"
    np.testing.assert_array_equal(failed.get_xdata(), [1, 3])
    np.testing.assert_array_equal(ax.get_lines()[1].get_xdata(), [0, 2])


@pytest.mark.parametrize(
    "search, match",
    [
        ("study", "cannot read a search history from str"),
        ([({}, 1e3)], r"no successful trial \(1 failed\)"),
    ],
)
def test_search_history_bad_input(search, match):
    with pytest.raises(ValueError, match=match):
        plot_search_history(search)


# --------------------------------------------------------------------------- error-centred figures
def test_output_error_draws_each_error_and_scores_every_sample():
    """The error curves are y - y_sim; a long record is drawn decimated, the RMSE is of every sample after n_init."""
    rng = np.random.default_rng(0)
    n = 50_000
    y = np.sin(np.arange(n) * 0.001)[:, None]
    e = 0.01 * rng.standard_normal((n, 1))
    e[31_234] = 0.9  # one spike: decimation must keep it
    full, zoom = plot_output_error(None, y, {"good": y - e, "poor": 0.8 * y}, n_init=10, dt=0.01, max_points=2000)
    lines = [ln for ln in full.get_lines() if not ln.get_label().startswith("_")]
    assert [ln.get_label().split(" (")[0] for ln in lines] == ["measured output", "error of good", "error of poor"]
    rmse_good = float(np.sqrt(np.mean(e[10:] ** 2)))
    assert f"RMSE {rmse_good:.3g}" in lines[1].get_label()
    assert all(len(ln.get_xdata()) <= 2000 for ln in lines)
    assert np.nanmax(lines[1].get_ydata()) == pytest.approx(0.9)  # the spike survives the decimation
    # the zoom window holds the spike, and is shaded on the full axis
    lo, hi = zoom.get_xlim()
    assert lo <= 312.34 <= hi and len(full.patches) == 1


def test_an_error_as_large_as_the_output_is_named_not_drawn():
    y = np.sin(np.linspace(0, 30, 3000))[:, None]
    fine = y + 1e-3 * np.cos(np.arange(3000))[:, None]
    full, zoom = plot_output_error(None, y, {"zero": np.zeros_like(y), "fine": fine})
    labels = [ln.get_label() for ln in full.get_lines() if not ln.get_label().startswith("_")]
    assert labels == ["measured output", "error of fine (RMSE 0.000707)"]
    assert "zero" in full.get_legend().get_title().get_text()
    # the fine model's error is far below the output: the zoom's y axis is on it
    assert zoom.get_ylim()[1] == pytest.approx(1.15e-3, rel=0.05) and "errors on the left axis" in zoom.get_title()
    (right,) = [a for a in zoom.figure.axes if a is not full and a is not zoom]  # the output, on its own scale
    assert right.get_ylim()[1] > 0.9
    with pytest.raises(ValueError, match="max_error"):
        plot_output_error(None, y, {"m": y}, max_error=0)


def test_output_error_refuses_a_bad_zoom():
    y = np.zeros((100, 1))
    with pytest.raises(ValueError, match=r"zoom = \(50, 20\); expected \(start, stop\) samples with 0 <= start < "
                                         r"stop <= 100"):
        plot_output_error(None, y, {"m": y}, zoom=(50, 20))


def test_a_diverged_model_does_not_flatten_the_others():
    y = np.sin(np.linspace(0, 10, 500))[:, None]
    wild = y.copy()
    wild[250:] = 1e6
    (ax,) = plot_output_error(None, y, {"wild": wild, "fine": y + 0.01}, zoom=False)
    assert ax.get_ylim()[1] < 10


def test_envelope_and_zoom_window():
    t = np.arange(10_001.0)
    v = np.cos(t / 500.0)
    td, vd = envelope(t, v, max_points=400)
    assert len(td) <= 400 and np.all(np.diff(td) >= 0)
    assert vd.max() == v.max() and vd.min() == v.min()
    e = np.zeros((1000, 2))
    e[:, 1] = 5.0  # large everywhere: relative to its own mean square it decides nothing
    e[700:710, 0] = 1.0
    a, b = zoom_window(e, 100)
    assert b - a == 100 and a <= 700 and 710 <= b


def test_error_spectrum_in_db():
    dt = 0.01
    t = np.arange(8192) * dt
    f, p = error_spectrum(np.sin(2 * np.pi * 5.0 * t) + 0.01 * np.sin(2 * np.pi * 20.0 * t), dt)
    assert f[np.argmax(p)] == pytest.approx(5.0, abs=0.1)
    near = lambda hz: p[np.argmin(abs(f - hz))]  # noqa: E731
    assert near(5.0) - near(20.0) == pytest.approx(40.0, abs=3.0)  # amplitude ratio 100: 40 dB
    ax = plot_error_spectrum(None, np.sin(2 * np.pi * t)[:, None], {"m": np.zeros((8192, 1))}, dt=dt)
    assert ax.get_xlabel() == "frequency [Hz]" and len(ax.get_lines()) == 2
    with pytest.raises(ValueError, match="expected at least 2"):
        error_spectrum([1.0])
