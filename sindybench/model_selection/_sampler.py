"""TPE seeded per trial, so that parallel and resumed workers never repeat each other."""

import threading

import numpy as np
from optuna.samplers import BaseSampler, TPESampler

__all__ = ["make_sampler"]


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
    """

    def __init__(self, seed):
        self.seed = seed
        self._samplers = {}
        self._lock = threading.Lock()

    def _sampler(self, trial):
        with self._lock:
            sampler = self._samplers.get(trial.number)
            if sampler is None:
                state = np.random.SeedSequence([self.seed, trial.number]).generate_state(1)[0]
                sampler = self._samplers[trial.number] = TPESampler(seed=int(state))
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


def make_sampler(random_state):
    """``TrialSeededTPE(random_state)``, or a plain unseeded ``TPESampler`` for ``None``."""
    return TPESampler() if random_state is None else TrialSeededTPE(int(random_state))
