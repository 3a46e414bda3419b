"""The one Optuna driver core: the study, its TPE sampler, and the trial's suggestions.

:func:`create_study` is the only place where sindybench makes an Optuna study;
:func:`~sindybench.model_selection.tune` (persistent, shared between workers)
and the inner search of :class:`~sindybench.HiddenStateSINDy`
(:func:`~sindybench.search.minimize`, in memory) both call it, and both turn a
search space into a trial's values with :func:`~sindybench.search.sample_params`
(each dimension's ``suggest``).
"""

import threading
import warnings

import numpy as np
import optuna
from optuna.samplers import BaseSampler, TPESampler

__all__ = ["TrialSeededTPE", "create_study", "make_sampler"]

#: Optuna's own default number of random (startup) trials before TPE models the results.
N_STARTUP_TRIALS = 10


class TrialSeededTPE(BaseSampler):
    """Optuna's TPE whose random draws for trial ``n`` are seeded by ``(seed, n)``.

    ``TPESampler(seed=seed)`` draws from one random stream per process: two
    workers started with the same seed, or a worker restarted after a crash,
    would propose the same first (random) trials again. Here every trial gets
    a fresh ``TPESampler`` seeded from the seed and the trial number, which the
    storage hands out once per study. A single in-process study is as
    reproducible as with one stream; workers sharing a study explore distinct
    points.

    Parameters
    ----------
    seed : int
    n_startup_trials : int, default=10
        Passed to every trial's ``TPESampler``.
    """

    def __init__(self, seed, n_startup_trials=N_STARTUP_TRIALS):
        self.seed = seed
        self.n_startup_trials = n_startup_trials
        self._samplers = {}
        self._lock = threading.Lock()

    def _sampler(self, trial):
        with self._lock:
            sampler = self._samplers.get(trial.number)
            if sampler is None:
                state = np.random.SeedSequence([self.seed, trial.number]).generate_state(1)[0]
                sampler = self._samplers[trial.number] = TPESampler(seed=int(state),
                                                                     n_startup_trials=self.n_startup_trials)
            return sampler

    def infer_relative_search_space(self, study, trial):
        return self._sampler(trial).infer_relative_search_space(study, trial)

    def sample_relative(self, study, trial, search_space):
        return self._sampler(trial).sample_relative(study, trial, search_space)

    def sample_independent(self, study, trial, param_name, param_distribution):
        return self._sampler(trial).sample_independent(study, trial, param_name, param_distribution)

    def before_trial(self, study, trial):
        self._sampler(trial).before_trial(study, trial)

    def after_trial(self, study, trial, state, values):
        sampler = self._sampler(trial)
        with self._lock:
            self._samplers.pop(trial.number, None)
        sampler.after_trial(study, trial, state, values)

    def reseed_rng(self):
        """Nothing to reseed: every trial is seeded from its number."""


def make_sampler(seed, *, per_trial=True, n_startup_trials=N_STARTUP_TRIALS):
    """The TPE sampler of a study.

    Parameters
    ----------
    seed : int or None
        None: an unseeded ``TPESampler``.
    per_trial : bool, default=True
        :class:`TrialSeededTPE` (``tune``: workers sharing a study draw
        distinct points); ``False``: one ``TPESampler(seed=seed)`` stream (the
        in-memory inner search).
    n_startup_trials : int, default=10
        Random trials before TPE models the results.

    Examples
    --------
    >>> type(make_sampler(0)).__name__, type(make_sampler(0, per_trial=False)).__name__
    ('TrialSeededTPE', 'TPESampler')
    """
    if seed is None:
        return TPESampler(n_startup_trials=n_startup_trials)
    if per_trial:
        return TrialSeededTPE(int(seed), n_startup_trials=n_startup_trials)
    return TPESampler(seed=int(seed), n_startup_trials=n_startup_trials)


def create_study(seed=None, *, per_trial=True, n_startup_trials=N_STARTUP_TRIALS, direction="minimize",
                 storage=None, study_name=None, load_if_exists=False):
    """An Optuna study with sindybench's TPE sampler (:func:`make_sampler`).

    Parameters
    ----------
    seed, per_trial, n_startup_trials
        The sampler, see :func:`make_sampler`.
    direction : {"minimize", "maximize"}, default="minimize"
    storage : optuna storage or None, default=None
        None keeps the study in memory.
    study_name : str, optional
    load_if_exists : bool, default=False
        Resume a study of that name in ``storage``.

    Returns
    -------
    optuna.study.Study

    Examples
    --------
    >>> from sindybench.search import Uniform, sample_params
    >>> study = create_study(0, per_trial=False)
    >>> study.optimize(lambda trial: sample_params({"a": Uniform(0.0, 1.0)}, trial)["a"], n_trials=3)
    >>> len(study.trials)
    3
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=optuna.exceptions.ExperimentalWarning)
        return optuna.create_study(
            storage=storage,
            study_name=study_name,
            sampler=make_sampler(seed, per_trial=per_trial, n_startup_trials=n_startup_trials),
            direction=direction,
            load_if_exists=load_if_exists,
        )

