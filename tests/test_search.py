"""sindybench.search: the dimensions, as_dimension, the study and sampler, the inner search."""

import math

import numpy as np
import optuna
import pytest
from optuna.distributions import FloatDistribution, IntDistribution

from sindybench.io import decode_value, encode_value
from sindybench.search import (
    Categorical,
    IntRange,
    LogNormal,
    LogUniform,
    Normal,
    Uniform,
    as_dimension,
    check_search_space,
    create_study,
    grid_points,
    minimize,
    sample_params,
)

optuna.logging.set_verbosity(optuna.logging.WARNING)


# --- as_dimension: the older spellings, read in one place ---------------------------------------------


@pytest.mark.parametrize(
    "spec, kw, expected",
    [
        ((0.1, 2.0), {}, Uniform(0.1, 2.0)),
        ((0.1, 2.0, False), {}, Uniform(0.1, 2.0)),
        ((1e-3, 1.0, True), {}, LogUniform(1e-3, 1.0)),
        ((5, 41), {}, IntRange(5, 41)),
        ((1, 64, True), {}, IntRange(1, 64, log=True)),
        ([7, 11, 15], {}, Categorical([7, 11, 15])),
        ((1, 10), {"real": True}, Uniform(1.0, 10.0)),
        ([1e4, 1e5, True], {"real": True}, LogUniform(1e4, 1e5)),
        (np.array([0.0, 2.0]), {"real": True}, Uniform(0.0, 2.0)),
        ((1e-4, 1.0), {"real": True, "log": True}, LogUniform(1e-4, 1.0)),
        ((1e-4, 1.0, False), {"real": True, "log": True}, LogUniform(1e-4, 1.0)),  # a fixed scale wins, as before
        ((-1.0, 1.0, True), {"real": True, "log": False}, Uniform(-1.0, 1.0)),
    ],
)
def test_as_dimension_reads_the_old_spellings(spec, kw, expected):
    dim = as_dimension(spec, **kw)
    assert dim == expected and type(dim) is type(expected)
    assert type(dim.low if hasattr(dim, "low") else 0.0) is type(getattr(expected, "low", 0.0))


@pytest.mark.parametrize(
    "dim", [Uniform(0.0, 1.0), LogNormal(0.0, 1.0), IntRange(1, 3), Categorical(["a"]), FloatDistribution(0.0, 1.0)]
)
def test_as_dimension_keeps_dimension_objects(dim):
    assert as_dimension(dim) is dim


@pytest.mark.parametrize(
    "spec, kw, match",
    [
        ((2.0, 1.0), {}, r"search_params\['a'\] = \(2.0, 1.0\); expected low < high\."),
        ((0.0, math.inf), {}, r"= \(0.0, inf\); expected low < high\."),
        ((0.0, 1.0, True), {}, r"= \(0.0, 1.0, True\) is log-scaled; expected low > 0\."),
        (("float", 0.0, 1.0), {}, r"expected numeric low and high\."),
        ((1.0,), {}, r"= \(1.0,\); expected \(low, high\), \(low, high, log\), a list of choices or Uniform"),
        (0.5, {}, r"= 0.5; expected \(low, high\), \(low, high, log\), a list of choices or Uniform"),
        ([], {}, r"search_params\['a'\] is an empty list; expected at least one choice\."),
        ([1, 1], {}, r"= \[1, 1\]: .*two choices share the label"),
        ("wide", {"real": True}, r"= 'wide'; expected \(low, high\), \(low, high, log\) or Uniform, LogUniform, "
                                 r"Normal, LogNormal\."),
        (IntRange(1, 3), {"real": True}, r"expected \(low, high\), \(low, high, log\) or Uniform"),
        ((0.0, 1.0), {"real": True, "log": True}, r"is log-scaled; expected low > 0"),
    ],
)
def test_as_dimension_says_what_was_wrong(spec, kw, match):
    with pytest.raises(ValueError, match=match):
        as_dimension(spec, name="search_params['a']", **kw)


