"""Planning on the navigate task's maps: occupancy grids, A*, hybrid A*, the planning baseline.

Layer: above ``world`` (it reads layouts and maps) and below ``tasks`` (the navigate task's
opt-in waypoint hint plans with it). ``wheelgym.baseline(env, planner="auto")`` drives a
navigate environment with :class:`PlanningNavigator` (docs/topics/planning.md).
"""

from wheelgym.planning.grid import OccupancyGrid, grid_from_world, inflate
from wheelgym.planning.navigator import (
    PLANNERS,
    PlanningNavigator,
    WaypointHint,
    plan_car,
    plan_path,
)
from wheelgym.planning.search import astar, cost_to_go, hybrid_astar, shortcut

__all__ = ["OccupancyGrid", "grid_from_world", "inflate", "astar", "cost_to_go", "shortcut",
           "hybrid_astar", "plan_path", "plan_car", "PlanningNavigator", "WaypointHint", "PLANNERS"]
