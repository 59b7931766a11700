"""Task modelling: from wrench recordings to 6D task ellipsoids, task models and distances (paper Sections 2, 7)."""
