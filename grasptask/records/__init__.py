"""Grasp records: a sweep's solutions table, its grasps read back, the exported scene, the paper's figures."""
