"""``report.html``: an output folder in one page to hand on.

The page holds what the command found and on what: the date, the versions and the command
line first, then the headline figures as tables (headers in words with units, values
rounded, `trackdyn.commands.report_tables`), every figure with its caption in words in the
order `trackdyn.commands.names.FIGURES` states (each command's main figure first), the
first rows of every CSV table, the inputs with their SHA-256, the options, the vehicle
parameters, the timings, and a link to every file of the folder. The figures are embedded
(PNG), so the page reads on its own when mailed or archived; its links are relative, so
they resolve beside the folder's files.
"""

from __future__ import annotations

import base64
from pathlib import Path

from trackdyn.commands.names import caption
from trackdyn.commands.report_tables import Table, csv_preview, headline_tables

REPORT = "report.html"
"""File name of the page in an output folder."""

_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{{ summary.title }}</title>
<style>
body { font-family: sans-serif; margin: 2em auto; max-width: 80em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; } h3 { font-size: 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
th { background: #eee; font-weight: normal; } td.number { text-align: right; }
td { font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; } img { max-width: 100%; border: 1px solid #ddd; }
code { background: #f4f4f4; padding: 0 0.2em; }
</style>
</head>
<body>
{% macro show(t) %}
{% if t.file %}<h3><a href="{{ t.file }}">{{ t.file }}</a></h3>
{% elif t.title %}<h3>{{ t.title }}</h3>{% endif %}
<table>{% if t.header %}<tr>{% for h in t.header %}<th>{{ h }}</th>{% endfor %}</tr>{% endif %}
{% for row in t.rows %}<tr>{% for v in row %}{% if not t.header and loop.first %}
<th scope="row">{{ v }}</th>{% else %}
<td{% if number(v) %} class="number"{% endif %}>{{ v }}</td>{% endif %}{% endfor %}</tr>
{% endfor %}</table>
{% if t.file and t.count > t.rows | length %}
<p>The first {{ t.rows | length }} of {{ t.count }} rows: the whole table is in
<a href="{{ t.file }}">{{ t.file }}</a>.</p>
{% endif %}
{% endmacro %}
<h1>{{ summary.title }}</h1>
<p>Written {{ created }} by trackdyn {{ summary.trackdyn_version }} ({{ versions }}).</p>
<p>Command: <code>{{ summary.command_line }}</code></p>
{% if headline %}
<h2>Headline figures</h2>
{% for t in headline %}{{ show(t) }}{% endfor %}
{% endif %}
{% if figures %}
<h2>Figures</h2>
{% for name, text, image in figures %}
<figure><img src="data:image/png;base64,{{ image }}" alt="{{ text }}">
<figcaption>Figure {{ loop.index }}. {{ text }} (<a href="{{ name }}">{{ name }}</a>)
</figcaption></figure>
{% endfor %}
{% endif %}
{% if tables %}
<h2>Tables</h2>
{% for t in tables %}{{ show(t) }}{% endfor %}
{% endif %}
<h2>Inputs</h2>
<table><tr><th>Input</th><th>Path</th><th>SHA-256</th></tr>
{% for name, item in summary.inputs.items() %}
<tr><td>{{ name }}</td><td>{{ item.path }}</td><td><code>{{ item.sha256 }}</code></td></tr>
{% endfor %}</table>
<h2>Options</h2>
{{ show(options) }}
{% if vehicle.rows %}<h2>Vehicle parameters (SI units)</h2>
{{ show(vehicle) }}{% endif %}
<h2>Timings [s]</h2>
{{ show(timings) }}
<h2>Files</h2>
<ul>{% for f in summary.files %}<li><a href="{{ f }}">{{ f }}</a></li>{% endfor %}</ul>
</body>
</html>
"""


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _option(value) -> str:
    """An option's value: a number to 6 significant digits, None as "not set"."""
    if value is None:
        return "not set"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _flat(values: dict, prefix: str = "") -> list[list[str]]:
    """Options as rows of a name and a value, tables inside them by dotted names, a list
    of tables numbered from 1 (``traffic 1.speed_kmh``)."""
    rows = []
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            rows += _flat(value, f"{name}.")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for k, item in enumerate(value, 1):
                rows += _flat(item, f"{name} {k}.")
        elif isinstance(value, list):
            rows.append([name, ", ".join(_option(v) for v in value)])
        else:
            rows.append([name, _option(value)])
    return rows


def _figures(files: list[Path]) -> list[tuple[str, str, str]]:
    """The PNG files as (name, caption, base64 data), in the order of their captions."""
    pngs = sorted((caption(p.stem), p) for p in files if p.suffix == ".png")
    return [(p.name, text, base64.b64encode(p.read_bytes()).decode("ascii"))
            for (_, text), p in pngs]  # fmt: skip


def render(summary: dict, folder: Path, currency: str | None = None) -> str:
    """The page of an output folder.

    Parameters
    ----------
    summary : dict
        The folder's ``summary.json`` content (`trackdyn.commands.staging.Record.summary`),
        infinite values as they are (shown as a tonnage never reached).
    folder : Path
        The folder holding the files the summary lists.
    currency : str, optional
        The currency that ends the names of costs (an interventions study's).
    """
    from jinja2 import Environment, select_autoescape

    env = Environment(autoescape=select_autoescape(default=True, default_for_string=True))
    files = [folder / name for name in summary["files"] if (folder / name).is_file()]
    versions = ", ".join(f"{k} {v}" for k, v in summary["versions"].items() if k != "trackdyn")
    timings = [[k, f"{v:.3g}"] for k, v in summary["timings_s"].items()]
    return env.from_string(_TEMPLATE).render(
        summary=summary,
        created=summary["created"].replace("T", " ").replace("Z", " UTC"),
        versions=versions,
        headline=headline_tables(summary["headline"], summary["command"], currency),
        figures=_figures(files),
        tables=[csv_preview(p, summary["command"], currency) for p in files if p.suffix == ".csv"],
        options=Table("", [], _flat(summary["options"])),
        vehicle=Table("", [], _flat(summary["vehicle"])),
        timings=Table("", [], timings),
        number=_number,
    )
