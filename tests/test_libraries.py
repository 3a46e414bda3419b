"""Feature libraries: names and values on known inputs, composition, spec, adapters, bad input."""

import json

import numpy as np
import pysindy as ps
import pytest
from numpy.testing import assert_allclose
from sklearn.base import clone
from sklearn.preprocessing import PolynomialFeatures

from sindybench.libraries import (
    AbsProductLibrary,
    ConcatLibrary,
    CustomLibrary,
    ExternalLibrary,
    FrictionLibrary,
    PolynomialLibrary,
    ProductLibrary,
    SqrtLibrary,
    TermsLibrary,
    as_library,
    library_from_spec,
    library_to_spec,
    terms_from_json,
    terms_to_json,
)
from sindybench.libraries._terms import (
    ABS_POW,
    POW,
    SIGN,
    SQRT,
    check_terms,
    evaluate_terms,
    evaluate_terms_jacobian,
    term_name,
)


@pytest.fixture
def Z(rng):
    return rng.normal(size=(50, 3))


# ------------------------------------------------------------------ polynomial
@pytest.mark.parametrize("degree", [1, 2, 3])
@pytest.mark.parametrize("include_bias", [True, False])
@pytest.mark.parametrize("interaction_only", [True, False])
def test_polynomial_matches_sklearn(Z, degree, include_bias, interaction_only):
    ours = PolynomialLibrary(degree=degree, include_bias=include_bias, interaction_only=interaction_only).fit(Z)
    ref = PolynomialFeatures(degree=degree, include_bias=include_bias, interaction_only=interaction_only).fit(Z)
    assert_allclose(ours.transform(Z), ref.transform(Z), rtol=1e-12)
    assert ours.n_output_features_ == ref.n_output_features_ == len(ours.terms_)


def test_polynomial_names_match_pysindy(Z):
    names = ["y0", "y1", "u0"]
    ours = PolynomialLibrary(degree=3).fit(Z).get_feature_names_out(names)
    ref = ps.PolynomialLibrary(degree=3).fit(Z).get_feature_names(names)
    assert sorted(ours) == sorted(ref)


def test_polynomial_variables_select_columns(Z):
    lib = PolynomialLibrary(degree=2, include_bias=False, variables=[2, 0]).fit(Z)
    assert lib.get_feature_names_out().tolist() == ["x0", "x2", "x0^2", "x0 x2", "x2^2"]
    assert_allclose(lib.transform(Z)[:, 3], Z[:, 0] * Z[:, 2])


def test_default_names_and_input_names(Z):
    lib = PolynomialLibrary(degree=1).fit(Z)
    assert lib.get_feature_names_out().tolist() == ["1", "x0", "x1", "x2"]
    assert lib.get_feature_names_out(["y", "v", "u"]).tolist() == ["1", "y", "v", "u"]


# ------------------------------------------------------------------------ sqrt
def test_sqrt_clips_before_root():
    Z = np.array([[-1.0, 4.0], [9.0, 16.0], [0.25, 100.0]])
    lib = SqrtLibrary(lower=0.0, upper=[4.0, 25.0]).fit(Z)
    assert lib.get_feature_names_out(["x1", "x2"]).tolist() == ["sqrt(x1)", "sqrt(x2)"]
    assert_allclose(lib.transform(Z), [[0.0, 2.0], [2.0, 4.0], [0.5, 5.0]])


def test_sqrt_lower_threshold(Z):
    lib = SqrtLibrary(lower=0.5, variables=[1]).fit(Z)
    assert_allclose(lib.transform(Z)[:, 0], np.sqrt(np.maximum(Z[:, 1], 0.5)))


# ---------------------------------------------------------------- abs products
def test_abs_product_values(Z):
    lib = AbsProductLibrary(pairs=[(2, 0)], include_abs=True).fit(Z)
    z, v = Z[:, 2], Z[:, 0]
    expected = np.column_stack([z * abs(v), abs(z) * v, abs(z) * abs(v), abs(z), abs(v)])
    assert_allclose(lib.transform(Z), expected)
    assert lib.get_feature_names_out(["v", "u", "z"]).tolist() == ["z |v|", "|z| v", "|z| |v|", "|z|", "|v|"]


