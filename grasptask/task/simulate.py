"""Synthetic sensorized-tool demonstrations of the paper's three tasks (Section 7; README, "The demonstration
simulator").

Each task is a small physical model of the contact between the tool tip and the environment, expressed in
the object frame (origin at the handle centre, z along the handle):

* drawing: the paper pushes the tip up with a normal force ``N(t)``; kinetic friction ``mu N`` opposes the
  tip's circular motion in the paper plane, so it turns with the circle. The pen is tilted from the paper
  normal and rolled about its own axis by an amount that differs per trial. The tip lies on the handle
  axis, so the lever arm gives torques about x and y and almost none about z.
* cutting: the blade is sawn back and forth; the candle resists with a force that flips with the stroke
  direction, and pushes back on the blade as the subject presses down. The knife is held inclined in its own
  x-z plane, so both forces load the tool's x and z axes; the lever arm along z makes the torque about y.
* screw driving: the subject pushes along the handle and twists in strokes (torque about z); the tip slips
  on the edge of the screw head, a lateral force in a direction fixed per trial that wobbles the tool
  (torques about x and y).

Every recording also carries subject and grasp-type scale factors, sensor noise, a sensor bias and the
end-effector's weight, measured in the sensor frame during an initial static window (no contact) that
``fit-task`` uses for bias removal. Some subjects' recordings are stored in the sensor frame, the rest
transformed to the object frame, so ingestion's frame transformation is exercised.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic.dataclasses import dataclass as schema
from scipy import signal, stats
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.io.config_schema import SCHEMA, load_yaml, validated
from grasptask.task.frames import transform_wrenches, wrench_transform
from grasptask.task.tool import ToolConfig

GRAVITY = 9.81
TASK_GRASPS = {"drawing": ("tripod", "cylindrical", "power"), "cutting": ("free",), "screwdriving": ("free",)}


@dataclass(frozen=True)
class Trial:
    task: str
    grasp: str
    subject: int
    trial: int


def trials(config: dict[str, Any]) -> list[Trial]:
    """The demonstration protocol: every task and grasp type, subjects x trials."""
    subjects, repeats = config["protocol"]["subjects"], config["protocol"]["trials"]
    return [
        Trial(task, grasp, s, r)
        for task, grasps in TASK_GRASPS.items()
        for grasp in grasps
        for s in range(1, subjects + 1)
        for r in range(1, repeats + 1)
    ]


@schema(frozen=True, config=SCHEMA)
class SimulateFile:
    """The simulator config's sections (``configs/simulate.yaml``); each holds the model's parameters."""

    protocol: dict[str, Any]
    sensor: dict[str, Any]
    subjects: dict[str, Any]
    tasks: dict[str, Any]
    description: str = ""


def load_config(path: str | Path) -> dict[str, Any]:
    """Load and check a simulator config; every section the model reads must be present."""
    config = load_yaml(path)
    validated(SimulateFile, config, path)
    for task in TASK_GRASPS:
        if task not in config["tasks"]:
            raise BadInputError(path, f"missing task section 'tasks.{task}'")
    return config


def _smooth(rng: np.random.Generator, n: int, rate: float, cutoff_hz: float) -> np.ndarray:
    """Zero-mean, unit-variance random process band-limited to ``cutoff_hz`` (hand tremor, varying effort)."""
    white = rng.standard_normal(n + 200)
    sos = signal.butter(2, cutoff_hz, fs=rate, output="sos")
    x = signal.sosfiltfilt(sos, white)[100:-100]
    return (x - x.mean()) / x.std()


def _lognormal(rng: np.random.Generator, sd: float) -> float:
    return float(np.exp(sd * rng.standard_normal() - 0.5 * sd**2))


def _tilt(alpha: float, azimuth: float, roll: float) -> np.ndarray:
    """Tool orientation in the world: rolled about its own axis, then tilted by ``alpha`` towards ``azimuth``."""
    axis = np.array([-np.sin(azimuth), np.cos(azimuth), 0.0])
    return (Rotation.from_rotvec(alpha * axis) * Rotation.from_rotvec([0.0, 0.0, roll])).as_matrix()


@dataclass(frozen=True)
class Contact:
    """A task's contact over time: force on the tool tip in the world frame, the tool's orientation in the
    world, the contact point in the object frame (fixed, or one row per sample) and any pure moment."""

    force_world: np.ndarray
    orientation: np.ndarray
    point: np.ndarray
    moment: np.ndarray | None = None


def _contact_point(p: dict, rng) -> np.ndarray:
    return np.asarray(p["contact_point_m"], dtype=float) + rng.normal(0.0, p.get("contact_point_sd_m", 0.0), 3)


def _drawing(p: dict, t: np.ndarray, rng, scale: float, rate: float) -> Contact:
    """Paper plane x-y, normal z in the world; the pen tip is a point on the handle axis."""
    n = len(t)
    freq = p["circle_hz"] * _lognormal(rng, 0.15)
    phase = 2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi)
    normal = scale * p["normal_force_n"] * (1 + p["normal_variation"] * _smooth(rng, n, rate, 1.5))
    normal = np.clip(normal, 0.05 * scale * p["normal_force_n"], None)
    aspect = p["stroke_aspect"] * _lognormal(rng, p["stroke_aspect_sd"])
    direction = np.stack([-np.sin(phase), aspect * np.cos(phase)], axis=1) / np.sqrt((1 + aspect**2) / 2)
    friction = p["friction"] * _lognormal(rng, p["friction_sd"])
    force = np.column_stack([friction * normal[:, None] * direction, normal])
    alpha = np.deg2rad(rng.normal(p["tilt_deg"], p["tilt_sd_deg"]))
    azimuth = np.deg2rad(rng.normal(p["tilt_azimuth_deg"], p["tilt_azimuth_sd_deg"]))
    roll = np.deg2rad(rng.normal(p["roll_deg"], p["roll_sd_deg"]))
    return Contact(force, _tilt(alpha, azimuth, roll), _contact_point(p, rng))


def _cutting(p: dict, t: np.ndarray, rng, scale: float, rate: float) -> Contact:
    """Sawing along the world x axis; the cut point travels along the blade edge (tool x) with the stroke."""
    n = len(t)
    freq = p["stroke_hz"] * _lognormal(rng, 0.15)
    phase = 2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi)
    effort = 1 + p["effort_variation"] * _smooth(rng, n, rate, 1.0)
    resist = -scale * p["cutting_force_n"] * effort * np.tanh(3 * np.sin(phase))
    press = scale * p["press_force_n"] * (1 + p["press_variation"] * _smooth(rng, n, rate, 1.0))
    lateral = scale * p["lateral_force_n"] * _smooth(rng, n, rate, 3.0)
    force = np.column_stack([resist, lateral, press])
    alpha = np.deg2rad(rng.normal(p["tilt_deg"], p["tilt_sd_deg"]))
    yaw = np.deg2rad(rng.normal(0.0, p["yaw_sd_deg"]))
    point = np.tile(_contact_point(p, rng), (n, 1))
    point[:, 0] += -p["blade_travel_m"] * np.cos(phase)
    # the kerf resists the wrist's small rolls of the blade: a moment about the tool axis
    moment = np.zeros((n, 3))
    moment[:, 2] = scale * p["kerf_torque_nm"] * _smooth(rng, n, rate, 2.0)
    # inclined in the tool's own x-z plane (azimuth 0, no roll), then turned a little about the vertical
    return Contact(force, Rotation.from_rotvec([0, 0, yaw]).as_matrix() @ _tilt(alpha, 0.0, 0.0), point, moment)


def _screwdriving(p: dict, t: np.ndarray, rng, scale: float, rate: float) -> Contact:
    """Axial push and twist strokes about z; the tip slips on the screw head's edge in a per-trial direction."""
    n = len(t)
    freq = p["turn_hz"] * _lognormal(rng, 0.15)
    turn = np.sin(2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi))
    push = scale * p["push_force_n"] * (1 + p["push_variation"] * _smooth(rng, n, rate, 0.8))
    slip_dir = rng.uniform(0, 2 * np.pi)
    wobble = turn + p["slip_bias"] + 0.5 * _smooth(rng, n, rate, 2.0)
    slip = scale * p["slip_force_n"] * _lognormal(rng, p["slip_sd"]) * wobble
    across = scale * p["slip_force_n"] * p["slip_across"] * _smooth(rng, n, rate, 2.0)
    fx = slip * np.cos(slip_dir) - across * np.sin(slip_dir)
    fy = slip * np.sin(slip_dir) + across * np.cos(slip_dir)
    force = np.column_stack([fx, fy, push])
    twist = (
        scale
        * p["twist_torque_nm"]
        * _lognormal(rng, p["twist_sd"])
        * (np.sqrt(np.maximum(turn, 0)) - p["twist_offset"])
    )
    moment = np.column_stack([np.zeros(n), np.zeros(n), twist])
    alpha = np.deg2rad(rng.normal(p["tilt_deg"], p["tilt_sd_deg"]))
    return Contact(force, _tilt(alpha, rng.uniform(0, 2 * np.pi), 0.0), _contact_point(p, rng), moment)


