"""Grasp mechanics and the independent grasp verifier (paper Section 5; SPEC section 7, verification).

Nothing here imports Pyomo or the synthesis model: the verifier is the independent judge of every grasp.
"""