def test_check_search_space_converts_only_when_asked():
    space = {"optimizer__threshold": (1e-3, 1.0, True), "differentiation__window_length": [7, 11]}
    assert check_search_space(space, name="search_params", convert=True) == {
        "optimizer__threshold": LogUniform(1e-3, 1.0), "differentiation__window_length": Categorical([7, 11])}
    assert space["optimizer__threshold"] == (1e-3, 1.0, True)  # the caller's dict is left alone
    with pytest.raises(ValueError, match=r"search_space\['optimizer__threshold'\] is \(0.001, 1.0, True\); expected "):
        check_search_space(space)
    with pytest.raises(ValueError, match=r"search_params\['x'\] = \(1.0, 0.0\); expected low < high"):
        check_search_space({"x": (1.0, 0.0)}, name="search_params", convert=True)


# --- the real dimensions' unit coordinate and support -------------------------------------------------


@pytest.mark.parametrize("dim", [Uniform(-2.0, 3.0), LogUniform(1e-3, 10.0), Normal(1.0, 0.2), LogNormal(2.0, 0.5)])
def test_unit_coordinate_round_trips_and_spans_the_support(dim):
    low, high = dim.support()
    assert dim.from_unit(0.0) == pytest.approx(low) and dim.from_unit(1.0) == pytest.approx(high)
    for z in (0.1, 0.5, 0.77):
        v = dim.from_unit(z)
        assert low <= v <= high and dim.to_unit(v) == pytest.approx(z, abs=1e-9)
    assert dim.from_unit(-0.5) == pytest.approx(low) and dim.from_unit(1.5) == pytest.approx(high)
    assert low <= dim.from_unit(-0.5) and dim.from_unit(1.5) <= high  # never outside the support


def test_normal_unit_coordinate_is_the_suggested_quantile():
    prior = LogNormal(math.log(5e4), 0.5)
    low, high = prior._quantiles()
    value = prior.suggest(optuna.trial.FixedTrial({"k:quantile": low + 0.3 * (high - low)}), "k")
    assert prior.from_unit(0.3) == value and prior.from_unit(0.5) == pytest.approx(5e4)
    assert Normal(1.0, 0.1).support() == pytest.approx((0.6, 1.4))


# --- the study: one place, the same suggestions as before ----------------------------------------------


def _suggested(study, space, n):
    study.optimize(lambda trial: sum(float(v) for v in sample_params(space, trial).values()), n_trials=n)
    return [t.params for t in study.trials]


def test_create_study_draws_what_the_old_samplers_drew():
    space = {"a": Uniform(0.0, 1.0), "b": LogUniform(1e-3, 1.0), "n": IntRange(1, 9), "c": Categorical([1, 2, 3])}
    # the inner search: one TPE stream seeded once, n_startup_trials given
    new = _suggested(create_study(12345, per_trial=False, n_startup_trials=4), space, 12)
    old = optuna.create_study(sampler=optuna.samplers.TPESampler(seed=12345, n_startup_trials=4))
    assert new == _suggested(old, space, 12)
    # tune: TPE seeded per trial from (seed, trial number), Optuna's default 10 startup trials
    tuned = _suggested(create_study(7), space, 12)
    seeds = [int(np.random.SeedSequence([7, n]).generate_state(1)[0]) for n in range(12)]
    assert tuned[0] == _suggested(optuna.create_study(sampler=optuna.samplers.TPESampler(seed=seeds[0])), space, 1)[0]
    assert tuned != new


def test_optuna_distributions_are_suggested_by_their_own_call():
    space = {"x": FloatDistribution(0.0, 1.0, step=0.25), "n": IntDistribution(2, 8, step=2)}
    study = create_study(0, per_trial=False)
    values = _suggested(study, space, 5)
    assert all(v["x"] in (0.0, 0.25, 0.5, 0.75, 1.0) and v["n"] in (2, 4, 6, 8) for v in values)


# --- minimize: TPE, then bounded Nelder-Mead on the real dimensions -------------------------------------


def test_minimize_refines_a_normal_prior_on_its_quantile():
    prior = Normal(1.0, 0.5)
    best, history = minimize(lambda v: (v["k"] - 1.3) ** 2, {"k": prior}, n_trials=30, n_local=15, n_starts=1,
                             random_state=0)
    assert abs(best["k"] - 1.3) < 1e-3 and len(history) <= 30
    low, high = prior.support()
    assert all(low <= v["k"] <= high for v, _ in history)


