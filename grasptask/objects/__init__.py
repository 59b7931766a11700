"""Objects as implicit surfaces g(p) (paper Section 4): superquadrics and Gaussian-process implicit surfaces."""

from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.object_files import load_object
from grasptask.objects.superquadric import Superquadric

__all__ = ["GPImplicitSurface", "Superquadric", "load_object"]
