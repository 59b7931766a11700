"""Gaussian-process implicit surfaces (paper Section 4, after Williams & Fitzgibbon 2006 and El-Khoury et al.
2013).

``g`` is the posterior mean of a GP with the thin-plate (triharmonic) generalized covariance ``k(r) = r^3`` and
a linear mean function fitted with it (universal kriging):

    g(p) = sum_k alpha_k |p - x_k|^3 + c_0 + c^T p

Training targets are signed distances: 0 at surface points and +-t at points offset by t along the outward
and inward normals (kept only where the offset point's nearest surface sample is the one it came from). ``g``
is therefore close to a signed distance in metres, it is C2 (smooth enough for IPOPT's exact Hessian), and
unlike a squared-exponential kernel it does not relax to its prior a centimetre from the data: it stays
negative inside and positive outside, far from the object too.

Support points are chosen greedily (Carr et al. 2001): start from points spread evenly by farthest-point
sampling, then add the surface samples the current fit misses most, until every sample of the pool is within
the tolerance or the support budget is spent.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from grasptask.objects.surface import ImplicitObject, SurfaceIndex, Symmetry

#: offsets along the normals (m) at which signed-distance targets are placed: outward (+) and inward (-)
OFFSETS = (0.004, 0.010, 0.020, -0.004, -0.010)


def farthest_point_sample(points: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    """Indices of ``k`` points spread evenly over ``points`` (greedy farthest-point sampling)."""
    rng = np.random.default_rng(seed)
    chosen = [int(rng.integers(len(points)))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(min(k, len(points)) - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(chosen)


def _chunked(function, points: np.ndarray, width: int, rows: int = 4096) -> np.ndarray:
    """``function`` over blocks of rows, so that no (points x support) array outgrows a few hundred MB."""
    out = np.empty((len(points), width) if width > 1 else len(points))
    for start in range(0, len(points), rows):
        out[start : start + rows] = function(points[start : start + rows])
    return out


def _cubed_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    squared = np.maximum((a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2 * a @ b.T, 0.0)
    return squared * np.sqrt(squared)


def _training_set(points, normals, tree, chosen, offsets):
    s, n = points[chosen], normals[chosen]
    inputs, targets = [s], [np.zeros(len(s))]
    for t in offsets:
        q = s + t * n
        keep = tree.query(q)[0] > 0.9 * abs(t)  # q is still closest to its own surface point
        inputs.append(q[keep])
        targets.append(np.full(keep.sum(), t))
    return np.concatenate(inputs), np.concatenate(targets)


@dataclass(eq=False)
class GPImplicitSurface(ImplicitObject):
    support: np.ndarray  # (K, 3) training inputs
    alpha: np.ndarray  # (K,) weights of the covariance terms
    mean_coefficients: np.ndarray  # (4,) c_0, c_x, c_y, c_z of the linear mean
    n_surface_support: int = 0
    name: str = "gp"
    symmetry: Symmetry | None = None

    def g(self, p: np.ndarray) -> np.ndarray:
        return _chunked(self._g, np.atleast_2d(p), 1)

    def gradient(self, p: np.ndarray) -> np.ndarray:
        return _chunked(self._gradient, np.atleast_2d(p), 3)

    def _g(self, p: np.ndarray) -> np.ndarray:
        linear = self.mean_coefficients[0] + p @ self.mean_coefficients[1:]
        return _cubed_distances(p, self.support) @ self.alpha + linear

    def _gradient(self, p: np.ndarray) -> np.ndarray:
        # grad |p - x|^3 = 3 |p - x| (p - x), summed without forming the (n, K, 3) differences
        squared = (p * p).sum(1)[:, None] + (self.support**2).sum(1)[None, :] - 2 * p @ self.support.T
        weights = 3 * np.sqrt(np.maximum(squared, 0.0)) * self.alpha
        return weights.sum(axis=1)[:, None] * p - weights @ self.support + self.mean_coefficients[1:]

    @cached_property
    def surface(self) -> SurfaceIndex:
        # each GP evaluation costs a sum over every support point: sample the surface a little more sparsely
        return SurfaceIndex.build(self, spacing=1e-3)

    def margin(self, p: np.ndarray) -> np.ndarray:
        """First-order distance to the surface, ``g / |grad g|`` (m)."""
        return self.g(p) / np.linalg.norm(self.gradient(p), axis=1)

    def bounds(self) -> np.ndarray:
        surface = self.support[: self.n_surface_support] if self.n_surface_support else self.support
        return np.stack([surface.min(axis=0), surface.max(axis=0)])

    @classmethod
    def solve(
        cls, inputs: np.ndarray, targets: np.ndarray, n_surface: int, smoothing: float = 0.0, name: str = "gp"
    ) -> GPImplicitSurface:
        """Kriging weights for the given training set: the saddle-point system of the covariance and the mean."""
        n = len(inputs)
        basis = np.hstack([np.ones((n, 1)), inputs])
        system = np.block(
            [[_cubed_distances(inputs, inputs) + smoothing * np.eye(n), basis], [basis.T, np.zeros((4, 4))]]
        )
        solution = np.linalg.solve(system, np.concatenate([targets, np.zeros(4)]))
        return cls(inputs, solution[:n], solution[n:], n_surface, name)

    @classmethod
    def fit(
        cls,
        points: np.ndarray,
        normals: np.ndarray,
        n_support: int = 250,
        max_support: int = 500,
        tolerance: float = 5e-4,
        offsets: tuple[float, ...] = OFFSETS,
        seed: int = 0,
        name: str = "gp",
    ) -> GPImplicitSurface:
        """Fit to surface points with outward normals (see the module docstring)."""
        points, normals = np.asarray(points, float), np.asarray(normals, float)
        normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        tree = cKDTree(points)
        chosen = farthest_point_sample(points, min(n_support, len(points)), seed)
        while True:
            inputs, targets = _training_set(points, normals, tree, chosen, offsets)
            model = cls.solve(inputs, targets, len(chosen), name=name)
            residual = np.abs(model.g(points))
            residual[chosen] = 0.0
            worst = np.argsort(residual)[::-1]
            worst = worst[residual[worst] > tolerance]
            room = max_support - len(chosen)
            if len(worst) == 0 or room <= 0:
                return model
            # add the worst misses, but not two from the same neighbourhood in one round
            picked, taken = [], np.zeros(len(points), dtype=bool)
            spacing = np.median(cKDTree(points[chosen]).query(points[chosen], k=2)[0][:, 1])
            for index in worst:
                if not taken[index]:
                    picked.append(index)
                    taken[tree.query_ball_point(points[index], spacing)] = True
                if len(picked) >= min(room, 100):
                    break
            chosen = np.concatenate([chosen, picked])