def test_minimize_leaves_integers_and_choices_at_the_start():
    space = {"x": (0.0, 1.0), "n": IntRange(1, 4), "c": ["a", "b"]}
    best, history = minimize(lambda v: (v["x"] - 0.3) ** 2 + v["n"] + (v["c"] == "b"), space, n_trials=25,
                             n_local=10, n_starts=1, random_state=1)
    tpe, local = history[:15], history[15:]
    start = min(tpe, key=lambda item: item[1])[0]
    assert local and all((v["n"], v["c"]) == (start["n"], start["c"]) for v, _ in local)
    assert best["x"] == pytest.approx(0.3, abs=1e-2)


def test_minimize_counts_failures_as_the_penalty():
    best, history = minimize(lambda v: math.nan if v["x"] > 0.5 else v["x"], {"x": Uniform(0.0, 1.0)}, n_trials=12,
                             penalty=7.0, random_state=0)
    scores = [s for _, s in history]
    assert 7.0 in scores and best["x"] <= 0.5 and min(scores) < 7.0
    with pytest.raises(ValueError, match=r"space\['x'\] = \(1.0, 0.0\); expected low < high"):
        minimize(lambda v: 0.0, {"x": (1.0, 0.0)}, n_trials=2)


# --- dimensions in model files --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "dim", [Uniform(0.0, 1.0), LogUniform(1e-3, 1.0), IntRange(1, 9, step=2), Categorical(["a", None, 3]),
            Normal(1.0, 0.1, n_sigma=3.0), LogNormal(0.0, 0.5)]
)
def test_dimensions_are_stored_by_their_fields(dim):
    data = encode_value({"k": dim}, "params.bounds")
    back = decode_value(data, "params.bounds")["k"]
    assert back == dim and type(back) is type(dim)


# --- the dimensions' edges: impossible values are refused, possible ones map finitely -------------------


@pytest.mark.parametrize("make, match", [
    (lambda: Normal(1.0, 0.1, n_sigma=10), r"n_sigma=10 gives the quantile range \[0.0, 1.0\]"),  # was (-inf, inf)
    (lambda: Normal(1.0, 0.1, n_sigma=1e-20), r"n_sigma=1e-20 gives the quantile range \[0.5, 0.5\]"),  # was /0
    (lambda: Uniform(-1e308, 1e308), "the span high - low overflows a float"),  # to_unit(0.0) was 0.0
    (lambda: Categorical("abc"), r"choices must be a list or tuple of choices; got 'abc' \(write \['abc'\]"),
    (lambda: Categorical(3), "choices must be a list or tuple of choices; got 3"),
    (lambda: Normal(1e300, 1e-300), r"its support at \+-n_sigma is \(1e\+300, 1e\+300\)"),
    (lambda: Uniform(1.0, 1.0 + 1e-15), "narrower than floating point resolves"),
    (lambda: LogNormal(750.0, 1.0), r"its support at \+-n_sigma is .*inf"),
    (lambda: LogNormal(-750.0, 1.0), r"its support .* and low > 0"),
])
def test_impossible_dimensions_are_refused(make, match):
    with pytest.raises(ValueError, match=match):
        make()


hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

EDGE = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                 st.sampled_from([0.0, -0.0, 5e-324, 1e-308, 1e-20, 1e-15, 8.0, 8.5, 37.0, 1e300, -1e300, 1e308,
                                  -1e308, 709.0, -745.0]))


@st.composite
def edge_dimensions(draw):
    kind = draw(st.sampled_from([Uniform, LogUniform, Normal, LogNormal]))
    args = [draw(EDGE), draw(EDGE)]
    if kind in (Normal, LogNormal) and draw(st.booleans()):
        args.append(draw(EDGE))
    return kind, args


