"""``grasptask report``: one self-contained page with the task ellipsoids, distances and synthesized grasps of a
results folder, each beside the paper's figures, written all at once or not at all."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from grasptask import __version__
from grasptask.errors import BadInputError
from grasptask.hand.hand_model import Hand
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.wording import plural
from grasptask.paths import as_paths
from grasptask.progress import timed_stage
from grasptask.records.reference import PaperSynthesis, read_paper_synthesis
from grasptask.records.sweeps import SOLUTIONS, Sweep
from grasptask.report import browser_check
from grasptask.report.browser_check import BrowserCheck
from grasptask.report.inputs import ResultsFolder, find_results, paper_setup, verifier_q
from grasptask.report.page import Section, render_html
from grasptask.report.sections import (
    Writer,
    distances_section,
    ellipsoid_figures_section,
    ellipsoid_tables_section,
    grasps_section,
    physics_section,
    sweeps_section,
)
from grasptask.report.style import task_order


@dataclass(frozen=True, kw_only=True)
class ReportOptions:
    """The results folder to report on, the report's folder (default: ``RESULTS/report``) and, with
    ``check_browser``, a check of the page in headless Chromium that can save the page's top (``screenshot``)
    and its first interactive view as drawn (``view_screenshot``). What the check needs is checked here, before
    the report is built, not after."""

    results: Path
    out: Path | None = None
    check_browser: bool = False
    screenshot: Path | None = None
    view_screenshot: Path | None = None

    def __post_init__(self) -> None:
        as_paths(self, "results", optional=("out", "screenshot", "view_screenshot"))
        for option, path in (("--screenshot", self.screenshot), ("--view-screenshot", self.view_screenshot)):
            if path is not None:
                if not self.check_browser:
                    raise BadInputError(option, "needs --check-browser (the screenshot is the browser's)")
                browser_check.check_screenshot_path(path)
        if self.check_browser and browser_check.find_chromium() is None:
            raise BadInputError("chromium", "not installed (apt-get install chromium chromium-driver)")

    @property
    def folder(self) -> Path:
        return self.out if self.out is not None else self.results / "report"


@dataclass(frozen=True)
class ReportSummary:
    index: Path
    figures: int
    views: int
    tables: int
    notes: list[str]
    seconds: float
    #: what the report was made from, one line each
    found: list[str] = field(default_factory=list)
    #: what headless Chromium saw of the page, with ``check_browser``
    browser: BrowserCheck | None = None


@timed_stage
def run_report(options: ReportOptions) -> ReportSummary:
    """Build the report and, with ``check_browser``, check it in headless Chromium."""
    summary = _build_report(options.results, options.folder)
    if not options.check_browser:
        return summary
    check = browser_check.check_page(summary.index, options.screenshot, view_screenshot=options.view_screenshot)
    return replace(summary, browser=check)


def _build_report(results_dir: str | Path, out: str | Path) -> ReportSummary:
    """Write ``out/index.html`` (self-contained), ``out/figures/*.png``, ``out/tables/*.md`` and
    ``out/report.json`` from the results folder ``results_dir``."""
    start = time.perf_counter()
    results = find_results(results_dir)
    sweeps = _sweeps(results)
    found = _found(results, sweeps)
    inputs = [
        p
        for p in (results.stats, results.ellipsoids, results.task_models, results.distances, results.distance_summary)
        if p.is_file()
    ]
    inputs += [s.run_file for s in sweeps.values()]
    inputs += [folder / "physics_summary.json" for folder in results.physics_folders()]
    provenance = Provenance.of("report", {"results": str(results_dir)}, inputs)
    with StagedOutput(out, provenance) as staged:
        writer = Writer(staged)
        paper = read_paper_synthesis()
        # the user's results first: their grasps, how they held, how the sweeps went; the tasks' ellipsoids
        # next, and the paper's Tables 1-10 last
        sections = [
            grasps_section(results, sweeps, paper, writer),
            physics_section(results, sweeps, writer),
            sweeps_section(results, sweeps, paper, writer),
        ]
        sections += [
            make(results, writer) for make in (ellipsoid_figures_section, distances_section, ellipsoid_tables_section)
        ]
        notes = [f"{s.title}: {n}" for s in sections for n in s.notes]
        summary_lines = _identity_lines(sweeps) + _summary_lines(sweeps, sections, paper)
        page = render_html(
            "grasptask report",
            f"results: {Path(results_dir).resolve()}; grasptask {__version__}; built {time.strftime('%Y-%m-%d %H:%M')}",
            summary_lines,
            sections,
        )
        staged.write_with("index.html", lambda p: p.write_text(page))
        staged.write_json(
            "report.json",
            {
                "figures": writer.figures,
                "views": writer.views,
                "tables": writer.tables,
                "notes": notes,
                "summary": summary_lines,
            },
        )
    index = Path(out) / "index.html"
    seconds = time.perf_counter() - start
    return ReportSummary(index, len(writer.figures), len(writer.views), len(writer.tables), notes, seconds, found)


def _sweeps(results: ResultsFolder) -> dict[str, Sweep]:
    """The results folder's sweeps by task, in the paper's order, each checked whole before any figure is drawn
    (a table of another hand is one line now, not after minutes of figures). A second sweep of a task is
    refused: one folder is reported at a time."""
    sweeps: dict[str, Sweep] = {}
    hands: dict[Path, Hand] = {}  # a mesh hand's sphere cover takes seconds: once for its sweeps
    for folder in results.sweep_folders():
        sweep = Sweep.open(folder / SOLUTIONS, hands=hands)
        for column in REPORTED:
            if column not in sweep.table.columns:
                raise BadInputError(sweep.solutions, "missing column", column=column)
        _ = sweep.optima
        if sweep.task in sweeps:
            raise BadInputError(
                sweep.run_file,
                f"a second sweep of task '{sweep.task}' (the first: {sweeps[sweep.task].folder}); report one folder",
            )
        sweeps[sweep.task] = sweep
    return {task: sweeps[task] for task in sorted(sweeps, key=task_order)}


#: what the report draws of each start, beyond what re-judging a table needs
REPORTED = ("status", "seconds", "verified")


def _found(results: ResultsFolder, sweeps: dict[str, Sweep]) -> list[str]:
    """What the report is made of, one line each, as the command says it."""
    lines = [f"sweep of {task}: {sweep.folder}" for task, sweep in sweeps.items()]
    lines += [f"unfinished sweep: {folder}" for folder in results.unfinished_sweeps()]
    for label, path in (("task models", results.task_models), ("ellipsoids", results.ellipsoids)):
        if path.is_file():
            lines.append(f"{label}: {path}")
    lines += [f"physics: {folder}" for folder in results.physics_folders()]
    lines += [f"export: {folder} (for other tools; the report draws the sweeps)" for folder in results.export_folders()]
    return lines


def _identity_lines(sweeps: dict[str, Sweep]) -> list[str]:
    """The top of the page: which hand grasped which object for which tasks, and when and how each was run."""
    groups: dict[tuple[str, str], list[str]] = {}
    for task, sweep in sweeps.items():
        obj = sweep.files.object
        name = sweep.run.get("object_name") or obj.stem  # run.json from before it was recorded: the file's
        groups.setdefault((f"{sweep.hand.name} ({sweep.files.hand})", f"{name} ({obj})"), []).append(task)
    lines = [f"Hand {hand} on object {obj}: {', '.join(tasks)}" for (hand, obj), tasks in groups.items()]
    for task, sweep in sweeps.items():
        run, made = sweep.run, sweep.run_file.stat().st_mtime
        library = run.get("library") or {}
        warm = (
            f" ({library.get('warm_starts')} of them warm starts from task '{library['from_task']}' of the grasp "
            f"library {library.get('folder')})"
            if library.get("from_task")
            else ""
        )
        lines.append(
            f"{task}: synthesized {time.strftime('%Y-%m-%d %H:%M', time.localtime(made))}, {run.get('starts', '?')} "
            f"starts{warm}, {run.get('backend', '?')} on {run.get('executor', '?')} x {run.get('workers', '?')}, "
            f"grasp config {Path(str(run.get('grasp_config', '?'))).name}, in {sweep.folder}"
        )
    return lines


def _summary_lines(sweeps: dict[str, Sweep], sections: list[Section], paper: PaperSynthesis) -> list[str]:
    lines = [s.summary for s in sections if s.summary]
    for task, sweep in sweeps.items():
        solutions = sweep.table
        quality = [verifier_q(row) for _, row in sweep.optima.iterrows()]
        best = f"best Q {min(quality):.4g}" if quality else "no grasp found"
        lines.append(
            f"{task}: {int(solutions['verified'].sum())}/{plural(len(solutions), 'start')} verified, "
            f"{plural(len(sweep.optima), 'distinct optimum')}, {best}, "
            f"median {solutions['seconds'].median():.1f} s per start"
            + (f" (paper: {paper.seconds})" if paper_setup(sweep.files) else "")
        )
    missing = [s.title for s in sections if not s.made]
    if missing:
        lines.append("Not made (inputs missing): " + "; ".join(missing))
    return lines