def test_abs_product_default_pairs_and_selection(Z):
    lib = AbsProductLibrary(products=["x|y|", "xy"]).fit(Z)
    # pairs (0, 1), (0, 2), (1, 2), two products each
    assert lib.n_output_features_ == 6
    assert_allclose(lib.transform(Z)[:, 5], Z[:, 1] * Z[:, 2])


def test_abs_product_power_and_self_pair(Z):
    lib = AbsProductLibrary(pairs=[(1, 1)], abs_power=2.0).fit(Z)
    # x|x|^2 and |x|^2 x coincide: one is dropped
    assert lib.get_feature_names_out().tolist() == ["x1 |x1|^2", "|x1|^2 |x1|^2"]
    assert_allclose(lib.transform(Z)[:, 0], Z[:, 1] ** 3)


def test_abs_product_bouc_wen_law(rng):
    """z' = A v - beta |v| z - gamma v |z| is a linear combination of the library columns."""
    Z = rng.normal(size=(40, 2))  # columns v, z
    lib = ConcatLibrary([PolynomialLibrary(degree=1, include_bias=False), AbsProductLibrary(pairs=[(1, 0)])]).fit(Z)
    v, z = Z[:, 0], Z[:, 1]
    target = 2.0 * v - 0.5 * np.abs(v) * z - 0.3 * v * np.abs(z)
    coef, *_ = np.linalg.lstsq(lib.transform(Z), target, rcond=None)
    names = lib.get_feature_names_out(["v", "z"]).tolist()
    assert_allclose(coef[names.index("v")], 2.0, atol=1e-10)
    assert_allclose(coef[names.index("z |v|")], -0.5, atol=1e-10)
    assert_allclose(coef[names.index("|z| v")], -0.3, atol=1e-10)


# ---------------------------------------------------------------------- custom
def test_custom_library_names_and_values(Z):
    lib = CustomLibrary(
        functions=[np.sin, lambda a, b: a * np.tanh(b)],
        names=["sin({})", lambda a, b: f"{a} tanh({b})"],
        variables=[0, 2],
    )
    with pytest.warns(UserWarning, match=r"functions\[1\] takes 2 arguments; only functions of one column"):
        lib.fit(Z)
    assert lib.terms_ is None
    assert lib.get_feature_names_out(["y", "v", "u"]).tolist() == ["sin(y)", "sin(u)", "y tanh(u)"]
    assert_allclose(lib.transform(Z), np.column_stack([np.sin(Z[:, 0]), np.sin(Z[:, 2]), Z[:, 0] * np.tanh(Z[:, 2])]))


def test_custom_library_default_names_and_constant(Z):
    lib = CustomLibrary(functions=[lambda x: 1.0], variables=[1]).fit(Z)
    assert lib.get_feature_names_out().tolist() == ["f0(x1)"]
    assert_allclose(lib.transform(Z), 1.0)


# ----------------------------------------------------------------- composition
def test_concat_equals_hstack_and_operator(Z):
    a, b = PolynomialLibrary(degree=2), SqrtLibrary(variables=[0])
    lib = (a + b).fit(Z)
    assert isinstance(lib, ConcatLibrary)
    assert_allclose(lib.transform(Z), np.hstack([clone(a).fit_transform(Z), clone(b).fit_transform(Z)]))
    assert len(lib.terms_) == lib.n_output_features_ == 11
    assert lib.get_feature_names_out()[-1] == "sqrt(x0)"


def test_concat_with_custom_compiles_and_without_is_python(Z):
    lib = ConcatLibrary([PolynomialLibrary(degree=1), CustomLibrary(functions=[np.cos])]).fit(Z)
    assert len(lib.terms_) == 7
    assert_allclose(lib.transform(Z)[:, 4:], np.cos(Z), rtol=1e-14)
    python = ConcatLibrary([PolynomialLibrary(degree=1), CustomLibrary(functions=[np.cos], compile=False)]).fit(Z)
    assert python.terms_ is None
    assert_allclose(python.transform(Z), lib.transform(Z), rtol=1e-14)


