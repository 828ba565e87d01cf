"""Episode files: one gzip JSON per scene plus ``index.json``, generated on demand and cached.

Layout: ``<dir>/<scene source>/<split>-<key>/<NNNNN>_<scene name>.json.gz`` and
``<dir>/<scene source>/<split>-<key>/index.json``, ``<dir>`` = ``episodes.dir``, by default
``<cache root>/episodes`` (`rvn_data.cache_root`), ``<key>`` a hash of the settings record below (`episodes.settings_record`) and
of the scenes' root folder, so sets made with other settings never meet. Every file carries
the settings that made it (generator version, episode settings, agent, navmesh settings,
scene loading options, split); reading a file made with other settings raises ValueError naming the
file and the first differing setting. Bytes are reproducible: JSON with sorted keys,
gzip with mtime 0. Episode ``e`` does not depend on how many were asked for, so a file
holding more episodes serves a request for fewer, and a short file is extended.
"""
from __future__ import annotations

import gzip
import json
import re
from pathlib import Path

from rvn_data.atomic import write_bytes_atomic
from rvn_data.cache_root import absolute, settings_key
from rvn_data.dataset.naming import scene_slug
from rvn_data.identity import check_identity
from rvn_data.benchmark.episodes import Episode, EpisodeSettings, sample_episodes

FORMAT_SCENE = "rvn-episodes/scene"
FORMAT_INDEX = "rvn-episodes/index"


def check_settings(path: Path, stored: dict, wanted: dict, what: str = "episode file",
                   hint: str = "use another episodes.dir or delete {dir}") -> None:
    """ValueError naming ``path`` and the settings that differ (`rvn_data.identity`)."""
    check_identity(path, stored, wanted, what, hint)


def _read_gzip_json(path: Path) -> dict:
    try:
        return json.loads(gzip.decompress(path.read_bytes()))
    except (OSError, EOFError, json.JSONDecodeError) as err:
        raise ValueError(f"episode file {path} is unreadable ({err}); delete it to regenerate") from None


def dumps_gzip_json(obj: dict) -> bytes:
    """Reproducible bytes: sorted-key JSON, gzip with mtime 0 and no file name."""
    raw = json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()
    return gzip.compress(raw, compresslevel=6, mtime=0)


