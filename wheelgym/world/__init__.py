"""The navigate task's world: arena walls, obstacles, collisions, range sensing and map files."""

from wheelgym.world.arena import Arena, World, build_space, k_clearance, k_ranges, pymunk_ranges
from wheelgym.world.maps import MAPS, MapArena, k_surface_dist, load_map

__all__ = ["Arena", "World", "build_space", "k_ranges", "k_clearance", "pymunk_ranges", "MAPS",
           "MapArena", "load_map", "k_surface_dist"]
