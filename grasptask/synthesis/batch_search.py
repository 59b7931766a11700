"""The search (SPEC section 12): every start of a batch moved at once by gradient steps on the palm pose and the
joints, nothing else, with a fixed iteration budget.

Each start minimises ``log Q + penalties`` (:mod:`grasptask.synthesis.batch_geometry`): eq. 12's Q from eq. 8's
closed form, scale-free as a logarithm so that one step size serves every task and hand, and the penalties of what
the paper's NLP holds as constraints, each squared in units of a millimetre (or of a hundredth of a radian). The
contacts' distance is held to a stand-off that falls from :attr:`BatchSearchConfig.standoff_m` to zero at
:attr:`BatchSearchConfig.standoff_until` of the iterations, as BODex's schedule does: the fingers close on the object
from outside rather than through it. Q enters after :attr:`BatchSearchConfig.quality_after` of them, once the pads
are near the surface, and with it eq. 10's and eq. 4's least residuals: their forces, activations and weights
carried from step to step and moved toward their least residual after each (BODex holds its force QP's solution
between solves alike).

The method is Adam (per-variable steps, cosine-decayed), the joints projected onto their limits after each step,
then damped Newton steps on the whole objective at no stand-off.
A start whose value or gradient is not finite stops where it is and is said so (``search-nan``); the rest of its
batch goes on, as each start's evaluation reads no other's. The whole budget runs as one compiled loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from grasptask.hand.hand_model import GraspingHand
from grasptask.objects.surface import ImplicitObject
from grasptask.synthesis.batch_geometry import (
    CONVERGED_M,
    FACING_SLACK,
    Field,
    HandArrays,
    StrengthArrays,
    TaskArrays,
    closed_form_q,
    closure_residual,
    closure_steps,
    contacts,
    distance,
    fingers,
    jax_module,
    rotation_vector,
    strength_matrix,
    strength_residuals,
    strength_steps,
)
from grasptask.synthesis.solver_config import BatchSearchConfig
from grasptask.task.task_model import TaskModel

#: the units the penalties are squared in: a millimetre, a hundredth of a radian
MM, CRAD = 1e-3, 1e-2
#: ... and eq. 4's wrench sum (of weights summing to 1 on unit cone edges): the polished grasps' are 0.0003 or
#: less, the end points whose polish took 250-340 IPOPT iterations 0.04-0.7
CLOSURE = 0.01


@dataclass(frozen=True)
class BatchEnd:
    """Where each start of a batch ended: its palm pose and joints, how far each contact is from the surface
    (m), the deepest collision sphere, Q of the closed form, and whether the search ended finite."""

    palm_rotation: np.ndarray  # (N, 3, 3)
    palm_position: np.ndarray  # (N, 3)
    joint_angles: np.ndarray  # (N, n), every joint (couplings applied)
    gaps: np.ndarray  # (N, b)
    depth: np.ndarray  # (N,) m, the deepest collision sphere's penetration (0: none)
    facing: np.ndarray  # (N,) worst pad facing shortfall, in cosine
    Q: np.ndarray  # (N,)
    finite: np.ndarray  # (N,) bool

    def converged(self) -> np.ndarray:
        """Every contact within :data:`CONVERGED_M` of the surface, no sphere deeper than that, the pads facing
        the surface within :data:`FACING_SLACK` of their limit."""
        near = (np.abs(self.gaps) <= CONVERGED_M).all(axis=1)
        facing = self.facing <= FACING_SLACK
        return self.finite & near & (self.depth <= CONVERGED_M) & facing & np.isfinite(self.Q)


@dataclass
class BatchSearch:
    """The search of one hand on one object for one task, traced and compiled once per batch size."""

    hand: GraspingHand
    obj: ImplicitObject
    task: TaskModel
    #: eq. 10 for the wrenches the first model holds, and eq. 4
    strength: StrengthArrays
    pad_angle_max_deg: float
    rolling: bool = True
    settings: BatchSearchConfig = field(default_factory=BatchSearchConfig)

    @cached_property
    def arrays(self) -> HandArrays:
        return HandArrays.of(self.hand, self.pad_angle_max_deg, self.rolling)

    @cached_property
    def field(self) -> Field:
        return Field.of(self.obj)

    def run(self, palm_rotation: np.ndarray, palm_position: np.ndarray, joints: np.ndarray) -> BatchEnd:
        """Search from each start ``(R_0, d_0, q_0)`` (batched, ``q_0`` every joint); where each ended. A batch
        smaller than the config's is filled up with copies of its first start and those ends dropped: one
        compiled search serves every batch (a start's end reads no other start)."""
        count, size = len(palm_position), self.settings.batch_size
        if 0 < count < size:
            fill = np.zeros(size - count, dtype=int)
            padded = [np.concatenate([a, np.asarray(a)[fill]]) for a in (palm_rotation, palm_position, joints)]
            ended = self._run(*padded)
            return BatchEnd(*(np.asarray(v)[:count] for v in vars(ended).values()))
        return self._run(palm_rotation, palm_position, joints)

    def _run(self, palm_rotation: np.ndarray, palm_position: np.ndarray, joints: np.ndarray) -> BatchEnd:
        jax = jax_module()
        jnp = jax.numpy
        arrays = self.arrays
        free = np.asarray(joints, dtype=float)[:, arrays.free]
        params = {"w": jnp.zeros((len(free), 3)), "d": jnp.asarray(palm_position, float), "q": jnp.asarray(free)}
        z = self._forces_start(len(free))
        task = self.task_arrays.arguments(jnp)
        final, z, finite = self._compiled(len(free))(params, jnp.asarray(palm_rotation, float), z, task)
        return self._end(final, np.asarray(palm_rotation, float), z, np.asarray(finite), task)

    @cached_property
    def task_arrays(self) -> TaskArrays:
        return TaskArrays.of(self.task, self.strength)

    def _forces_start(self, count: int) -> dict:
        """Eq. 10's forces and activations a start carries (per wrench searched, its columns), at zero, and eq.
        4's weights, at their mean."""
        jnp = jax_module().numpy
        b = len(self.arrays.fingers)
        edges = b * self.strength.edges
        forces = jnp.zeros((count, 2 * len(self.strength.axes), self.strength.columns(b)))
        return {"forces": forces, "closure": jnp.full((count, edges), 1.0 / edges)}

    def value(self, params: dict, rotation0: Any, standoff: Any, quality: Any, z: Any, task: dict) -> tuple[Any, Any]:
        """One start's value at eq. 10's forces and activations and eq. 4's weights ``z`` (held: the search moves
        them apart, by :func:`strength_steps` and :func:`closure_steps`) for the ``task``
        (:meth:`TaskArrays.arguments`), and what ends it (its gaps, deepest sphere, facing shortfall, Q, and eq.
        10's matrix, from which the forces are moved)."""
        jnp = jax_module().numpy
        arrays, s = self.arrays, self.settings
        rotation = rotation0 @ rotation_vector(jnp, params["w"])
        q = jnp.asarray(arrays.couple) @ params["q"] + arrays.couple_offset
        placed = fingers(jnp, arrays, rotation, params["d"], q)
        touch = contacts(jnp, arrays, self.field, placed)
        Q = closed_form_q(jnp, touch.points, touch.jacobians, task["axes"], s.rho)
        gap = (touch.gaps - standoff) / MM
        spheres = jnp.concatenate([p.spheres for p in placed] + [params["d"] + arrays.palm_points @ rotation.T])
        radii = np.concatenate([f.sphere_radii for f in arrays.fingers] + [arrays.palm_radii])
        depth = jnp.maximum(-distance(jnp, self.field, spheres, jnp.asarray(radii)), 0.0)
        facing = jnp.stack([jnp.dot(p.pad_normal, n) for p, n in zip(placed, touch.normals, strict=True)])
        short = jnp.maximum(arrays.pad_cos - facing, 0.0)
        flat = np.array([f.flat for f in arrays.fingers])
        tilt = jnp.where(flat, 1.0 - facing, 0.0)
        limits = jnp.maximum(q - arrays.upper, 0.0) + jnp.maximum(arrays.lower - q, 0.0)
        M = strength_matrix(jnp, self.strength, touch, [p.pad_tangent for p in placed])
        held = strength_residuals(jnp, M, z["forces"], task)
        closure = closure_residual(M, z["closure"])
        value = (
            quality * s.strength_weight * (jnp.sum((held / s.strength_unit) ** 2) + jnp.sum((closure / CLOSURE) ** 2))
            + quality * jnp.log(Q)
            + jnp.sum(gap**2)
            + jnp.sum((depth / MM) ** 2)
            + s.facing_weight * jnp.sum((short / 0.01) ** 2 + (tilt / 0.01) ** 2)
            + jnp.sum((limits / CRAD) ** 2)
            + self._self_collision(jnp, placed)
        )
        return value, (touch.gaps, jnp.max(depth), jnp.max(short), Q, M)

    def _self_collision(self, jnp: Any, placed: list) -> Any:
        pairs = self.arrays.proxy_pairs
        if not len(pairs):
            return 0.0
        centres = jnp.concatenate([p.spheres[f.proxies] for p, f in zip(placed, self.arrays.fingers, strict=True)])
        radii = np.concatenate([f.sphere_radii[f.proxies] for f in self.arrays.fingers])
        apart = jnp.sqrt(jnp.sum((centres[pairs[:, 0]] - centres[pairs[:, 1]]) ** 2, axis=-1) + 1e-18)
        overlap = jnp.maximum(radii[pairs[:, 0]] + radii[pairs[:, 1]] - apart, 0.0)
        return jnp.sum((overlap / MM) ** 2)

    @cached_property
    def _runners(self) -> dict[int, Any]:
        return {}

    def _compiled(self, size: int) -> Any:
        """The whole search of a batch of ``size`` starts as one compiled function (made once per size)."""
        if size not in self._runners:
            self._runners[size] = self._build()
        return self._runners[size]

    @cached_property
    def _judged(self) -> Any:
        """Each end point's gaps, deepest sphere, facing shortfall and Q, at no stand-off (compiled once)."""
        jax = jax_module()
        return jax.jit(jax.vmap(self.value, in_axes=(0, 0, None, None, 0, None)))

    def _forces_moved(self, M: Any, z: dict, task: dict, finite: Any) -> dict:
        """Each start's eq. 10 forces and activations and eq. 4's weights ``z`` moved toward their least
        residuals at its matrix ``M``, where its search is still finite."""
        jax = jax_module()
        jnp = jax.numpy
        steps, M = self.settings.strength_steps, jnp.nan_to_num(M)
        forces = jax.vmap(lambda m, zz: strength_steps(jnp, self.strength, m, zz, task, steps))(M, z["forces"])
        closure = jax.vmap(lambda m, phi: closure_steps(jnp, self.strength, m, phi, steps))(M, z["closure"])
        return {
            "forces": jnp.where(finite[:, None, None], forces, z["forces"]),
            "closure": jnp.where(finite[:, None], closure, z["closure"]),
        }

    def _build(self) -> Any:
        jax = jax_module()
        jnp = jax.numpy
        s, arrays = self.settings, self.arrays
        steps = {"w": s.step_turn_rad, "d": s.step_position_m, "q": s.step_joint_rad}
        low, high = arrays.lower[arrays.free], arrays.upper[arrays.free]
        graded = jax.vmap(jax.value_and_grad(self.value, has_aux=True), in_axes=(0, 0, None, None, 0, None))
        total = s.iterations

        def run(params: dict, rotation0: Any, z: Any, task: dict) -> tuple:
            def body(t: Any, state: tuple) -> tuple:
                params, first, second, finite, z = state
                progress = t / total
                standoff = s.standoff_m * jnp.maximum(0.0, 1.0 - progress / s.standoff_until)
                quality = jnp.clip((progress - s.quality_after) / 0.1, 0.0, 1.0)
                (value, aux), grads = graded(params, rotation0, standoff, quality, z, task)
                ok = jnp.isfinite(value)
                for grad in grads.values():
                    ok = ok & jnp.all(jnp.isfinite(grad), axis=-1)
                finite = finite & ok
                decay = 0.1 + 0.45 * (1 + jnp.cos(jnp.pi * progress))
                new, moments, squares = {}, {}, {}
                for key, grad in grads.items():
                    grad = jnp.where(finite[:, None], jnp.nan_to_num(grad), 0.0)
                    moments[key] = 0.9 * first[key] + 0.1 * grad
                    squares[key] = 0.999 * second[key] + 0.001 * grad**2
                    mean, var = moments[key] / (1 - 0.9 ** (t + 1)), squares[key] / (1 - 0.999 ** (t + 1))
                    new[key] = params[key] - steps[key] * decay * mean / (jnp.sqrt(var) + 1e-12)
                new["q"] = jnp.clip(new["q"], low, high)
                z = self._forces_moved(aux[-1], z, task, finite)
                return new, moments, squares, finite, z

            zeros = {k: jnp.zeros_like(v) for k, v in params.items()}
            state = (params, zeros, dict(zeros), jnp.ones(len(params["q"]), dtype=bool), z)
            params, _, _, finite, z = jax.lax.fori_loop(0, total, body, state)
            return self._newton(params, rotation0, finite, z, task)

        return jax.jit(run)

    def _newton(self, params: dict, rotation0: Any, finite: Any, z: Any, task: dict) -> tuple[dict, Any, Any]:
        """Damped Newton steps on each start's whole objective (no stand-off, Q in full) at its eq. 10 forces,
        in units of Adam's steps: the Hessian's eigenvalues taken by magnitude (a saddle is left, not climbed
        to), a step kept only where it lowers the value, the damping shrunk after a kept step and grown after a
        refused one; the forces moved toward their least residual after each."""
        jax = jax_module()
        jnp = jax.numpy
        s, arrays = self.settings, self.arrays
        n = params["q"].shape[1]
        scale = jnp.asarray(np.r_[np.full(3, s.step_turn_rad), np.full(3, s.step_position_m),
                                  np.full(n, s.step_joint_rad)])  # fmt: skip
        low, high = arrays.lower[arrays.free], arrays.upper[arrays.free]

        def f(x: Any, rotation: Any, zz: Any) -> tuple[Any, Any]:
            return self.value({"w": x[:3], "d": x[3:6], "q": x[6:]}, rotation, 0.0, 1.0, zz, task)

        value = jax.vmap(f)
        graded = jax.vmap(jax.value_and_grad(f, has_aux=True))
        hessian = jax.vmap(jax.hessian(lambda x, r, zz: f(x, r, zz)[0]))

        def body(_: Any, state: tuple) -> tuple:
            x, damping, z = state
            (current, here), g = graded(x, rotation0, z)
            g = g * scale
            h = hessian(x, rotation0, z) * scale[:, None] * scale[None, :]
            h = jnp.where(jnp.isfinite(h), h, 0.0)
            e, v = jnp.linalg.eigh(h)
            along = jnp.einsum("nji,nj->ni", v, g) / (jnp.abs(e) + damping[:, None])
            trial = x - jnp.einsum("nij,nj->ni", v, along) * scale
            trial = trial.at[:, 6:].set(jnp.clip(trial[:, 6:], low, high))
            tried, there = value(trial, rotation0, z)
            keep = finite & jnp.isfinite(tried) & (tried < current)
            x = jnp.where(keep[:, None], trial, x)
            damping = jnp.clip(jnp.where(keep, damping * 0.3, damping * 4.0), 1e-6, 1e6)
            M = jnp.where(keep[:, None, None], there[-1], here[-1])
            z = self._forces_moved(M, z, task, finite)
            return x, damping, z

        x = jnp.concatenate([params["w"], params["d"], params["q"]], axis=1)
        x, _, z = jax.lax.fori_loop(0, s.newton_iterations, body, (x, jnp.ones(len(x)), z))
        return {"w": x[:, :3], "d": x[:, 3:6], "q": x[:, 6:]}, z, finite

    def _end(self, params: dict, rotation0: np.ndarray, z: Any, finite: np.ndarray, task: dict) -> BatchEnd:
        jax = jax_module()
        jnp = jax.numpy
        _, (gaps, depth, short, Q, _) = self._judged(params, jnp.asarray(rotation0), 0.0, 1.0, z, task)
        turns = Rotation.from_rotvec(np.array(params["w"])).as_matrix()  # exp([w]x), as rotation_vector
        rotations = np.einsum("nij,njk->nik", rotation0, turns)
        joints = np.asarray(params["q"]) @ self.arrays.couple.T + self.arrays.couple_offset
        return BatchEnd(rotations, np.asarray(params["d"]), joints, np.asarray(gaps), np.asarray(depth),
                        np.asarray(short), np.asarray(Q), finite)  # fmt: skip
