"""The physics check's protocol for one grasp: close and settle, then each test wrench ramped in and held,
from the settled state each time, and the object's worst motion from where the hand settled it.

The tests are the task's own wrenches, +-gamma_i u_i for the ellipsoid's six axes (eq. 10's 12 blocks), with
their torques about the task frame's origin, and DexGraspBench's six +-axis forces of ``m a`` at the centre of
mass, so that the numbers compare with theirs. Gravity is off: the recorded wrenches are the whole load."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from grasptask.grasp.grasp import Grasp
from grasptask.hand.model import Hand
from grasptask.objects.surface import ImplicitObject
from grasptask.physics.controller import FingertipController, Gains
from grasptask.physics.scene import ObjectBody, Scene, build_scene
from grasptask.physics.settings import PhysicsSettings
from grasptask.task.model import TaskModel


@dataclass(frozen=True)
class Test:
    """A wrench on the object: force (N) and torque (N m) in the world frame, the torque about ``about``
    (``"frame"``: the object frame's origin, where the task was recorded; ``"com"``: its centre of mass)."""

    name: str
    wrench: np.ndarray
    about: str

    def grip_n(self, contacts: np.ndarray, friction: float) -> float:
        """The normal force per finger that friction needs to carry this wrench: ``|f| / (mu b)`` for the
        force, and ``|tau| / (mu sum_j r_j)`` for the torque, ``r_j`` each contact's distance from the torque's
        axis through the task frame's origin (the hand's grip, raised with the load as a person's is)."""
        force, torque = np.linalg.norm(self.wrench[:3]), np.linalg.norm(self.wrench[3:])
        grip = force / (friction * len(contacts))
        if torque > 0:
            levers = np.linalg.norm(np.cross(self.wrench[3:] / torque, contacts), axis=1)
            grip += torque / (friction * max(float(levers.sum()), 1e-6))
        return float(grip)


@dataclass(frozen=True)
class Motion:
    """The object's largest translation (m) and rotation (deg) during a phase, from where it started it."""

    translation_m: float
    rotation_deg: float
    #: the largest actuator activation the controller asked for (1: some tendon or motor at its limit)
    peak_activation: float = 0.0

    def within(self, translation_m: float, rotation_deg: float) -> bool:
        return self.translation_m <= translation_m and self.rotation_deg <= rotation_deg


@dataclass(frozen=True)
class PhysicsResult:
    settle: Motion
    tests: dict[str, Motion]
    passed: bool
    benchmark_passed: bool
    failed_test: str | None  # the first of the task's tests that moved the object too far (None: none did)
    seconds: float
    #: with ``check_grasp(..., trace=True)``: per phase (``"settle"`` and each test), the object's motion at
    #: every control step, ``(n, 3)``: seconds into the phase, translation (m), rotation (deg)
    traces: dict[str, np.ndarray] = field(default_factory=dict)

    def worst(self, prefix: str = "task") -> Motion:
        chosen = [m for name, m in self.tests.items() if name.startswith(prefix)]
        return Motion(
            max(m.translation_m for m in chosen),
            max(m.rotation_deg for m in chosen),
            max(m.peak_activation for m in chosen),
        )

    def record(self) -> dict[str, object]:
        """The columns of one row of ``physics.parquet``."""
        task, bench = self.worst("task"), self.worst("dexgraspbench")
        failed = self.settle if self.failed_test == "settle" else self.tests.get(self.failed_test or "")
        return {
            "physics_passed": self.passed,
            "physics_settle_translation_m": self.settle.translation_m,
            "physics_settle_rotation_deg": self.settle.rotation_deg,
            "physics_worst_translation_m": task.translation_m,
            "physics_worst_rotation_deg": task.rotation_deg,
            "physics_failed_wrench": self.failed_test or "",
            # at its limit (1.0) while the object went: the hand, as controlled, ran out of strength; below 1,
            # the contacts slipped with strength to spare
            "physics_failed_peak_activation": failed.peak_activation if failed is not None else float("nan"),
            "dexgraspbench_passed": self.benchmark_passed,
            "dexgraspbench_worst_translation_m": bench.translation_m,
            "dexgraspbench_worst_rotation_deg": bench.rotation_deg,
            "physics_seconds": self.seconds,
        }


def task_tests(task: TaskModel) -> list[Test]:
    """``+-gamma_i u_i`` for each axis of the task ellipsoid, named ``task+u1`` ... ``task-u6``."""
    return [
        Test(f"task{'+-'[s]}u{i + 1}", (1.0 - 2.0 * s) * task.lengths[i] * task.axes[i], "frame")
        for i in range(len(task.lengths))
        for s in (0, 1)
    ]


def benchmark_tests(mass_kg: float, settings: PhysicsSettings) -> list[Test]:
    """DexGraspBench's force-closure test: forces of ``m a`` along -x, +x, -y, +y, -z, +z."""
    force = mass_kg * settings.benchmark_acceleration_m_s2
    tests = []
    for axis, label in enumerate("xyz"):
        for sign in (-1.0, 1.0):
            wrench = np.zeros(6)
            wrench[axis] = sign * force
            tests.append(Test(f"dexgraspbench{'-+'[sign > 0]}{label}", wrench, "com"))
    return tests


def _rotations_deg(quats: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The angle of each unit quaternion's rotation from ``reference``: the scalar part of ``q r^-1`` is
    ``q . r``."""
    return np.degrees(2.0 * np.arccos(np.minimum(np.abs(quats @ reference), 1.0)))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for two 3-vectors (np.cross's generality costs more than a control step)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when it is a contiguous increasing range, else as it is."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


class _Run:
    """One simulation of a scene with its controller, and the object's pose to measure motion from."""

    def __init__(self, scene: Scene, settings: PhysicsSettings):
        self.scene, self.settings = scene, settings
        self.data = mujoco.MjData(scene.model)
        gains = Gains(
            settings.tip_stiffness_n_per_m,
            settings.tip_damping_ns_per_m,
            settings.posture_stiffness_nm_per_rad,
            settings.posture_damping_nms_per_rad,
        )
        self.controller = FingertipController(
            scene.actuation, scene.posture, scene.contacts, scene.normals, settings.squeeze_m, gains
        )
        self.preload_n = 0.0
        self.jacobians = np.zeros((len(scene.pad_sites), 3, scene.model.nv))
        self.sites = [int(site) for site in scene.pad_sites]
        # the hand's joints as slices where they are contiguous (they are, before the object's free joint): a
        # view costs less than fancy indexing at every control step
        self.qpos, self.dof = _as_slice(scene.hand_qpos), _as_slice(scene.hand_dof)
        self.every = max(1, int(round(settings.control_period_s / settings.timestep_s)))
        self.data.qpos[scene.hand_qpos] = scene.posture
        self.data.qpos[scene.object_qpos : scene.object_qpos + 7] = [0, 0, 0, 1, 0, 0, 0]
        mujoco.mj_forward(scene.model, self.data)

    def control(self) -> np.ndarray:
        scene, data = self.scene, self.data
        for k, site in enumerate(self.sites):
            mujoco.mj_jacSite(scene.model, data, self.jacobians[k], None, site)
        return self.controller.activations(
            data.qpos[self.qpos], data.qvel[self.dof], data.site_xpos[scene.pad_sites], self.jacobians[:, :, self.dof]
        )

    def simulate(self, seconds: float, test: Test | None = None, trace: list | None = None) -> Motion:
        """Run for ``seconds`` (the test's wrench ramped in over ``ramp_s``, then held) and return the worst
        motion from the pose at the start; ``trace`` collects the motion at every control step."""
        model, data, scene, settings = self.scene.model, self.data, self.scene, self.settings
        body = scene.object_body
        steps = int(round(seconds / settings.timestep_s))
        positions, quats = np.empty((steps + 1, 3)), np.empty((steps + 1, 4))
        positions[0], quats[0] = data.xpos[body], data.xquat[body]
        peak = 0.0
        grip = 0.0 if test is None else settings.grip_safety * test.grip_n(scene.contacts, scene.friction)
        for step in range(steps):
            ramp = min(1.0, (step + 1) * settings.timestep_s / settings.ramp_s)
            if self.preload_n > 0:
                self.controller.scale = 1.0 + ramp * grip / self.preload_n
            if step % self.every == 0:
                data.ctrl[:] = self.control()
                peak = max(peak, float(data.ctrl.max(initial=0.0)))
            if test is not None:
                force, torque = ramp * test.wrench[:3], ramp * test.wrench[3:]
                if test.about == "frame":  # xfrc_applied acts at the centre of mass
                    torque = torque + _cross(data.xpos[body] - data.xipos[body], force)
                data.xfrc_applied[body, :3], data.xfrc_applied[body, 3:] = force, torque
            mujoco.mj_step(model, data)
            positions[step + 1], quats[step + 1] = data.xpos[body], data.xquat[body]
        data.xfrc_applied[:] = 0.0
        moved = np.linalg.norm(positions[1:] - positions[0], axis=1)
        turned = _rotations_deg(quats[1:], quats[0])
        if trace is not None:
            kept = np.arange(self.every - 1, steps, self.every)
            trace.extend(zip((kept + 1) * settings.timestep_s, moved[kept], turned[kept], strict=True))
        return Motion(float(moved.max(initial=0.0)), float(turned.max(initial=0.0)), peak)


def check_grasp(
    scene: Scene, task: TaskModel, mass_kg: float, settings: PhysicsSettings, trace: bool = False
) -> PhysicsResult:
    """Hold ``scene``'s grasp against every test wrench of ``task`` and DexGraspBench's six forces; ``trace``
    keeps the object's motion over every phase (:attr:`PhysicsResult.traces`)."""
    began = time.perf_counter()
    run = _Run(scene, settings)
    traces: dict[str, list] = {}
    settle = run.simulate(settings.settle_s, trace=traces.setdefault("settle", []) if trace else None)
    run.preload_n = run.controller.hold(run.data.site_xpos[scene.pad_sites].copy())
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    settled = np.zeros(mujoco.mj_stateSize(scene.model, spec))
    mujoco.mj_getState(scene.model, run.data, settled, spec)
    controls = run.controller.current.copy()
    held = (run.controller.rest.copy(), run.controller.preload.copy())
    tests: dict[str, Motion] = {}
    for test in task_tests(task) + benchmark_tests(mass_kg, settings):
        mujoco.mj_setState(scene.model, run.data, settled, spec)
        mujoco.mj_forward(scene.model, run.data)
        run.controller.current = controls.copy()
        run.controller.rest, run.controller.preload = held[0].copy(), held[1].copy()
        kept = traces.setdefault(test.name, []) if trace else None
        tests[test.name] = run.simulate(settings.ramp_s + settings.hold_s, test, kept)
    ours = (settings.max_translation_m, settings.max_rotation_deg)
    theirs = (settings.benchmark_translation_m, settings.benchmark_rotation_deg)
    failed = next((n for n, m in tests.items() if n.startswith("task") and not m.within(*ours)), None)
    return PhysicsResult(
        settle=settle,
        tests=tests,
        passed=settle.within(*ours) and failed is None,
        benchmark_passed=settle.within(*theirs)
        and all(m.within(*theirs) for n, m in tests.items() if n.startswith("dexgraspbench")),
        failed_test=failed if failed is not None else (None if settle.within(*ours) else "settle"),
        seconds=time.perf_counter() - began,
        traces={name: np.array(rows).reshape(-1, 3) for name, rows in traces.items()},
    )


def hold_grasp(
    hand: Hand,
    obj: ImplicitObject,
    body: ObjectBody,
    grasp: Grasp,
    friction: float,
    task: TaskModel,
    settings: PhysicsSettings,
    trace: bool = False,
) -> PhysicsResult:
    """``grasp`` by ``hand`` on ``obj`` (``body`` its MuJoCo parts) built into a scene and put through
    :func:`check_grasp`."""
    scene = build_scene(hand, obj, body, grasp, friction, settings)
    return check_grasp(scene, task, body.mass_kg, settings, trace)
