"""Inspecting generated datasets: collision clips, maps, statistics (notebooks/collision_clips.ipynb)."""
from rvn_data.inspect.clips import (Clip, collisions, collisions_by_scene, dataset_stats, first_collision,
                                    list_trajectories, load_clip, markdown_table)
from rvn_data.inspect.maps import SceneMap, draw_clip, scene_map
from rvn_data.inspect.plots import animation_frames, clip_figure, stats_figure, write_animation

__all__ = ["Clip", "SceneMap", "animation_frames", "clip_figure", "collisions", "collisions_by_scene", "dataset_stats",
           "draw_clip", "first_collision", "list_trajectories", "load_clip", "markdown_table", "scene_map",
           "stats_figure", "write_animation"]
