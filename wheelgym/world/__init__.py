"""The navigate task's world: arena walls, obstacles, collisions and range sensing."""

from wheelgym.world.arena import Arena, World, build_space, k_clearance, k_ranges, pymunk_ranges

__all__ = ["Arena", "World", "build_space", "k_ranges", "k_clearance", "pymunk_ranges"]
