"""The report: it builds from whatever a results folder holds, says what is missing, and opens in Chromium."""

from __future__ import annotations

import json
import re
import shutil
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest
from grasp_fixtures import ball_sweep, drawing_like_task, results_with_tasks

from grasptask.report.browser_check import check_page, find_chromium
from grasptask.report.paper_tables import PAPER_TABLES
from grasptask.stages import ReportOptions, run_report


@pytest.fixture(scope="module")
def full_report(simulated, tmp_path_factory):
    results = results_with_tasks(simulated, tmp_path_factory.mktemp("report") / "results")
    run = ball_sweep(results)
    assert run["verified"] == 2 and run["distinct_optima"] == 1
    # an interrupted sweep: a per-start log but no summary
    (results / "grasps" / "cutting").mkdir(parents=True)
    (results / "grasps" / "cutting" / "solutions.jsonl").write_text('{"start_id": 0}\n')
    summary = run_report(ReportOptions(results=results))
    return results, summary


def _markup(page: str) -> str:
    """The page without its inline scripts' text (plotly.js holds 'src="' in its own strings)."""
    return re.sub(r"<script[^>]*>.*?</script>", "<script></script>", page, flags=re.S)


def test_report_from_task_results_only(simulated, tmp_path):
    results = results_with_tasks(simulated, tmp_path / "results")
    summary = run_report(ReportOptions(results=results, out=tmp_path / "out"))
    out = tmp_path / "out"
    figures = sorted(p.name for p in (out / "figures").iterdir())
    assert figures == [
        "distance_embedding.png",
        "distance_heatmap.png",
        "ellipsoids_cutting.png",
        "ellipsoids_drawing.png",
        "ellipsoids_screwdriving.png",
    ]
    tables = [f"table_{t.number:02d}.md" for t in PAPER_TABLES] + ["task_distances.md"]
    tables += [f"axes_{task}.md" for task in ("cutting", "drawing", "screwdriving")]
    assert sorted(p.name for p in (out / "tables").iterdir()) == sorted(tables)
    page = (out / "index.html").read_text()
    # self-contained: every figure inline, nothing fetched from elsewhere
    assert len(re.findall(r'<img src="data:image/png;base64,', page)) == len(figures)
    markup = _markup(page)
    assert not re.search(r'src="(?!data:)', markup) and "<link" not in markup
    # the missing synthesis is a note that says what to run, in the page and in the summary
    assert any("grasptask synthesize" in note for note in summary.notes)
    assert "Not made (inputs missing)" in page and "grasptask synthesize" in page


def test_tables_put_each_value_beside_the_paper(simulated, tmp_path):
    run_report(ReportOptions(results=results_with_tasks(simulated, tmp_path / "results"), out=tmp_path / "out"))
    table5 = (tmp_path / "out" / "tables" / "table_05.md").read_text()
    assert "Table 5:" in table5 and "proj paper" in table5 and "proj diff" in table5
    ours = pd.read_csv(simulated[0] / "tasks" / "stats.csv", dtype={"axis": str})
    value = ours.query("group == 'drawing_tripod' and domain == 'force' and stat == 'proj' and axis == 'z'")["value"]
    row = next(line for line in table5.splitlines() if "drawing_tripod" in line and "| force" in line and "| z" in line)
    cells = [c.strip() for c in row.strip("|").split("|")]
    # group, domain, axis, ours, paper (0.59 in the paper's Table 5), difference
    assert float(cells[3]) == pytest.approx(float(value.iloc[0]), abs=1e-3)
    assert float(cells[4]) == pytest.approx(0.59)
    assert float(cells[5]) == pytest.approx(float(cells[3]) - 0.59, abs=2e-3)


def test_report_with_a_sweep_renders_every_optimum(full_report):
    results, summary = full_report
    out = results / "report"
    figures = {p.name for p in (out / "figures").iterdir()}
    assert {"grasp_drawing_00.png", "synthesis_sweeps.png"} <= figures
    quality = (out / "tables" / "grasp_quality.md").read_text()
    assert "drawing" in quality and "0.37, 9.7" not in quality  # a ball is not the paper's tool: no Table 11
    sweeps = (out / "tables" / "synthesis_sweeps.md").read_text()
    assert "459 +- 186" not in sweeps and "2 (67%; 0 on a retry)" in sweeps
    assert any("cutting" in note and "--resume" in note for note in summary.notes)
    report = json.loads((out / "report.json").read_text())
    assert len(report["figures"]) == summary.figures == len(figures)


