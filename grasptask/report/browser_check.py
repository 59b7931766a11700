"""Open a report in headless Chromium (Debian's ``chromium`` and ``chromium-driver``) and check that every image
loads, the console stays free of errors, and each interactive view draws a non-empty WebGL scene (Chromium's
software GL, SwiftShader) once scrolled into sight; optionally save a screenshot of the top of the page and of one
view. How long the page and its views took is measured and said, never judged: on a busy machine a page that
works loads slower, and the verdict must not change with the load."""

from __future__ import annotations

import io
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError
from grasptask.io.child_processes import Reaper
from grasptask.io.locking import make_owned_folder, probe_writable, remove_stale_folders

#: without the background-networking flags Chromium keeps trying to reach Google's hosts on a closed network;
#: WebGL runs on SwiftShader, Chromium's software GL, which it no longer falls back to unasked
FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-dev-shm-usage",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)


#: how long a view may take to draw once in sight before it counts as never drawn (s): a hang guard, not a
#: judgement of speed (an idle machine draws one in about 1 s)
DRAW_WAIT_S = 60.0
#: a view's border band (px) that its scene must stay out of, and the drawn pixels tolerated there (an axis
#: label's anti-aliasing gave up to 27 in views that were whole; a cropped one, 150 and more)
EDGE_BAND_PX, MAX_EDGE_PIXELS = 4, 60
#: the browser profiles' folder names in the temporary folder, followed by their owner's identity
PROFILE_PREFIX = "grasptask-chromium-"
#: a drawn view must colour at least this many pixels of its WebGL scene (the hand, cones, task axes or
#: ellipsoids; the legend, which is not WebGL, is hidden first): grey axes alone are an empty scene
MIN_COLOURED_PIXELS = 400


@dataclass(frozen=True)
class ViewCheck:
    key: str
    drawn: bool
    draw_s: float
    coloured_pixels: int
    canvases: int
    #: coloured pixels at the view's border: more than a few, and the camera crops the scene
    edge_pixels: int = 0

    @property
    def ok(self) -> bool:
        drew = self.drawn and self.canvases > 0
        return drew and self.coloured_pixels >= MIN_COLOURED_PIXELS and self.edge_pixels <= MAX_EDGE_PIXELS


@dataclass(frozen=True)
class BrowserCheck:
    images: int
    broken_images: list[str] = field(default_factory=list)
    console_errors: list[str] = field(default_factory=list)
    title: str = ""
    ready_s: float = 0.0  # from navigation to the load event
    views: list[ViewCheck] = field(default_factory=list)
    view_errors: list[str] = field(default_factory=list)

    @property
    def failed_views(self) -> list[ViewCheck]:
        return [v for v in self.views if not v.ok]

    @property
    def ok(self) -> bool:
        return (
            self.images > 0
            and not self.broken_images
            and not self.console_errors
            and not self.failed_views
            and not self.view_errors
        )

    def problems(self) -> list[str]:
        """One line per thing that failed."""
        lines = [f"image did not load: {alt}" for alt in self.broken_images] + list(self.console_errors)
        if self.images == 0:
            lines.append("the page shows no image: its results folder holds nothing to report")
        for view in self.failed_views:
            lines.append(
                f"view {view.key}: drawn {view.drawn} in {view.draw_s:.1f} s, {view.canvases} canvases, "
                f"{view.coloured_pixels} coloured pixels (needs {MIN_COLOURED_PIXELS}), {view.edge_pixels} at its "
                f"border (the camera crops it beyond {MAX_EDGE_PIXELS})"
            )
        return lines + self.view_errors


def find_chromium() -> tuple[str, str] | None:
    """Paths of the browser and its driver, or None when they are not installed."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    return (browser, driver) if browser and driver else None


def check_screenshot_path(path: str | Path) -> None:
    """One line, before any work, when a screenshot cannot be saved at ``path``: a folder, or a place that
    cannot take a file (the check found it only after the browser had run, and exited 0 with no file)."""
    path = Path(path).absolute()
    if path.is_dir():
        raise BadInputError(path, "is a folder: a screenshot needs a file name (.png)")
    probe_writable(next(p for p in path.parents if p.exists()), path)  # the rest is made when it is saved


def _coloured(png: bytes) -> np.ndarray:
    """Which pixels are not a grey (white background, grey grid and object, black text): the hand, the contacts,
    the cones and the task's axes."""
    from matplotlib.image import imread  # deferred: matplotlib, only to read a screenshot

    rgb = imread(io.BytesIO(png), format="png")[..., :3]
    return (rgb.max(axis=-1) - rgb.min(axis=-1)) > 0.2


def _coloured_pixels(png: bytes) -> int:
    return int(_coloured(png).sum())


def _edge_pixels(png: bytes, area: dict, band: int = EDGE_BAND_PX) -> int:
    """Drawn pixels (coloured, or the object's mid grey) within ``band`` of the plot area's border (``area``:
    plotly's ``l, t, w, h`` in pixels): a scene the camera crops runs into it."""
    from matplotlib.image import imread  # deferred: matplotlib, only to read a screenshot

    rgb = imread(io.BytesIO(png), format="png")[..., :3]
    left, top = int(area["l"]), int(area["t"])
    rgb = rgb[top : top + int(area["h"]), left : left + int(area["w"])]
    light = rgb.mean(axis=-1)
    drawn = ((rgb.max(axis=-1) - rgb.min(axis=-1)) > 0.2) | ((light > 0.4) & (light < 0.8))
    inner = np.zeros_like(drawn)
    inner[band:-band, band:-band] = True
    return int((drawn & ~inner).sum())


