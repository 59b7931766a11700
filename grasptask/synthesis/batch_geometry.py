"""The search's batch evaluation (SPEC section 12): a grasp's geometry as functions of the palm pose and the
joints alone, for every start of a batch at once, in JAX (``jit`` and ``vmap``; a GPU where one is present).

A start's variables are the palm's turn ``w`` (a rotation vector: ``R_h = R_0 exp([w]x)``, ``R_0`` the start's), its
position ``d`` and its free joints (a coupled joint follows its master, ``q = C q_free + offset``). From them:

- **eq. 2**, the forward kinematics of :mod:`grasptask.hand.kinematics`, written again on arrays: every link's
  frame, each pad's sphere centre, point and normal, every collision sphere's centre;
- **the contact geometry**: the object's distance ``d(x)`` (a superquadric's and a GP's first-order distance
  ``g / |grad g|``, a scan's signed-distance grid as a cubic B-spline), the inward normal ``-grad d / |grad d|``;
  a rolling pad's contact is its sphere's point nearest the surface, ``p = c - (r - compliance) n_out``; a fixed or
  flat pad's, its point; eq. 7's Jacobians ``a_k x (p - P_k)`` there;
- **eq. 12**'s Q from eq. 8's closed form (:func:`closed_form_q`, the value of the force problem's eq. 8 part): the
  task forces that balance each axis with the least squared joint torques, tr((G W^-1 G^T + I / rho)^-1 U Gamma
  U^T);
- **the penalties** for what the paper's NLP holds as constraints: the contact distance (eq. 3, on a stand-off
  that the search lowers to zero), the hand's collision spheres outside the object (eq. 14), the pads facing the
  surface, a flat pad's face on it, coupled joints within their own limits, and the fingers clear of each other.

Nothing here is the NLP's code (Pyomo) or the verifier's; the tests hold its contacts, normals and Jacobians to
:mod:`grasptask.hand.kinematics` at the same pose to 1e-9.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from grasptask.hand.hand_model import GraspingHand
from grasptask.objects.distance_grid import DistanceGrid
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.mesh_object import MeshObject, PointCloudObject
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject
from grasptask.task.task_model import TaskModel

#: the self-collision proxies a finger keeps of its spheres (farthest points): the pairs between fingers grow as
#: their square
SELF_PROXIES = 12
#: a search converged with every contact within this of the surface and no collision sphere deeper than this
#: inside it (m): the polish, started there, settles the rest (the human hand's drawing: 92 of 126 end points at
#: 1 mm against 75 at 0.5 mm, every polish of them verified)
CONVERGED_M = 1e-3
#: ... and every pad within this (in cosine) of its facing limit
FACING_SLACK = 0.02


def jax_module() -> Any:
    """JAX, on one thread of the CPU (a worker's own core: the pool runs one worker a core), in float64, its
    compiled searches kept on disk beside the object cache (``GRASPTASK_CACHE``): a worker's first batch of a
    hand and object compiles for about a minute; after that the search is traced again (7 s) and its compiled
    code loaded (3 s), for any task (:class:`TaskArrays` are arguments, not constants)."""
    flags = os.environ.get("XLA_FLAGS", "")
    if "intra_op_parallelism_threads" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} --xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1".strip()
    import jax

    jax.config.update("jax_enable_x64", True)
    from grasptask.io.cache import folder  # compiled searches kept with the other slow per-object work

    kept = folder()
    if kept is not None and not getattr(jax.config, "jax_compilation_cache_dir", None):
        jax.config.update("jax_compilation_cache_dir", str(kept / "jax"))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    return jax


@dataclass(frozen=True)
class FingerArrays:
    """One finger's chain as arrays: per joint its offset, fixed rotation, axis and whether it slides; its pad;
    its collision spheres by link."""

    offsets: np.ndarray  # (n, 3)
    rotations: np.ndarray  # (n, 3, 3)
    axes: np.ndarray  # (n, 3)
    sliding: np.ndarray  # (n,) bool
    pad_point: np.ndarray  # (3,) in the last link's frame
    pad_centre: np.ndarray  # (3,)
    pad_normal: np.ndarray  # (3,)
    pad_tangent: np.ndarray  # (3,) the direction each friction cone's first edge follows
    contact_offset: float  # r - compliance for a rolling pad, 0 for a point
    flat: bool
    sphere_links: np.ndarray  # (s,) int
    sphere_centres: np.ndarray  # (s, 3)
    sphere_radii: np.ndarray  # (s,)
    proxies: np.ndarray  # indices of the spheres that stand for the finger against the others


@dataclass(frozen=True)
class HandArrays:
    """The grasping hand as arrays: its fingers, its palm's spheres, the joints' coupling and limits."""

    fingers: tuple[FingerArrays, ...]
    palm_points: np.ndarray  # (k, 3)
    palm_radii: np.ndarray  # (k,)
    couple: np.ndarray  # (joints, free): q = couple @ q_free + offset
    couple_offset: np.ndarray  # (joints,)
    free: np.ndarray  # (free,) the free joints' columns
    lower: np.ndarray  # (joints,)
    upper: np.ndarray  # (joints,)
    pad_cos: np.ndarray  # (b,) cos of each pad's facing limit
    proxy_pairs: np.ndarray  # (pairs, 2) indices into the stacked proxies, of different fingers, clear at mid-range

    @property
    def slices(self) -> list[slice]:
        out, start = [], 0
        for finger in self.fingers:
            out.append(slice(start, start + len(finger.axes)))
            start += len(finger.axes)
        return out

    @classmethod
    def of(cls, hand: GraspingHand, pad_angle_max_deg: float, rolling: bool = True) -> HandArrays:
        offsets = hand.contact_offsets(rolling)
        fingers = []
        for k, finger in enumerate(hand.fingers.values()):
            centres = np.array([s.center for s in finger.spheres]).reshape(-1, 3)
            fingers.append(
                FingerArrays(
                    offsets=np.array([j.offset for j in finger.joints], dtype=float),
                    rotations=np.array([np.eye(3) if j.rotation is None else j.rotation for j in finger.joints]),
                    axes=np.array([j.axis for j in finger.joints], dtype=float),
                    sliding=np.array([j.sliding for j in finger.joints], dtype=bool),
                    pad_point=np.asarray(finger.pad.point, dtype=float),
                    pad_centre=np.asarray(finger.pad.centre, dtype=float),
                    pad_normal=np.asarray(finger.pad.normal, dtype=float),
                    pad_tangent=np.asarray(finger.pad.tangent, dtype=float),
                    contact_offset=float(offsets[k]),
                    flat=bool(finger.pad.flat),
                    sphere_links=np.array([s.link for s in finger.spheres], dtype=int),
                    sphere_centres=centres,
                    sphere_radii=np.array([s.radius for s in finger.spheres], dtype=float),
                    proxies=_farthest(centres, SELF_PROXIES),
                )
            )
        couple, shift, free = _coupling(hand)
        limits = np.cos(np.radians(hand.pad_angle_limits(pad_angle_max_deg)))
        arrays = cls(
            tuple(fingers), np.asarray(hand.palm.points, float).reshape(-1, 3), np.asarray(hand.palm.radii, float),
            couple, shift, free, hand.lower, hand.upper, np.asarray(limits, float), np.zeros((0, 2), dtype=int),
        )  # fmt: skip
        return _with_proxy_pairs(arrays, hand)


def _farthest(points: np.ndarray, k: int) -> np.ndarray:
    """Up to ``k`` of ``points`` spread by farthest-point sampling from the first (deterministic)."""
    if len(points) <= k:
        return np.arange(len(points))
    chosen = [0]
    distance = np.linalg.norm(points - points[0], axis=1)
    while len(chosen) < k:
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(sorted(chosen))


def _coupling(hand: GraspingHand) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q = C q_free + offset`` for the hand's couplings (chains followed to their master)."""
    n = hand.n_joints
    rule = {dep: (ind, ratio, off) for dep, ind, ratio, off in hand.couplings()}
    free = np.array([k for k in range(n) if k not in rule], dtype=int)
    column = {k: c for c, k in enumerate(free)}
    couple, shift = np.zeros((n, len(free))), np.zeros(n)
    for k in range(n):
        ratio, offset, master = 1.0, 0.0, k
        while master in rule:
            ind, r, o = rule[master]
            offset, ratio, master = r * offset + o, ratio * r, ind
        couple[k, column[master]] = ratio
        shift[k] = offset
    return couple, shift, free


def _with_proxy_pairs(arrays: HandArrays, hand: GraspingHand) -> HandArrays:
    """The pairs of self-collision proxies of different fingers that are clear of each other at mid-range: a
    hand whose adjacent fingers' covers touch at rest is not pushed apart."""
    from dataclasses import replace

    from grasptask.hand.kinematics import forward

    pose = forward(hand, hand.mid_range())
    centres, radii, owner = [], [], []
    for k, (finger, placed) in enumerate(zip(arrays.fingers, pose.fingers.values(), strict=True)):
        centres.append(placed.samples[0][finger.proxies])
        radii.append(finger.sphere_radii[finger.proxies])
        owner += [k] * len(finger.proxies)
    if not centres or sum(len(c) for c in centres) == 0:
        return arrays
    c, r, who = np.vstack(centres), np.concatenate(radii), np.array(owner)
    i, j = np.triu_indices(len(c), k=1)
    apart = (who[i] != who[j]) & (np.linalg.norm(c[i] - c[j], axis=1) > r[i] + r[j])
    return replace(arrays, proxy_pairs=np.column_stack([i[apart], j[apart]]).astype(int))


@dataclass(frozen=True)
class Field:
    """The object's distance field as data for :func:`distance`: its kind and its arrays."""

    kind: str  # "superquadric", "gp" or "grid"
    arrays: dict[str, Any]

    @classmethod
    def of(cls, obj: ImplicitObject) -> Field:
        if isinstance(obj, Superquadric):
            return cls("superquadric", {"a": obj.a, "e1": obj.e1, "e2": obj.e2, "rotation": obj.rotation,
                                        "position": obj.position})  # fmt: skip
        if isinstance(obj, GPImplicitSurface):
            return cls("gp", {"support": obj.support, "alpha": obj.alpha, "mean": obj.mean_coefficients})
        if isinstance(obj, (MeshObject, PointCloudObject)):
            return cls("grid", _grid_arrays(obj.distance_grid))
        raise TypeError(f"no batch distance field for {type(obj).__name__}")


def _grid_arrays(grid: DistanceGrid) -> dict[str, Any]:
    """A cubic B-spline's coefficients of the grid (smoothed as the NLP's surrogate is), for :func:`distance`."""
    from scipy import ndimage

    from grasptask.synthesis.spline import SMOOTHING_CELLS

    smooth = ndimage.gaussian_filter(grid.values, SMOOTHING_CELLS, mode="nearest")
    coefficients = ndimage.spline_filter(smooth, order=3, mode="nearest")
    padded = np.pad(coefficients, 2, mode="edge")  # every point's 4 x 4 x 4 neighbours inside
    return {"origin": grid.origin, "spacing": float(grid.spacing), "coefficients": padded,
            "shape": np.array(grid.values.shape)}  # fmt: skip


# --- the evaluation, in JAX --------------------------------------------------------------------------------------


def distance(jnp: Any, field: Field, points: Any, inflate: Any = 0.0) -> Any:
    """The signed distance (m, negative inside) of ``points`` (..., 3) to the object grown by ``inflate`` (m, one
    per point or one for all): a superquadric's and a GP's first-order distance ``g / |grad g|`` (the
    superquadric's ``g = F^(e1/2) - 1`` of its half-sizes grown by ``inflate``, the NLP's own measure: the radial
    distance beside a long thin cylinder overstates the clearance), a grid's cubic B-spline."""
    import jax

    a = field.arrays
    if field.kind == "grid":
        return _grid_distance(jnp, a, points) - inflate
    if field.kind == "superquadric":
        size = jnp.asarray(a["a"]) + jnp.asarray(inflate)[..., None]

        def g(x: Any) -> Any:
            local = ((x - a["position"]) @ a["rotation"] / size) ** 2 + 1e-30
            base = local[..., 0] ** (1 / a["e2"]) + local[..., 1] ** (1 / a["e2"])
            return (base ** (a["e2"] / a["e1"]) + local[..., 2] ** (1 / a["e1"])) ** (a["e1"] / 2) - 1

        grown = 0.0
    else:

        def g(x: Any) -> Any:
            squared = jnp.sum((x[..., None, :] - a["support"]) ** 2, axis=-1) + 1e-30
            return jnp.sum(squared**1.5 * a["alpha"], axis=-1) + a["mean"][0] + x @ a["mean"][1:]

        grown = inflate
    value, grad = g(points), jax.grad(lambda x: jnp.sum(g(x)))(points)
    return value / jnp.sqrt(jnp.sum(grad**2, axis=-1) + 1e-30) - grown


def _grid_distance(jnp: Any, a: dict, points: Any) -> Any:
    """The cubic B-spline of the grid at ``points``, and beyond the grid the distance to it added (clamped)."""
    spacing, origin, shape = a["spacing"], jnp.asarray(a["origin"]), jnp.asarray(a["shape"])
    upper = origin + spacing * (shape - 1)
    inside = jnp.clip(points, origin, upper)
    beyond = jnp.sqrt(jnp.sum((points - inside) ** 2, axis=-1) + 1e-16) - 1e-8
    cell = (inside - origin) / spacing
    base = jnp.clip(jnp.floor(cell), 0, shape - 2).astype(int)
    t = cell - base
    weights = [_cubic_weights(jnp, t[..., i]) for i in range(3)]  # each (..., 4)
    coefficients = jnp.asarray(a["coefficients"])
    total = 0.0
    for i in range(4):
        for j in range(4):
            for k in range(4):
                c = coefficients[base[..., 0] + 1 + i, base[..., 1] + 1 + j, base[..., 2] + 1 + k]
                total = total + weights[0][..., i] * weights[1][..., j] * weights[2][..., k] * c
    return total + beyond


def _cubic_weights(jnp: Any, t: Any) -> Any:
    """The uniform cubic B-spline's four basis values at ``t`` in [0, 1], for the knots -1, 0, 1, 2."""
    s = 1 - t
    return jnp.stack([s**3 / 6, (3 * t**3 - 6 * t**2 + 4) / 6, (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6, t**3 / 6], -1)


# --- one start's grasp, traced once and mapped over the batch ----------------------------------------------------


def rotation_vector(jnp: Any, w: Any) -> Any:
    """``exp([w]x)``: the rotation by ``|w|`` about ``w`` (Rodrigues, smooth through 0)."""
    theta = jnp.sqrt(jnp.sum(w * w) + 1e-24)
    k = _skew(jnp, w / theta)
    return jnp.eye(3) + jnp.sin(theta) * k + (1 - jnp.cos(theta)) * (k @ k)


def _skew(jnp: Any, v: Any) -> Any:
    zero = jnp.zeros_like(v[0])
    return jnp.stack([jnp.stack([zero, -v[2], v[1]]), jnp.stack([v[2], zero, -v[0]]), jnp.stack([-v[1], v[0], zero])])


def _about(jnp: Any, axis: np.ndarray, angle: Any) -> Any:
    """Rodrigues about a fixed unit ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return jnp.eye(3) + jnp.sin(angle) * k + (1 - jnp.cos(angle)) * (k @ k)


@dataclass(frozen=True)
class Finger:
    """One finger of one start, in the object frame: each joint's position and axis, the pad's sphere centre,
    point and normal, and the collision spheres' centres."""

    joints: Any  # (n, 3)
    axes: Any  # (n, 3)
    pad_centre: Any
    pad_point: Any
    pad_normal: Any
    pad_tangent: Any
    spheres: Any  # (s, 3)


def fingers(jnp: Any, hand: HandArrays, rotation: Any, position: Any, q: Any) -> list[Finger]:
    """Eq. 2 for one start: every finger at joint values ``q`` (all joints, ``hand_model`` order), the palm at
    ``rotation``, ``position``."""
    out = []
    for finger, columns in zip(hand.fingers, hand.slices, strict=True):
        frame, point = jnp.eye(3), jnp.zeros(3)
        positions, axes, frames = [], [], []
        for k in range(len(finger.axes)):
            point = point + frame @ finger.offsets[k]
            frame = frame @ finger.rotations[k]
            axis = frame @ finger.axes[k]
            angle = q[columns.start + k]
            if finger.sliding[k]:
                point = point + angle * axis
            else:
                frame = frame @ _about(jnp, finger.axes[k], angle)
            positions.append(point)
            axes.append(axis)
            frames.append(frame)
        links = jnp.stack(frames)[finger.sphere_links]  # (s, 3, 3)
        starts = jnp.stack(positions)[finger.sphere_links]
        spheres = starts + jnp.einsum("sij,sj->si", links, finger.sphere_centres)
        out.append(
            Finger(
                joints=jnp.stack(positions) @ rotation.T + position,
                axes=jnp.stack(axes) @ rotation.T,
                pad_centre=rotation @ (point + frame @ finger.pad_centre) + position,
                pad_point=rotation @ (point + frame @ finger.pad_point) + position,
                pad_normal=rotation @ (frame @ finger.pad_normal),
                pad_tangent=rotation @ (frame @ finger.pad_tangent),
                spheres=spheres @ rotation.T + position,
            )
        )
    return out


@dataclass(frozen=True)
class Contacts:
    """Each finger's contact on the object: its point, inward normal, eq. 7's Jacobian (rows a_k x (p - P_k)), and
    how far its sphere's centre (a point pad's point) stands off the surface beyond where it should."""

    points: Any  # (b, 3)
    normals: Any  # (b, 3) inward
    jacobians: list  # per finger (n_j, 3)
    gaps: Any  # (b,) m


def contacts(jnp: Any, hand: HandArrays, field: Field, placed: list[Finger]) -> Contacts:
    import jax

    points, normals, jacobians, gaps = [], [], [], []
    for finger, pose in zip(hand.fingers, placed, strict=True):
        at = pose.pad_centre if finger.contact_offset > 0 else pose.pad_point
        gap, grad = jax.value_and_grad(lambda x: distance(jnp, field, x))(at)
        outward = grad / jnp.sqrt(jnp.sum(grad * grad) + 1e-30)
        point = at - finger.contact_offset * outward
        rows = jnp.where(finger.sliding[:, None], pose.axes, jnp.cross(pose.axes, point - pose.joints))
        points.append(point)
        normals.append(-outward)
        jacobians.append(rows)
        gaps.append(gap - finger.contact_offset)
    return Contacts(jnp.stack(points), jnp.stack(normals), jacobians, jnp.stack(gaps))


def closed_form_q(jnp: Any, points: Any, jacobians: list, axes_matrix: Any, rho: float, floor: float = 1e-10) -> Any:
    """Eq. 12's Q of eq. 8's closed form: tr((G W^-1 G^T + I / rho)^-1 U Gamma U^T), ``W = blockdiag(J^T J)``:
    the sum over the axes of min_f gamma_i (|J^T f|^2 + rho |G f - u_i|^2), the force problem's eq. 8 part.
    ``axes_matrix`` is ``U Gamma^1/2`` (:class:`TaskArrays`); ``floor`` m^2 on W's diagonal keeps a finger with
    fewer than three joints invertible."""
    K = jnp.eye(6) / rho
    for j, J in enumerate(jacobians):
        W = J.T @ J + floor * jnp.eye(3)
        G = jnp.concatenate([jnp.eye(3), _skew(jnp, points[j])])
        K = K + G @ jnp.linalg.solve(W, G.T)
    B = axes_matrix
    return jnp.trace(jnp.linalg.solve(K, B @ B.T))


@dataclass(frozen=True)
class StrengthArrays:
    """Eq. 10 as the search holds it: the task axes whose real wrenches ``+-L_i u_i`` the first model holds
    (their values come with the task, :class:`TaskArrays`), the linearised friction cones (``mu``, ``edges``
    each), the hand's transmission ``T`` and torque map ``A`` with its activation cap and each transmission
    row's full strength (its scale). The least normal force is left to the polish: as a hinge in the search it
    held the default human hand's fingers 2-16 mm off the tool (4 of 4 test starts failed, none without it)."""

    axes: tuple[int, ...]  # the task's axes, by rank
    mu: float
    edges: int
    transmission: np.ndarray  # (r, joints)
    torque_map: np.ndarray  # (r, actuators)
    cap: float
    row_strength: np.ndarray  # (r,) N m
    #: the lever (m) a wrench's torque rows are divided by, so that its force and torque rows weigh alike
    lever_m: float
    #: eq. 4's least weight of a primitive wrench
    closure_floor: float

    @classmethod
    def of(cls, capability: Any, axes: list[int], settings: Any, lever_m: float) -> StrengthArrays:
        """``lever_m``: the object's size (half its bounding box's diagonal)."""
        cap = settings.activation_cap(capability.kind) - settings.activation_margin
        strength = np.abs(capability.torque_map).sum(axis=1) * cap
        return cls(
            tuple(axes), settings.friction_scale * settings.friction_coefficient, settings.cone_edges,
            np.asarray(capability.transmission, float), np.asarray(capability.torque_map, float), cap,
            np.maximum(strength, 1e-9), float(lever_m), float(settings.force_closure_min_weight),
        )  # fmt: skip

    def columns(self, b: int) -> int:
        """Eq. 10's variables of one wrench: ``b`` contacts' cone-edge forces, then the activations."""
        return b * self.edges + self.torque_map.shape[1]


@dataclass(frozen=True)
class TaskArrays:
    """What the search reads of a task, handed to the compiled search as arguments (so that one compile serves
    every task of a hand and object): eq. 8's ``U Gamma^1/2`` and eq. 10's wrenches, their torques divided by
    the lever, with their sizes."""

    axes_matrix: np.ndarray  # (6, 6)
    targets: np.ndarray  # (k, 6)
    sizes: np.ndarray  # (k,)

    @classmethod
    def of(cls, task: TaskModel, strength: StrengthArrays | None) -> TaskArrays:
        matrix = np.asarray(task.axes, dtype=float).T * np.sqrt(np.asarray(task.weights, dtype=float))
        if strength is None:
            return cls(matrix, np.zeros((0, 6)), np.zeros(0))
        lever = np.r_[1.0, 1.0, 1.0, np.full(3, strength.lever_m)]
        wrenches = np.array([sign * task.lengths[a] * np.asarray(task.axes[a], float) / lever
                             for a in strength.axes for sign in (1.0, -1.0)])  # fmt: skip
        return cls(matrix, wrenches, np.linalg.norm(wrenches, axis=1))

    def arguments(self, jnp: Any) -> dict:
        return {"axes": jnp.asarray(self.axes_matrix), "targets": jnp.asarray(self.targets),
                "sizes": jnp.asarray(self.sizes)}  # fmt: skip


def strength_matrix(jnp: Any, strength: StrengthArrays, touch: Contacts, tangents: list) -> Any:
    """Eq. 10's rows for one start, scaled: ``[G_edges, 0; T J^T L, -A]`` (wrench rows per unit of nothing, torque
    rows per unit of each row's full strength), columns the cone-edge forces (eq. 24's edges about the normal,
    the first along the pad's tangent) then the activations."""
    m, mu = strength.edges, strength.mu
    angles = 2 * np.pi * np.arange(1, m + 1) / m
    scale = 1.0 / np.sqrt(1 + mu**2)
    wrench_columns, torque_columns = [], []
    sizes = [len(J) for J in touch.jacobians]
    offsets = np.cumsum([0, *sizes])
    for j, (J, x_d) in enumerate(zip(touch.jacobians, tangents, strict=True)):
        n = touch.normals[j]
        w = x_d - jnp.dot(x_d, n) * n
        t1 = w / jnp.sqrt(jnp.sum(w * w) + 1e-30)
        t2 = jnp.cross(n, t1)
        around = np.cos(angles)[:, None] * t1[None, :] + np.sin(angles)[:, None] * t2[None, :]
        edges = scale * (n[None, :] + mu * around)
        torque = jnp.cross(touch.points[j], edges) / strength.lever_m
        wrench_columns.append(jnp.concatenate([edges, torque], axis=1))  # (m, 6)
        torques = edges @ J.T  # (m, n_j): J^T l per edge
        full = jnp.zeros((m, offsets[-1])).at[:, offsets[j] : offsets[j + 1]].set(torques)
        torque_columns.append(full)
    G = jnp.concatenate(wrench_columns).T  # (6, b m)
    carried = (strength.transmission @ jnp.concatenate(torque_columns).T) / strength.row_strength[:, None]
    produced = -strength.torque_map / strength.row_strength[:, None]
    top = jnp.concatenate([G, jnp.zeros((6, strength.torque_map.shape[1]))], axis=1)
    return jnp.concatenate([top, jnp.concatenate([carried, produced], axis=1)])


def strength_residuals(jnp: Any, M: Any, z: Any, task: dict) -> Any:
    """Each wrench's eq. 10 residuals at forces and activations ``z`` (k, columns): the wrench rows relative to
    the wrench's size, the torque rows in shares of full strength (``task``: :meth:`TaskArrays.arguments`)."""
    targets, size = task["targets"], task["sizes"][:, None]
    c = jnp.concatenate([targets, jnp.zeros((len(targets), M.shape[0] - 6))], axis=1)
    rows = z @ M.T - c
    return jnp.concatenate([rows[:, :6] / size, rows[:, 6:]], axis=1)


def _lipschitz(jnp: Any, S: Any) -> Any:
    """A step bound for projected gradient on each ``|S_k x - c_k|^2`` (``S`` (k, rows, columns)): 1.1 times the
    Hessian's largest eigenvalue, ``2 sigma_max(S_k)^2``, by eight power iterations (an underestimate by little)."""
    v = jnp.ones((S.shape[0], S.shape[2]))
    for _ in range(8):
        v = jnp.einsum("krc,kr->kc", S, jnp.einsum("krc,kc->kr", S, v))
        v = v / jnp.sqrt(jnp.sum(v * v, axis=1, keepdims=True) + 1e-300)
    return 2.2 * jnp.sum(jnp.einsum("krc,kc->kr", S, v) ** 2, axis=1) + 1e-12


def strength_steps(jnp: Any, strength: StrengthArrays, M: Any, z: Any, task: dict, steps: int) -> Any:
    """``steps`` projected-gradient steps on the sum of squared :func:`strength_residuals` over ``z`` (edge
    forces >= 0, activations within [0, cap]), from ``z``: the search carries ``z`` from one of its iterations
    to the next, so a few steps each move it toward the least residual of the moving geometry. Each wrench's step
    is its own (:func:`_lipschitz`). The forces lag their least residual
    (the tool's Gram matrices are near singular): the penalty pulls the grasp toward holding the wrenches more
    than it measures how far it is (docs/notebook.md)."""
    import jax

    n_edges = z.shape[-1] - strength.torque_map.shape[1]
    upper = jnp.concatenate([jnp.full(n_edges, jnp.inf), jnp.full(M.shape[1] - n_edges, strength.cap)])
    rows = jnp.concatenate([jnp.tile(1.0 / task["sizes"][:, None], (1, 6)),
                            jnp.ones((len(z), M.shape[0] - 6))], axis=1)  # fmt: skip
    S = rows[:, :, None] * M[None]  # (k, rows, columns): each wrench's rows as it weighs them
    lipschitz = _lipschitz(jnp, S)[:, None]

    def loss(zz: Any) -> Any:
        return jnp.sum(strength_residuals(jnp, M, zz, task) ** 2)

    gradient = jax.grad(loss)

    def body(_: Any, zz: Any) -> Any:
        return jnp.clip(zz - gradient(zz) / lipschitz, 0.0, upper)

    return jax.lax.fori_loop(0, steps, body, z)


def closure_residual(M: Any, phi: Any) -> Any:
    """Eq. 4's wrench sum ``sum phi w`` of the primitive wrenches (the cone edges' columns of
    :func:`strength_matrix`'s wrench rows, torques divided by the lever) at weights ``phi``."""
    return M[:6, : phi.shape[-1]] @ phi


def closure_steps(jnp: Any, strength: StrengthArrays, M: Any, phi: Any, steps: int) -> Any:
    """``steps`` projected-gradient steps on ``|sum phi w|^2`` over eq. 4's weights (each at least the floor,
    summing to 1), from ``phi``, carried from one step of the search to the next as eq. 10's forces are."""
    import jax

    W = M[:6, : phi.shape[-1]]
    lipschitz = _lipschitz(jnp, W[None])[0]
    n, floor = phi.shape[-1], strength.closure_floor
    radius = 1.0 - n * floor

    def project(u: Any) -> Any:  # onto {u >= floor, sum u = 1}: the simplex of the weights above the floor
        y = u - floor
        ordered = -jnp.sort(-y)
        excess = (jnp.cumsum(ordered) - radius) / jnp.arange(1, n + 1)
        count = jnp.sum(ordered > excess)
        theta = excess[count - 1]
        return jnp.maximum(y - theta, 0.0) + floor

    def body(_: Any, u: Any) -> Any:
        return project(u - 2.0 * W.T @ (W @ u) / lipschitz)

    return jax.lax.fori_loop(0, steps, body, phi)
