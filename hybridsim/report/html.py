"""Self-contained HTML pages: one style, tables of numbers, figures embedded as PNG.

Both HTML reports - the stability report (:mod:`hybridsim.report.stability`) and
the report of ``hybridsim reproduce`` - are written with these, so they look alike
and open anywhere without their folder (every figure is inside the page).
"""
import base64
import html
import io

STYLE = ("body{font-family:sans-serif;max-width:%(width)dpx;margin:2em auto;color:#222}"
         "table{border-collapse:collapse;margin:1em 0}"
         "td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px;vertical-align:top}th{background:#f0f0f0}"
         "figure{display:inline-block;margin:0.4em;max-width:%(figure)s}img{max-width:100%%}"
         "figcaption{font-size:12px;color:#555}")


def escape(text):
    """``text`` (any value) as HTML text."""
    return html.escape(str(text))


def fmt(v):
    """A cell's text: 4 significant digits, yes/no, '–' for None."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def table(rows, cols, head=None):
    """An HTML table of ``rows`` (dicts) with columns ``cols`` (their keys), cells by :func:`fmt`.

    Parameters
    ----------
    rows : list of dict
    cols : list of str
        The keys shown, in order.
    head : list of str, optional
        The column titles (default: the keys).
    """
    top = "".join(f"<th>{escape(c)}</th>" for c in (head or cols))
    body = "".join("<tr>" + "".join(f"<td>{escape(fmt(r.get(c)))}</td>" for c in cols) + "</tr>" for r in rows)
    return f"<table><tr>{top}</tr>{body}</table>"


def png_base64(fig, dpi=110):
    """A matplotlib figure as base64 PNG text."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return base64.b64encode(buf.getvalue()).decode()


def file_base64(path):
    """A PNG file as base64 text."""
    with open(path, "rb") as fh:
        return base64.b64encode(fh.read()).decode()


def figure(png, caption):
    """An embedded figure: ``png`` base64 PNG text (:func:`png_base64`), ``caption`` plain text."""
    return f"<figure><img src='data:image/png;base64,{png}'/><figcaption>{escape(caption)}</figcaption></figure>"


def page(title, body, width=1100, figure_width="100%"):
    """A whole page: ``title`` (plain text) and ``body`` (HTML) with the reports' style.

    ``figure_width``: the CSS width limit of a figure (``"48%"`` puts two side by side).
    """
    style = STYLE % {"width": width, "figure": figure_width}
    return (f'<!DOCTYPE html><html><head><meta charset="utf-8">\n<title>{escape(title)}</title>\n'
            f"<style>{style}</style></head><body>\n{body}\n</body></html>\n")
