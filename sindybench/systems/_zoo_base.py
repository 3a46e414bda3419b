"""What every system of the zoo shares: the excitation signals, the integrators, noise and records.

A :class:`ZooSystem` is data, not a test: a name, its true equations as text,
class tags, a default excitation, noise level and record lengths, and a
:meth:`ZooSystem.record` that returns an estimation and a test record
(``u``, ``y``, ``dt``, and the noise-free outputs). The plant is either open
loop (``plant(u, dt) -> y_true``) or a loop (``loop(r, noise, dt) -> (u,
y_true)``: the excitation is then the reference of a controller that sees the
noisy measurement, and ``u`` is the plant input the controller applied).

Randomness comes only from ``random_state``: one seed gives four independent
streams (estimation excitation, test excitation, estimation noise, test
noise), so a record is reproduced exactly by its seed.
"""

import zlib

import numpy as np
from scipy.signal import cont2discrete, lfilter
from sklearn.utils import Bunch

from .._validation import check_integer
from ._signals import check_rng, multisine

__all__ = ["TAGS", "Excitation", "ZooSystem", "integrate", "integrate_loop", "linear_plant", "ode_plant"]

TAGS = {
    "linear": "linear dynamics, linear output",
    "nonlinear": "a nonlinear right-hand side or output",
    "hidden_state": "a state that is not measured (a velocity, an upper tank, a hysteretic force)",
    "hard_nonlinearity": "a non-smooth term: saturation, dead zone, backlash, friction, overflow, impact",
    "unstable": "an open-loop unstable plant (recorded under a stabilising controller)",
    "integrating": "an open-loop integrator (recorded under a controller)",
    "closed_loop": "recorded under feedback: the input depends on the measured (noisy) output",
    "dead_time": "a pure input delay",
    "lightly_damped": "modes with damping ratios of a few percent",
    "block_oriented": "linear blocks and a static nonlinearity (Wiener, Hammerstein)",
    "hysteresis": "a memory nonlinearity (backlash, Bouc-Wen)",
    "friction": "Coulomb or Stribeck friction",
    "flow": "square-root or power-law outflow of a tank",
    "oscillator": "a forced nonlinear oscillator",
    "multi_input": "more than one input",
    "multi_output": "more than one output",
    "coloured_noise": "the output noise is coloured (first-order autoregressive, pole 0.9)",
    "long_record": "a long estimation record (tens of thousands of samples)",
    "short_record": "a short estimation record (a few hundred samples)",
}

_COLOUR_POLE = 0.9


