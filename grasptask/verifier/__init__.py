"""The independent grasp verifier (paper Section 5): contact, friction, strength and task-wrench checks.

Nothing here imports Pyomo or the synthesis model: the verifier is the independent judge of every grasp.
"""