TASK_MODELS: dict[str, Callable] = {"drawing": _drawing, "cutting": _cutting, "screwdriving": _screwdriving}


def simulate_trial(config: dict[str, Any], trial: Trial, seed: int) -> tuple[np.ndarray, bool]:
    """Samples ``(n, 7)`` of one trial (t in s, N, N.m) and whether they are stored in the sensor frame."""
    rng = np.random.default_rng(
        [seed, list(TASK_GRASPS).index(trial.task), trial.subject, trial.trial, hash_grasp(trial.grasp)]
    )
    sensor, p = config["sensor"], task_parameters(config, trial.task, trial.grasp)
    rate = float(sensor["rate_hz"])
    scale = (
        subject_scales(config, seed)[trial.subject - 1]
        * _lognormal(rng, config["subjects"]["trial_sd"])
        * p.get("scale", 1.0)
    )
    duration = p["duration_s"] * _lognormal(rng, 0.15)
    static = float(sensor["static_s"])
    t = np.arange(0.0, static + duration, 1.0 / rate)
    task_t = t[t >= static] - static
    contact = TASK_MODELS[trial.task](p, task_t, rng, scale, rate)
    orientation = contact.orientation
    force = contact.force_world @ orientation  # rows: R^T f, the world force in the tool's object frame
    torque = np.cross(contact.point, force)
    if contact.moment is not None:
        torque += contact.moment
    wrench = np.zeros((len(t), 6))
    wrench[t >= static] = np.column_stack([force, torque])
    # the end effector's weight, seen in the tool frame held at the trial's orientation
    weight = orientation.T @ np.array([0.0, 0.0, -GRAVITY * sensor["end_effector_mass_kg"]])
    wrench += np.concatenate([weight, np.cross(sensor["end_effector_com_m"], weight)])
    # to the sensor frame, where bias and noise live
    tool = sensor_tool(config)
    to_sensor = np.linalg.inv(wrench_transform(tool.sensor_rotation, tool.sensor_position))
    measured = wrench @ to_sensor.T
    measured += np.concatenate([rng.normal(0, sensor["bias_force_n"], 3), rng.normal(0, sensor["bias_torque_nm"], 3)])
    noise = np.concatenate([np.full(3, sensor["noise_force_n"]), np.full(3, sensor["noise_torque_nm"])])
    measured += rng.standard_normal(measured.shape) * noise
    in_sensor_frame = trial.subject in set(sensor["sensor_frame_subjects"])
    if not in_sensor_frame:
        measured = transform_wrenches(measured, tool.sensor_rotation, tool.sensor_position)
    return np.column_stack([t, measured]), in_sensor_frame