class Excitation:
    """An excitation signal of the zoo: its kind and parameters, drawn with a generator.

    Parameters
    ----------
    kind : {"prbs", "steps", "multisine", "filtered_noise"}
        ``"prbs"``: a random binary signal ``offset +- amplitude`` whose level
        may switch every ``hold`` samples; ``"steps"``: levels drawn uniformly
        in ``[low, high]``, each held a random number of samples between
        ``hold`` and ``2 hold``; ``"multisine"``: random-phase multisine with
        every DFT line from ``f_min`` to ``f_max`` Hz, standard deviation
        ``std``; ``"filtered_noise"``: white Gaussian noise through a
        second-order Butterworth low-pass at ``f_max`` Hz, scaled to ``std``.
    **params
        ``amplitude, offset, hold, low, high, f_min, f_max, std`` as the kind uses them.

    Examples
    --------
    >>> e = Excitation("prbs", amplitude=2.0, hold=5)
    >>> u = e(100, dt=0.1, n_inputs=1, rng=np.random.default_rng(0))
    >>> u.shape, sorted(set(np.round(u.ravel(), 6).tolist()))
    ((100, 1), [-2.0, 2.0])
    >>> e
    Excitation('prbs', amplitude=2.0, hold=5)
    """

    KINDS = ("prbs", "steps", "multisine", "filtered_noise")
    # kind -> (required parameters, optional parameters)
    _PARAMS = {
        "prbs": ((), ("amplitude", "offset", "hold")),
        "steps": (("low", "high", "hold"), ()),
        "multisine": (("f_max",), ("f_min", "std", "offset")),
        "filtered_noise": (("f_max",), ("std", "offset")),
    }

    def __init__(self, kind, **params):
        if kind not in self.KINDS:
            raise ValueError(f"kind must be one of {list(self.KINDS)}; got {kind!r}.")
        required, optional = self._PARAMS[kind]
        missing = [p for p in required if p not in params]
        unknown = sorted(set(params) - set(required) - set(optional))
        if missing or unknown:
            raise ValueError(f"a {kind!r} excitation takes {list(required)} and optionally {list(optional)}; "
                             f"got {sorted(params)}.")
        self.kind = kind
        self.params = params

    def __repr__(self):
        args = "".join(f", {k}={v!r}" for k, v in self.params.items())
        return f"Excitation({self.kind!r}{args})"

    def describe(self):
        """One line of text for the docs."""
        p = self.params
        off = p.get("offset", 0.0)
        if self.kind == "prbs":
            return f"PRBS {off:g} +- {p.get('amplitude', 1.0):g}, switching every {p.get('hold', 1)} samples at most"
        if self.kind == "steps":
            return f"random steps in [{p['low']:g}, {p['high']:g}], held {p['hold']}-{2 * p['hold']} samples"
        band = f"{p.get('f_min', 0.0):g}-{p['f_max']:g} Hz" if self.kind == "multisine" else f"below {p['f_max']:g} Hz"
        kind = "multisine" if self.kind == "multisine" else "filtered Gaussian noise"
        return f"{kind} {band}, std {p.get('std', 1.0):g}" + (f", offset {off:g}" if off else "")

    def __call__(self, n, *, dt, n_inputs, rng):
        """Draw ``n`` samples of ``n_inputs`` independent columns."""
        return np.hstack([self._column(n, dt, rng) for _ in range(n_inputs)])

    def _column(self, n, dt, rng):
        p = self.params
        off = p.get("offset", 0.0)
        if self.kind == "prbs":
            hold = int(p.get("hold", 1))
            bits = rng.integers(0, 2, size=-(-n // hold)) * 2 - 1
            return (off + p.get("amplitude", 1.0) * np.repeat(bits, hold)[:n]).reshape(-1, 1)
        if self.kind == "steps":
            hold = int(p["hold"])
            levels = []
            while sum(len(x) for x in levels) < n:
                levels.append(np.full(int(rng.integers(hold, 2 * hold + 1)), rng.uniform(p["low"], p["high"])))
            return np.concatenate(levels)[:n].reshape(-1, 1)
        if self.kind == "multisine":
            u = multisine(n, fs=1.0 / dt, f_min=p.get("f_min", 0.0), f_max=p["f_max"], std=p.get("std", 1.0),
                          random_state=rng)
            return off + u
        # filtered noise: second-order Butterworth low-pass, a short warm-up dropped
        from scipy.signal import butter

        b, a = butter(2, min(2 * p["f_max"] * dt, 0.99))
        w = lfilter(b, a, rng.standard_normal(n + 200))[200:]
        return (off + p.get("std", 1.0) * (w - w.mean()) / w.std()).reshape(-1, 1)


def _rk4_step(rhs, x, u, h):
    """One classical Runge-Kutta step of ``x' = rhs(x, u)`` of length ``h``, the input held."""
    k1 = rhs(x, u)
    k2 = rhs(x + 0.5 * h * k1, u)
    k3 = rhs(x + 0.5 * h * k2, u)
    k4 = rhs(x + h * k3, u)
    return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def integrate(rhs, x0, u, dt, *, n_substeps=1, project=None):
    """Fixed-step RK4 of ``x' = rhs(x, u)`` with the input held over each sample.

    Parameters
    ----------
    rhs : callable
        ``rhs(x, u) -> ndarray`` (``x`` and ``u`` 1-D arrays).
    x0 : array-like of shape (n_states,)
    u : ndarray of shape (n_samples, n_inputs)
    dt : float
    n_substeps : int, default=1
        RK4 steps per sample.
    project : callable, optional
        ``project(x) -> x`` applied after every step (clipping a level to its
        tank, for instance): a state constraint.

    Returns
    -------
    ndarray of shape (n_samples, n_states)
        The state at each sample instant, before the sample's input acts.

    Examples
    --------
    >>> x = integrate(lambda x, u: -x + u, [0.0], np.ones((301, 1)), 0.01)
    >>> round(float(x[-1, 0]), 4), round(1 - float(np.exp(-3.0)), 4)
    (0.9502, 0.9502)
    """
    x = np.array(x0, dtype=float)
    out = np.empty((u.shape[0], x.size))
    h = dt / n_substeps
    for i in range(u.shape[0]):
        out[i] = x
        ui = u[i]
        for _ in range(n_substeps):
            x = _rk4_step(rhs, x, ui, h)
            if project is not None:
                x = project(x)
    return out


def integrate_loop(rhs, x0, r, noise, dt, *, measure, control, n_substeps=1):
    """RK4 of a plant under a sampled controller: ``u[k] = control(r[k], measure(x[k]) + noise[k], x[k])``.

    Returns
    -------
    u : ndarray of shape (n_samples, n_inputs)
        The plant input the controller applied (held over each sample).
    x : ndarray of shape (n_samples, n_states)
    """
    x = np.array(x0, dtype=float)
    n = r.shape[0]
    states = np.empty((n, x.size))
    inputs = []
    h = dt / n_substeps
    for i in range(n):
        states[i] = x
        ui = np.atleast_1d(np.asarray(control(r[i], measure(x) + noise[i], x), dtype=float))
        inputs.append(ui)
        for _ in range(n_substeps):
            x = _rk4_step(rhs, x, ui, h)
    return np.asarray(inputs), states


def linear_plant(A, B, C, D=None, *, delay=0):
    """An exact (zero-order-hold) simulator of ``x' = A x + B u``, ``y = C x + D u`` with an input delay.

    Parameters
    ----------
    A, B, C, D : array-like
        Continuous-time state-space matrices (``D`` zero by default).
    delay : int, default=0
        Pure input delay in samples (the first ``delay`` samples see ``u = 0``).

    Returns
    -------
    callable
        ``plant(u, dt) -> y`` of shape (n_samples, n_outputs), from ``x = 0``.

    Examples
    --------
    >>> plant = linear_plant([[-1.0]], [[1.0]], [[1.0]])
    >>> y = plant(np.ones((101, 1)), 0.05)
    >>> bool(abs(y[-1, 0] - (1 - np.exp(-5.0))) < 1e-12)
    True
    """
    A, B, C = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (A, B, C))
    D = np.zeros((C.shape[0], B.shape[1])) if D is None else np.atleast_2d(np.asarray(D, dtype=float))

    def plant(u, dt):
        Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), dt, method="zoh")
        if delay:
            u = np.vstack([np.zeros((delay, u.shape[1])), u[:-delay]])
        x = np.zeros(A.shape[0])
        states = np.empty((u.shape[0], A.shape[0]))
        drive = u @ Bd.T
        for i in range(u.shape[0]):
            states[i] = x
            x = Ad @ x + drive[i]
        return states @ Cd.T + u @ Dd.T

    plant.matrices = (A, B, C, D)
    return plant


