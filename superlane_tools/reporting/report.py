"""Run reports: Markdown and a self-contained-looking HTML with the tables and plots."""

from __future__ import annotations

import html
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import pandas as pd

from superlane_tools.reporting.atomic import write_text_atomic


class Section(NamedTuple):
    """One report section: a title, paragraphs / bullets, tables and images.

    Attributes:
        title: Heading.
        lines: Markdown lines (bullets start with ``- ``).
        tables: DataFrames shown as tables.
        images: Image paths relative to the report.
    """

    title: str
    lines: Sequence[str] = ()
    tables: Sequence[pd.DataFrame] = ()
    images: Sequence[str] = ()


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "n/a"
        return f"{value:.3g}" if abs(value) < 1e-2 or abs(value) >= 1e4 else f"{value:.3f}"
    if value is None or value is pd.NA:
        return "n/a"
    return str(value)


def _cell(text: str) -> str:
    """Escape a Markdown table cell: a ``|`` would end the cell, a newline the row."""
    return text.replace("|", "\\|").replace("\n", " ")


def markdown_table(frame: pd.DataFrame) -> str:
    """Return a GitHub-flavoured Markdown table of a DataFrame (floats to 3 significant digits)."""
    cols = [_cell(str(c)) for c in frame.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    lines += [
        "| " + " | ".join(_cell(_fmt(v)) for v in row) + " |"
        for row in frame.itertuples(index=False)
    ]
    return "\n".join(lines)


def latex_table(frame: pd.DataFrame) -> str:
    """Return a LaTeX ``tabular`` of a DataFrame (booktabs rules)."""

    def cell(value: object) -> str:
        text = f"{value:.3g}" if isinstance(value, float) else str(value)
        return text.replace("%", r"\%").replace("_", r"\_").replace("#", r"\#")

    spec = "l" + "r" * (len(frame.columns) - 1)
    lines = [
        rf"\begin{{tabular}}{{{spec}}}",
        r"\toprule",
        " & ".join(cell(c) for c in frame.columns) + r" \\",
        r"\midrule",
    ]
    lines += [" & ".join(cell(v) for v in row) + r" \\" for row in frame.itertuples(index=False)]
    lines += [r"\bottomrule", r"\end{tabular}", ""]
    return "\n".join(lines)


def html_table(frame: pd.DataFrame) -> str:
    """Return an HTML table of a DataFrame."""
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in frame.columns)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in row) + "</tr>"
        for row in frame.itertuples(index=False)
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


_CODE = re.compile(r"`([^`]+)`")
_BOLD = re.compile(r"\*\*([^*]+)\*\*")


def _inline(text: str) -> str:
    """Escape text for HTML; render Markdown inline code as ``<code>``, ``**bold**`` as ``<b>``."""
    return _BOLD.sub(r"<b>\1</b>", _CODE.sub(r"<code>\1</code>", html.escape(text)))


def write_report(
    path: Path,
    title: str,
    sections: Sequence[Section],
    html_too: bool = True,
    preamble: Sequence[str] = (),
) -> list[Path]:
    """Write the Markdown report ``path`` (and the HTML one beside it); return the files.

    The one report writer of the package: ``slt reprocess`` and the batch fleet summary use it.
    ``preamble``: Markdown bullets (``- ...``) under the title, before the first section (e.g.
    the tool version, command line and date).
    """
    md = [f"# {title}", "", *preamble, *([""] if preamble else [])]
    for sec in sections:
        md += [f"## {sec.title}", "", *sec.lines, ""]
        for table in sec.tables:
            md += [markdown_table(table), ""]
        for image in sec.images:
            md += [f"![{Path(image).stem}]({image})", ""]
    paths = [write_text_atomic(path, "\n".join(md))]
    if html_too:
        parts = [
            "<!DOCTYPE html><html><head><meta charset='utf-8'>",
            f"<title>{html.escape(title)}</title><style>body{{font-family:sans-serif;"
            "max-width:1100px;margin:auto}table{border-collapse:collapse;margin:8px 0}"
            "td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}img{max-width:100%}"
            "code{background:#f3f3f3;padding:0 3px;border-radius:3px}"
            "</style></head><body>",
            f"<h1>{html.escape(title)}</h1>",
        ]
        if preamble:
            items = "".join(f"<li>{_inline(ln.removeprefix('- '))}</li>" for ln in preamble)
            parts.append(f"<ul>{items}</ul>")
        for sec in sections:
            parts.append(f"<h2>{html.escape(sec.title)}</h2>")
            bullets = [ln[2:] for ln in sec.lines if ln.startswith("- ")]
            text = [ln for ln in sec.lines if not ln.startswith("- ") and ln]
            parts += [f"<p>{_inline(t)}</p>" for t in text]
            if bullets:
                parts.append("<ul>" + "".join(f"<li>{_inline(b)}</li>" for b in bullets) + "</ul>")
            parts += [html_table(t) for t in sec.tables]
            parts += [f"<img src='{html.escape(i)}' alt='{html.escape(i)}'>" for i in sec.images]
        parts.append("</body></html>")
        paths.append(write_text_atomic(path.with_suffix(".html"), "\n".join(parts)))
    return paths
