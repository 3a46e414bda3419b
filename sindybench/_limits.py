"""What an argument or a model file may ask for, and how a message quotes what it was given.

A small file or argument must not make the package hang or allocate without
bound: :func:`check_size` bounds the product of the sizes something asks for
(not each one alone), :func:`check_memory` an array before it is allocated,
both with a clear ``ValueError`` naming every factor. :func:`shown` cuts a
quoted value to a readable length, so no message echoes megabytes.
"""

import math

__all__ = ["MAX_BYTES", "check_memory", "check_size", "shown"]

#: The most memory that one argument or one model file may make the package allocate (else a clear error).
MAX_BYTES = 2**30

#: The longest quotation of a given value in a message (characters of its repr).
MAX_SHOWN = 120


def shown(value, limit=MAX_SHOWN):
    """``repr(value)`` for a message, cut to ``limit`` characters.

    Every message that quotes what it was given goes through here, so that a
    value of megabytes (a class name, a list) is not echoed whole.

    Examples
    --------
    >>> shown("tanks")
    "'tanks'"
    >>> shown("x" * 10**7, limit=20)
    "'xxxxxxxxxxxxxxxxxxx... (10,000,002 characters)"
    """
    if isinstance(value, str) and len(value) > limit:  # repr of the start only: a 1 GB string stays cheap
        text = repr(value[:limit])
        total = len(text) + len(value) - limit
    else:
        text = repr(value)
        total = len(text)
    return text if total <= limit else f"{text[:limit]}... ({total:,} characters)"


def check_size(what, factors, *, limit, unit, advice=""):
    """Refuse, before any work, what asks for more than ``limit`` units in all: the product of ``factors``.

    A limit on each setting alone lets a small file or argument ask for their
    product (a grid per hidden state, sub-steps per sample of a window); this
    check bounds the product, and names every factor.

    Parameters
    ----------
    what : str
        What asks for it (an estimator and its settings, a file's field).
    factors : dict
        ``{description: count}``, multiplied together.
    limit : int
    unit : str
        What the product counts ("bytes", "integration steps").
    advice : str, optional
        A sentence on what to change, appended to the message.

    Examples
    --------
    >>> check_size("the grid", {"grid points per hidden state": 100, "hidden states": 1}, limit=10**4, unit="points")
    >>> check_size("the initial-state grid", {"grid points": 10**4, "samples": 200, "sub-steps": 1000},
    ...            limit=10**8, unit="integration steps")
    Traceback (most recent call last):
    ...
    ValueError: the initial-state grid asks for 10,000 grid points x 200 samples x 1,000 sub-steps = 2e+09 integration steps; expected at most 1e+08.
    """
    total = math.prod(int(v) for v in factors.values())
    if total > limit:
        product = " x ".join(f"{int(v):,} {k}" for k, v in factors.items())
        raise ValueError(f"{what} asks for {product} = {total:.3g} {unit}; expected at most {limit:.3g}."
                         + (f" {advice}" if advice else ""))


def check_memory(what, shape, *, itemsize=8, advice=""):
    """Refuse, before allocating, an array of ``shape`` (``itemsize`` bytes each) past :data:`MAX_BYTES` (1 GiB).

    Examples
    --------
    >>> check_memory("the bootstrap records", (50, 400, 1))
    >>> check_memory("the bootstrap records", (10**6, 400, 1))
    Traceback (most recent call last):
    ...
    ValueError: the bootstrap records would take 1,000,000 x 400 x 1 values of 8 bytes = 3.2 GB; expected at most 1.07 GB (1 GiB).
    """
    total = math.prod(int(s) for s in shape) * itemsize
    if total > MAX_BYTES:
        dims = " x ".join(f"{int(s):,}" for s in shape)
        raise ValueError(f"{what} would take {dims} values of {itemsize} bytes = {total / 1e9:.3g} GB; expected at "
                         f"most {MAX_BYTES / 1e9:.3g} GB (1 GiB)." + (f" {advice}" if advice else ""))
