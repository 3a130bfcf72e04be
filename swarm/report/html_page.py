"""The pieces every report page shares: Markdown and HTML tables, embedded PNG figures, and one
self-contained page layout (no network, no JavaScript: styles inline, figures as data URIs) that
reads on a laptop and on a phone (viewport meta, images that shrink, tables that scroll sideways)."""

from __future__ import annotations

import base64
import html
import re
import struct

STYLE = (
    "*{box-sizing:border-box}"
    "html{-webkit-text-size-adjust:100%;text-size-adjust:100%}"
    "body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,Helvetica,Arial,sans-serif;"
    "font-size:16px;line-height:1.45;color:#1a1a1a;background:#fff;margin:0 auto;"
    "padding:1rem 1.25rem 3rem;max-width:1200px}"
    "h1{font-size:1.55rem;line-height:1.25;margin:.4em 0 .6em}"
    "h2{font-size:1.2rem;margin:1.8em 0 .5em;padding-bottom:.2em;border-bottom:1px solid #ddd}"
    ".verdict{font-size:1.15rem;font-weight:bold;margin:1em 0;padding:.6em .9em;border-left:6px solid #888;"
    "background:#f3f3f3;color:#222}"
    ".verdict.met{border-color:#009E73;background:#e6f5ef;color:#00573f}"
    ".verdict.not-met{border-color:#D55E00;background:#fbece3;color:#8a3300}"
    ".table-wrap{overflow-x:auto;-webkit-overflow-scrolling:touch;margin:.6em 0 1em;max-width:100%}"
    "table{border-collapse:collapse;font-size:14px}"
    "td,th{border:1px solid #ccc;padding:4px 9px;text-align:left;vertical-align:top}"
    "th{background:#f2f2f2}"
    "td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}"
    ".short{white-space:nowrap}.long{min-width:14em}"
    "figure{margin:.8em 0 1.6em}"
    "img{display:block;max-width:100%;height:auto;border:1px solid #eee}"
    "figcaption{font-size:.9rem;color:#444;margin-top:.35em}"
    "p.note{color:#444}"
    "footer{margin-top:3em;font-size:.85rem;color:#555}"
    "@media (max-width:640px){body{padding:.6rem .7rem 2rem}h1{font-size:1.3rem}h2{font-size:1.1rem}"
    "table{font-size:13px}td,th{padding:3px 6px}.verdict{font-size:1.05rem}"
    # on a phone a figure keeps a readable size and scrolls sideways, like the tables
    "figure{overflow-x:auto;-webkit-overflow-scrolling:touch}figure img{max-width:none;width:720px}}"
)

#: A cell that is one number, maybe signed, with a short unit ("12", "-3.5 dB", "87.2%", "6225 s"):
#: right-aligned in columns of numbers.
_NUMBER = re.compile(r"^[-+−]?\d[\d,]*(\.\d+)?(e[-+]?\d+)?\s?(%|s|m|min|dB|deg)?$")


#: Cells up to this many characters do not wrap.
SHORT_CELL = 24


def md_cell(text: str) -> str:
    """A cell's text safe inside a Markdown table (pipes escaped, no line breaks)."""
    return text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")


def md_table(rows: list[list[str]], header: bool = True) -> str:
    """A Markdown table; without a header row, an empty one (Markdown needs one)."""
    if not header:
        rows = [[""] * len(rows[0]), *rows]
    out = ["| " + " | ".join(md_cell(c) for c in rows[0]) + " |", "|" + "---|" * len(rows[0])]
    out += ["| " + " | ".join(md_cell(c) for c in r) + " |" for r in rows[1:]]
    return "\n".join(out)


def _is_number(text: str) -> bool:
    return bool(_NUMBER.match(text.strip()))


def html_table(rows: list[list[str]], header: bool = True) -> str:
    """An HTML table in a wrapper that scrolls sideways on narrow screens; in a table with a header
    row, cells that are plain numbers are right-aligned."""
    body = rows[1:] if header else rows

    def cell(tag: str, text: str) -> str:
        # short cells stay on one line (the wrapper scrolls); long text wraps, but not to a sliver
        if header and tag == "td" and _is_number(text):
            cls = " class='num'"
        else:
            cls = " class='short'" if len(text) <= SHORT_CELL else " class='long'"
        return f"<{tag}{cls}>{html.escape(text)}</{tag}>"

    head = "<tr>" + "".join(cell("th", c) for c in rows[0]) + "</tr>" if header else ""
    cells = "".join("<tr>" + "".join(cell("td", c) for c in r) + "</tr>" for r in body)
    return f"<div class='table-wrap'><table>{head}{cells}</table></div>"


def png_size(png: bytes) -> tuple[int, int]:
    """Width and height of a PNG from its header (0, 0 if it is not one)."""
    if len(png) < 24 or png[:8] != b"\x89PNG\r\n\x1a\n":
        return 0, 0
    return struct.unpack(">II", png[16:24])


def html_figure(heading: str, png: bytes, alt: str | None = None, caption: str = "") -> str:
    """A section with a PNG embedded as a data URI (with its size, so the page does not jump)."""
    data = base64.b64encode(png).decode("ascii")
    w, h = png_size(png)
    size = f" width='{w}' height='{h}'" if w and h else ""
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return (
        f"<h2>{html.escape(heading)}</h2><figure><img alt='{html.escape(alt or heading, quote=True)}'"
        f"{size} src='data:image/png;base64,{data}'>{cap}</figure>"
    )


def html_page(title: str, body: list[str]) -> str:
    """One self-contained page."""
    return (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
        + "".join(body)
        + "</body></html>\n"
    )
