"""``identify``'s candidates kept in an Optuna study, so that a search that stops can be resumed.

Each evaluated candidate is one finished trial (created whole by the search's
own process with :func:`optuna.trial.create_trial`: no trial is ever left
RUNNING), its settings as user attributes and as fixed parameters (the
threshold, the input delay), its value the mean validation error (a failed or
diverged candidate is a FAIL trial with its reason). A second ``fit`` with the
same storage, study name, data and search settings reads the candidates back
instead of fitting them again. The storage is opened the way
:func:`~sindybench.model_selection.tune` opens it
(:func:`~sindybench.model_selection._storage.make_storage`: SQLite and other
databases, or a journal file whose torn last record is mended), and the study
is made by :func:`~sindybench.search.create_study`.

Without a storage, the searches of one process can share their candidates inside
:func:`shared_candidates`: a second search of the same data and settings (another
``families`` list, say) takes the candidates it has in common with the first as the
first computed them (the same Python objects' copies, so bit for bit the same), and
computes only the others. ``run all`` runs each benchmark inside it, so that the row
"identified automatically, equations only" costs only what the row "identified
automatically" did not already compute.
"""

import contextlib
import copy
import hashlib
import json
import logging
import math

import numpy as np
import optuna

from ..model_selection._storage import describe_storage, make_storage
from ..search import create_study

__all__ = ["CandidateStore", "fingerprint", "shared_candidates"]

logger = logging.getLogger(__name__)

#: the study's user attribute that names the data and the search settings it was made with
STUDY_ATTR = "identify_call"
#: the default study name with a storage
DEFAULT_STUDY = "identify"
#: the candidates of the searches inside :func:`shared_candidates` (signature -> key -> row), else None
_SHARED = None


@contextlib.contextmanager
def shared_candidates():
    """Let the searches without a storage inside this block share their candidates (see the module text).

    A search reads back a candidate only when its signature (the data's
    fingerprint and the settings that change a candidate's result, as a storage
    checks them) and its key are those of a candidate computed before in the
    block; nested blocks share the outer one's candidates. On leaving the
    outermost block they are dropped.

    Examples
    --------
    >>> with shared_candidates():
    ...     first = CandidateStore(None, None, {"data": "abc"})
    ...     first.put("k", {"errors": [0.5]})
    ...     CandidateStore(None, None, {"data": "abc"}).get("k"), CandidateStore(None, None, {"data": "xyz"}).get("k")
    ({'errors': [0.5]}, None)
    >>> CandidateStore(None, None, {"data": "abc"}).get("k") is None
    True
    """
    global _SHARED
    outer = _SHARED
    if outer is None:
        _SHARED = {}
    try:
        yield
    finally:
        _SHARED = outer


def fingerprint(X, y, dt):
    """A SHA-256 of the records (shapes and float64 values) and the sample time.

    Examples
    --------
    >>> a = fingerprint([np.zeros((3, 1))], [np.ones((3, 1))], 0.1)
    >>> a == fingerprint([np.zeros((3, 1))], [np.ones((3, 1))], 0.1), a == fingerprint([np.zeros((3, 1))],
    ...                                                                                    [np.ones((3, 1))], 0.2)
    (True, False)
    """
    h = hashlib.sha256(repr(float(dt)).encode())
    for X_r, y_r in zip(X, y):
        for a in (X_r, y_r):
            a = np.ascontiguousarray(a, dtype=np.float64)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
    return h.hexdigest()


def _encode(errors):
    return [e if math.isfinite(e) else None for e in errors]


def _decode(errors):
    return [math.inf if e is None else float(e) for e in errors]


