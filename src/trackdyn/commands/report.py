"""``report.html``: an output folder in one self-contained page.

The page holds the run's provenance (version, command line, inputs with their SHA-256,
options, vehicle parameters, timings), its headline figures, every CSV table of the folder
and every figure (PNG, embedded), and lists the files. It needs no other file and no
network: it can be mailed or archived on its own.
"""

from __future__ import annotations

import base64
import csv
from pathlib import Path

REPORT = "report.html"
"""File name of the page in an output folder."""
MAX_ROWS = 200
"""Rows of a CSV table shown; a longer table is cut, saying so."""

_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{{ summary.title }}</title>
<style>
body { font-family: sans-serif; margin: 2em auto; max-width: 80em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
th { background: #eee; } td.number { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; } img { max-width: 100%; border: 1px solid #ddd; }
code { background: #f4f4f4; padding: 0 0.2em; }
</style>
</head>
<body>
<h1>{{ summary.title }}</h1>
<p>trackdyn {{ summary.trackdyn_version }}: <code>{{ summary.command_line }}</code></p>
{% if summary.headline %}
<h2>Headline figures</h2>
{{ pairs(summary.headline) }}
{% endif %}
{% for name, image in figures %}
<figure><img src="data:image/png;base64,{{ image }}" alt="{{ name }}">
<figcaption>{{ name }}</figcaption></figure>
{% endfor %}
{% for name, header, rows, cut in tables %}
<h2>{{ name }}</h2>
<table><tr>{% for h in header %}<th>{{ h }}</th>{% endfor %}</tr>
{% for row in rows %}<tr>{% for v in row %}
<td{% if number(v) %} class="number"{% endif %}>{{ v }}</td>{% endfor %}</tr>
{% endfor %}</table>
{% if cut %}
<p>The first {{ rows | length }} of {{ cut }} rows; the file holds them all.</p>
{% endif %}
{% endfor %}
<h2>Inputs</h2>
<table><tr><th>input</th><th>path</th><th>SHA-256</th></tr>
{% for name, item in summary.inputs.items() %}
<tr><td>{{ name }}</td><td>{{ item.path }}</td><td><code>{{ item.sha256 }}</code></td></tr>
{% endfor %}</table>
<h2>Options</h2>
{{ pairs(summary.options) }}
{% if summary.vehicle %}<h2>Vehicle parameters (SI units)</h2>
{{ pairs(summary.vehicle) }}{% endif %}
<h2>Timings</h2>
{{ pairs(summary.timings_s) }}
<h2>Files</h2>
<ul>{% for f in summary.files %}<li>{{ f }}</li>{% endfor %}</ul>
</body>
</html>
"""


def _number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def _table(path: Path) -> tuple[str, list[str], list[list[str]], int]:
    with open(path, newline="") as file:
        rows = [row for row in csv.reader(file) if row and not row[0].startswith("#")]
    header, body = (rows[0], rows[1:]) if rows else ([], [])
    return path.name, header, body[:MAX_ROWS], len(body) if len(body) > MAX_ROWS else 0


def render(summary: dict, folder: Path) -> str:
    """The page of an output folder.

    Parameters
    ----------
    summary : dict
        The folder's ``summary.json`` content (`trackdyn.commands.staging.Record.summary`).
    folder : Path
        The folder holding the files the summary lists.
    """
    from jinja2 import Environment, select_autoescape
    from markupsafe import Markup, escape

    def pairs(values: dict) -> Markup:
        rows = "".join(
            f"<tr><td>{escape(k)}</td><td>{escape(_shown(v))}</td></tr>" for k, v in values.items()
        )
        return Markup(f"<table>{rows}</table>")

    env = Environment(autoescape=select_autoescape(default=True, default_for_string=True))
    files = [folder / name for name in summary["files"] if (folder / name).is_file()]
    figures = [
        (p.name, base64.b64encode(p.read_bytes()).decode("ascii"))
        for p in files
        if p.suffix == ".png"
    ]
    tables = [_table(p) for p in files if p.suffix == ".csv"]
    template = env.from_string(_TEMPLATE)
    return template.render(
        summary=summary, figures=figures, tables=tables, pairs=pairs, number=_number
    )


def _shown(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, dict | list):
        import json

        return json.dumps(value)
    return "default" if value is None else str(value)