def test_report_views_are_inlined_once_and_share_the_object(full_report):
    """An interactive view per optimum and per task's ellipsoids, plotly.js inlined once (packed), nothing from
    the network, and the object's surface written once however many views show it."""
    from grasptask.report.page import packed_plotly

    results, summary = full_report
    page = (results / "report" / "index.html").read_text()
    report = json.loads((results / "report" / "report.json").read_text())
    assert report["views"] == ["view-grasp_drawing_00"] + [  # the user's grasps first
        f"view-ellipsoids_{t}" for t in ("drawing", "cutting", "screwdriving")
    ]
    assert summary.views == 4 and page.count('<div class="view"') == 4
    assert page.count(packed_plotly()[:200]) == 1 and page.count('id="plotly-gz"') == 1
    markup = _markup(page)
    assert not re.search(r'src="(?!data:)', markup) and not re.search(r"(src|href)=.https?:", markup)
    assert page.count('id="shared-mesh-') == 1
    # the figure data parses, and the grasp view's pads carry their hover text
    data = re.search(r'<script type="application/json" id="view-grasp_drawing_00-data">(.*?)</script>', page, re.S)
    figure = json.loads(data.group(1))
    contacts = next(t for t in figure["data"] if t["name"] == "contacts")
    assert len(contacts["text"]) == 3 and all("largest |force|" in t and "Q " in t for t in contacts["text"])
    assert len(data.group(1)) < 150_000  # a view's own data; a paper report holds 57 of them within 15 MB


@pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium and chromium-driver are not installed")
def test_report_opens_in_headless_chromium(full_report, tmp_path):
    results, summary = full_report
    check = check_page(summary.index, tmp_path / "top.png", view_screenshot=tmp_path / "view.png")
    assert check.ok, check.problems()
    assert check.images == summary.figures and check.title == "grasptask report"
    # every interactive view drew a WebGL scene with something in it, within 5 s of coming into sight
    assert len(check.views) == summary.views and all(v.ok and v.canvases for v in check.views)
    for shot in ("top.png", "view.png"):
        assert (tmp_path / shot).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_bad_input(cli, simulated, tmp_path):
    result = cli("report", "--results", tmp_path / "nowhere")
    assert result.exit_code == 2 and "results folder not found" in result.output
    assert len(result.output.strip().splitlines()) == 1
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    broken = results / "grasps" / "drawing" / "solutions.parquet"
    broken.write_text("not parquet")
    result = cli("report", "--results", results)
    assert result.exit_code == 2 and str(broken) in result.output and "Parquet" in result.output
    assert not (results / "report").exists()


@pytest.mark.skipif(find_chromium() is None, reason="Debian's chromium and chromium-driver are not installed")
def test_the_browser_check_fails_an_empty_view(tmp_path):
    """A view whose scene shows nothing but its grey axes does not pass: the check can fail."""
    import plotly.graph_objects as go

    from grasptask.report.interactive import figure_json
    from grasptask.report.page import Figure, Section, View, render_html
    from grasptask.report.style import apply_style, save_figure

    empty = go.Figure(go.Scatter3d(x=[0.0], y=[0.0], z=[0.0], mode="markers", marker={"size": 0.1}))
    empty.update_layout(template="none", height=400)
    data, shared = figure_json(empty)
    import matplotlib.pyplot as plt

    apply_style()
    fig = plt.figure()
    save_figure(fig, tmp_path / "blank.png")
    plt.close(fig)
    section = Section(
        "s", "S", blocks=[View("view-empty", data, "nothing", 400, shared), Figure(tmp_path / "blank.png", "")]
    )
    page = tmp_path / "index.html"
    page.write_text(render_html("t", "", [], [section]))
    check = check_page(page)
    assert [v.key for v in check.views] == ["view-empty"]
    view = check.views[0]
    assert view.drawn and view.canvases and not view.ok and not check.ok
    assert "view-empty" in " ".join(check.problems())