def _check_view(driver: Any, element: Any, save: Path | None) -> ViewCheck:
    """Scroll ``element`` into sight, wait for the page to draw it, then look at what its WebGL scene shows."""
    from selenium.webdriver.support.ui import WebDriverWait  # deferred: only for the browser check

    key = element.get_attribute("id")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", element)
    began = time.perf_counter()
    try:
        WebDriverWait(driver, DRAW_WAIT_S, poll_frequency=0.05).until(
            lambda d: d.execute_script("return arguments[0].dataset.state === 'drawn';", element)
        )
    except Exception:  # noqa: BLE001 - a view that never draws is a failed check, not a crash
        return ViewCheck(key, False, time.perf_counter() - began, 0, 0)
    seconds = float(driver.execute_script("return Number(arguments[0].dataset.drawMs) / 1000;", element))
    canvases = int(driver.execute_script("return arguments[0].querySelectorAll('canvas').length;", element))
    if save is not None:
        save.parent.mkdir(parents=True, exist_ok=True)
        save.write_bytes(element.screenshot_as_png)
    driver.execute_async_script(
        "var done = arguments[arguments.length - 1];"
        "Plotly.relayout(arguments[0], {showlegend: false, title: {text: ''}}).then(function () { done(); });",
        element,
    )
    png = element.screenshot_as_png
    area = driver.execute_script("return arguments[0]._fullLayout._size;", element)
    return ViewCheck(key, True, seconds, _coloured_pixels(png), canvases, _edge_pixels(png, area))


def check_page(
    page: Path,
    screenshot: Path | None = None,
    width: int = 1280,
    height: int = 900,
    view_screenshot: Path | None = None,
) -> BrowserCheck:
    """Open ``page`` and check it (see the module docstring); ``view_screenshot`` saves the first grasp view
    (or the first view) as drawn."""
    found = find_chromium()
    if found is None:
        raise BadInputError(
            "chromium", "not installed (apt-get install chromium chromium-driver, or make setup-browser)"
        )
    os.environ.setdefault("SE_OFFLINE", "true")  # selenium must not try to download a driver
    temporary = Path(tempfile.gettempdir())
    remove_stale_folders(temporary, PROFILE_PREFIX)  # the folders of checks that were killed
    scratch = make_owned_folder(temporary, PROFILE_PREFIX)
    # the driver and the browser in a group of their own, which the reaper kills, and whose folder it removes,
    # however this process ends (a kill -9 left chromedriver, 11 Chromium processes and the profile behind)
    with Reaper((scratch,)) as reaper:
        driver = _start_driver(found, scratch, reaper, width, height)
        try:
            return _inspect(driver, page, screenshot, view_screenshot)
        finally:
            driver.quit()


def _start_driver(found: tuple[str, str], scratch: Path, reaper: Reaper, width: int, height: int) -> Any:
    """Chromium under its driver, with its profile and temporary files in ``scratch``, the driver's process
    group armed in ``reaper`` as soon as it runs, before it starts the browser."""
    from selenium import webdriver  # deferred: only for the browser check
    from selenium.webdriver.chrome.service import Service  # deferred: only for the browser check

    browser, driver_path = found
    profile, own_tmp = scratch / "profile", scratch / "tmp"  # the browser's profile, and its temporary files
    own_tmp.mkdir()
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in (*FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    service = Service(
        executable_path=driver_path,
        env={**os.environ, "TMPDIR": str(own_tmp)},
        popen_kw={"start_new_session": True},
    )
    started = service.start

    def start_and_arm() -> None:
        started()
        reaper.arm(service.process.pid)

    service.start = start_and_arm  # type: ignore[method-assign]
    return webdriver.Chrome(service=service, options=options)


def _inspect(driver: Any, page: Path, screenshot: Path | None, view_screenshot: Path | None) -> BrowserCheck:
    """The page loaded in ``driver``: its images, every view drawn, the console's errors."""
    from selenium.webdriver.common.by import By  # deferred: only for the browser check

    driver.set_script_timeout(DRAW_WAIT_S)
    driver.get(Path(page).resolve().as_uri())
    ready = driver.execute_script(
        "var t = performance.getEntriesByType('navigation')[0]; return t ? t.loadEventEnd / 1000 : 0;"
    )
    images = driver.execute_script(
        "return Array.from(document.images).map(i => [i.alt, i.complete && i.naturalWidth > 0]);"
    )
    if screenshot is not None:
        Path(screenshot).parent.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(screenshot))
    elements = driver.find_elements(By.CSS_SELECTOR, "div.view")
    keys = [str(e.get_attribute("id")) for e in elements]
    pictured = next((k for k in keys if k.startswith("view-grasp")), keys[0] if keys else None)
    views = [
        _check_view(driver, e, view_screenshot if k == pictured else None) for e, k in zip(elements, keys, strict=True)
    ]
    view_errors = list(driver.execute_script("return (window.grasptaskViews || {errors: []}).errors;"))
    errors = [e["message"] for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
    broken = [alt for alt, ok in images if not ok]
    return BrowserCheck(len(images), broken, errors, driver.title, float(ready), views, view_errors)
