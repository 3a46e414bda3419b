"""identify._latent_hard: the latent family's hinge candidate (levels from the estimation record's input)."""

import numpy as np
import pytest

from sindybench.hidden import HiddenStateSINDy
from sindybench.identify._latent_hard import LATENT_HINGE, latent_hinge_library, offset_range
from sindybench.identify._space import data_settings, make_estimator, structures
from sindybench.libraries import PolynomialLibrary, SqrtLibrary


def test_the_levels_are_the_inputs_quantiles():
    u = np.r_[np.ones(50), np.linspace(1.0, 11.0, 101)][:, None]
    lib = latent_hinge_library(u).fit(np.zeros((1, 3)))
    names = lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()
    high, low = float(np.quantile(u, 0.8)), float(np.quantile(u, 0.2))
    assert names[4:] == [f"max(z0-{high!r}, 0)", f"max(z0-{high!r}, 0) u0", f"max({low!r}-z0, 0)",
                         f"max({low!r}-z0, 0) u0"]
    assert offset_range(lib).low == pytest.approx(-0.5 * (high - low))
    base = PolynomialLibrary(degree=1) + SqrtLibrary(variables=[0, 1])
    lib = latent_hinge_library(u, base=base, lower=False).fit(np.zeros((1, 3)))
    assert lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()[-2:] == [f"max(z0-{high!r}, 0)",
                                                                        f"max(z0-{high!r}, 0) u0"]


def test_no_level_without_a_varying_input():
    assert latent_hinge_library(np.zeros((10, 0))) is None
    assert latent_hinge_library(np.ones((10, 1))) is None


def _record(n=600):
    t = np.arange(n) * 0.05
    u = np.sin(0.7 * t)[:, None]
    y = np.cos(0.5 * t)[:, None] - 2.0  # a negative output: no root proposed, the lower hinge kept
    return u, y


def test_the_latent_family_gets_one_hinge_candidate_with_hard_libraries_only():
    u, y = _record()
    settings = data_settings(u, y, 0.05, families=["order1+latent"])
    hinge = [s for s, _ in structures(u, y, 0.05, settings, families=["order1+latent"]) if s["library"] == LATENT_HINGE]
    assert len(hinge) == 1
    assert not [s for s, _ in structures(u, y, 0.05, settings, families=["order1+latent"], libraries=["linear"])
                if s["library"] == LATENT_HINGE]
    (struct, lib), = [(s, lib) for s, lib in structures(u, y, 0.05, settings, families=["order1+latent"])
                      if s["library"] == LATENT_HINGE]
    est = make_estimator(struct, lib, 0.0, 0.05, settings)
    assert isinstance(est, HiddenStateSINDy)
    hidden = est.hidden
    # warm started from the plain candidate: its gauge, start and search, the hinges placed by its latent range
    plain, = [(s, lib) for s, lib in structures(u, y, 0.05, settings, families=["order1+latent"])
              if s["library"] == "linear"]
    plain_hidden = make_estimator(*plain, 0.0, 0.05, settings).hidden
    assert hidden.levels == "range" and plain_hidden.levels == "library"
    assert {k: v for k, v in hidden.get_params().items() if k != "levels"} == \
        {k: v for k, v in plain_hidden.get_params().items() if k != "levels"}
    assert sorted(hidden.search_space()) == ["tau"]


def test_an_indicator_of_the_output_proposes_one_of_the_latent_state():
    """Where the advice proposes an indicator on the output (a pile-up: an overflow), the hinge candidate gets the
    latent state's indicator at its upper level, alone and times the input; elsewhere it has none."""
    u, y = _record()
    settings = data_settings(u, y, 0.05, families=["order1+latent"])

    def names(indicator):
        s = {**settings, "indicator": [indicator]}
        (lib,) = [lib for st, lib in structures(u, y, 0.05, s, families=["order1+latent"])
                  if st["library"] == LATENT_HINGE]
        return lib.fit(np.zeros((1, 3))).get_feature_names_out(["y0", "z0", "u0"]).tolist()

    high = float(np.quantile(u, 0.8))
    assert [n for n in names(-1.5) if n.startswith("[z0")] == [f"[z0>={high:g}]", f"[z0>={high:g}] u0"]
    assert [n for n in names(-1.5) if n.startswith("[y0")]  # the output's own indicator stays in the base
    assert not [n for n in names(None) if n.startswith("[")]


def test_the_hinge_candidate_starts_from_the_plain_candidate_and_ends_no_worse():
    """Its plain stage is the plain candidate's own fit (same gauge, search, refinement): the same training
    simulation error; the hinges then lower it or the plain model is kept (the guarantee is on the training record:
    a free run from other start samples may still differ either way)."""
    import warnings

    u, y = _record()
    y = y + 0.3 * np.maximum(u - 0.5, 0.0)  # a kink the plain lag misses
    settings = data_settings(u, y, 0.05, families=["order1+latent"])
    cands = {s["library"]: (s, lib) for s, lib in structures(u, y, 0.05, settings, families=["order1+latent"])}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hinge = make_estimator(*cands[LATENT_HINGE], 0.0, 0.05, settings).fit(u, y)
        plain = make_estimator(*cands["linear"], 0.0, 0.05, settings).fit(u, y)
    record = hinge.refinement_["range_levels"]
    assert record["plain_cost"] == pytest.approx(plain.refinement_["cost"], rel=1e-6)
    assert record["cost"] <= record["plain_cost"]
    if record["kept"]:  # the final model holds the hinges, their levels from the plain model's latent range
        assert any(name.startswith("max(z0") for name in hinge.library_.get_feature_names_out(["y0", "z0", "u0"]))
