"""Readable model equations, shared by every estimator's ``equations()``."""

from ._validation import check_integer

__all__ = ["format_coef", "format_equation"]

# Magnitude from which coefficients switch from fixed-point to exponent notation.
LARGE = 1e6


def format_coef(c, precision=3):
    """Magnitude of ``c`` as text: ``precision`` decimals, or significant digits if unreadable.

    Fixed-point is unreadable for a small coefficient that it would show
    with fewer than two significant digits (``|c| < min(0.1, 10**(1 - precision))``)
    and for ``|c| >= 1e6``; such coefficients use ``%.{precision}g``.

    Examples
    --------
    >>> format_coef(-4.8216), format_coef(0.0052341), format_coef(2.5e7), format_coef(3e-9, 2)
    ('4.822', '0.00523', '2.5e+07', '3e-09')
    """
    a = abs(float(c))
    if a != 0 and (a < min(0.1, 10.0 ** (1 - precision)) or a >= LARGE):
        return f"{a:.{max(precision, 1)}g}"
    return f"{a:.{precision}f}"


def format_equation(name, coef, features, *, precision=3):
    """One equation ``name' = a + b x - c y``, skipping zero coefficients.

    Parameters
    ----------
    name : str
        The differentiated variable (``'`` is appended).
    coef : sequence of float
        One coefficient per feature.
    features : sequence of str
        Feature names; the feature ``"1"`` (the constant) shows as its number.
    precision : int, default=3
        Decimals of the coefficients (see :func:`format_coef`).

    Returns
    -------
    str
        ``name' = 0`` when every coefficient is zero.

    Examples
    --------
    >>> format_equation("y0", [0.0, -4.8216, 0.74, 1.7421], ["1", "y0", "y0 u0", "u0^2"])
    "y0' = -4.822 y0 + 0.740 y0 u0 + 1.742 u0^2"
    >>> format_equation("y", [2.0, -0.5], ["1", "y"], precision=1)
    "y' = 2.0 - 0.5 y"
    >>> format_equation("y", [0.0], ["y"])
    "y' = 0"
    """
    precision = check_integer(precision, "precision", low=0)
    parts = []
    for c, feature in zip(coef, features):
        if c == 0:
            continue
        text = format_coef(c, precision)
        if parts:
            text = f"- {text}" if c < 0 else f"+ {text}"
        elif c < 0:
            text = f"-{text}"
        parts.append(text if feature == "1" else f"{text} {feature}")
    return f"{name}' = " + (" ".join(parts) if parts else "0")