class CandidateStore:
    """The evaluated candidates of a search: read back by key, and recorded as they finish.

    Parameters
    ----------
    storage : None, str, path-like or optuna storage
        As :func:`~sindybench.model_selection.tune` takes it; None keeps nothing.
    study_name : str or None
        None = ``"identify"``.
    signature : dict
        The data's fingerprint (``"data"``) and the settings that change a
        candidate's result; a stored study made with another one is refused.

    Attributes
    ----------
    study : optuna.study.Study or None
    n_read : int
        Candidates read back (counted by the search, which reads whole paths).
    """

    def __init__(self, storage, study_name, signature):
        self.study, self.n_read = None, 0
        self._done = {}
        self._shared = None  # the rows computed by this process's searches of the same signature (shared_candidates)
        if storage is None:
            if _SHARED is not None:
                self._shared = _SHARED.setdefault(json.dumps(signature, sort_keys=True, default=str), {})
            return
        name = DEFAULT_STUDY if study_name is None else study_name
        study = create_study(0, storage=make_storage(storage), study_name=name, load_if_exists=True)
        stored = study.user_attrs.get(STUDY_ATTR)
        where = f"study {name!r} in storage {describe_storage(storage)!r}"
        if stored is not None and stored.get("data") != signature["data"]:
            raise ValueError(f"{where} was made on other data (fingerprint {str(stored.get('data'))[:12]}, this "
                             f"data {signature['data'][:12]}); expected the same records and dt to resume it. Pass "
                             "another study_name (the stored study is left as it is).")
        if stored is not None and stored != signature:
            changed = sorted(k for k in set(stored) | set(signature) if stored.get(k) != signature.get(k))
            was = ", ".join(f"{k}={stored.get(k)!r}" for k in changed)
            now = ", ".join(f"{k}={signature.get(k)!r}" for k in changed)
            raise ValueError(f"{where} was made with other settings ({was}; got {now}); expected the same settings to "
                             "resume it. Pass another study_name (the stored study is left as it is).")
        if stored is None and (study.user_attrs or study.get_trials(deepcopy=False)):
            raise ValueError(f"{where} was not made by identify (it holds {len(study.trials)} trials and the "
                             f"attributes {sorted(study.user_attrs)}); expected a new study or one of identify's. "
                             "Pass another study_name (the stored study is left as it is).")
        if stored is None:
            study.set_user_attr(STUDY_ATTR, signature)
        for trial in study.get_trials(deepcopy=False):
            key = trial.user_attrs.get("key")
            if key is not None and trial.state in (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL):
                self._done[key] = trial.user_attrs
        self.study = study
        if self._done:
            logger.info("identify: %d candidates of %s read back", len(self._done), where)

    @staticmethod
    def key(row, **extra):
        """The text that names a candidate: its structure, threshold, stage and ``extra``."""
        names = ("family", "library", "derivative", "input_hold", "input_delay", "threshold", "stage")
        return json.dumps({**{k: row[k] for k in names}, **extra}, sort_keys=True)

    def get(self, key):
        """The stored row of ``key`` (the candidate's settings, ``errors``, ``n_terms``, ``max_row_terms``,
        ``fit_time``, ``status``, and the screen's ``path_length``), or None."""
        if self._shared is not None:
            row = self._shared.get(key)
            return None if row is None else copy.deepcopy(row)
        attrs = self._done.get(key)
        if attrs is None:
            return None
        row = {k: v for k, v in attrs.items() if k != "key"}
        row["errors"] = _decode(attrs["errors"])
        return row

    def put(self, key, row, **extra):
        """Record ``row`` (a candidate's settings and result) as one finished trial named ``key``."""
        if self._shared is not None:  # a copy, as computed (the search may change its rows later)
            self._shared.setdefault(key, copy.deepcopy(dict(row, **extra)))
            return
        if self.study is None or key in self._done:
            return
        attrs = {k: row[k] for k in ("family", "library", "derivative", "input_hold", "input_delay", "threshold",
                                     "refine", "stage", "n_terms", "max_row_terms", "fit_time", "status")}
        attrs.update(extra, key=key, errors=_encode(row["errors"]))
        if row.get("equations") is not None:
            attrs["equations"] = list(row["equations"])
        if row.get("support") is not None:  # the terms the refit of a chosen candidate keeps
            attrs["support"] = row["support"]
        ok = row["errors"] and all(math.isfinite(e) for e in row["errors"])
        dists = {"threshold": optuna.distributions.FloatDistribution(row["threshold"], row["threshold"]),
                 "input_delay": optuna.distributions.IntDistribution(row["input_delay"], row["input_delay"])}
        trial = optuna.trial.create_trial(
            state=optuna.trial.TrialState.COMPLETE if ok else optuna.trial.TrialState.FAIL,
            value=float(np.mean(row["errors"])) if ok else None,
            params={"threshold": float(row["threshold"]), "input_delay": int(row["input_delay"])},
            distributions=dists, user_attrs=attrs)
        self.study.add_trial(trial)
        self._done[key] = attrs
