"""identify._space: the order-1 latent family's cascade candidate (``cascade+hard``)."""

import warnings

import numpy as np
import pytest

from sindybench.identify._space import LATENT_CASCADE, LATENT_HINGE, data_settings, make_estimator, structures
from sindybench.systems import get_system


def _candidates(u, y, dt, settings):
    return {s["library"]: (s, lib) for s, lib in structures(u, y, dt, settings, families=["order1+latent"])}


def test_the_cascade_candidate_comes_with_the_hinge_candidate_of_a_positive_output_only():
    t = np.arange(600) * 0.05
    u, y = np.sin(0.7 * t)[:, None], np.cos(0.5 * t)[:, None] + 2.0  # a level: stays positive
    settings = data_settings(u, y, 0.05, families=["order1+latent"])
    assert settings["positive"] == [0]
    cands = _candidates(u, y, 0.05, settings)
    assert LATENT_HINGE in cands and LATENT_CASCADE in cands
    signed = data_settings(u, y - 2.0, 0.05, families=["order1+latent"])  # a displacement: the hinges alone
    assert LATENT_HINGE in _candidates(u, y - 2.0, 0.05, signed)
    assert LATENT_CASCADE not in _candidates(u, y - 2.0, 0.05, signed)
    assert not [s for s, _ in structures(u, y, 0.05, settings, families=["order1+latent"], libraries=["linear"])
                if s["library"] == LATENT_CASCADE]
    struct, lib = cands[LATENT_CASCADE]
    hidden = make_estimator(struct, lib, 0.0, 0.05, settings).hidden
    assert hidden.cascade and hidden.scale == "units"
    assert not make_estimator(*cands[LATENT_HINGE], 0.0, 0.05, settings).hidden.cascade


@pytest.fixture(scope="module")
def tanks():
    """The zoo's two tanks in series (the hidden upper one overflows), the levels non-negative, a fixed threshold.

    The settings say what the physics says of the levels (non-negative: roots proposed) and propose an indicator
    of the measured level at a fixed threshold (its 97 % quantile), the hard term of ``linear+hard``.
    """
    rec = get_system("hidden_tank_overflow").record(0)
    settings = data_settings(rec.u, rec.y, rec.dt, families=["order1+latent"])
    settings = dict(settings, positive=[0], indicator=[float(np.quantile(rec.y, 0.97))])
    cands = _candidates(rec.u, rec.y, rec.dt, settings)
    fitted = {}
    for name in ("linear+hard", LATENT_CASCADE):
        model = make_estimator(*cands[name], 0.0, rec.dt, settings)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted[name] = model.fit(rec.u, rec.y)
    return rec, fitted


def test_the_cascade_recovers_two_tanks_better_than_a_fixed_threshold(tanks):
    rec, fitted = tanks
    y_init = np.clip(rec.y_test[:10], 0.0, None)  # the levels are held non-negative; the noise is not
    err = {name: float(np.sqrt(np.mean((m.predict(rec.u_test, y_init=y_init) - rec.y_test) ** 2)))
           for name, m in fitted.items()}
    # measured: 0.0377 against 0.0440 (the noise is 0.011); the output's spread is 1.1
    assert err[LATENT_CASCADE] < 0.9 * err["linear+hard"]
    assert err[LATENT_CASCADE] < 0.05 * np.std(rec.y_test)
    cascade = fitted[LATENT_CASCADE]
    names = cascade.library_.get_feature_names_out(["y0", "z0", "u0"])
    assert not [n for n, c in zip(names, cascade.coef_[1]) if c != 0 and "y0" in n]  # z0' = f(z0, u0)
    assert any(c != 0 and "max(z0" in n for n, c in zip(names, cascade.coef_[1]))  # the overflow on z0
