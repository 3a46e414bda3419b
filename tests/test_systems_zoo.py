"""The zoo of simulated systems: registry, records, noise, truth, and a quick identification floor."""

import warnings

import numpy as np
import pytest

from sindybench.baselines import ARX
from sindybench.metrics import fit_index
from sindybench.systems import TAGS, ZOO, Excitation, ZooSystem, get_system, zoo_systems
from sindybench.systems._zoo_base import integrate, linear_plant
from sindybench.systems._zoo_closedloop import _pendulum, _unstable_lag

SYSTEMS = zoo_systems()
NAMES = [s.name for s in SYSTEMS]
SHORT = [s for s in SYSTEMS if s.n_samples <= 10_000]


def test_registry_holds_at_least_30_systems_with_unique_names():
    assert len(SYSTEMS) >= 30
    assert len(set(NAMES)) == len(NAMES) == len(ZOO)
    assert all(ZOO[name] is get_system(name) for name in NAMES)


def test_registry_covers_the_classes_of_the_issues():
    tags = {t for s in SYSTEMS for t in s.tags}
    assert set(TAGS) <= tags  # every declared class has at least one system
    kinds = {s.excitation.kind for s in SYSTEMS}
    assert kinds == set(Excitation.KINDS)
    assert min(s.noise for s in SYSTEMS) <= 0.002 and max(s.noise for s in SYSTEMS) >= 0.02
    assert min(s.n_samples for s in SYSTEMS) == 300 and max(s.n_samples for s in SYSTEMS) == 100_000
    hidden_hard = {s.name for s in zoo_systems(["hidden_state", "hard_nonlinearity"])}
    assert {"hidden_tank_overflow", "hidden_saturation", "friction_hidden_velocity", "impacts"} <= hidden_hard
    assert len(zoo_systems("multi_output")) >= 2 and len(zoo_systems("multi_input")) >= 3


@pytest.mark.parametrize("system", SYSTEMS, ids=NAMES)
def test_system_is_documented(system):
    assert system.equations and all(isinstance(eq, str) and eq for eq in system.equations)
    assert system.description
    assert set(system.tags) <= set(TAGS) and system.tags
    assert ("linear" in system.tags) != ("nonlinear" in system.tags)
    assert ("closed_loop" in system.tags) == system.closed_loop
    assert 300 <= system.n_samples <= 100_000 and system.n_test >= 300
    assert 0.001 <= system.noise <= 0.05


@pytest.mark.parametrize("system", SYSTEMS, ids=NAMES)
def test_record_is_finite_reproducible_and_seeded(system):
    a = system.record(1, n_samples=240, n_test=120)
    b = system.record(1, n_samples=240, n_test=120)
    c = system.record(2, n_samples=240, n_test=120)
    assert a.u.shape == (240, system.n_inputs) and a.y.shape == a.y_true.shape == (240, system.n_outputs)
    assert a.u_test.shape == (120, system.n_inputs) and a.y_test.shape == a.y_test_true.shape == (120, system.n_outputs)
    assert a.dt == system.dt
    for key in ("u", "y", "y_true", "u_test", "y_test", "y_test_true"):
        assert np.all(np.isfinite(a[key])), key
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.allclose(a.y, c.y) and not np.allclose(a.u_test, c.u_test)
    assert not np.allclose(a.u, a.u_test[: len(a.u)].repeat(2, axis=0)[: len(a.u)])  # test input is its own draw


@pytest.mark.parametrize("system", SHORT, ids=[s.name for s in SHORT])
def test_default_record_has_declared_lengths_and_noise(system):
    rec = system.record(0)
    assert rec.y.shape == (system.n_samples, system.n_outputs)
    assert rec.y_test.shape == (system.n_test, system.n_outputs)
    assert np.all(np.isfinite(rec.y)) and np.all(np.isfinite(rec.y_test))
    assert np.all(rec.y_true.std(axis=0) > 0), "the output must move"
    reference = rec.r.std(axis=0) if system.closed_loop else rec.y_true.std(axis=0)
    measured = (rec.y - rec.y_true).std(axis=0) / reference
    np.testing.assert_allclose(measured, system.noise, rtol=0.25)
    np.testing.assert_allclose(rec.noise_std, system.noise * reference)


@pytest.mark.slow
def test_long_record_has_declared_length_and_noise():
    system = get_system("second_order_long")
    rec = system.record(0)
    assert rec.y.shape == (100_000, 1) and np.all(np.isfinite(rec.y))
    np.testing.assert_allclose((rec.y - rec.y_true).std() / rec.y_true.std(), system.noise, rtol=0.1)


