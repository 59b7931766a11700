"""The physics check's protocol for one grasp: close and settle, then each test wrench ramped in and held, from
the settled state each time, and the object's worst motion from where the hand settled it. A test stops as soon
as the object has moved past its thresholds: it has failed, and the rest would cost time only."""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand.hand_model import Hand
from grasptask.objects.surface import ImplicitObject
from grasptask.physics.actuation import ActuatorMap
from grasptask.physics.grip import GripController
from grasptask.physics.loads import Test, benchmark_tests, task_tests
from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.physics.scene import ObjectBody, Scene, build_scene
from grasptask.physics.seating import Seating, seat
from grasptask.physics.sensing import hand_contacts, link_loads, pad_loads, penetration_m
from grasptask.physics.spring import SpringController
from grasptask.physics.timeline import PhaseTrace
from grasptask.task.task_model import TaskModel


@dataclass(frozen=True)
class Motion:
    """The object's largest translation (m) and rotation (deg) during a phase, from where it started it, and what
    the hand did meanwhile: the largest actuator activation (1: some tendon or motor at its limit), whether the
    actuators saturated, and the worst link's friction use at the phase's end, under the full load (or where
    the object went past the thresholds); each pad's (:func:`~grasptask.physics.sensing.pad_loads`) there, or
    where a pad last pressed once the object began to go."""

    translation_m: float
    rotation_deg: float
    peak_activation: float = 0.0
    saturated: bool = False
    friction_use: float = 0.0
    pads: np.ndarray | None = field(default=None, compare=False)

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
    #: the deepest penetration of the hand's collision geometry into the object (m): at the synthesized pose,
    #: and once the hand has settled
    initial_penetration_m: float = 0.0
    settled_penetration_m: float = 0.0
    #: the largest joint motion that seated the fingers at rest on the object first (deg; nan: not seated)
    seat_deg: float = 0.0
    controller: str = "grip"
    #: why the grasp was dropped (:func:`why_dropped`; :data:`HELD_WHY` where it held)
    why: dict[str, object] = field(default_factory=lambda: dict(HELD_WHY))
    #: with ``check_grasp(..., trace=True)``: per phase (``"settle"`` and each test), every control step
    traces: dict[str, PhaseTrace] = field(default_factory=dict)
    #: with ``trace=True``: the simulation's state where the hand had settled (``qpos``, ``qvel``, ``ctrl``),
    #: from which every test started, and the scene's state at the start (the seated posture)
    settled_state: dict[str, np.ndarray] = field(default_factory=dict)
    start_state: dict[str, np.ndarray] = field(default_factory=dict)

    def worst(self, prefix: str = "task") -> Motion:
        chosen = [m for name, m in self.tests.items() if name.startswith(prefix)]
        return Motion(
            max(m.translation_m for m in chosen),
            max(m.rotation_deg for m in chosen),
            max(m.peak_activation for m in chosen),
            any(m.saturated for m in chosen),
            max(m.friction_use for m in chosen),
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
            # over closing and the task's tests: the hand's effort and the friction its contacts used
            "physics_peak_activation": max(self.settle.peak_activation, task.peak_activation),
            "physics_saturated": self.settle.saturated or task.saturated,
            "physics_friction_use": max(self.settle.friction_use, task.friction_use),
            "physics_initial_penetration_mm": 1e3 * self.initial_penetration_m,
            "physics_penetration_mm": 1e3 * self.settled_penetration_m,
            "physics_seat_deg": self.seat_deg,
            "physics_controller": self.controller,
            "dexgraspbench_passed": self.benchmark_passed,
            "dexgraspbench_worst_translation_m": bench.translation_m,
            "dexgraspbench_worst_rotation_deg": bench.rotation_deg,
            "physics_seconds": self.seconds,
            **self.why,
        }