def _check_edge(kind, args):
    try:
        dim = kind(*args)
    except ValueError as exc:
        assert str(exc)
        return
    low, high = dim.support()
    assert math.isfinite(low) and math.isfinite(high) and low < high, (dim, low, high)
    if kind in (LogUniform, LogNormal):
        assert low > 0, dim
    values = [dim.from_unit(z) for z in (-1.0, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0)]
    assert all(math.isfinite(v) and low <= v <= high for v in values), (dim, values)
    assert values == sorted(values), (dim, values)  # monotone in the unit coordinate
    for v in (low, high, values[3]):
        z = dim.to_unit(v)  # within [0, 1] up to the rounding of a support a few ulps wide
        assert math.isfinite(z) and -1e-3 <= z <= 1 + 1e-3, (dim, v, z)
    if high - low > 1e-6 * max(abs(low), abs(high)):  # a support wider than rounding: the coordinate round-trips
        assert dim.to_unit(values[3]) == pytest.approx(0.5, abs=1e-6), dim


def _run_edges(n, derandomize):
    @settings(max_examples=n, derandomize=derandomize, deadline=None, database=None)
    @given(case=edge_dimensions())
    def check(case):
        _check_edge(*case)

    check()


def test_dimensions_at_their_edges_are_refused_or_map_finitely():
    _run_edges(300, derandomize=True)


@pytest.mark.slow
def test_dimensions_at_their_edges_are_refused_or_map_finitely_at_length():
    _run_edges(5000, derandomize=False)
@pytest.mark.parametrize("kwargs, match", [
    (dict(n_trials=0), r"n_trials must be an integer >= 1; got 0\."),  # was: min() arg is an empty sequence
    (dict(n_trials=2.5), r"n_trials must be an integer >= 1; got 2\.5\."),
    (dict(n_trials=5, n_local=5), r"n_local must be an integer in \[0, 4\]; got 5\."),
    (dict(n_trials=5, n_local=-1), r"n_local must be an integer in \[0, 4\]; got -1\."),
    (dict(n_trials=5, n_local=2, n_starts=0), r"n_starts must be an integer >= 1; got 0\."),
    (dict(n_trials=5, step=0.0), r"step must be a finite number > 0; got 0\.0\."),
])
def test_minimize_refuses_budgets_it_cannot_spend(kwargs, match):
    calls = []
    with pytest.raises(ValueError, match=match):
        minimize(lambda v: calls.append(v) or 0.0, {"a": Uniform(0.0, 1.0)}, **kwargs)
    assert calls == []


# --- grid_points and sampler="grid": the same points at every seed ----------------------------------


def test_grid_points_spread_each_scale_evenly_and_enumerate_choices():
    space = {"tau": LogUniform(1.0, 100.0), "hold": Categorical(["zoh", "linear"]), "k": IntRange(1, 9)}
    points = grid_points(space, 18)
    assert len(points) == 18  # 3 cells per real or integer axis, times 2 choices
    taus = sorted({p["tau"] for p in points})
    assert np.allclose(np.diff(np.log(taus)), np.log(100.0) / 3)  # equal cells on the log scale
    assert sorted({p["hold"] for p in points}) == ["linear", "zoh"]
    assert sorted({p["k"] for p in points}) == [2, 5, 8]
    assert grid_points(space, 18) == points


def test_grid_points_are_cut_at_n_and_refuse_an_empty_grid():
    assert len(grid_points({"c": Categorical(list("abcde"))}, 3)) == 3
    assert len(grid_points({"a": Uniform(0.0, 1.0)}, 1)) == 1
    with pytest.raises(ValueError, match="n must be at least 1"):
        grid_points({"a": Uniform(0.0, 1.0)}, 0)


def test_minimize_on_a_grid_does_not_depend_on_the_seed():
    def objective(v):
        return (np.log(v["a"]) - 1.0) ** 2

    runs = [minimize(objective, {"a": LogUniform(0.1, 100.0)}, n_trials=12, n_local=4, random_state=seed,
                     sampler="grid") for seed in (0, 1, 7)]
    assert all(r[1] == runs[0][1] for r in runs)
    assert abs(np.log(runs[0][0]["a"]) - 1.0) < 0.2
    with pytest.raises(ValueError, match="sampler must be 'tpe' or 'grid'"):
        minimize(objective, {"a": LogUniform(0.1, 100.0)}, n_trials=3, sampler="random")
