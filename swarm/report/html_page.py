"""The pieces every report page shares: Markdown and HTML tables, embedded PNG figures, and one
self-contained page layout (no network: styles inline, figures as data URIs)."""

from __future__ import annotations

import base64
import html

STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:1400px}"
    "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:2px 8px;"
    "font-size:13px;text-align:left}img{max-width:100%}"
)


def md_table(rows: list[list[str]], header: bool = True) -> str:
    """A Markdown table; without a header row, an empty one (Markdown needs one)."""
    if not header:
        rows = [[""] * len(rows[0]), *rows]
    out = ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    out += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    return "\n".join(out)


def html_table(rows: list[list[str]], header: bool = True) -> str:
    body = rows[1:] if header else rows
    head = "<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in rows[0]) + "</tr>" if header else ""
    cells = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in body)
    return f"<table>{head}{cells}</table>"


def html_figure(heading: str, png: bytes) -> str:
    """A section with a PNG embedded as a data URI."""
    alt = html.escape(heading)
    data = base64.b64encode(png).decode("ascii")
    return f"<h2>{alt}</h2><img alt='{alt}' src='data:image/png;base64,{data}'>"


def html_page(title: str, body: list[str]) -> str:
    """One self-contained page."""
    return (
        "<!DOCTYPE html>\n<html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
        + "".join(body)
        + "</body></html>\n"
    )