def test_custom_library_compiles_one_column_functions(Z):
    """np.sign and a tanh of a scaled column become user operations: compiled values, derivatives, names."""
    lib = CustomLibrary(functions=[np.sign, lambda v: np.tanh(v / 0.02)], names=["sign({})", "tanh({}/0.02)"],
                        variables=[1]).fit(Z)
    assert [int(t[0][1]) >= 16 for t in lib.terms_] == [True, True]
    assert lib.get_feature_names_out(["y", "v", "u"]).tolist() == ["sign(v)", "tanh(v/0.02)"]
    assert term_name(lib.terms_[1], ["y", "v", "u"]) == "tanh(v/0.02)"
    assert_allclose(lib.transform(Z), np.column_stack([np.sign(Z[:, 1]), np.tanh(Z[:, 1] / 0.02)]), rtol=1e-14)
    jac = evaluate_terms_jacobian(lib.terms_, Z)
    assert_allclose(jac[:, 0, 1], 0.0)  # the rule for np.sign
    assert_allclose(jac[:, 1, 1], (1 - np.tanh(Z[:, 1] / 0.02) ** 2) / 0.02, rtol=1e-5, atol=1e-6)  # differences
    assert_allclose(jac[:, :, [0, 2]], 0.0)
    with pytest.raises(ValueError, match="cannot be saved as JSON"):
        terms_to_json(lib.terms_)


def _twice_cos(v):
    return 2.0 * np.cos(v)


def test_custom_library_derivative_and_pickle(Z):
    import pickle

    lib = CustomLibrary(functions=[np.sin], derivatives=[_twice_cos]).fit(Z)  # a wrong one, to see it is used
    assert_allclose(evaluate_terms_jacobian(lib.terms_, Z)[:, 0, 0], 2.0 * np.cos(Z[:, 0]), rtol=1e-14)
    again = pickle.loads(pickle.dumps(lib))
    assert again.terms_ == lib.terms_
    assert_allclose(again.transform(Z), lib.transform(Z), rtol=0)


@pytest.mark.parametrize(
    "function, match",
    [(lambda v: np.array([v, v]), "returns array"), (lambda v: {"a": v}["a"] + "x", "cannot be compiled by numba")],
    ids=["array", "untypable"],
)
def test_custom_library_that_cannot_compile_warns_and_runs_in_python(Z, function, match):
    lib = CustomLibrary(functions=[function])
    with pytest.warns(UserWarning, match=match):
        lib.fit(Z)
    assert lib.terms_ is None


def test_custom_library_bad_derivatives(Z):
    with pytest.raises(ValueError, match="one entry"):
        CustomLibrary(functions=[np.sin], derivatives=[None, None]).fit(Z)
    with pytest.raises(ValueError, match=r"derivatives\[0\] is not callable"):
        CustomLibrary(functions=[np.sin], derivatives=[1.0]).fit(Z)


def test_concat_drops_repeated_terms(Z):
    # before: x0, x1, x2 twice (two collinear columns, a coefficient split between them; issue 18, case 18)
    lib = (PolynomialLibrary(degree=1) + PolynomialLibrary(degree=3, include_bias=False)).fit(Z)
    names = lib.get_feature_names_out().tolist()
    assert names == PolynomialLibrary(degree=3).fit(Z).get_feature_names_out().tolist()
    assert len(names) == len(set(names)) == lib.n_output_features_ == len(lib.terms_) == 20
    assert_allclose(lib.transform(Z), PolynomialLibrary(degree=3).fit_transform(Z))
    # a repeat in canonical form (x0 x0 is x0^2) is a repeat too; the first occurrence stays
    lib = ConcatLibrary([PolynomialLibrary(degree=2, variables=[0]),
                         TermsLibrary(terms=[[[0, POW, 1.0, 0.0], [0, POW, 1.0, 0.0]], [[1, SIGN, 0, 0]]])]).fit(Z)
    assert lib.get_feature_names_out().tolist() == ["1", "x0", "x0^2", "sign(x1)"]
    assert lib.terms_[2] == ((0, POW, 2.0, 0.0),)


def test_concat_without_repeats_keeps_every_column(Z):
    # the libraries of the benchmark experiments have no repeated term: their columns are unchanged
    parts = [PolynomialLibrary(degree=2), SqrtLibrary(variables=[0, 1]), TermsLibrary(terms=[[[1, SIGN, 0, 0]]])]
    lib = ConcatLibrary(parts).fit(Z)
    assert lib.terms_ == [t for p in parts for t in clone(p).fit(Z).terms_]


