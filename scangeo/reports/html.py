"""A self-contained HTML document: tables, figures embedded as base64 PNG, no external resources.

Every table sits in its own box (``div.scroll``): it fits the page (its headings wrap), or it scrolls
sideways inside that box, whose edge then shows a shadow where more of the table lies; the page itself
never scrolls sideways (tests/reports/test_report_layout.py checks it in a browser at 800 and 1400 px).
"""
from __future__ import annotations

import base64
import html
import re
from dataclasses import dataclass, field

STYLE = """
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; margin: 2em auto; max-width: 1200px;
       padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.05em; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.8em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; white-space: nowrap; }
th { background: #f2f2f2; white-space: normal; vertical-align: bottom; }
td:first-child, th:first-child { text-align: left; }
td.text { text-align: left; white-space: normal; } td.wide { min-width: 22em; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
.scroll { overflow-x: auto; max-width: 100%;
          background: linear-gradient(to right, #fff 30%, #fff0) left / 3em 100% no-repeat local,
                      linear-gradient(to left, #fff 30%, #fff0) right / 3em 100% no-repeat local,
                      radial-gradient(farthest-side at 0 50%, #0003, #0000) left / 1em 100% no-repeat scroll,
                      radial-gradient(farthest-side at 100% 50%, #0003, #0000) right / 1em 100% no-repeat scroll; }
.note { font-size: 0.9em; color: #444; } .warn { color: #a33; }
"""


def esc(text) -> str:
    return html.escape(str(text), quote=True)


def _cell(text) -> str:
    """A cell's text, escaped; the tables' Markdown emphasis (``**yes**``, shared with comparison.md) in bold."""
    return re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", esc(text))


def table(head: list[str], rows: list[list[str]], table_id: str | None = None, text_columns=(),
          wide_columns=()) -> str:
    """An HTML table in its own box (module docstring); columns in ``text_columns`` are left-aligned, those
    in ``wide_columns`` wrap wide."""
    attr = f' id="{esc(table_id)}"' if table_id else ""
    out = [f'<div class="scroll"><table{attr}>',
           "<thead><tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr></thead><tbody>"]
    for r in rows:
        cells = "".join(f'<td class="text{" wide" if i in wide_columns else ""}">{_cell(c)}</td>'
                        if i in text_columns else f"<td>{_cell(c)}</td>" for i, c in enumerate(r))
        out.append(f"<tr>{cells}</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def figure(png: bytes, caption: str, fig_id: str) -> str:
    """A figure with its PNG embedded as a data URI."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure id="{esc(fig_id)}"><img class="report-figure" alt="{esc(caption)}" '
            f'src="data:image/png;base64,{data}"><figcaption>{esc(caption)}</figcaption></figure>')


def paragraph(text: str, cls: str = "note") -> str:
    return f'<p class="{cls}">{esc(text)}</p>'


def bullet_list(items: list[str]) -> str:
    return "<ul>" + "".join(f"<li>{esc(i)}</li>" for i in items) + "</ul>" if items else ""


@dataclass
class Section:
    """A titled part of the document; ``parts`` are HTML fragments made by the functions above."""

    title: str
    section_id: str
    parts: list[str] = field(default_factory=list)


def document(title: str, intro: list[str], sections: list[Section]) -> str:
    """The whole HTML page."""
    toc = "".join(f'<li><a href="#{esc(s.section_id)}">{esc(s.title)}</a></li>' for s in sections)
    body = [f"<h1>{esc(title)}</h1>", *intro, f"<nav><ol>{toc}</ol></nav>"]
    for s in sections:
        body.append(f'<section id="{esc(s.section_id)}"><h2>{esc(s.title)}</h2>')
        body.extend(s.parts)
        body.append("</section>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>\n" + "\n".join(body)
            + "\n</body></html>\n")


__all__ = ["Section", "bullet_list", "document", "esc", "figure", "paragraph", "table"]
