"""HTML pieces of the report: the stylesheet, embedded PNG figures, error boxes, numbers."""

from __future__ import annotations

import base64
import html
import io
import traceback

import numpy as np

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1180px;
margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;
margin-top:1.6em}h3{margin-bottom:.3em}
table{border-collapse:collapse;font-size:.88em;margin:.5em 0}
th,td{border:1px solid #ccc;padding:3px 7px;text-align:right}th{background:#f2f2f2}
td.l,th.l{text-align:left}tr.fail td{background:#fde8e8}
.verdict{padding:.7em 1em;border-radius:6px;font-weight:600;margin:.6em 0}
.ok{background:#e5f5e5;border:1px solid #7c7}.bad{background:#fde8e8;border:1px solid #d77}
.warn{background:#fff6dd;border:1px solid #db5;padding:.4em .8em;border-radius:6px;margin:.3em 0}
.err{background:#fde8e8;border:1px solid #d77;padding:.5em;border-radius:6px}
img{max-width:100%;height:auto;display:block;margin:.5em 0;border:1px solid #eee}
.cap{font-size:.88em;color:#555;margin-top:-.2em}pre{background:#f7f7f7;padding:.6em;
overflow:auto;font-size:.8em;max-height:40em}nav a{margin-right:.8em}code{font-size:.9em}
"""


def figure_to_base64(fig, dpi: int = 80) -> str:
    """PNG of a figure as base64 text."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def section_error(title: str, exc: BaseException) -> str:
    tb = "".join(traceback.format_exception_only(type(exc), exc)).strip()
    return (f'<div class="err">Section “{html.escape(title)}” failed: '
            f"<code>{html.escape(tb)}</code></div>")


def _img(fig, dpi: int, alt: str) -> str:
    return (f'<img alt="{html.escape(alt)}" src="data:image/png;base64,'
            f'{figure_to_base64(fig, dpi)}">')


def _fmt(x: float, digits: int = 4) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"
