"""MkDocs hook: the docs' numbers come from the benchmarks' results files, at build time.

A page marks a place with ``<!-- results: NAME -->``; the hook puts there the table that
``benchmarks/NAME.py`` makes of ``benchmarks/results/NAME.json`` (its ``markdown_table``, or its printed
``report`` as a list), and the machine it was measured on. So no number in the docs can go stale: rerunning a
benchmark rewrites its file, and the next build shows it.
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
MARK = re.compile(r"<!-- results: ([a-z_]+) -->")


def benchmark(name: str) -> ModuleType:
    path = BENCHMARKS / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", path)
    if spec is None or spec.loader is None or not path.is_file():
        raise ValueError(f"{path}: no such benchmark")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def machine_line(results: dict) -> str:
    machine = results.get("machine", {})
    cpu = machine.get("cpu", {}).get("model")
    cores = machine.get("cpus")
    where = ", ".join(x for x in (f"{cores} cores" if cores else "", cpu or "") if x)
    return f"*Measured by `benchmarks/{{name}}.py`{' on ' + where if where else ''}.*"


def results_block(name: str) -> str:
    results = json.loads((BENCHMARKS / "results" / f"{name}.json").read_text())
    module = benchmark(name)
    if hasattr(module, "markdown_table"):
        body = module.markdown_table(results)
    else:
        body = "\n".join(f"- {line}" for line in module.report(results).splitlines())
    return f"{body}\n\n{machine_line(results).format(name=name)}\n"


def on_page_markdown(markdown: str, **_: Any) -> str:
    return MARK.sub(lambda match: results_block(match.group(1)), markdown)
