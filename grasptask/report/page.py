"""The report's content as plain data (sections of figures, tables and notes) and its one-file HTML form, with
every image embedded so the page can be mailed."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd


@dataclass(frozen=True)
class Figure:
    file: Path  # the PNG, already written
    caption: str


@dataclass(frozen=True)
class Table:
    name: str  # tables/<name>.md
    caption: str
    frame: pd.DataFrame


@dataclass(frozen=True)
class Note:
    text: str


@dataclass
class Section:
    key: str
    title: str
    intro: str = ""
    blocks: list = field(default_factory=list)
    summary: str = ""  # one line for the top of the page

    @property
    def made(self) -> bool:
        return any(isinstance(b, (Figure, Table)) for b in self.blocks)

    @property
    def notes(self) -> list[str]:
        return [b.text for b in self.blocks if isinstance(b, Note)]


STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 0 auto;
       max-width: 1180px; padding: 1.5em 2em 4em; color: #222; line-height: 1.45; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
nav ul { columns: 2; } .meta { color: #555; }
.summary { background: #f4f6fa; border-left: 4px solid #1f77b4; padding: 0.6em 1em; }
.note { background: #fff6e0; border-left: 4px solid #e0a000; padding: 0.5em 1em; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { color: #444; font-size: 0.92em; margin-top: 0.3em; }
table { border-collapse: collapse; font-size: 0.86em; margin: 0.4em 0 0.2em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
.caption { font-weight: 600; margin-top: 1.2em; }
"""


def markdown(table: Table) -> str:
    return f"**{table.caption}**\n\n{table.frame.to_markdown(index=False, floatfmt='.3g')}\n"


def _image(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img src="data:image/png;base64,{data}" alt="{html.escape(path.stem)}">'


def _block(block) -> str:
    if isinstance(block, Figure):
        return f"<figure>{_image(block.file)}<figcaption>{html.escape(block.caption)}</figcaption></figure>"
    if isinstance(block, Table):
        body = block.frame.to_html(index=False, na_rep="-", border=0, float_format=lambda v: f"{v:.4g}")
        return f'<p class="caption">{html.escape(block.caption)}</p>{body}'
    if isinstance(block, Note):
        return f'<p class="note">{html.escape(block.text)}</p>'
    raise TypeError(f"not a report block: {block!r}")


def render_html(title: str, meta: str, summary: list[str], sections: list[Section]) -> str:
    toc = "".join(f'<li><a href="#{s.key}">{html.escape(s.title)}</a></li>' for s in sections)
    items = "".join(f"<li>{html.escape(line)}</li>" for line in summary)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>",
        f'<h1>{html.escape(title)}</h1><p class="meta">{html.escape(meta)}</p>',
        f'<div class="summary"><ul>{items}</ul></div>',
        f"<nav><ul>{toc}</ul></nav>",
    ]
    for section in sections:
        parts.append(f'<section id="{section.key}"><h2>{html.escape(section.title)}</h2>')
        if section.intro:
            parts.append(f"<p>{html.escape(section.intro)}</p>")
        parts.extend(_block(b) for b in section.blocks)
        parts.append("</section>")
    parts.append("</body></html>\n")
    return "\n".join(parts)
