"""A deterministic grid over a search space: the same points at every seed.

:func:`grid_points` spreads ``n`` points over a space: real dimensions at the
centres of equal cells of their own scale (linear, log, or the prior's
quantile), integers rounded from those centres without repeats, every choice
of a categorical dimension. :func:`~sindybench.search.minimize` evaluates them
with ``sampler="grid"`` instead of TPE trials.
"""

import math

import numpy as np

from ._space import Categorical, IntRange, LogUniform, Uniform

__all__ = ["grid_points"]


def _axis(dim, m):
    """The grid values of one dimension with ``m`` cells (categorical: every choice)."""
    if isinstance(dim, Categorical):
        return list(dim.choices)
    centres = (np.arange(m) + 0.5) / m
    if isinstance(dim, IntRange):
        unit = LogUniform(dim.low, dim.high) if dim.log else Uniform(dim.low, dim.high)
        values = [int(dim.low + dim.step * round((unit.from_unit(z) - dim.low) / dim.step)) for z in centres]
        return sorted({min(v, int(dim.high)) for v in values})
    if not hasattr(dim, "from_unit"):
        raise ValueError(f"a grid needs dimensions of sindybench.search (Uniform, LogUniform, IntRange, Categorical, "
                         f"Normal, LogNormal); got {dim!r}.")
    return [dim.from_unit(float(z)) for z in centres]


def grid_points(space, n):
    """At most ``n`` points of ``space`` on a grid, the same at every call: a list of ``{name: value}``.

    Each real or integer dimension gets ``m`` cells, with ``m`` the largest
    integer such that ``m ** n_axes`` times the number of choice combinations
    is at most ``n`` (at least 1); the points are the product of the axes in
    the order of ``space`` (truncated to ``n`` when the choices alone are more).

    Parameters
    ----------
    space : dict
        ``{name: dimension}`` of :mod:`sindybench.search` dimensions.
    n : int
        The most points.

    Returns
    -------
    list of dict

    Examples
    --------
    >>> from sindybench.search import LogUniform
    >>> [round(p["tau"], 3) for p in grid_points({"tau": LogUniform(1.0, 1000.0)}, 3)]
    [3.162, 31.623, 316.228]
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be at least 1; got {n!r}.")
    names = list(space)
    choices = math.prod(len(d.choices) for d in space.values() if isinstance(d, Categorical))
    n_axes = sum(not isinstance(d, Categorical) for d in space.values())
    m = max(1, int(np.floor((n / choices) ** (1.0 / n_axes) + 1e-9))) if n_axes else 1
    axes = [_axis(space[k], m) for k in names]
    points = [{}]
    for name, axis in zip(names, axes):
        points = [{**p, name: v} for p in points for v in axis]
    return points[:n]
