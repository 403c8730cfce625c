"""Obstacles from a scene file's ``[[obstacles]]`` tables, planar (:mod:`.obstacles`) or 3-D (:mod:`.spatial`).

Examples
--------
>>> obstacle_from_dict("[[obstacles]] #1", {"kind": "cylinder", "centre": [90, 30], "radius": 12})
Cylinder(centre=(90.0, 30.0), radius=12.0, side='auto')
>>> obstacle_from_dict("[[obstacles]] #1", {"kind": "sphere", "centre": [100, 0, 30], "radius": 12})
Sphere(centre=(100.0, 0.0, 30.0), radius=12.0, side='auto')
>>> obstacle_from_dict("[[obstacles]] #1", {"kind": "cone"})
Traceback (most recent call last):
...
esba.model.contact.obstacles.ObstacleError: [[obstacles]] #1: kind='cone': allowed are half-plane, cylinder, plane, sphere (plane, sphere and a cylinder with an axis are 3-D)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from esba.infra import checks

from . import obstacles
from .obstacles import OBSTACLE_KINDS, Obstacle, ObstacleError
from .spatial import SPATIAL_KINDS, is_spatial, spatial_obstacle_from_dict

__all__ = ["obstacle_from_dict"]


def obstacle_from_dict(where: str, item: Any) -> Obstacle:
    """An obstacle from a scene file's ``[[obstacles]]`` table: a 3-D one (``plane``, ``sphere``, a
    ``cylinder`` with an ``axis`` or a three-number centre) or a planar one (``half-plane``, ``cylinder``)."""
    if isinstance(item, Mapping) and is_spatial(item):
        return spatial_obstacle_from_dict(where, item)
    if isinstance(item, Mapping) and item.get("kind") not in OBSTACLE_KINDS:
        names = list(OBSTACLE_KINDS) + [k for k in SPATIAL_KINDS if k not in OBSTACLE_KINDS]
        raise ObstacleError(f"{where}: kind={checks.quote(item.get('kind'))}: allowed are {', '.join(names)} (plane, sphere and a cylinder with an axis are 3-D)")
    return obstacles.obstacle_from_dict(where, item)
