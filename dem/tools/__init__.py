"""Checks and benchmarks that drive an engine's scene: collisions, energy balance, speed, profiles."""