def _renamed_fingers(table: pd.DataFrame) -> pd.DataFrame:
    """The same grasps with another hand's finger names (a BarrettHand's table under a human run.json)."""
    return table.rename(columns=lambda c: c.replace("_thumb_", "_finger3_"))


@pytest.mark.parametrize(
    "table, change, message",
    [
        ("solutions", lambda t: t.assign(seconds=t["seconds"].astype(str)), "column 'seconds'"),
        ("solutions", lambda t: t.assign(seconds=float("inf")), "column 'seconds'"),
        ("optima", lambda t: t.assign(palm_x=float("inf")), "column 'palm_x'"),
        ("optima", _renamed_fingers, "not a table of hand"),
    ],
    ids=["seconds-as-text", "infinite-seconds", "infinite-palm", "another-hands-table"],
)
def test_a_sweep_the_report_would_choke_on_is_one_line(cli, simulated, tmp_path, table, change, message):
    """A TypeError, a ValueError from the renderer, 8 RuntimeWarnings or 'need at least one array to stack'
    before; now one line naming the file and column, and no report."""
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    path = results / "grasps" / "drawing" / f"{table}.parquet"
    change(pd.read_parquet(path)).to_parquet(path)
    result = cli("report", "--results", results)
    assert result.exit_code == 2 and message in result.output and str(path) in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (results / "report").exists()


def test_screenshots_are_checked_before_the_report_is_built(cli, simulated, tmp_path):
    results = results_with_tasks(simulated, tmp_path / "results")
    result = cli("report", "--results", results, "--screenshot", tmp_path / "top.png")
    assert result.exit_code == 2 and "needs --check-browser" in result.output
    if find_chromium() is not None:
        result = cli("report", "--results", results, "--check-browser", "--screenshot", tmp_path)
        assert result.exit_code == 2 and "is a folder" in result.output
    assert not (results / "report").exists()


def test_a_browser_check_says_why_an_empty_page_fails():
    from grasptask.report.browser_check import BrowserCheck

    empty = BrowserCheck(images=0)
    assert not empty.ok and any("no image" in line for line in empty.problems())


def test_a_missing_chromium_is_said_before_the_report_is_built(cli, simulated, tmp_path, monkeypatch):
    import grasptask.report.browser_check as browser

    monkeypatch.setattr(browser, "find_chromium", lambda: None)
    results = results_with_tasks(simulated, tmp_path / "results")
    result = cli("report", "--results", results, "--check-browser")
    assert result.exit_code == 2 and "chromium" in result.output and "not installed" in result.output
    assert not (results / "report").exists()


def test_a_report_on_a_bare_synthesize_folder_names_the_hand_and_the_object(cli, simulated, tmp_path):
    """`synthesize --out X` writes X/<task>/: the report found nothing there ('0 figures', exit 0)."""
    import shutil

    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    bare = tmp_path / "bare"
    shutil.copytree(results / "grasps", bare)
    result = cli("report", "--results", bare)
    assert result.exit_code == 0, result.output
    assert f"found sweep of drawing: {bare / 'drawing'}" in result.output
    assert f"found task models: {results / 'tasks' / 'task_models.json'}" in result.output
    # the ellipsoids and recordings fit-task and simulate wrote beside those task models are drawn too
    assert f"found ellipsoids: {results / 'tasks' / 'ellipsoids.parquet'}" in result.output
    page = (bare / "report" / "index.html").read_text()
    assert "Hand human" in page and "on object ball" in page and "drawing: synthesized" in page
    report = json.loads((bare / "report" / "report.json").read_text())
    assert any(name.startswith("grasp_drawing") for name in report["figures"])
    assert {"ellipsoids_drawing", "ellipsoids_cutting"} <= {Path(name).stem for name in report["figures"]}


def test_a_folder_with_nothing_to_report_is_one_line(cli, tmp_path):
    (tmp_path / "empty" / "notes").mkdir(parents=True)
    result = cli("report", "--results", tmp_path / "empty")
    assert result.exit_code == 2 and "holds nothing to report" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "empty" / "report").exists()


