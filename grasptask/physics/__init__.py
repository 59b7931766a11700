"""The physics check: a second judge, separate from the analytic verifier, that holds each grasp in
MuJoCo against its own task's wrenches (:mod:`grasptask.physics.scene`, :mod:`grasptask.physics.protocol`).

The package imports nothing itself, so that reading its settings does not load MuJoCo."""