def test_sindy_with_repeated_terms_gets_one_coefficient():
    from sindybench import STLS, SINDy
    from sindybench.simulate import simulate

    u = np.sin(np.arange(0, 10, 0.01))[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.5], u, dt=0.01, input_hold="linear")
    library = PolynomialLibrary(degree=1) + PolynomialLibrary(degree=2, include_bias=False)
    model = SINDy(library=library, optimizer=STLS(threshold=0.1), dt=0.01).fit(u, y)
    assert model.equations(precision=1) == ["y0' = -2.0 y0 + 1.0 u0"]


def test_friction_library_values_and_names():
    Z = np.array([[2.0, -0.5], [-1.0, 0.0], [0.0, 3.0]])
    lib = FrictionLibrary(powers=[1.0, 2.0]).fit(Z)
    assert lib.get_feature_names_out(["x", "v"]).tolist() == [
        "sign(x)", "sign(v)", "sign(x) |x|", "sign(v) |v|", "sign(x) |x|^2", "sign(v) |v|^2"]
    assert_allclose(lib.transform(Z), np.column_stack([np.sign(Z), Z, np.sign(Z) * Z**2]))
    assert FrictionLibrary(variables=[1]).fit(Z).get_feature_names_out(["x", "v"]).tolist() == ["sign(v)"]


@pytest.mark.parametrize("powers, match", [("2", "powers must be a sequence of numbers > 0"),
                                           (3.0, "powers must be a sequence of numbers > 0"),
                                           ([0.0], "powers must be a finite number > 0"),
                                           ([np.nan], "powers must be a finite number > 0")])
def test_friction_library_bad_powers(powers, match):
    with pytest.raises(ValueError, match=match):
        FrictionLibrary(powers=powers).fit(np.zeros((2, 1)))


def test_sindy_finds_coulomb_friction(tmp_path):
    # a velocity v' = u - 0.5 v - 0.3 sign(v), simulated and identified with polynomial + friction terms
    from sindybench import STLS, SINDy, load_model
    from sindybench.io import save_model
    from sindybench.simulate import simulate

    t = np.arange(0, 40, 0.01)
    u = (np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t))[:, None]
    y = simulate(lambda x, u: np.array([u[0] - 0.5 * x[0] - 0.3 * np.sign(x[0])]), [0.2], u, dt=0.01,
                 input_hold="linear")
    library = PolynomialLibrary(degree=1) + FrictionLibrary(variables=[0])
    model = SINDy(library=library, optimizer=STLS(threshold=0.05), dt=0.01).fit(u, y)
    coef = dict(zip(model.library_.get_feature_names_out(["y0", "u0"]), model.coef_[0]))
    assert {k for k, c in coef.items() if c != 0} == {"y0", "u0", "sign(y0)"}
    assert coef["y0"] == pytest.approx(-0.5, rel=0.06) and coef["u0"] == pytest.approx(1.0, rel=0.01)
    assert coef["sign(y0)"] == pytest.approx(-0.3, rel=0.06)  # the differentiated kinks cost a few percent
    assert model.score(u, y) > 0.99
    save_model(model, tmp_path / "friction.json")
    loaded = load_model(tmp_path / "friction.json")
    np.testing.assert_array_equal(loaded.predict(u, y_init=y), model.predict(u, y_init=y))


def test_concat_nested_params():
    lib = ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary()])
    assert lib.get_params()["libraries__0__degree"] == 2
    lib.set_params(libraries__0__degree=3, libraries__1__upper=5.0)
    assert (lib.libraries[0].degree, lib.libraries[1].upper) == (3, 5.0)
    assert clone(lib).libraries[0].degree == 3


def test_product_compiled_equals_columnwise(Z):
    left = PolynomialLibrary(degree=1, variables=[0])
    compiled = ProductLibrary(left, PolynomialLibrary(degree=1)).fit(Z)
    external = ProductLibrary(left, as_library(ps.PolynomialLibrary(degree=1))).fit(Z)
    assert compiled.terms_ is not None and external.terms_ is None
    assert_allclose(compiled.transform(Z), external.transform(Z), rtol=1e-12)
    assert compiled.get_feature_names_out().tolist() == ["1", "x0", "x1", "x2", "x0", "x0^2", "x0 x1", "x0 x2"]
    assert external.get_feature_names_out().tolist() == ["1", "x0", "x1", "x2", "x0", "x0 x0", "x0 x1", "x0 x2"]


