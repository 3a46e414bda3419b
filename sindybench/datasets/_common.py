"""Small helpers shared by the loaders: split Bunches and the returned dataset Bunch."""

import numpy as np
from sklearn.utils import Bunch

__all__ = ["make_dataset", "make_split"]


def make_split(u, y, dt, *, start=0, name):
    """One record split as a Bunch.

    ``u`` and ``y`` become float arrays of shape (n, 1); ``t`` is the time of
    each sample since the start of the record the split was cut from
    (``(start + k) * dt``), so consecutive splits have consecutive times.
    """
    u = np.asarray(u, dtype=float).reshape(-1, 1)
    y = np.asarray(y, dtype=float).reshape(-1, 1)
    if u.shape[0] != y.shape[0]:
        raise ValueError(f"{name}: u has {u.shape[0]} samples and y has {y.shape[0]}; expected the same number.")
    t = (start + np.arange(u.shape[0])) * dt
    return Bunch(u=u, y=y, t=t, dt=float(dt), name=name)


def make_dataset(u, y, dt, *, n_train, test, remotes, paths, **info):
    """The Bunch a loader returns.

    The estimation record ``u, y`` gives ``estimation`` (all of it), ``train``
    (its first ``n_train`` samples) and ``validation`` (the rest); then come
    ``test``, ``dt``, the loader's own ``info`` (``n_init``, ``units``,
    ``DESCR``, ...) and ``source``: where each file came from (filename, url,
    member, sha256, local path).
    """
    return Bunch(
        train=make_split(u[:n_train], y[:n_train], dt, name="train"),
        validation=make_split(u[n_train:], y[n_train:], dt, start=n_train, name="validation"),
        test=test,
        estimation=make_split(u, y, dt, name="estimation"),
        dt=dt,
        **info,
        source=[
            Bunch(filename=r.filename, url=r.url, member=r.member, sha256=r.sha256, path=str(p))
            for r, p in zip(remotes, paths)
        ],
    )
