"""Write notebooks/collision_clips.ipynb (run this after editing the cells below):

    python notebooks/make_collision_clips.py

The notebook's logic lives in `rvn_data.inspect`; the cells only call it.
"""
from __future__ import annotations

import os
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

CELLS = [
    ("md", """# Collision clips of a negative dataset

Opens a dataset made by `rvn-gen dataset=negative` (GNM folders with `rvn_meta.json` sidecars),
lists its collisions by scene, plays one clip (frames beside a top-down map with the path and the
collision marked) and plots the dataset's statistics. The map is rebuilt from the clip's scene
(procedural scenes need nothing; mesh scenes need their file at the sidecar's `spec`).

Install and start it from the repository root (`pip install -e '.[notebooks]'`, then
`RVN_DATASET=outputs/rvn_negative jupyter lab`), or pass a folder to `dataset_path` below.
Relative paths are read from the folder Jupyter was started in (`$PWD`, or `RVN_LAUNCH_DIR`),
not from `notebooks/`. `RVN_CLIP` picks a trajectory by name. The animation goes to
`RVN_CLIPS_OUT`, else under the cache root: `$RVN_CACHE_DIR/clips/`, else
`outputs/cache/clips/` (never into the dataset or the repository)."""),
    ("code", """import os

from rvn_data.inspect.paths import clips_dir, dataset_path

DATASET = dataset_path()  # $RVN_DATASET or outputs/rvn_negative (an rvn-gen dataset=negative out_dir)
CLIP = os.environ.get("RVN_CLIP")  # trajectory name; None = the first clip that ends in a collision
OUT = clips_dir(DATASET)  # the animation is written here
SCENE_OPTIONS = {}  # loader options for mesh scenes, e.g. {"up_axis": "z"} for HM3D
print(f"dataset {DATASET}; clips go to {OUT}")"""),
    ("code", """%matplotlib inline
from IPython.display import Image, Markdown, display

from rvn_data.inspect import (animation_frames, clip_figure, collisions, collisions_by_scene, dataset_stats,
                              first_collision, list_trajectories, load_clip, markdown_table, scene_map,
                              stats_figure, write_animation)

metas = list_trajectories(DATASET)
print(f"{DATASET}: {len(metas)} trajectories, {len(collisions(metas))} end in a collision")"""),
    ("md", "## Collisions by scene"),
    ("code", """display(Markdown(markdown_table(collisions_by_scene(metas))))"""),
    ("code", """display(Markdown(markdown_table(collisions(metas)[:20])))"""),
    ("md", """## One clip

Frames t_c − k_pre … t_c + k_post; the image is frozen at I_{t_c} after the collision, and the
poses after it are the commanded (colliding) ones."""),
    ("code", """clip = load_clip(DATASET, CLIP or first_collision(metas))
smap = scene_map(clip.meta, **SCENE_OPTIONS)
clip_figure(clip, smap)"""),
    ("code", """gif = write_animation(animation_frames(clip, smap), OUT / f"{clip.name}.gif", fps=3)
print(gif)
display(Image(filename=str(gif)))"""),
    ("md", "## Dataset statistics"),
    ("code", """stats = dataset_stats(metas)
stats_figure(stats)"""),
]


def build() -> nbformat.NotebookNode:
    nb = new_notebook(cells=[new_markdown_cell(src) if kind == "md" else new_code_cell(src) for kind, src in CELLS])
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    for i, cell in enumerate(nb.cells):
        cell["id"] = f"cell-{i:02d}"  # stable ids: the file does not change when regenerated
    return nb


def main(path: Path = Path(__file__).with_name("collision_clips.ipynb")) -> Path:
    nb = build()
    nbformat.validate(nb)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    nbformat.write(nb, str(tmp))
    os.replace(tmp, path)
    return path


if __name__ == "__main__":
    print(main())
