"""Seeded generators of urban scenes and chessboards whose 3-D lines are known exactly."""
from .scene import Scene, SceneObject

__all__ = ["Scene", "SceneObject"]