def ode_plant(rhs, x0, output, *, n_substeps=1, project=None, post=None):
    """An open-loop simulator ``plant(u, dt) -> y`` of ``x' = rhs(x, u)``, ``y = output(x)`` (RK4, see :func:`integrate`).

    ``output`` maps the state array (n_samples, n_states) to the outputs;
    ``post(y, u)``, if given, maps the noise-free outputs once more (an
    operator with memory on the output, such as backlash).
    """
    def plant(u, dt):
        y = np.asarray(output(integrate(rhs, x0, u, dt, n_substeps=n_substeps, project=project)), float)
        y = y.reshape(u.shape[0], -1)
        return y if post is None else post(y, u)

    return plant


def _streams(random_state, name):
    """Four independent generators from one seed (an int, None, a RandomState or a Generator) and the system's name.

    The name enters the seed, so that two systems recorded with one seed do not share their noise.
    """
    if random_state is None or isinstance(random_state, (int, np.integer)):
        seed = random_state
    else:
        seed = int(check_rng(random_state).integers(0, 2**32 - 1)) if isinstance(random_state, np.random.Generator) \
            else int(check_rng(random_state).randint(0, 2**32 - 1))
    if seed is not None and int(seed) < 0:
        raise ValueError(f"random_state must be a non-negative integer, a generator or None; got {random_state!r}.")
    entropy = None if seed is None else [int(seed), zlib.crc32(name.encode())]
    return [np.random.default_rng(s) for s in np.random.SeedSequence(entropy).spawn(4)]


def _unit_noise(n, n_outputs, colour, rng):
    w = rng.standard_normal((n + 1, n_outputs))
    if colour == "white":
        return w[1:]
    # AR(1) with pole 0.9 started in its stationary distribution, scaled to unit variance
    gain = np.sqrt(1 - _COLOUR_POLE**2)
    zi = _COLOUR_POLE * w[:1] / gain
    e = lfilter([1.0], [1.0, -_COLOUR_POLE], w[1:], axis=0, zi=zi)[0]
    return e * gain


