"""Scenes: procedural apartments (the embedded default), mesh files, HM3D layout."""
from rvn_data.scenes.scene import NEUTRAL_GREY, Part, Scene, SceneError

__all__ = ["NEUTRAL_GREY", "Part", "Scene", "SceneError"]
