"""surf-swarm: mission planning and simulation for swarms of small skid-steered surf-zone robots."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("surf-swarm")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