def _rotations_deg(quats: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The angle of each unit quaternion's rotation from ``reference``: the scalar part of ``q r^-1`` is
    ``q . r``."""
    return np.degrees(2.0 * np.arccos(np.minimum(np.abs(quats @ reference), 1.0)))


Controller = GripController | SpringController


def controller_for(scene: Scene, settings: PhysicsSettings) -> Controller:
    if settings.controller == "spring":
        return SpringController.of(scene, settings)
    return GripController.of(scene, settings)


#: past this share of a test's thresholds the object is going: the pads are read at every control step from then
#: on, so that a dropped grasp's why is the last state in which a pad still pressed, not the empty hand after
GOING = 0.25


class _Run:
    """One simulation of a scene with its controller."""

    def __init__(self, scene: Scene, settings: PhysicsSettings):
        self.scene, self.settings = scene, settings
        self.data = mujoco.MjData(scene.model)
        self.controller: Controller = controller_for(scene, settings)
        self.mapping = ActuatorMap.of(scene.actuation)
        self.every = max(1, int(round(settings.control_period_s / settings.timestep_s)))
        self.data.qpos[scene.hand_qpos] = scene.posture
        self.data.qpos[scene.object_qpos : scene.object_qpos + 7] = [0, 0, 0, 1, 0, 0, 0]
        mujoco.mj_forward(scene.model, self.data)

    def simulate(
        self, seconds: float, test: Test | None = None, stop: tuple[float, float] | None = None, trace=None
    ) -> Motion:
        """Run for ``seconds`` (the test's wrench ramped in over ``ramp_s``, then held) and return the worst
        motion from the pose at the start; stop early once the motion passes ``stop`` (m, deg); ``trace``
        collects the motion at every control step."""
        model, data, scene, settings = self.scene.model, self.data, self.scene, self.settings
        body = scene.object_body
        start_position, start_quat = data.xpos[body].copy(), data.xquat[body].copy()
        periods = max(1, int(round(seconds / (settings.timestep_s * self.every))))
        period_s = settings.timestep_s * self.every
        peak, saturated, moved, turned = 0.0, False, 0.0, 0.0
        held: np.ndarray | None = None  # the pads the last time one still pressed, once the object began to go
        for k in range(periods):
            ramp = min(1.0, k * period_s / settings.ramp_s) if test is not None else 0.0
            contacts = hand_contacts(scene, data)
            if stop is not None and (moved > GOING * stop[0] or turned > GOING * stop[1]):
                pads = pad_loads(scene, data, link_loads(scene, data, contacts))
                held = pads if not np.isnan(pads[:, 0]).all() else held
            wanted = self.controller.torques(data, contacts, test, ramp)
            mapped = self.mapping(wanted)
            data.ctrl[:] = mapped.activations
            peak, saturated = max(peak, float(mapped.activations.max(initial=0.0))), saturated or mapped.saturated
            if test is not None:
                applied = ramp * test.wrench
                force, torque = applied[:3], applied[3:]
                if test.about == "frame":  # xfrc_applied acts at the centre of mass
                    torque = torque + np.cross(data.xpos[body] - data.xipos[body], force)
                data.xfrc_applied[body, :3], data.xfrc_applied[body, 3:] = force, torque
            mujoco.mj_step(model, data, nstep=self.every)
            now_moved = float(np.linalg.norm(data.xpos[body] - start_position))
            now_turned = float(_rotations_deg(data.xquat[body][None], start_quat)[0])
            moved, turned = max(moved, now_moved), max(turned, now_turned)
            if trace is not None:
                wrench = data.xfrc_applied[body].copy()
                joints, pose = data.qpos[scene.hand_qpos], data.qpos[scene.object_qpos : scene.object_qpos + 7]
                trace.append(PhaseTrace.row((k + 1) * period_s, now_moved, now_turned, wrench, data.ctrl, pose, joints))
            if stop is not None and (moved > stop[0] or turned > stop[1]):
                break
        loads = link_loads(scene, data, hand_contacts(scene, data))  # under the full load, held or going
        data.xfrc_applied[:] = 0.0
        use = max((load.friction_use for load in loads), default=0.0)
        return Motion(moved, turned, peak, saturated, use, pad_loads(scene, data, loads) if held is None else held)


def _state(data: mujoco.MjData) -> dict[str, np.ndarray]:
    """What a MuJoCo keyframe holds of ``data``: positions, velocities and controls."""
    return {"qpos": data.qpos.copy(), "qvel": data.qvel.copy(), "ctrl": data.ctrl.copy()}


def check_grasp(
    scene: Scene,
    task: TaskModel,
    mass_kg: float,
    settings: PhysicsSettings,
    trace: bool = False,
    seating: Seating | None = None,
) -> PhysicsResult:
    """Hold ``scene``'s grasp against every test wrench of ``task`` and DexGraspBench's six forces; ``trace``
    keeps the object's motion over every phase (:attr:`PhysicsResult.traces`). ``seating``: how the scene's
    posture was seated from the synthesized one (None: it is the synthesized one)."""
    began = time.perf_counter()
    run = _Run(scene, settings)
    initial = penetration_m(scene, run.data) if seating is None else seating.synthesized_depth_m
    traces: dict[str, list] = {}
    ours = (settings.max_translation_m, settings.max_rotation_deg)
    theirs = (settings.benchmark_translation_m, settings.benchmark_rotation_deg)
    start = _state(run.data)
    settle = run.simulate(settings.settle_s, trace=traces.setdefault("settle", []) if trace else None)
    settled_depth = penetration_m(scene, run.data)
    settled_state = _state(run.data)
    run.controller.hold(run.data)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    settled = np.zeros(mujoco.mj_stateSize(scene.model, spec))
    mujoco.mj_getState(scene.model, run.data, settled, spec)
    shared = {id(scene): scene}  # the scene is the same for every test: its spec cannot be copied anyway
    held = copy.deepcopy(run.controller, shared)
    tests: dict[str, Motion] = {}
    for test in task_tests(task) + benchmark_tests(mass_kg, settings):
        mujoco.mj_setState(scene.model, run.data, settled, spec)
        mujoco.mj_forward(scene.model, run.data)
        run.controller = copy.deepcopy(held, dict(shared))
        kept = traces.setdefault(test.name, []) if trace else None
        limit = ours if test.of_task else theirs
        tests[test.name] = run.simulate(settings.ramp_s + settings.hold_s, test, None if trace else limit, kept)
    failed = next((n for n, m in tests.items() if n.startswith("task") and not m.within(*ours)), None)
    failed = failed if failed is not None else (None if settle.within(*ours) else "settle")
    return PhysicsResult(
        settle=settle,
        tests=tests,
        passed=settle.within(*ours) and failed is None,
        benchmark_passed=settle.within(*theirs)
        and all(m.within(*theirs) for n, m in tests.items() if n.startswith("dexgraspbench")),
        failed_test=failed,
        seconds=time.perf_counter() - began,
        initial_penetration_m=initial,
        settled_penetration_m=settled_depth,
        seat_deg=0.0 if seating is None else seating.moved_deg,
        controller=settings.controller,
        traces={name: PhaseTrace.of(rows, scene.model.nu, len(scene.hand_qpos)) for name, rows in traces.items()},
        settled_state=settled_state if trace else {},
        start_state=start if trace else {},
        why=why_dropped(scene, failed, settle if failed == "settle" else tests.get(failed or "")),
    )


#: a pad using this much of its friction is said to slip
SLIPPING = 0.95
#: :func:`why_dropped`'s columns for a grasp that held
HELD_WHY: dict[str, object] = {
    "physics_why": "", "physics_slip_finger": "", "physics_slip_friction_use": float("nan"),
    "physics_slip_normal_off_deg": float("nan"), "physics_lost_contact": "", "physics_friction": float("nan"),
    "physics_strength": float("nan"),
}  # fmt: skip


def why_dropped(scene: Scene, test: str | None, motion: Motion | None) -> dict[str, object]:
    """The columns that say why a grasp was dropped, from its failed phase's pads where the object went past the
    thresholds: the pad using the most friction (or the pads that pressed on nothing), the angle between
    MuJoCo's contact normal there and the object's own at the synthesized contact (the normal the NLP and the
    verifier worked with), the friction and the strength; one line ``physics_why``. :data:`HELD_WHY` where it
    held."""
    why = dict(HELD_WHY)
    if test is None or motion is None or motion.pads is None:
        return why
    names, pads = scene.finger_names, motion.pads
    loaded = ~np.isnan(pads[:, 0])
    lost = [names[f] for f in np.flatnonzero(~loaded)]
    why.update(physics_lost_contact=";".join(lost), physics_friction=scene.friction, physics_strength=scene.strength)
    said = [f"{', '.join(lost)} pressed on nothing"] if lost else []
    if loaded.any():
        f = int(np.nanargmax(np.where(loaded, pads[:, 1], np.nan)))
        off = float(np.degrees(np.arccos(np.clip(pads[f, 2:] @ scene.normals[f], -1.0, 1.0))))
        why.update(physics_slip_finger=names[f], physics_slip_friction_use=pads[f, 1], physics_slip_normal_off_deg=off)
        verb = "slipped, using" if pads[f, 1] >= SLIPPING else "used the most friction,"
        said.append(
            f"{names[f]} {verb} {pads[f, 1]:.2f} of mu {scene.friction:g}, MuJoCo's normal there {off:.1f} deg off "
            "the object's at the synthesized contact"
        )
    strength = "at its limit" if motion.saturated else f"at {motion.peak_activation:.2f} of its limit"
    said.append(f"peak activation {strength} ({scene.strength:g}x the hand model's strength)")
    why["physics_why"] = f"{test}: " + "; ".join(said)
    return why


def seated_scene(
    hand: Hand,
    obj: ImplicitObject,
    body: ObjectBody,
    grasp: Grasp,
    friction: float,
    settings: PhysicsSettings,
    strength: float = 1.0,
    pad_torsion: float = 0.0,
) -> tuple[Scene, Seating]:
    """``grasp`` by ``hand`` on ``obj`` (``body`` its MuJoCo parts) built into a scene, the hand ``strength``
    times as strong as its model (its flat pads twisting with ``pad_torsion``), its fingers seated at rest on
    the object (:mod:`grasptask.physics.seating`)."""
    scene = build_scene(hand, obj, body, grasp, friction, settings, strength, pad_torsion)
    seating = seat(scene, hand, scene.posture)
    if seating.joints is not None:
        scene = replace(scene, posture=seating.joints)
    return scene, seating


def hold_grasp(
    hand: Hand,
    obj: ImplicitObject,
    body: ObjectBody,
    grasp: Grasp,
    friction: float,
    task: TaskModel,
    settings: PhysicsSettings,
    strength: float = 1.0,
    pad_torsion: float = 0.0,
) -> PhysicsResult:
    """:func:`seated_scene`'s grasp put through :func:`check_grasp` (a check that keeps its trace is
    :meth:`~grasptask.physics.judge.Holding.traced`'s)."""
    scene, seating = seated_scene(hand, obj, body, grasp, friction, settings, strength, pad_torsion)
    return check_grasp(scene, task, body.mass_kg, settings, seating=seating)
