"""Model equations as MathML (rendered by the browser itself: no script, no network)."""

import re

from ._html import esc

_TOKEN = re.compile(r"\s*(?:(?P<num>\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z_0-9]*'*)"
                    r"|(?P<op><=|>=|[-+=()\[\]|,<>^*/±]))")
_FUNCTIONS = {"sign", "abs", "sin", "cos", "tan", "tanh", "exp", "log", "clip", "step", "sat"}
_OPS = {"-": "\u2212", "<=": "\u2264", ">=": "\u2265", "*": "\u22c5", "±": "\u00b1"}
_DOTS = {1: "\u02d9", 2: "\u00a8"}  # a dot above per derivative; higher ones as primes


def _name(token):
    """``y0'`` as a dotted ``y`` with subscript 0; ``sqrt``-like function names upright; ``inf`` as infinity."""
    primes = len(token) - len(token.rstrip("'"))
    base = token.rstrip("'")
    if base == "inf":
        return "<mi>\u221e</mi>"
    if base in _FUNCTIONS:
        return f'<mi mathvariant="normal">{esc(base)}</mi>'
    m = re.fullmatch(r"([A-Za-z_]+?)_?(\d+)", base)
    letters, index = (m.group(1), m.group(2)) if m else (base, None)
    core = f"<mi>{esc(letters)}</mi>" if len(letters) == 1 else f'<mi mathvariant="normal">{esc(letters)}</mi>'
    if primes and primes in _DOTS and len(letters) == 1:
        core = f"<mover>{core}<mo>{_DOTS[primes]}</mo></mover>"  # not an accent: Chromium draws it into the y
    elif primes:
        core = f"<msup>{core}<mo>{chr(0x2032) * primes}</mo></msup>"
    return f"<msub>{core}<mn>{index}</mn></msub>" if index is not None else core


def _parse(tokens, i, stop=None):
    """MathML of ``tokens[i:]`` up to the closing ``stop``; returns ``(items, next index)``."""
    items = []
    while i < len(tokens):
        kind, text = tokens[i]
        if stop is not None and kind == "op" and text == stop:
            return items, i + 1
        if kind == "name" and text == "sqrt" and i + 1 < len(tokens) and tokens[i + 1] == ("op", "("):
            inner, i = _parse(tokens, i + 2, ")")
            items.append(f"<msqrt>{''.join(inner)}</msqrt>")
            continue
        if kind == "op" and text == "^" and items and i + 1 < len(tokens):
            exponent = tokens[i + 1]
            if exponent == ("op", "("):
                inner, i = _parse(tokens, i + 2, ")")
                sup = f"<mrow>{''.join(inner)}</mrow>"
            else:
                sup, i = (f"<mn>{esc(exponent[1])}</mn>" if exponent[0] == "num" else _name(exponent[1])), i + 2
            items[-1] = f"<msup>{items[-1]}{sup}</msup>"
            continue
        if kind == "num":
            items.append(f"<mn>{esc(text)}</mn>")
        elif kind == "name":
            items.append(_name(text))
        else:
            fence = ' stretchy="false"' if text in "()[]|" else ""
            items.append(f"<mo{fence}>{esc(_OPS.get(text, text))}</mo>")
        i += 1
    return items, i


def is_equation(line):
    """True for a line ``lhs = rhs`` of terms; False for a text line (a latent state's gauge, a fixed row)."""
    return " = " in line and ":" not in line and "(fixed" not in line


def equation_mathml(line):
    """One equation line (as ``equations()`` writes it) as a ``<math>`` element.

    Examples
    --------
    >>> m = equation_mathml("y0' = -2.00 y0 + sqrt(y0)")
    >>> m.startswith('<math display="block"><msub><mover><mi>y'), m.count("<msqrt>"), "<mn>2.00</mn>" in m
    (True, 1, True)
    """
    tokens, pos = [], 0
    while pos < len(line):
        m = _TOKEN.match(line, pos)
        if m is None or m.end() == pos:
            if line[pos:].strip() == "":
                break
            tokens.append(("op", line[pos]))  # an unknown character stays as an operator
            pos += 1
            continue
        kind = m.lastgroup
        tokens.append((kind, m.group(kind)))
        pos = m.end()
    items, _ = _parse(tokens, 0)
    return f'<math display="block">{"".join(items)}</math>'


def split_terms(rhs, per_line=5):
    """``rhs`` cut before a top-level ``+`` or ``-`` into pieces of at most ``per_line`` terms (MathML does not wrap).

    Examples
    --------
    >>> split_terms("1.0 - 2.0 y0 + 3.0 (y0 - u0) + 4.0 u0", per_line=2)
    ['1.0 - 2.0 y0', '+ 3.0 (y0 - u0) + 4.0 u0']
    """
    cuts, depth = [], 0
    for i, ch in enumerate(rhs):
        depth += (ch in "([") - (ch in ")]")
        if depth == 0 and ch in "+-" and rhs[i - 1:i] == " " and rhs[i + 1:i + 2] == " ":
            cuts.append(i)
    cuts = cuts[per_line - 1::per_line]
    return [rhs[a:b].strip() for a, b in zip([0] + cuts, cuts + [len(rhs)])]


def equations_html(lines, per_line=5):
    """The equation lines as MathML (text lines as text), each with its plain text beneath for copying.

    A long equation is typeset over several lines of ``per_line`` terms, the
    continuation lines indented.
    """
    out = ['<div class="eq">']
    for line in lines:
        if not is_equation(line):
            out.append(f"<p>{esc(line)}</p>")
            continue
        lhs, rhs = line.split(" = ", 1)
        pieces = split_terms(rhs, per_line)
        inline = lambda text: equation_mathml(text).replace(' display="block"', "", 1)  # noqa: E731 (left-aligned)
        out.append(f'<div class="eqline">{inline(f"{lhs} = {pieces[0]}")}</div>')
        out += [f'<div class="eqline cont">{inline(p)}</div>' for p in pieces[1:]]
    out.append("</div><details><summary class=note>as text</summary><pre class=eqtext>")
    out.append(esc("\n".join(lines)))
    out.append("</pre></details>")
    return "".join(out)
