"""Grasp mechanics and the independent grasp verifier (paper Section 5).

Nothing here imports Pyomo or the synthesis model: the verifier is the independent judge of every grasp.
"""
