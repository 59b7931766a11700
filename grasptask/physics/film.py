"""A physics check you can watch: one phase of a traced check (the test that dropped the grasp, or its worst
one) rendered offscreen by MuJoCo, frame by frame from the recorded poses, as a short GIF.

MuJoCo picks its OpenGL platform (``MUJOCO_GL``) when it is first imported, and a process that has already
imported it for the physics check cannot change it. So the frames are rendered in a child process, from the
exported scene's own files (:mod:`grasptask.physics.scene_file`), with ``MUJOCO_GL=egl`` unless the user set
another; where no platform works, :func:`offscreen_unavailable` says why, once, and nothing is filmed."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np

#: the film's size (pixels), frame count at most and frame time (ms): small enough for a report to hold a few
WIDTH, HEIGHT, MAX_FRAMES, FRAME_MS = 320, 240, 25, 80
#: the film's colours: the object as the report draws it, the hand pale
OBJECT_RGBA, HAND_RGBA = (0.93, 0.6, 0.25, 1.0), (0.85, 0.82, 0.78, 1.0)
#: the seconds a child process may take to render a film
TIMEOUT_S = 120
PROBE = """
import mujoco
model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom size="0.1"/></worldbody></mujoco>')
renderer = mujoco.Renderer(model, 8, 8)
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer.update_scene(data)
renderer.render()
"""


def _environment() -> dict[str, str]:
    return {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL") or "egl", "OPENBLAS_NUM_THREADS": "1"}


@lru_cache(maxsize=1)
def offscreen_unavailable() -> str | None:
    """None where MuJoCo can render offscreen here, else its reason in one line."""
    try:
        done = subprocess.run(
            [sys.executable, "-c", PROBE], capture_output=True, text=True, env=_environment(), timeout=TIMEOUT_S
        )
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"MuJoCo could not start rendering ({type(error).__name__})"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
    return f"MuJoCo cannot render offscreen here (MUJOCO_GL={_environment()['MUJOCO_GL']}: " + (
        f"{lines[-1].strip()})" if lines else f"exit code {done.returncode})"
    )


def film(files: dict[str, bytes], qpos: np.ndarray, lookat: np.ndarray, distance: float) -> bytes | None:
    """The GIF of ``qpos`` (one row per frame, the scene's whole ``qpos``) in the scene ``files`` hold, seen from
    ``distance`` (m) at ``lookat``; None where offscreen rendering is unavailable or fails."""
    if offscreen_unavailable() is not None:
        return None
    picked = np.unique(np.linspace(0, len(qpos) - 1, min(len(qpos), MAX_FRAMES)).round().astype(int))
    with tempfile.TemporaryDirectory(prefix="grasptask-film-") as scratch:
        folder = Path(scratch)
        for name, content in files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(content)
        np.save(folder / "frames.npy", np.asarray(qpos, dtype=float)[picked])
        camera = {"lookat": [float(v) for v in lookat], "distance": float(distance)}
        (folder / "camera.json").write_text(json.dumps(camera))
        command = [sys.executable, "-m", "grasptask.physics.film", str(folder)]
        try:
            done = subprocess.run(command, capture_output=True, env=_environment(), timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            return None
        out = folder / "film.gif"
        return out.read_bytes() if done.returncode == 0 and out.is_file() else None


def _render(folder: Path) -> None:
    """The child process: every frame of ``folder/frames.npy`` rendered, written as ``folder/film.gif``."""
    import mujoco
    from PIL import Image

    model = mujoco.MjModel.from_xml_path(str(folder / "scene.xml"))
    data = mujoco.MjData(model)
    camera = json.loads((folder / "camera.json").read_text())
    view = mujoco.MjvCamera()
    view.lookat[:], view.distance, view.azimuth, view.elevation = camera["lookat"], camera["distance"], 135.0, -25.0
    # the object orange and the hand pale, under a bright headlight: MuJoCo's grey on grey in the dark is unreadable
    body = model.body("object").id
    model.geom_rgba[:] = np.where((model.geom_bodyid == body)[:, None], OBJECT_RGBA, HAND_RGBA)
    model.vis.headlight.ambient[:], model.vis.headlight.diffuse[:] = 0.45, 0.6
    frames = []
    with mujoco.Renderer(model, HEIGHT, WIDTH) as renderer:
        for qpos in np.load(folder / "frames.npy"):
            data.qpos[:] = qpos
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=view)
            frames.append(Image.fromarray(renderer.render()).convert("P", palette=Image.Palette.ADAPTIVE, colors=64))
    frames[0].save(folder / "film.gif", save_all=True, append_images=frames[1:], duration=FRAME_MS, loop=0)


if __name__ == "__main__":
    _render(Path(sys.argv[1]))
