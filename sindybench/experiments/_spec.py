"""Declarative description of a benchmark and of the models trained on it."""

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

__all__ = ["Benchmark", "ModelSpec"]


@dataclass(frozen=True)
class ModelSpec:
    """One model of the study's table: how to build it and how to tune it.

    Parameters
    ----------
    key : str
        Short identifier, used in file names and in ``results.json``.
    label : str
        Human-readable name for tables and figure legends.
    make : callable
        ``make(*, random_state, quick, dt, n_val, n_samples) -> estimator``
        (unfitted; ``n_samples`` rows of training + validation data, of which
        the last ``n_val`` validate, for estimators that search inside ``fit``).
    search_space : callable or None
        ``search_space(quick, n_init) -> dict`` of search dimensions keyed by
        nested parameter name, for :func:`sindybench.model_selection.tune`
        (``n_init``: the initial test samples a model may use);
        ``None`` fits the estimator as built (its own inner search, if any,
        still runs inside ``fit``).
    n_trials : int
        Outer search budget of a default run.
    n_trials_quick : int
        Outer search budget with ``--quick``.
    description : str
        One sentence on what the model is, for the reports.
    max_train, max_train_quick : int or None
        Train this model on at most the first ``max_train`` training samples
        (the validation block is unchanged); ``None``: all of them. For
        models whose cost grows with the record (NN-ARX on Bouc-Wen).
    refines : str or None
        Key of an earlier model of the benchmark that this row refines: the
        runner clones that fitted model, holds the hyperparameters its
        searches chose (outer and inner), sets the parameters that ``make``
        returns (e.g. ``refine=OutputErrorRefinement(...)``,
        ``initial_state="fit"``) and fits it on the whole estimation record.
    k_step : bool
        Also report this row's k-step-ahead scores on the test sets (the
        protocol of the designated row's, :func:`~sindybench.experiments._best.k_step_scores`).
    """

    key: str
    label: str
    make: Callable
    search_space: Callable | None = None
    n_trials: int = 0
    n_trials_quick: int = 0
    description: str = ""
    max_train: int | None = None
    max_train_quick: int | None = None
    refines: str | None = None
    k_step: bool = False

    def train_cap(self, *, quick):
        """Largest number of training samples this model uses (``None``: all)."""
        return self.max_train_quick if quick else self.max_train

    def train_rows(self, *, quick, n_train, n_samples):
        """Rows of the estimation record (``n_train`` training samples, then validation) this model is fitted on.

        ``slice(None)`` (all rows), or the first :meth:`train_cap` training
        rows followed by the whole validation block.

        Examples
        --------
        >>> spec = ModelSpec("m", "M", None, max_train=3)
        >>> spec.train_rows(quick=False, n_train=5, n_samples=7)
        array([0, 1, 2, 5, 6])
        >>> spec.train_rows(quick=True, n_train=5, n_samples=7)
        slice(None, None, None)
        """
        cap = self.train_cap(quick=quick)
        return slice(None) if cap is None or cap >= n_train else np.r_[:cap, n_train:n_samples]

    def budget(self, *, quick, trials=None):
        """Number of outer search trials for this run (0 without a search space)."""
        if self.search_space is None or self.refines is not None:
            return 0
        if trials is not None:
            return int(trials)
        return self.n_trials_quick if quick else self.n_trials


@dataclass(frozen=True)
class Benchmark:
    """One benchmark of the study.

    Parameters
    ----------
    name : str
        CLI name, e.g. ``"cascaded-tanks"``.
    title : str
        Title for reports.
    load : callable
        ``load(data_home=..., download_if_missing=...) -> Bunch`` with
        ``train``, ``validation`` and ``test`` (a Bunch or a dict of Bunches).
    models : tuple of ModelSpec
    output_label, input_label : str
        Axis labels (with units) for the figures.
    n_init : int
        Number of initial test samples a model may use to initialise its state
        (overridden by the dataset's own ``n_init`` when it declares one).
    hysteresis_test : str or None
        Test set on which to draw force-displacement loops.
    n_train_quick : int or None
        With ``--quick``, train on the first ``n_train_quick`` training samples
        only (``None``: all of them).
    test_sets_quick : tuple of str or None
        With ``--quick``, evaluate on these test sets only (``None``: all).
    notes : str
        Paragraph for the report: what the study did, what differs here.
    reported_model : str or None
        Key of the row that gets the extra reports (k-step prediction, smoothed
        start, standard errors, prediction band), designated by its structure,
        never by a test score (``None``: no extra reports).
    band_members, band_members_quick : int
        Members of that row's bootstrap ensemble (full and ``--quick`` runs;
        0 skips the band, with ``band_skip_reason`` in the report).
    band_skip_reason : str
        Why the band is skipped or smaller, for the report.
    cost : float
        Roughly the seconds of one core a default run takes (measured); only
        orders the benchmarks that run at once, the longest first.
    """

    name: str
    title: str
    load: Callable
    models: tuple = field(default_factory=tuple)
    output_label: str = "y"
    input_label: str = "u"
    n_init: int = 10
    hysteresis_test: str | None = None
    n_train_quick: int | None = None
    test_sets_quick: tuple | None = None
    notes: str = ""
    reported_model: str | None = None
    band_members: int = 10
    band_members_quick: int = 5
    band_skip_reason: str = ""
    cost: float = 1.0

    def model(self, key):
        """Return the model spec called ``key``."""
        for spec in self.models:
            if spec.key == key:
                return spec
        raise KeyError(f"{self.name} has no model {key!r}; models: {[m.key for m in self.models]}.")
