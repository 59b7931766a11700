"""``grasptask hand`` on a LEAP-sized hand (6,600 collision spheres, as the published LEAP URDF's thin boxes make
them): the page draws every sphere from one template sphere and a centre and radius each, and stays under 3 MB
(13.9 MB when each was a mesh of its own)."""

from __future__ import annotations

import base64
import json
import re

import numpy as np

from grasptask.hand import load_hand
from grasptask.report.browser_check import check_page, find_chromium
from tests.hand_files import write_leap_like

MAX_PAGE_BYTES = 3_000_000


def test_a_leap_sized_hand_page_is_small_and_draws_every_sphere(tmp_path, cli):
    urdf = write_leap_like(tmp_path)
    hand = load_hand(urdf)
    spheres = sum(len(f.spheres) for f in hand.fingers.values()) + len(hand.palm.radii)
    assert spheres > 5000
    result = cli("hand", urdf, "--out", tmp_path / "check")
    assert result.exit_code == 0, result.output
    page = tmp_path / "check" / "hand.html"
    assert page.stat().st_size < MAX_PAGE_BYTES, page.stat().st_size
    text = page.read_text()
    figure = json.loads(re.search(r'id="view-hand-data">(.*?)</script>', text, re.S).group(1).replace("<\\/", "</"))
    instanced = [t for t in figure["data"] if (t.get("meta") or {}).get("spheres")]
    drawn = [np.frombuffer(base64.b64decode(t["meta"]["spheres"]["data"]), "<f4").reshape(-1, 4) for t in instanced]
    assert sum(len(d) for d in drawn) == spheres  # every sphere, none dropped
    assert all((d[:, 3] > 0).all() and np.isfinite(d).all() for d in drawn)
    if find_chromium() is not None:  # the page builds the spheres and draws them, offline, with no error
        checked = check_page(page)
        assert checked.views and all(v.ok for v in checked.views), checked.problems()
        assert not checked.view_errors and not checked.console_errors