def test_the_paper_is_compared_only_on_its_own_setup(full_report):
    """A ball's Q beside the paper's tool's said nothing: no paper column for another object."""
    from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT
    from grasptask.records.sweeps import SweepFiles
    from grasptask.report.inputs import paper_setup

    results, summary = full_report
    tables = results / "report" / "tables"
    header = [(tables / f"{name}.md").read_text().splitlines()[2] for name in ("grasp_quality", "synthesis_sweeps")]
    assert all("|" in line and "paper" not in line for line in header)
    files = SweepFiles(DEFAULT_HAND, DEFAULT_OBJECT, DEFAULT_GRASP_CONFIG, None, None, "drawing")
    assert paper_setup(files)
    assert not paper_setup(replace(files, task="juggling"))
    assert not paper_setup(replace(files, object=Path("ball.yaml")))


def test_a_grasp_has_one_q_in_its_view_and_its_table(full_report):
    """A view's title said Q = 0.01007 (the NLP's) and its subtitle Q 0.005094 (the verifier's)."""
    results, _ = full_report
    page = (results / "report" / "index.html").read_text()
    shown = set(re.findall(r"optimum 0: Q = ([0-9.e-]+)", page)) | set(re.findall(r"Q ([0-9.e-]+), epsilon", page))
    table = (results / "report" / "tables" / "grasp_quality.md").read_text().splitlines()
    row = next(line for line in table if line.startswith("| drawing"))
    assert shown == {row.split("|")[3].strip()}, (shown, row)
    assert "lower is better" in page


def test_the_page_opens_with_the_users_grasps_and_ends_with_the_papers_tables(full_report):
    """The grasps came 10,000 px down, after the paper's Tables 1-10."""
    results, _ = full_report
    page = (results / "report" / "index.html").read_text()
    headings = re.findall(r'<section id="([a-z_-]+)"', page)
    assert headings[0] == "grasps" and headings[-1] == "tables", headings
    card = page.index("DRAWING (human: thumb orange, index green, middle purple): 2 of 3 starts verified")
    assert card < page.index('id="view-grasp_drawing_00"') < page.index('<section id="tables"')


def test_the_browser_check_finds_a_scene_the_camera_crops():
    """A view whose object runs into the plot area's border fails the check (a sugar box's top was cut off)."""
    import io

    import matplotlib.pyplot as plt
    import numpy as np

    from grasptask.report.browser_check import MAX_EDGE_PIXELS, _edge_pixels

    def png(top: int) -> bytes:
        image = np.ones((200, 300, 3))
        image[top:150, 100:200] = 0.6  # the object's grey
        image[120:140, 120:140] = (0.9, 0.5, 0.1)  # a finger
        buffer = io.BytesIO()
        plt.imsave(buffer, image, format="png")
        return buffer.getvalue()

    area = {"l": 0, "t": 20, "w": 300, "h": 180}
    assert _edge_pixels(png(60), area) == 0
    assert _edge_pixels(png(0), area) > MAX_EDGE_PIXELS


def test_a_view_fits_a_tall_scene_with_the_camera_farther_away():
    import numpy as np

    from grasptask.report.interactive import DEFAULT_EYE, fitted_camera

    cube = np.array([[0, 0, 0], [1, 1, 1]], dtype=float)
    tall = np.array([[0, 0, 0], [0.4, 0.4, 2.0]])
    assert fitted_camera(cube)["eye"]["z"] == DEFAULT_EYE[2]
    assert fitted_camera(tall)["eye"]["z"] > 1.3 * DEFAULT_EYE[2]


def test_a_folder_of_exports_alone_is_reported_as_found(cli, tmp_path):
    export = tmp_path / "shared" / "drawing"
    export.mkdir(parents=True)
    (export / "grasps.json").write_text('{"task": "drawing", "kind": "optimum", "grasps": []}')
    result = cli("report", "--results", tmp_path / "shared")
    assert result.exit_code == 0 and f"found export: {export}" in result.output, result.output


def test_a_robot_hands_fingers_are_named_by_their_colours():
    from grasptask.exports.scene_meshes import colour_legend

    assert colour_legend(["thumb", "index", "middle"]) == "thumb orange, index green, middle purple"
    assert colour_legend(["ff_tip", "mf_tip", "th_tip"]) == "ff_tip orange, mf_tip green, th_tip purple"


