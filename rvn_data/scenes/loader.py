"""`load_scene(spec)`: a mesh path or `procedural:<split>/<index>` → `Scene`."""
from __future__ import annotations

import re
from pathlib import Path

from rvn_data.scenes.hm3d import hm3d_scene_id
from rvn_data.scenes.mesh_file import load_mesh_file
from rvn_data.scenes.scene import Scene, SceneError

PROCEDURAL = re.compile(r"^procedural:([a-z]+)/(\d+)$")


def load_scene(spec: str | Path, up_axis: str = "y", unit_scale: float = 1.0, level: bool = False) -> Scene:
    """Load a scene. Procedural specs ignore the mesh options (they are y-up metres)."""
    spec = str(spec)
    if spec.startswith("procedural:"):
        m = PROCEDURAL.match(spec)
        if m is None:
            raise SceneError(f"scene spec {spec!r} malformed; expected procedural:<split>/<index>, "
                             "e.g. procedural:train/0")
        from rvn_data.scenes.procedural import make_apartment  # lazy: heavy generator

        try:
            return make_apartment(m.group(1), int(m.group(2)))
        except (ValueError, IndexError, KeyError) as exc:
            if isinstance(exc, SceneError):
                raise
            raise SceneError(f"scene {spec!r}: {exc}") from exc
    return load_mesh_file(Path(spec).expanduser(), up_axis=up_axis, unit_scale=unit_scale, level=level,
                          scene_id=hm3d_scene_id(spec))
