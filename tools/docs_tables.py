"""MkDocs hook: the docs' tables of numbers and of settings are made at build time, from their one source.

- ``<!-- results: NAME -->`` becomes the table that ``benchmarks/NAME.py`` makes of
  ``benchmarks/results/NAME.json`` (its ``markdown_table``, or its printed ``report`` as a list), and the machine
  it was measured on. Rerunning a benchmark rewrites its file, and the next build shows it.
- ``<!-- summary: NAME -->`` becomes what the run says, a list made by that benchmark's ``summary`` of the same
  file, so that the prose's figures cannot go stale either.
- ``<!-- settings: MODULE.CLASS -->`` becomes a config schema's keys, defaults and meanings (the ``#:``
  comments above each field), so that no default is written twice.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import inspect
import json
import re
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
MARK = re.compile(r"<!-- results: ([a-z_]+) -->")
SUMMARY = re.compile(r"<!-- summary: ([a-z_]+) -->")
SETTINGS = re.compile(r"<!-- settings: ([a-z_.]+)\.([A-Za-z]+) -->")


def benchmark(name: str) -> ModuleType:
    path = BENCHMARKS / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", path)
    if spec is None or spec.loader is None or not path.is_file():
        raise ValueError(f"{path}: no such benchmark")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def machine_line(name: str, results: dict) -> str:
    machine = results.get("machine", {})
    cpu = machine.get("cpu", {}).get("model")
    cores = machine.get("cpus")
    where = ", ".join(x for x in (f"{cores} cores" if cores else "", cpu or "") if x)
    return f"*Measured by `benchmarks/{name}.py`{' on ' + where if where else ''}.*"


def saved(name: str) -> dict:
    return json.loads((BENCHMARKS / "results" / f"{name}.json").read_text())


def bullets(text: str) -> str:
    return "\n".join(f"- {line}" for line in text.splitlines())


def results_block(name: str) -> str:
    results, module = saved(name), benchmark(name)
    body = module.markdown_table(results) if hasattr(module, "markdown_table") else bullets(module.report(results))
    return f"{body}\n\n{machine_line(name, results)}\n"


def summary_block(name: str) -> str:
    return bullets(benchmark(name).summary(saved(name))) + "\n"


def meanings(schema: type) -> dict[str, str]:
    """Each field's ``#:`` comment lines, joined: what the key means, from the one place it is declared."""
    found, comment = {}, []
    for line in inspect.getsource(schema).splitlines():
        text = line.strip()
        if text.startswith("#:"):
            comment.append(text[2:].strip())
            continue
        field = re.match(r"(\w+):", text)
        if field and comment:
            found[field.group(1)] = " ".join(comment)
        comment = []
    return found


def shown(value: Any) -> str:
    if dataclasses.is_dataclass(value):
        value = dataclasses.asdict(value)  # type: ignore[arg-type]
    if isinstance(value, dict):
        return ", ".join(f"`{k}: {json.dumps(v)}`" for k, v in value.items()) or "`{}`"
    return f"`{json.dumps(list(value) if isinstance(value, tuple) else value)}`"


def settings_block(module: str, name: str) -> str:
    schema = getattr(importlib.import_module(module), name)
    meaning = meanings(schema)
    lines = ["| key | default | what it means |", "|---|---|---|"]
    for field in dataclasses.fields(schema):
        if field.default is not dataclasses.MISSING:
            default = shown(field.default)
        elif field.default_factory is not dataclasses.MISSING:
            default = shown(field.default_factory())
        else:
            default = "required"
        lines.append(f"| `{field.name}` | {default} | {meaning.get(field.name, '')} |")
    return "\n".join(lines) + "\n"


def on_page_markdown(markdown: str, **_: Any) -> str:
    markdown = MARK.sub(lambda match: results_block(match.group(1)), markdown)
    markdown = SUMMARY.sub(lambda match: summary_block(match.group(1)), markdown)
    return SETTINGS.sub(lambda match: settings_block(match.group(1), match.group(2)), markdown)