def test_your_own_recordings_are_not_set_beside_the_papers_tables(simulated, tmp_path):
    """Recordings that are not the bundled simulator's (no provenance saying so) get their own groups' table and
    a line saying why there is no comparison; the simulator's get Tables 1-10."""
    results = tmp_path / "results"
    shutil.copytree(simulated[0] / "tasks", results / "tasks")
    (results / "recordings").mkdir()
    shutil.copy(simulated[0] / "recordings" / "manifest.csv", results / "recordings" / "manifest.csv")
    run_report(ReportOptions(results=results, out=tmp_path / "out"))
    tables = sorted(p.name for p in (tmp_path / "out" / "tables").iterdir())
    assert "own_groups.md" in tables and not [t for t in tables if t.startswith("table_")]
    page = (tmp_path / "out" / "index.html").read_text()
    assert "are not set beside them" in page and "Tables 1-10: " not in page


def _physics_results(simulated, root: Path) -> Path:
    """The ball sweep judged in physics (with a task light enough for it), laid out as the pipelines lay it out."""
    from grasptask.stages import PhysicsOptions, run_physics

    results = results_with_tasks(simulated, root)
    ball_sweep(results)
    tasks = results / "light_tasks.json"
    tasks.write_text(json.dumps({"tasks": {"drawing": drawing_like_task().to_dict()}}))
    solutions = results / "grasps" / "drawing" / "solutions.parquet"
    run_physics(PhysicsOptions(solutions=solutions, tasks=tasks, out=results / "physics" / "drawing"))
    return results


@pytest.fixture(scope="module")
def physics_report(simulated, tmp_path_factory):
    results = _physics_results(simulated, tmp_path_factory.mktemp("physics-report") / "results")
    run_report(ReportOptions(results=results))
    return results


def test_each_optimum_is_traced_with_its_worst_moment_and_filmed_where_mujoco_can_render(physics_report):
    from grasptask.hand import load_hand
    from grasptask.physics.film import offscreen_unavailable

    physics = physics_report / "physics" / "drawing"
    summary = json.loads((physics / "physics_summary.json").read_text())
    optima = pd.read_parquet(physics_report / "grasps" / "drawing" / "optima.parquet")
    [moment] = summary["traced"]
    assert moment["start_id"] == int(optima["start_id"].iloc[0]) and moment["phase"] in ("settle", *TASK_PHASES)
    assert len(moment["object_pose"]) == 7 and len(moment["joint_angles"]) == load_hand().grasping_hand().n_joints
    trace = pd.read_parquet(physics / "physics_trace.parquet")
    assert set(trace["start_id"]) == {moment["start_id"]} and trace["phase"].nunique() == 19
    page = (physics_report / "report" / "index.html").read_text()
    assert (physics_report / "report" / "figures" / "physics_drawing.png").is_file()
    assert "physics, worst moment: " in page  # the moment's legend entry in the grasp's 3D view
    reason = offscreen_unavailable()
    if reason is None:
        from PIL import Image

        assert Image.open(physics / moment["film"]).n_frames > 10
        assert summary["films_unavailable"] is None and "data:image/gif;base64," in page
    else:
        assert summary["films_unavailable"] == reason and "No films of the check" in page


TASK_PHASES = tuple(f"task{sign}u{k}" for k in range(1, 7) for sign in "+-")


def test_the_physics_paths_and_films_open_in_headless_chromium(physics_report, tmp_path):
    summary = json.loads((physics_report / "report" / "report.json").read_text())
    check = check_page(physics_report / "report" / "index.html")
    assert check.ok, check.problems()
    assert check.images == len(summary["figures"]) and "physics_drawing" in summary["figures"]
    assert len(check.views) == len(summary["views"]) and all(v.ok and v.canvases for v in check.views)


def test_without_offscreen_rendering_the_report_says_so_once_and_draws_the_paths(simulated, tmp_path, monkeypatch):
    from grasptask.physics import film

    monkeypatch.setattr(film, "offscreen_unavailable", lambda: "no OpenGL platform here")
    results = _physics_results(simulated, tmp_path / "results")
    physics = results / "physics" / "drawing"
    assert json.loads((physics / "physics_summary.json").read_text())["films_unavailable"] == "no OpenGL platform here"
    assert not (physics / "films").exists()
    run_report(ReportOptions(results=results))
    page = (results / "report" / "index.html").read_text()
    assert page.count("No films of the check: no OpenGL platform here") == 1 and "data:image/gif" not in page
    assert (results / "report" / "figures" / "physics_drawing.png").is_file()
