"""Grasp records: what a sweep stores and how it is read back: the solutions table's schema, a finished sweep's
grasps, and the paper's own figures to compare with."""
