"""The newest features' hostile inputs (issue 87's audit): each one line naming the value and its bound, exit 2,
nothing written, before any solver runs. The hand files' cases are in ``test_hand_limits.py``, the MATLAB files'
in ``test_matlab_cells.py``."""

from __future__ import annotations

import re

import numpy as np
import pytest

from grasptask.errors import BadInputError
from grasptask.task.preprocess import MAX_RESAMPLED, Preprocess, resample


def test_a_resample_rate_beyond_any_sensor_is_refused(cli, recording_factory, tmp_path):
    recording = recording_factory()
    result = cli("fit-task", recording, "--out", tmp_path / "out", "--resample", "1e9")
    assert result.exit_code == 2 and "1000000000.0 is not in the range 0<x<=100000" in result.output
    assert not (tmp_path / "out").exists()
    with pytest.raises(BadInputError, match="1e\\+09 Hz is beyond 100000 Hz"):
        Preprocess(resample_hz=1e9)
    long = np.array([0.0, 3600.0 * 10])  # ten hours at the highest rate: more samples than a recording may hold
    with pytest.raises(ValueError, match=re.escape(f"3.6e+09 samples, beyond {MAX_RESAMPLED:.3g}")):
        resample(long, np.zeros((2, 6)), 100_000.0)


def test_a_torsional_friction_beyond_any_pad_is_refused(cli, tasks, tmp_path):
    config = tmp_path / "grasp.yaml"
    config.write_text("torsional_friction_m: 1.0e6\n")
    result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "g", "--grasp-config",
                 config, "--starts", "1")  # fmt: skip
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "torsional_friction_m" in lines[0] and "0.05" in lines[0] and "grasp.yaml" in lines[0], lines[0]
    assert not (tmp_path / "g").exists()