def test_product_operator_merges_abs_and_sqrt(Z):
    lib = (SqrtLibrary(variables=[0]) * AbsProductLibrary(pairs=[(1, 2)], products=["x|y|"])).fit(Z)
    assert_allclose(lib.transform(Z)[:, 0], np.sqrt(np.maximum(Z[:, 0], 0)) * Z[:, 1] * abs(Z[:, 2]))


# --------------------------------------------------------- terms, spec, adapters
def test_terms_library_reproduces_fitted_library(Z):
    lib = (PolynomialLibrary(degree=2) + SqrtLibrary(upper=2.0) + AbsProductLibrary()).fit(Z)
    again = TermsLibrary(terms=terms_from_json(json.loads(json.dumps(terms_to_json(lib.terms_))))).fit(Z)
    assert_allclose(again.transform(Z), lib.transform(Z))
    assert again.get_feature_names_out().tolist() == lib.get_feature_names_out().tolist()


@pytest.mark.parametrize(
    "lib",
    [
        PolynomialLibrary(degree=3, interaction_only=True, variables=[0, 1]),
        SqrtLibrary(lower=0.1, upper=np.inf),
        AbsProductLibrary(pairs=[(0, 1)], include_abs=True, abs_power=1.5),
        ConcatLibrary([PolynomialLibrary(), ProductLibrary(SqrtLibrary(), AbsProductLibrary())]),
        TermsLibrary(terms=[(), ((0, SIGN, 0.0, 0.0),)]),
    ],
    ids=["poly", "sqrt", "abs", "nested", "terms"],
)
def test_spec_round_trip(Z, lib):
    spec = library_to_spec(lib)
    text = json.dumps(spec, allow_nan=False)
    again = library_from_spec(json.loads(text))
    assert_allclose(clone(again).fit_transform(Z), clone(lib).fit_transform(Z))


def test_spec_rejects_custom():
    with pytest.raises(ValueError, match="CustomLibrary is not a registered class"):
        library_to_spec(CustomLibrary(functions=[np.sin]))


@pytest.mark.parametrize(
    "pslib", [ps.PolynomialLibrary(degree=2), ps.FourierLibrary(n_frequencies=2)], ids=["poly", "fourier"]
)
def test_as_library_accepts_pysindy(Z, pslib):
    lib = as_library(pslib).fit(Z)
    ref = clone(pslib).fit(Z)
    assert lib.terms_ is None
    assert_allclose(lib.transform(Z), np.asarray(ref.transform(Z)))
    assert lib.get_feature_names_out(["a", "b", "c"]).tolist() == ref.get_feature_names(["a", "b", "c"])


def test_as_library_accepts_sklearn_transformer_and_none(Z):
    lib = as_library(PolynomialFeatures(degree=2)).fit(Z)
    assert isinstance(lib, ExternalLibrary)
    assert lib.get_feature_names_out()[4] == "x0^2"
    assert as_library(None).get_params() == PolynomialLibrary().get_params()
    own = SqrtLibrary()
    assert as_library(own) is own


def test_evaluate_terms_every_operation():
    Z = np.array([[-2.0, 9.0], [0.0, -1.0], [3.0, 0.25]])
    terms = [((0, POW, 3, 0),), ((0, ABS_POW, 0.5, 0),), ((1, SQRT, 0.0, 4.0),), ((0, SIGN, 0, 0), (1, POW, 1, 0))]
    expected = np.array([[-8.0, np.sqrt(2.0), 2.0, -9.0], [0.0, 0.0, 0.0, -0.0], [27.0, np.sqrt(3.0), 0.5, 0.25]])
    assert_allclose(evaluate_terms(terms, Z), expected)