class ZooSystem:
    """One simulated system of the zoo: its truth, its default experiment, its records.

    Parameters
    ----------
    name : str
    equations : sequence of str
        The true equations as text (``'`` a time derivative; ``y`` the measured outputs).
    tags : sequence of str
        Class tags, keys of :data:`TAGS`.
    excitation : Excitation
        The default input (open loop) or reference (closed loop).
    dt : float
        Sampling interval.
    n_samples, n_test : int
        Default lengths of the estimation and test records.
    noise : float
        Output noise standard deviation relative to the standard deviation of
        the noise-free estimation output (open loop) or of the reference
        (closed loop), per output: 0.01 is 1 %.
    noise_colour : {"white", "coloured"}
        White Gaussian, or first-order autoregressive (pole 0.9) of the same
        standard deviation.
    n_inputs, n_outputs : int
    plant : callable, optional
        ``plant(u, dt) -> y_true`` of an open-loop system.
    loop : callable, optional
        ``loop(r, noise, dt) -> (u, y_true)`` of a closed-loop system (one of
        ``plant`` and ``loop``).
    description : str
        One paragraph for the docs.
    truth : dict, optional
        Facts the tests check (``dc_gain``, ``open_loop_poles``, ...).

    See Also
    --------
    sindybench.systems.zoo_systems : the registry, filtered by tags.

    Examples
    --------
    >>> from sindybench.systems import get_system
    >>> system = get_system("dead_time")
    >>> system.tags, system.truth["delay"]
    (('linear', 'dead_time'), 10)
    >>> rec = system.record(0, n_samples=500, n_test=200)
    >>> rec.u.shape, rec.y.shape, rec.y_test_true.shape
    ((500, 1), (500, 1), (200, 1))
    >>> bool(np.all(rec.y_true[:11] == 0.0))  # at rest until the delayed input arrives
    True
    """

    def __init__(self, name, *, equations, tags, excitation, dt, n_samples, n_test, noise, noise_colour="white",
                 n_inputs=1, n_outputs=1, plant=None, loop=None, description="", truth=None):
        unknown = set(tags) - set(TAGS)
        if unknown:
            raise ValueError(f"unknown tags {sorted(unknown)} for system {name!r}; expected tags from {sorted(TAGS)}.")
        if (plant is None) == (loop is None):
            raise ValueError(f"system {name!r} needs exactly one of plant (open loop) and loop (closed loop).")
        if noise_colour not in ("white", "coloured"):
            raise ValueError(f"noise_colour must be 'white' or 'coloured'; got {noise_colour!r}.")
        self.name = name
        self.equations = tuple(equations)
        self.tags = tuple(tags) + (("coloured_noise",) if noise_colour == "coloured" else ())
        self.excitation = excitation
        self.dt = float(dt)
        self.n_samples = int(n_samples)
        self.n_test = int(n_test)
        self.noise = float(noise)
        self.noise_colour = noise_colour
        self.n_inputs = int(n_inputs)
        self.n_outputs = int(n_outputs)
        self.plant = plant
        self.loop = loop
        self.description = description
        self.truth = dict(truth or {})

    def __repr__(self):
        return f"ZooSystem({self.name!r})"

    @property
    def closed_loop(self):
        """Whether the record is taken under feedback."""
        return self.loop is not None

    def record(self, random_state=None, *, n_samples=None, n_test=None):
        """Simulate an estimation record and a test record.

        Parameters
        ----------
        random_state : int, Generator, RandomState or None, default=None
            The seed of both excitations and both noise sequences.
        n_samples, n_test : int, optional
            Lengths of the estimation and test records (default the system's).

        Returns
        -------
        Bunch
            ``u, y`` (estimation input and measured output, 2-D), ``y_true``
            (its noise-free output), ``u_test, y_test, y_test_true``, ``r,
            r_test`` (the references of a closed-loop record, else None),
            ``dt``, ``name`` and ``noise_std`` (the absolute noise standard
            deviation per output).
        """
        n = check_integer(self.n_samples if n_samples is None else n_samples, "n_samples", low=20)
        n_t = check_integer(self.n_test if n_test is None else n_test, "n_test", low=20)
        rng_e, rng_t, rng_ne, rng_nt = _streams(random_state, self.name)
        r_e = self.excitation(n, dt=self.dt, n_inputs=self.n_inputs if self.plant else self.n_outputs, rng=rng_e)
        r_t = self.excitation(n_t, dt=self.dt, n_inputs=self.n_inputs if self.plant else self.n_outputs, rng=rng_t)
        e_e = _unit_noise(n, self.n_outputs, self.noise_colour, rng_ne)
        e_t = _unit_noise(n_t, self.n_outputs, self.noise_colour, rng_nt)
        if self.plant is not None:
            u_e, y_e = r_e, np.asarray(self.plant(r_e, self.dt), float).reshape(n, -1)
            u_t, y_t = r_t, np.asarray(self.plant(r_t, self.dt), float).reshape(n_t, -1)
            scale = self.noise * y_e.std(axis=0)
        else:
            scale = self.noise * r_e.std(axis=0)
            u_e, y_e = self.loop(r_e, e_e * scale, self.dt)
            u_t, y_t = self.loop(r_t, e_t * scale, self.dt)
        closed = self.loop is not None
        return Bunch(u=u_e, y=y_e + e_e * scale, y_true=y_e, u_test=u_t, y_test=y_t + e_t * scale, y_test_true=y_t,
                     r=r_e if closed else None, r_test=r_t if closed else None, dt=self.dt, name=self.name,
                     noise_std=scale)