def subject_scales(config: dict[str, Any], seed: int) -> np.ndarray:
    """Each subject's effort factor: stratified quantiles of a log-normal with mean 1, in a seeded order.

    Stratifying makes the panel span the population as a recruited one would, so that group means do not
    hinge on one unusually strong or weak subject among seven.
    """
    n, sd = config["protocol"]["subjects"], config["subjects"]["scale_sd"]
    quantiles = stats.norm.ppf((np.arange(n) + 0.5) / n)
    return np.exp(sd * np.random.default_rng([seed, 1000]).permutation(quantiles) - 0.5 * sd**2)


def task_parameters(config: dict[str, Any], task: str, grasp: str) -> dict[str, Any]:
    """A task's parameters with its grasp type's overrides (``tasks.<task>.grasps.<grasp>``) applied."""
    params = dict(config["tasks"][task])
    params.update(params.pop("grasps", {}).get(grasp, {}))
    return params


def hash_grasp(grasp: str) -> int:
    return sum(ord(c) * 31**i for i, c in enumerate(grasp)) % (2**31)


def sensor_tool(config: dict[str, Any]) -> ToolConfig:
    sensor = config["sensor"]
    rotation = Rotation.from_euler("xyz", sensor["rotation_rpy_deg"], degrees=True).as_matrix()
    return ToolConfig(
        name="sensorized_tool", sensor_position=np.asarray(sensor["position_m"], float), sensor_rotation=rotation
    )


def tool_yaml(config: dict[str, Any]) -> str:
    sensor = config["sensor"]
    return (
        "name: sensorized_tool\n"
        "description: simulated sensorized tool; the 6-axis sensor sits between the handle and the end effector\n"
        "sensor:\n"
        f"  position_m: {list(map(float, sensor['position_m']))}\n"
        f"  rotation_rpy_deg: {list(map(float, sensor['rotation_rpy_deg']))}\n"
    )


def simulate(
    config: dict[str, Any], seed: int, progress: Callable[[Iterable], Iterable] = iter
) -> Iterator[tuple[Trial, np.ndarray, bool]]:
    """Yield ``(trial, samples, in_sensor_frame)`` for the whole protocol."""
    for trial in progress(trials(config)):
        samples, in_sensor = simulate_trial(config, trial, seed)
        yield trial, samples, in_sensor
