"""Grasp records: sweeps read back as grasps (:mod:`grasptask.records.sweeps`)."""