def test_coloured_noise_is_correlated_and_white_noise_is_not():
    coloured = get_system("tank_power_law").record(0)
    white = get_system("single_tank").record(0)

    def lag1(e):
        e = e.ravel() - e.mean()
        return float(e[1:] @ e[:-1] / (e @ e))

    assert 0.8 < lag1(coloured.y - coloured.y_true) < 0.97
    assert abs(lag1(white.y - white.y_true)) < 0.1


@pytest.mark.parametrize("name", ["first_order", "first_order_short", "third_order", "fourth_order_two_modes",
                                  "fifth_order_nonminimum_phase", "eighth_order", "dead_time"])
def test_linear_step_response_settles_at_the_dc_gain(name):
    system = get_system(name)
    y = system.plant(np.ones((int(200 / system.dt), 1)), system.dt)
    assert y[-1, 0] == pytest.approx(system.truth["dc_gain"], rel=1e-3)


def test_dc_gains_match_the_equations():
    assert get_system("first_order").truth["dc_gain"] == pytest.approx(1.0)
    assert get_system("first_order_short").truth["dc_gain"] == pytest.approx(2.0)
    assert get_system("fourth_order_two_modes").truth["dc_gain"] == pytest.approx(1.0 + 2.0 / 9.0)
    # acceleration out: no static gain beyond the direct feedthrough
    assert get_system("flexible_arm").truth["dc_gain"] == pytest.approx(0.1)


def test_flexible_arm_has_three_lightly_damped_modes():
    poles = get_system("flexible_arm").truth["poles"]
    upper = poles[poles.imag > 0]
    assert len(poles) == 6 and len(upper) == 3
    np.testing.assert_allclose(sorted(np.abs(upper)), [20.0, 55.0, 110.0], rtol=1e-9)
    assert np.all(-upper.real / np.abs(upper) <= 0.05)


def test_dead_time_delays_the_response_by_declared_samples():
    system = get_system("dead_time")
    delay = system.truth["delay"]
    y = system.plant(np.ones((50, 1)), system.dt)
    assert delay == 10
    assert np.all(y[: delay + 1] == 0.0) and y[delay + 1, 0] > 0


@pytest.mark.parametrize("name, rhs, x0", [("inverted_pendulum_pd", _pendulum, [0.01, 0.0]),
                                           ("unstable_first_order", _unstable_lag, [0.01])])
def test_unstable_plant_diverges_open_loop_but_the_closed_loop_record_is_bounded(name, rhs, x0):
    system = get_system(name)
    assert np.max(np.real(system.truth["open_loop_poles"])) > 0.4
    # open loop, no input: a small offset grows at least tenfold in a few seconds
    x = integrate(rhs, x0, np.zeros((int(5 / system.dt), 1)), system.dt)
    assert abs(x[-1, 0]) > 10 * abs(x0[0])
    rec = system.record(0)
    assert np.abs(rec.y_true).max() < 5 * np.abs(rec.r).max()
    assert np.abs(rec.y_test_true).max() < 5 * np.abs(rec.r_test).max()
    # under feedback the output follows the reference
    assert np.corrcoef(rec.r.ravel(), rec.y_true.ravel())[0, 1] > 0.6


def test_closed_loop_input_depends_on_the_measurement_noise():
    system = get_system("integrator_p_control")
    rec = system.record(0)
    # u = r - y_measured exactly: the noise enters the input
    np.testing.assert_allclose(rec.u, rec.r - rec.y, atol=1e-12)


def test_hidden_tank_overflows_and_saturation_clips():
    from sindybench.systems._zoo_hidden import _hidden_saturation, _hidden_tanks

    tanks = get_system("hidden_tank_overflow")
    u = tanks.excitation(tanks.n_samples, dt=tanks.dt, n_inputs=1, rng=np.random.default_rng(0))
    x = integrate(_hidden_tanks, [0.0, 0.0], u, tanks.dt, project=lambda s: np.clip(s, 0.0, 10.0))
    assert 0.05 < np.mean(x[:, 0] >= 10.0 - 1e-9) < 0.6
    sat = get_system("hidden_saturation")
    u = sat.excitation(sat.n_samples, dt=sat.dt, n_inputs=1, rng=np.random.default_rng(0))
    x = integrate(_hidden_saturation, [0.0, 0.0], u, sat.dt,
                  project=lambda s: np.array([min(max(s[0], -1.0), 1.0), s[1]]))
    assert 0.05 < np.mean(np.abs(x[:, 0]) >= 1.0 - 1e-9) < 0.6


