"""Scene lists of a split: `scene_specs(source, split, ...)` → specs for `load_scene`.

Sources: `procedural` (`procedural:<split>/<i>`; 800 train / 50 val / 50 test), `mesh_dir`
(a directory of GLB/glTF/OBJ/PLY files, or of folders of them (a folder a scan, as Habitat's MP3D and HM3D), each
scan once (`scene_meshes`: Habitat's `<id>.basis.glb` where no `<id>.glb`, semantic meshes left out):
`<root>/<split>/` when it exists, else the meshes directly in `<root>`,
as for every split without its folder, and the commands say so (`shared_splits`); one mesh file, or a text file
listing paths), `list_file` (a text file listing paths; relative paths are relative to the file; blank lines and
`#` comments ignored) and `hm3d` (`<root>/<split>/<NNNNN-id>/<id>.glb`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rvn_data.scenes.hm3d import hm3d_scenes
from rvn_data.scenes.mesh_file import SUFFIXES
from rvn_data.scenes.scene import SceneError

PROCEDURAL_SPLITS = {"train": 800, "val": 50, "test": 50}
SOURCES = ("procedural", "mesh_dir", "list_file", "hm3d")


@dataclass(frozen=True)
class ScenesConfig:
    """Which scenes a command uses (conf/scenes/*.yaml; rvn_data.scenes.sets.scene_specs)."""

    source: str = "procedural"  # procedural | mesh_dir | hm3d
    root: str | None = None  # folder (or list file) of the scenes; null for procedural
    split: str = "${split}"  # the command's split
    num_scenes: int | None = None  # null = every scene of the split
    first_scene: int = 0  # index of the first scene within the split
    up_axis: str = "y"  # the meshes' up axis on disk (y or z; z is rotated to y on load)
    unit_scale: float = 1.0  # metres per mesh unit
    level: bool = False  # rotate each scene so its floor is horizontal


def _list_file(path: Path) -> list[str]:
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise SceneError(f"scenes.root={path} is neither a text file listing meshes nor a mesh file "
                         f"({', '.join(SUFFIXES)}); point it at a folder of mesh files, one mesh, or a list") from None
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            p = Path(line).expanduser()
            out.append(str(p if p.is_absolute() else path.parent / p))
    if not out:
        raise SceneError(f"scene list {str(path)!r} names no mesh files")
    missing = [p for p in out if not Path(p).is_file()]
    if missing:
        raise SceneError(f"scene list {str(path)!r} names {len(missing)} mesh file(s) that do not exist, "
                         f"e.g. {missing[0]!r}")
    return out


def _scene_name(path: Path) -> tuple[str, str]:
    """(scene, role) of a mesh file as Habitat's datasets name them: ``<id>.glb`` the scene, ``<id>.basis.glb`` the
    same scene with Basis textures, ``<id>.semantic.glb`` / ``<id>_semantic.ply`` its semantic annotation mesh."""
    name = path.name.lower()
    for suffix, role in ((".basis.glb", "basis"), (".semantic.glb", "semantic"), ("_semantic.ply", "semantic")):
        if name.endswith(suffix):
            return name[:-len(suffix)], role
    return name.rsplit(".", 1)[0], "mesh"


def scene_meshes(paths: list[Path]) -> list[str]:
    """The scenes among a folder's mesh files, sorted: a ``<id>.basis.glb`` only where no ``<id>.glb`` (the same
    scan, as HM3D ships both), and no semantic annotation mesh of a scene that is there (HM3D's ``<id>.semantic.glb``,
    MP3D's ``<id>_semantic.ply``: object ids as colours, not the scan's)."""
    roles: dict[str, set[str]] = {}
    for p in paths:
        scene, role = _scene_name(p)
        roles.setdefault(scene, set()).add(role)
    keep = []
    for p in paths:
        scene, role = _scene_name(p)
        has = roles[scene]
        if (role == "basis" and "mesh" in has) or (role == "semantic" and has & {"mesh", "basis"}):
            continue
        keep.append(str(p))
    return sorted(keep)


def _meshes_in(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if p.is_file() and p.name.lower().endswith(SUFFIXES)]


def _mesh_dir(root: Path, split: str) -> list[str]:
    if root.is_file() and root.name.lower().endswith(SUFFIXES):
        return [str(root)]  # one mesh: a set of one scene
    if root.is_file():
        return _list_file(root)
    if not root.is_dir():
        raise SceneError(f"scene folder {str(root)!r} not found; set scenes.root to a folder of "
                         "mesh files or a text file listing them")
    base = root / split if (root / split).is_dir() else root
    files = scene_meshes(_meshes_in(base))
    if not files:  # a folder a scan, as Habitat's MP3D (<id>/<id>.glb) and HM3D (<NNNNN-id>/<id>.basis.glb) lay out
        files = [f for folder in sorted(p for p in base.iterdir() if p.is_dir()) for f in scene_meshes(_meshes_in(folder))]
    if not files:
        raise SceneError(f"no mesh files ({', '.join(SUFFIXES)}) in {str(base)!r} or in its folders")
    return files


def shared_splits(source: str, split: str, root: str | Path | None) -> list[str]:
    """The other splits (of train, val and test) that take the same meshes as ``split``: a ``mesh_dir`` folder
    without ``<split>/`` gives the split every mesh directly in it, and so it does to each split without its folder
    (a model's training scenes are then its evaluation scenes). Empty where splits are disjoint: procedural and HM3D
    scenes, a split with a folder of its own, a list file or one mesh (the user's explicit choice)."""
    if source != "mesh_dir" or root is None or str(root) in ("", "???"):
        return []
    root = Path(root).expanduser()
    if not root.is_dir() or (root / split).is_dir():
        return []
    return [other for other in PROCEDURAL_SPLITS if other != split and not (root / other).is_dir()]


def shared_splits_note(root: str | Path, split: str, others: list[str]) -> str:
    """One line saying that ``split`` takes the same meshes as the splits ``others`` (`shared_splits`)."""
    root = Path(root).expanduser()
    return (f"scenes.root={root} has no {split}/ folder, so split={split} takes every mesh in it, as split "
            f"{' and '.join(others)} {'does' if len(others) == 1 else 'do'}: their scenes are the same; put each "
            f"split's meshes in a folder of its own ({root}/train, {root}/val, {root}/test) to keep them apart")


def _check_distinct_names(specs: list[str], where: str) -> None:
    """SceneError when two meshes would get one scene name, e.g. Replica's <room>/mesh.ply: their trajectories, seeds
    and episodes are named by it, so the second would pass for the first. The name compared is the file name up to its
    first dot, case aside: the loader's scene id outside HM3D's <NNNNN-id> folders (`hm3d.hm3d_scene_id`), and what
    rvn-gen's trajectory names begin with (`rvn_data.dataset.naming.scene_slug`, the file's stem) in them too."""
    seen: dict[str, str] = {}
    for spec in specs:
        name = Path(spec).name.split(".")[0].lower()
        if name in seen:
            raise SceneError(f"{where}: {seen[name]!r} and {spec!r} would both be scene {name!r}, and RVN names a "
                             f"scene's trajectories, episodes and random draws by it; give each scan a file name of its "
                             f"own (a link named after its folder will do)")
        seen[name] = spec


def scene_specs(source: str, split: str, root: str | Path | None = None,
                num_scenes: int | None = None, first_scene: int = 0, setting: str = "scenes.first_scene") -> list[str]:
    """Specs (`procedural:<split>/<i>` or mesh paths) of a split, `first_scene` onward, at most
    `num_scenes` of them (None: all). A `first_scene` past the split's last scene is a ValueError
    naming `setting` (the command's name for it) and the split's size."""
    if source not in SOURCES:
        raise ValueError(f"scene source {source!r} unknown; use one of {list(SOURCES)}")
    if first_scene < 0 or (num_scenes is not None and num_scenes < 0):
        raise ValueError(f"first_scene={first_scene}, num_scenes={num_scenes} must be >= 0")
    if source == "procedural":
        if split not in PROCEDURAL_SPLITS:
            raise ValueError(f"split {split!r} unknown; procedural splits are {list(PROCEDURAL_SPLITS)}")
        specs = [f"procedural:{split}/{i}" for i in range(PROCEDURAL_SPLITS[split])]
    else:
        if root is None or str(root) in ("", "???"):
            raise ValueError(f"scene source {source!r} needs a root (scenes.root=...)")
        root = Path(root).expanduser()
        if source == "hm3d":
            specs = [str(p) for p in hm3d_scenes(root, split)]
        elif source == "list_file":
            if not root.is_file():
                raise SceneError(f"scene list {str(root)!r} not found")
            specs = _list_file(root)
        else:
            specs = _mesh_dir(root, split)
        _check_distinct_names(specs, f"scenes.root={root}")
    if first_scene > 0 and first_scene >= len(specs):
        raise ValueError(f"{setting}={first_scene} is past the last scene: the {split} split has {len(specs)} scenes "
                         f"(indices 0 to {len(specs) - 1}); choose {setting} from 0 to {len(specs) - 1}")
    specs = specs[first_scene:]
    return specs if num_scenes is None else specs[:num_scenes]
