"""The Python API page's first example, run as a reader would run it: pasted into a script and started with
``python script.py``. Its ``__main__`` guard is what lets the solver workers import the script again."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def test_the_api_pages_example_runs_as_a_script(tmp_path):
    example = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)[0]
    assert 'if __name__ == "__main__":' in example
    script = tmp_path / "script.py"
    script.write_text(example.replace("starts=4", "starts=2"))
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "105 ellipsoids" in done.stdout
    assert (tmp_path / "results" / "nb" / "grasps" / "drawing" / "run.json").is_file()
