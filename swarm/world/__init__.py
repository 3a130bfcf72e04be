"""The world the robots work in: `BeachMap` (terrain class and elevation per cell, named regions),
its file format (`maps/NAME.yaml` with a `.npz` grid beside it), GeoJSON and ESRI ASCII DEM I/O,
and the procedural beach generator (`swarm.world.generate`)."""

from swarm.world.beachmap import REGION_KINDS, BeachMap, Region
from swarm.world.io import load_map, save_map

__all__ = ["REGION_KINDS", "BeachMap", "Region", "load_map", "save_map"]