def test_linear_plant_matches_integration():
    plant = linear_plant([[0.0, 1.0], [-4.0, -0.8]], [[0.0], [1.0]], [[1.0, 0.0]])
    u = np.sin(0.3 * np.arange(400))[:, None]
    x = integrate(lambda s, v: np.array([s[1], -4.0 * s[0] - 0.8 * s[1] + v[0]]), [0.0, 0.0], u, 0.05, n_substeps=4)
    np.testing.assert_allclose(plant(u, 0.05), x[:, :1], atol=1e-7)


@pytest.mark.parametrize("kind, params, check", [
    ("prbs", {"amplitude": 2.0, "offset": 1.0, "hold": 7}, lambda u: set(np.round(u.ravel(), 9)) == {-1.0, 3.0}),
    ("steps", {"low": 1.0, "high": 5.0, "hold": 10}, lambda u: u.min() >= 1.0 and u.max() <= 5.0
     and len(np.unique(u)) >= 10),
    ("multisine", {"f_min": 0.1, "f_max": 1.0, "std": 2.0}, lambda u: np.allclose(u.std(axis=0, ddof=1), 2.0)),
    ("filtered_noise", {"f_max": 0.5, "std": 3.0}, lambda u: abs(u.std() - 3.0) < 1e-9),
])
def test_excitation_kinds(kind, params, check):
    u = Excitation(kind, **params)(500, dt=0.1, n_inputs=2, rng=np.random.default_rng(0))
    assert u.shape == (500, 2) and check(u) and not np.allclose(u[:, 0], u[:, 1])
    assert Excitation(kind, **params).describe()


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="kind must be one of"):
        Excitation("chirp")
    with pytest.raises(ValueError, match="a 'steps' excitation takes"):
        Excitation("steps", low=0.0, hold=3)
    with pytest.raises(ValueError, match="a 'prbs' excitation takes"):
        Excitation("prbs", amplitud=1.0)
    with pytest.raises(ValueError, match="unknown system 'nope'"):
        get_system("nope")
    with pytest.raises(ValueError, match="unknown tags"):
        zoo_systems(["linear", "wobbly"])
    with pytest.raises(ValueError, match="unknown tags"):
        ZooSystem("x", equations=["y' = u"], tags=["wobbly"], excitation=Excitation("prbs"), dt=1.0,
                  n_samples=100, n_test=100, noise=0.01, plant=linear_plant([[-1.0]], [[1.0]], [[1.0]]))
    with pytest.raises(ValueError, match="exactly one of plant"):
        ZooSystem("x", equations=["y' = u"], tags=["linear"], excitation=Excitation("prbs"), dt=1.0,
                  n_samples=100, n_test=100, noise=0.01)
    with pytest.raises(ValueError, match="n_samples"):
        get_system("first_order").record(0, n_samples=5)
    with pytest.raises(ValueError, match="random_state must be a non-negative"):
        get_system("first_order").record(-1)


def test_generator_seed_is_accepted_and_reproducible():
    system = get_system("bilinear")
    a = system.record(np.random.default_rng(5), n_samples=100, n_test=50)
    b = system.record(np.random.default_rng(5), n_samples=100, n_test=50)
    np.testing.assert_array_equal(a.y, b.y)


def test_systems_of_one_seed_do_not_share_noise():
    a = get_system("first_order").record(0, n_samples=200, n_test=50)
    b = get_system("dead_time").record(0, n_samples=200, n_test=50)
    ea, eb = (a.y - a.y_true).ravel() / a.noise_std, (b.y - b.y_true).ravel() / b.noise_std
    assert abs(np.corrcoef(ea, eb)[0, 1]) < 0.3


# ------------------------------------------------------------------ a quick identification floor (CI subset)
@pytest.mark.parametrize("name, family, floor", [("first_order", "first_order", 97.0),
                                                 ("second_order", "order2", 97.0),
                                                 ("hammerstein", "first_order", 97.0)])
def test_identify_and_arx_reach_a_fit_floor_on_small_systems(name, family, floor):
    from sindybench import identify

    rec = get_system(name).record(0, n_samples=1000, n_test=500)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the cheap budget: one family (the one holding the truth), the rest of the defaults
        model = identify(rec.u, rec.y, dt=rec.dt, families=[family], show_progress_bar=False, random_state=0)
    y_hat = model.predict(rec.u_test, y_init=rec.y_test[:10])
    assert fit_index(rec.y_test, y_hat, skip=10) >= floor
    if name != "hammerstein":
        # the exact second-order ARX is biased by the output noise at this fast sampling (fit 63 % on
        # second_order); six lags absorb the bias
        arx = ARX(na=6, nb=6, nk=1).fit(rec.u, rec.y)
        assert fit_index(rec.y_test, arx.predict(rec.u_test, y_init=rec.y_test[:10]), skip=10) >= 95.0