class EpisodeStore:
    """The cached episode set of one split under ``root`` (config ``episodes.dir``)."""

    def __init__(self, root: str | Path, split: str, settings: dict, scenes_root: str | Path | None = None):
        self.split = split
        self.settings = settings
        source = settings["scenes"].get("source") or "scenes"
        key = settings_key({"settings": settings, "scenes_root": absolute(scenes_root)})
        self.dir = Path(root).expanduser() / re.sub(r"[^A-Za-z0-9_.-]", "_", str(source)) / f"{split}-{key}"
        self.index_path = self.dir / "index.json"

    def scene_path(self, scene_index: int, spec: str) -> Path:
        """The scene's file in this set (its index in the split's scene list, its name)."""
        return self.dir / f"{int(scene_index):05d}_{scene_slug(spec)}.json.gz"

    def _index_settings(self) -> list[tuple[Path, dict]]:
        """[(index.json, the settings it records)], or [] when there is no index yet."""
        if not self.index_path.exists():
            return []
        try:
            return [(self.index_path, json.loads(self.index_path.read_text())["settings"])]
        except (json.JSONDecodeError, KeyError) as err:
            raise ValueError(f"episode index {self.index_path} is unreadable ({err}); delete it") from None

    def _check_made_here(self, files: list[tuple[Path, dict]]) -> None:
        """Raise, naming the file and the settings that differ, if any of ``files`` (path, recorded
        settings) was made with other settings than this store's."""
        for path, stored in files:
            check_settings(path, stored, self.settings)

    def read_scene(self, scene_index: int, spec: str) -> dict | None:
        """The stored file of a scene (``scene_id``, ``fingerprint``, ``episodes``: list of
        `Episode`), or None if there is none; raises if it, or the set's index, was made with
        other settings."""
        path = self.scene_path(scene_index, spec)
        data = _read_gzip_json(path) if path.exists() else None
        if data is not None and data.get("format") != FORMAT_SCENE:
            raise ValueError(f"episode file {path} is not an RVN episode file (format={data.get('format')!r})")
        self._check_made_here(self._index_settings() + ([(path, data["settings"])] if data else []))
        if data is None:
            return None
        if int(data["scene_index"]) != int(scene_index):
            raise ValueError(f"episode file {path} holds scene index {data['scene_index']}, expected {scene_index}")
        data["episodes"] = [Episode.from_json(e, data["scene_id"], scene_index) for e in data["episodes"]]
        return data

    def write_scene(self, scene_index: int, spec: str, scene_id: str, fingerprint: str,
                    episodes: list[Episode]) -> Path:
        path = self.scene_path(scene_index, spec)
        payload = {
            "format": FORMAT_SCENE,
            "settings": self.settings,
            "scene_id": scene_id,
            "scene_index": int(scene_index),
            "scene_name": scene_slug(spec),
            "fingerprint": fingerprint,
            "episodes": [e.to_json() for e in episodes],
        }
        try:
            write_bytes_atomic(path, dumps_gzip_json(payload))
        except OSError as err:
            raise ValueError(f"cannot write episode file {path} ({err.strerror or err}); set cache_dir= or "
                             "RVN_CACHE_DIR (or episodes.dir=) to a writable folder") from None
        return path

    def check_scene(self, stored: dict, scene_index: int, spec: str, scene_id: str, fingerprint: str) -> None:
        """Raise if a stored file was made for another scene or another version of its mesh."""
        path = self.scene_path(scene_index, spec)
        if stored["scene_id"] != scene_id:
            raise ValueError(f"episode file {path} is for scene {stored['scene_id']!r}, not {scene_id!r}; "
                             "delete it to regenerate")
        if stored.get("fingerprint") != fingerprint:
            raise ValueError(f"episode file {path} was made for another version of scene {scene_id!r} (mesh "
                             f"fingerprint {stored.get('fingerprint')} != {fingerprint}); delete it to regenerate")

    def write_index(self) -> Path:
        """(Re)write index.json from the scene files present."""
        files = [(path, _read_gzip_json(path)) for path in sorted(self.dir.glob("*.json.gz"))]
        self._check_made_here(self._index_settings() + [(path, data["settings"]) for path, data in files])
        scenes = [{"file": path.name, "scene_id": data["scene_id"], "scene_index": data["scene_index"],
                   "fingerprint": data.get("fingerprint"), "episodes": len(data["episodes"])} for path, data in files]
        index = {"format": FORMAT_INDEX, "settings": self.settings, "split": self.split, "scenes": scenes}
        text = json.dumps(index, sort_keys=True, indent=1, allow_nan=False) + "\n"
        write_bytes_atomic(self.index_path, text.encode())
        return self.index_path

    def episodes_for(self, scene_index: int, spec: str, count: int, open_navmesh, loaded=None) -> list[Episode]:
        """The first ``count`` episodes of a scene, generated and saved when missing.

        ``open_navmesh()`` -> (scene, navmesh) is called only when generation is needed;
        ``loaded`` = (scene, navmesh) already at hand is checked against the file's scene id
        and mesh fingerprint (and used for generation).
        """
        stored = self.read_scene(scene_index, spec)
        have = stored["episodes"] if stored else []
        if loaded is not None and stored:
            self.check_scene(stored, scene_index, spec, loaded[0].scene_id, loaded[0].fingerprint())
        if len(have) >= count:
            return have[:count]
        scene, navmesh = loaded if loaded is not None else open_navmesh()
        fingerprint = scene.fingerprint()
        if stored:
            self.check_scene(stored, scene_index, spec, scene.scene_id, fingerprint)
        settings = EpisodeSettings(**self.settings["episodes"])
        new = sample_episodes(navmesh, settings, self.split, scene.scene_id, scene_index, range(len(have), count))
        episodes = have + new
        self.write_scene(scene_index, spec, scene.scene_id, fingerprint, episodes)
        return episodes
