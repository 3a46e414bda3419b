"""The zoo's registry: every simulated system by name, for the benchmark and the tests to iterate."""

from . import (
    _zoo_blockoriented,
    _zoo_closedloop,
    _zoo_flows,
    _zoo_friction,
    _zoo_hidden,
    _zoo_linear,
    _zoo_mimo,
    _zoo_oscillators,
)
from ._zoo_base import TAGS

__all__ = ["ZOO", "get_system", "zoo_systems"]

ZOO = {
    s.name: s
    for module in (_zoo_linear, _zoo_closedloop, _zoo_blockoriented, _zoo_friction, _zoo_flows, _zoo_oscillators,
                   _zoo_mimo, _zoo_hidden)
    for s in module.SYSTEMS
}


def zoo_systems(tags=None):
    """The systems of the zoo, in registry order; with ``tags``, those carrying every one of them.

    Parameters
    ----------
    tags : str or sequence of str, optional
        Class tags (keys of :data:`~sindybench.systems.TAGS`).

    Returns
    -------
    list of ZooSystem

    Examples
    --------
    >>> len(zoo_systems()) >= 30
    True
    >>> [s.name for s in zoo_systems(["unstable", "linear"])]
    ['unstable_first_order']
    >>> record = get_system("first_order").record(0)
    >>> record.u.shape, record.y.shape, record.y_test_true.shape, record.dt
    ((2000, 1), (2000, 1), (1000, 1), 0.1)
    """
    if tags is None:
        return list(ZOO.values())
    tags = [tags] if isinstance(tags, str) else list(tags)
    unknown = sorted(set(tags) - set(TAGS))
    if unknown:
        raise ValueError(f"unknown tags {unknown}; expected tags from {sorted(TAGS)}.")
    return [s for s in ZOO.values() if set(tags) <= set(s.tags)]


def get_system(name):
    """The zoo's system called ``name``.

    Examples
    --------
    >>> get_system("van_der_pol").equations
    ("y'' = (1 - y^2) y' - y + u",)
    """
    try:
        return ZOO[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown system {name!r}; expected one of {sorted(ZOO)}.") from None
