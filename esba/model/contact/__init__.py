"""Contact geometry: obstacles in a scene and the actuator's surfaces they touch.

:mod:`.obstacles` (a flat probe or wall, a half-plane; a cylinder, a disc in the plane: validated,
frozen, each with its signed distance for NumPy and CasADi) and :mod:`.surface` (the points of the
inextensible layer and of the dorsal surface along whole segments of the chain of arcs, and the
closest point of each segment to an obstacle). The constrained equilibrium that uses them is
:mod:`esba.statics.contact`. May import :mod:`esba.infra` and the rest of :mod:`esba.model`.

The obstacles are planar today. A 3-D obstacle (a plane, a sphere, a cylinder of any axis) is the
same protocol in three coordinates: ``dimension``, ``distance(q)`` on points of that dimension,
its gradient and Hessian in q, and ``parameters()`` for the symbolic distance.
"""

from .obstacles import OBSTACLE_KINDS, SIDES, Cylinder, HalfPlane, Obstacle, ObstacleError, obstacle_from_dict

__all__ = ["Obstacle", "HalfPlane", "Cylinder", "ObstacleError", "obstacle_from_dict", "OBSTACLE_KINDS", "SIDES"]
