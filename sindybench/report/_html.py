"""The page: one self-contained HTML file (inline CSS, a few lines of JS to sort tables, figures as base64 PNG)."""

import base64
import html
import io
import math
import numbers
import os
import tempfile
from pathlib import Path

import numpy as np

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;color:#1a1a1a;background:#fafafa}
main{max-width:1200px;margin:0 auto;padding:1rem 2rem 4rem}
header{background:#22313f;color:#fff;padding:1rem 2rem}
header h1{margin:0;font-size:1.5rem}header p{margin:.3rem 0 0;color:#cfd8e0}
nav{font-size:.9rem;margin:.5rem 0 1rem}nav a{margin-right:1rem}
h2{border-bottom:2px solid #22313f;padding-bottom:.2rem;margin-top:2.2rem}
h3{margin-top:1.4rem}
table{border-collapse:collapse;font-size:.85rem;margin:.5rem 0;background:#fff}
th,td{border:1px solid #d0d7de;padding:.25rem .5rem;text-align:left;vertical-align:top}
th{background:#eef2f5}td.num{text-align:right;font-variant-numeric:tabular-nums}
table.sortable th{cursor:pointer;user-select:none}table.sortable th:after{content:" \\2195";color:#8a99a8}
tr.chosen td{background:#fff4d6;font-weight:600}tr.failed td{color:#8a3b3b}
.cards{display:flex;flex-wrap:wrap;gap:.8rem;margin:1rem 0}
.card{background:#fff;border:1px solid #d0d7de;border-radius:6px;padding:.6rem 1rem;min-width:10rem}
.card b{display:block;font-size:1.4rem}.card span{font-size:.8rem;color:#555}
.eq{background:#fff;border:1px solid #d0d7de;border-radius:6px;padding:.6rem 1rem;font-size:1.15rem;overflow-x:auto}
.eqline{margin:.3rem 0}.eqline.cont{margin-top:-.1rem;padding-left:4rem}.eqtext{font-size:.8rem;color:#555}
.warn{background:#fff4e5;border-left:4px solid #e8a33d;padding:.5rem 1rem;margin:.5rem 0}
.note{color:#555;font-size:.9rem}
figure{margin:1rem 0;background:#fff;border:1px solid #d0d7de;border-radius:6px;padding:.5rem}
figure img{max-width:100%;height:auto;display:block}figcaption{font-size:.85rem;color:#444;margin-top:.3rem}
.scroll{max-height:32rem;overflow:auto}
code{font-size:.85rem}
"""

# sort a table by the clicked column: numbers as numbers, the rest as text; a second click reverses
_JS = """
document.querySelectorAll("table.sortable").forEach(function (table) {
  table.querySelectorAll("th").forEach(function (th, col) {
    th.addEventListener("click", function () {
      var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
      var dir = th.dataset.dir === "asc" ? -1 : 1;
      th.dataset.dir = dir === 1 ? "asc" : "desc";
      rows.sort(function (a, b) {
        var x = a.cells[col].dataset.v || a.cells[col].textContent;
        var y = b.cells[col].dataset.v || b.cells[col].textContent;
        var p = parseFloat(x), q = parseFloat(y);
        if (!isNaN(p) && !isNaN(q)) return dir * (p - q);
        if (!isNaN(p)) return -dir;
        if (!isNaN(q)) return dir;
        return dir * x.localeCompare(y);
      });
      rows.forEach(function (r) { body.appendChild(r); });
    });
  });
});
"""


def esc(text):
    """``text`` escaped for HTML."""
    return html.escape(str(text), quote=True)


def fmt(value, digits=4):
    """A cell's text: numbers to ``digits`` significant digits, None as an empty cell."""
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        if math.isnan(v):
            return ""
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else f"{v:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(fmt(v, digits) for v in value)
    return str(value)


def table(headers, rows, *, sortable=False, row_classes=None, raw=()):
    """An HTML table; cells are escaped except the columns named in ``raw`` (already HTML)."""
    out = [f'<table{" class=sortable" if sortable else ""}><thead><tr>']
    out += [f"<th>{esc(h)}</th>" for h in headers]
    out.append("</tr></thead><tbody>")
    for k, row in enumerate(rows):
        cls = (row_classes or {}).get(k)
        out.append(f'<tr class="{cls}">' if cls else "<tr>")
        for h, v in zip(headers, row):
            num = isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))
            sort_key = f' data-v="{float(v)!r}"' if num and math.isfinite(float(v)) else ""
            text = str(v) if h in raw else esc(fmt(v))
            out.append(f'<td class="num"{sort_key}>{text}</td>' if num else f"<td>{text}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def key_values(pairs):
    """A two-column table of ``(name, value)`` pairs."""
    return table(["", ""], list(pairs)).replace("<thead><tr><th></th><th></th></tr></thead>", "")


def figure(fig, caption, *, dpi=80):
    """``fig`` (a matplotlib figure, or PNG bytes already drawn) as an ``<img>`` of an inline base64 PNG, captioned."""
    if isinstance(fig, bytes):
        png = fig
    else:
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=dpi)
        png = buffer.getvalue()
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img alt="{esc(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def new_figure(nrows=1, *, figsize, height_ratios=None, sharex=False):
    """A figure outside pyplot (no global state) and its list of stacked Axes."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    kw = {"height_ratios": height_ratios} if height_ratios else {}
    axes = fig.subplots(nrows, 1, squeeze=False, sharex=sharex, gridspec_kw=kw)[:, 0]
    return fig, list(axes)


def page(title, subtitle, sections):
    """The whole page: a header, a table of contents and the ``(id, heading, body HTML)`` sections."""
    nav = " ".join(f'<a href="#{esc(i)}">{esc(h)}</a>' for i, h, _ in sections)
    body = "".join(f'<section id="{esc(i)}"><h2>{esc(h)}</h2>{b}</section>' for i, h, b in sections)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{esc(title)}</title><style>{_CSS}</style></head><body>"
            f"<header><h1>{esc(title)}</h1><p>{esc(subtitle)}</p></header>"
            f"<main><nav>{nav}</nav>{body}</main><script>{_JS}</script></body></html>\n")


def write_text_atomic(path, text):
    """Write ``text`` to ``path`` through a temporary file in the same folder, renamed into place at the end."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"path {path} is a folder; expected the path of the HTML file to write.")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"path {path}: the folder {path.parent} does not exist; expected an existing folder.")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
