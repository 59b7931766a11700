"""Open a report in headless Chromium (Debian's ``chromium`` and ``chromium-driver``) and check that every image
loads and the console stays free of errors; optionally save a screenshot of the top of the page."""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from grasptask.errors import BadInputError

#: without the background-networking flags Chromium keeps trying to reach Google's hosts on a closed network
FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)


@dataclass(frozen=True)
class BrowserCheck:
    images: int
    broken_images: list[str] = field(default_factory=list)
    console_errors: list[str] = field(default_factory=list)
    title: str = ""

    @property
    def ok(self) -> bool:
        return self.images > 0 and not self.broken_images and not self.console_errors


def find_chromium() -> tuple[str, str] | None:
    """Paths of the browser and its driver, or None when they are not installed."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    return (browser, driver) if browser and driver else None


def check_page(page: Path, screenshot: Path | None = None, width: int = 1280, height: int = 900) -> BrowserCheck:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    found = find_chromium()
    if found is None:
        raise BadInputError(
            "chromium", "not installed (apt-get install chromium chromium-driver, or make setup-browser)"
        )
    os.environ.setdefault("SE_OFFLINE", "true")  # selenium must not try to download a driver
    browser, driver_path = found
    with tempfile.TemporaryDirectory(prefix="grasptask-chromium-") as profile:
        options = webdriver.ChromeOptions()
        options.binary_location = browser
        for flag in (*FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}"):
            options.add_argument(flag)
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        driver = webdriver.Chrome(service=Service(executable_path=driver_path), options=options)
        try:
            driver.get(Path(page).resolve().as_uri())
            images = driver.execute_script(
                "return Array.from(document.images).map(i => [i.alt, i.complete && i.naturalWidth > 0]);"
            )
            errors = [e["message"] for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
            if screenshot is not None:
                Path(screenshot).parent.mkdir(parents=True, exist_ok=True)
                driver.save_screenshot(str(screenshot))
            title = driver.title
        finally:
            driver.quit()
    return BrowserCheck(len(images), [alt for alt, ok in images if not ok], errors, title)
