"""HM3D layout: `<root>/<split>/<NNNNN-id>/<id>.glb` (z-up on disk, rotated on load).

The plain `<id>.glb` (HM3D's glb download: JPEG textures) is preferred over `<id>.basis.glb` (its Habitat download:
Basis Universal textures, decoded with the optional `rvn[basis]`, rvn_data/scenes/basis_textures.py); the
`<id>.basis.navmesh` Habitat ships beside it is used with
`navmesh.source=auto` (the default, `build`, builds from the mesh) (see rvn_data/navmesh/source.py).
"""
from __future__ import annotations

import re
from pathlib import Path

from rvn_data.scenes.scene import SceneError

SCENE_DIR = re.compile(r"^\d{5}-[A-Za-z0-9]+$")


def scene_mesh(scene_dir: Path) -> Path | None:
    """The mesh of one HM3D scene folder (`<id>.glb`, else `<id>.basis.glb`), or None."""
    sid = scene_dir.name.split("-", 1)[1]
    for name in (f"{sid}.glb", f"{sid}.basis.glb"):
        if (scene_dir / name).is_file():
            return scene_dir / name
    return None


def hm3d_scenes(root: str | Path, split: str) -> list[Path]:
    """Mesh paths of a split, sorted by folder name (SceneError if the split folder is missing)."""
    base = Path(root) / split
    if not base.is_dir():
        raise SceneError(f"HM3D split folder {str(base)!r} not found; set scenes.root to the folder "
                         f"holding {split}/<NNNNN-id>/<id>.glb")
    out = []
    for d in sorted(p for p in base.iterdir() if p.is_dir() and SCENE_DIR.match(p.name)):
        mesh = scene_mesh(d)
        if mesh is not None:
            out.append(mesh)
    if not out:
        raise SceneError(f"no HM3D scenes (<NNNNN-id>/<id>.glb) under {str(base)!r}")
    return out


def hm3d_scene_id(path: str | Path) -> str:
    """`NNNNN-id` for a mesh inside an HM3D scene folder, else the file name without suffixes."""
    p = Path(path)
    return p.parent.name if SCENE_DIR.match(p.parent.name) else p.name.split(".")[0]
