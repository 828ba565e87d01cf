"""Scenes: procedural apartments (the embedded default), mesh files, HM3D layout."""
from rvn_data.scenes.scene import NEUTRAL_GREY, Part, Scene, SceneError
from rvn_data.scenes.loader import load_scene
from rvn_data.scenes.mesh_file import load_mesh_file
from rvn_data.scenes.sets import PROCEDURAL_SPLITS, scene_specs

__all__ = ["NEUTRAL_GREY", "PROCEDURAL_SPLITS", "Part", "Scene", "SceneError", "load_mesh_file",
           "load_scene", "scene_specs"]