# ------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("lib", "match"),
    [
        (PolynomialLibrary(degree=-1), "degree must be an integer >= 0"),
        (PolynomialLibrary(degree=1.5), "degree must be an integer >= 0"),
        (PolynomialLibrary(include_bias="yes"), "include_bias must be True or False"),
        (PolynomialLibrary(interaction_only=None), "interaction_only must be True or False"),
        (PolynomialLibrary(degree=0, include_bias=False), "has no terms"),
        (PolynomialLibrary(variables=[3]), r"variables contains 3; expected column indices in \[0, 2\]"),
        (PolynomialLibrary(variables=[0, 0]), "repeated entries"),
        (PolynomialLibrary(variables=[]), "variables is empty"),
        (PolynomialLibrary(variables="x0"), "sequence of column indices"),
        (PolynomialLibrary(variables=[0.5]), "integer column indices"),
        (SqrtLibrary(lower=-1.0), "lower must be >= 0"),
        (SqrtLibrary(lower=2.0, upper=1.0), "lower must be < upper"),
        (SqrtLibrary(upper=[1.0, 2.0]), "upper has 2 entries; expected a scalar or 3"),
        (SqrtLibrary(lower=np.nan), "lower contains NaN"),
        (AbsProductLibrary(products=["x^y"]), "products contains"),
        (AbsProductLibrary(products="x|y|"), "products must be a non-empty sequence"),
        (AbsProductLibrary(pairs=[(0, 1)], variables=[0, 1]), "either pairs or variables"),
        (AbsProductLibrary(pairs=[(0, 1, 2)]), "pairs must be a non-empty sequence of"),
        (AbsProductLibrary(pairs=[(0, 5)]), "pairs contains 5"),
        (AbsProductLibrary(variables=[1]), "needs two variables"),
        (AbsProductLibrary(abs_power=0.0), "abs_power must be a finite number > 0"),
        (CustomLibrary(functions=None), "functions must be a non-empty sequence"),
        (CustomLibrary(functions=[np.sin], names=["a", "b"]), "one name per function"),
        (CustomLibrary(functions=[1.0]), r"functions\[0\] is not callable"),
        (CustomLibrary(functions=[lambda: 1.0]), "takes no positional argument"),
        (ConcatLibrary([]), "libraries must be a non-empty sequence"),
        (ConcatLibrary([PolynomialLibrary(), "poly"]), "library must be a sindybench library"),
        (ProductLibrary(PolynomialLibrary(), None), "right is None"),
        (ExternalLibrary(object()), "library must have fit and transform"),
        (TermsLibrary(terms=[((0, 7, 1, 0),)]), "unknown operation 7"),
        (TermsLibrary(terms=[((3, POW, 1, 0),)]), r"terms\[0\] uses column 3"),
        (TermsLibrary(terms=[("x",)]), "is not a sequence of"),
        (TermsLibrary(), "terms is None"),
    ],
)
def test_bad_parameters(Z, lib, match):
    with pytest.raises(ValueError, match=match):
        lib.fit(Z)


def test_bad_input_nan(Z):
    Z[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        PolynomialLibrary().fit(Z)


def test_bad_input_wrong_width(Z):
    lib = PolynomialLibrary().fit(Z)
    with pytest.raises(ValueError, match="features"):
        lib.transform(Z[:, :2])


def test_bad_input_names_length(Z):
    lib = PolynomialLibrary().fit(Z)
    with pytest.raises(ValueError, match="input_features"):
        lib.get_feature_names_out(["a", "b"])


def test_custom_bad_output_shape(Z):
    lib = CustomLibrary(functions=[lambda x: np.ones(3)], compile=False).fit(Z)
    with pytest.raises(ValueError, match=r"returned shape \(3,\); expected \(50,\)"):
        lib.transform(Z)


def test_bad_spec():
    with pytest.raises(ValueError, match=r"library.estimator.class: unknown class 'Foo'; expected one of \["):
        library_from_spec({"class": "Foo", "params": {}})


def test_bad_nested_param():
    with pytest.raises(ValueError, match="libraries__<index>__<param>"):
        ConcatLibrary([PolynomialLibrary()]).set_params(libraries__4__degree=2)


def test_check_terms_rejects_string():
    with pytest.raises(ValueError, match="must be a sequence of terms"):
        check_terms("x0")


def test_sqrt_per_variable_mismatch_uses_selection(Z):
    lib = SqrtLibrary(upper=[1.0, 2.0], variables=[0, 2]).fit(Z)
    assert [t[0][3] for t in lib.terms_] == [1.0, 2.0]
    assert lib.terms_[1][0][0] == 2
    assert SQRT == lib.terms_[0][0][1]
