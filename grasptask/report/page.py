"""The report's content as plain data (sections of figures, tables and notes) and its one-file HTML form, with
every image embedded so the page can be mailed."""

from __future__ import annotations

import base64
import gzip
import html
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import pandas as pd


@dataclass(frozen=True)
class Figure:
    file: Path  # the PNG (or a film's GIF), already written
    caption: str


@dataclass(frozen=True)
class Table:
    name: str  # tables/<name>.md
    caption: str
    frame: pd.DataFrame


@dataclass(frozen=True)
class Note:
    text: str


@dataclass(frozen=True)
class View:
    """An interactive plotly view: its figure as JSON (:func:`grasptask.report.interactive.figure_json`),
    drawn by the page when it scrolls into sight."""

    key: str
    figure: str
    caption: str
    height: int = 560
    shared: dict[str, str] = field(default_factory=dict)  # trace data several views use, by key


@dataclass
class Section:
    key: str
    title: str
    intro: str = ""
    blocks: list = field(default_factory=list)
    summary: str = ""  # one line for the top of the page

    @property
    def made(self) -> bool:
        return any(isinstance(b, (Figure, Table, View)) for b in self.blocks)

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
div.view { border: 1px solid #eee; margin: 1.2em 0 0.3em; }
.view-placeholder { color: #777; padding: 1em; }
@media print { div.view, div.view + figcaption { display: none; } }
"""

#: draws each view when it comes near the viewport and releases it when it leaves: a page of 40 3D views would
#: otherwise hold 40 WebGL contexts, and browsers drop the oldest beyond 16. ``window.grasptaskViews`` tells a
#: test browser what was drawn, how fast, and what failed.
VIEWS_SCRIPT = """
(function () {
  var views = Array.prototype.slice.call(document.querySelectorAll("div.view"));
  var state = window.grasptaskViews;
  function draw(div) {
    if (div.dataset.state) { return; }
    div.dataset.state = "drawing";
    var started = performance.now();
    var figure = JSON.parse(document.getElementById(div.dataset.figure).textContent);
    figure.data.forEach(function (trace) {
      var key = trace.meta && trace.meta.shared;
      if (key) { Object.assign(trace, JSON.parse(document.getElementById("shared-" + key).textContent)); }
      if (trace.meta && trace.meta.spheres) { instance(trace, trace.meta.spheres); }
    });
    div.innerHTML = "";
    Plotly.newPlot(div, figure.data, figure.layout, {responsive: true, displaylogo: false}).then(function () {
      div.dataset.state = "drawn";
      div.dataset.drawMs = String(performance.now() - started);
      state.drawn += 1;
    }, function (error) { state.errors.push(div.id + ": " + error); });
  }
  function instance(trace, spec) {  // one template sphere, placed and scaled at each centre
    var raw = atob(spec.data), bytes = new Uint8Array(raw.length);
    for (var b = 0; b < raw.length; b++) { bytes[b] = raw.charCodeAt(b); }
    var s = new Float32Array(bytes.buffer), tv = spec.vertices, tf = spec.faces;
    var nv = tv.length / 3, nf = tf.length / 3, n = s.length / 4;
    var x = new Float32Array(n * nv), y = new Float32Array(n * nv), z = new Float32Array(n * nv);
    var i = new Int32Array(n * nf), j = new Int32Array(n * nf), k = new Int32Array(n * nf);
    for (var q = 0; q < n; q++) {
      var r = s[4 * q + 3];
      for (var v = 0; v < nv; v++) {
        x[q * nv + v] = s[4 * q] + r * tv[3 * v];
        y[q * nv + v] = s[4 * q + 1] + r * tv[3 * v + 1];
        z[q * nv + v] = s[4 * q + 2] + r * tv[3 * v + 2];
      }
      for (var f = 0; f < nf; f++) {
        i[q * nf + f] = q * nv + tf[3 * f];
        j[q * nf + f] = q * nv + tf[3 * f + 1];
        k[q * nf + f] = q * nv + tf[3 * f + 2];
      }
    }
    Object.assign(trace, {x: x, y: y, z: z, i: i, j: j, k: k});
  }
  function release(div) {
    if (div.dataset.state === "drawn") { Plotly.purge(div); delete div.dataset.state; }
  }
  var observer = new IntersectionObserver(function (entries) {
    entries.forEach(function (entry) {
      if (entry.isIntersecting) { draw(entry.target); } else { release(entry.target); }
    });
  }, {rootMargin: "400px 0px"});
  views.forEach(function (div) { observer.observe(div); });
})();
"""


#: unpacks the page's one copy of plotly.js (gzip, then base64: 2.0 MB in place of 4.8) with the browser's own
#: DecompressionStream, runs it, then the views script: a page stays one file that works offline
LOADER_SCRIPT = """
(function () {
  window.grasptaskViews = {total: document.querySelectorAll("div.view").length, drawn: 0, errors: []};
  var packed = atob(document.getElementById("plotly-gz").textContent.trim());
  var bytes = new Uint8Array(packed.length);
  for (var i = 0; i < packed.length; i++) { bytes[i] = packed.charCodeAt(i); }
  var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  new Response(stream).text().then(function (code) {
    [code, document.getElementById("views-script").textContent].forEach(function (text) {
      var script = document.createElement("script");
      script.textContent = text;
      document.head.appendChild(script);
    });
  }, function (error) { window.grasptaskViews.errors.push("plotly.js: " + error); });
})();
"""


@lru_cache(maxsize=1)
def packed_plotly() -> str:
    """plotly.js, gzipped (without a time stamp: the same bytes every time) and in base64."""
    from plotly.offline import get_plotlyjs  # deferred: plotly's bundle, only when a page has views

    return base64.b64encode(gzip.compress(get_plotlyjs().encode(), compresslevel=9, mtime=0)).decode("ascii")


def markdown(table: Table) -> str:
    return f"**{table.caption}**\n\n{table.frame.to_markdown(index=False, floatfmt='.3g')}\n"


def _image(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    kind = "gif" if path.suffix.lower() == ".gif" else "png"
    return f'<img src="data:image/{kind};base64,{data}" alt="{html.escape(path.stem)}">'


def _block(block) -> str:
    if isinstance(block, Figure):
        return f"<figure>{_image(block.file)}<figcaption>{html.escape(block.caption)}</figcaption></figure>"
    if isinstance(block, Table):
        body = block.frame.to_html(index=False, na_rep="-", border=0, float_format=lambda v: f"{v:.4g}")
        return f'<p class="caption">{html.escape(block.caption)}</p>{body}'
    if isinstance(block, Note):
        return f'<p class="note">{html.escape(block.text)}</p>'
    if isinstance(block, View):
        return (
            f'<div class="view" id="{block.key}" data-figure="{block.key}-data" style="height:{block.height}px">'
            '<p class="view-placeholder">Interactive 3D view: drawn when it scrolls into sight (needs JavaScript)'
            f'</p></div><script type="application/json" id="{block.key}-data">{block.figure}</script>'
            f"<figcaption>{html.escape(block.caption)}</figcaption>"
        )
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
    views = [b for s in sections for b in s.blocks if isinstance(b, View)]
    shared = {key: data for view in views for key, data in view.shared.items()}
    parts += [f'<script type="application/json" id="shared-{key}">{data}</script>' for key, data in shared.items()]
    if views:  # the library once for every view, inline and packed: the page works offline and can be mailed
        parts += [
            f'<script type="application/gzip;base64" id="plotly-gz">{packed_plotly()}</script>',
            f'<script type="text/plain" id="views-script">{VIEWS_SCRIPT}</script>',
            f"<script>{LOADER_SCRIPT}</script>",
        ]
    parts.append("</body></html>\n")
    return "\n".join(parts)
