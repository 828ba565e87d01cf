"""`rvn-scene`: inspect a scene (`info`), draw its top-down navmesh map (`map`), render
sample views (`views`), write its navmesh as a Habitat/Recast file (`navmesh`). SCENE is a
mesh path or `procedural:<split>/<index>`.

Bad input prints one line on stderr and exits with code 2 (-o is checked before the scene is
loaded), the convention of every RVN tool (`rvn_data.cli.common`).
"""
from __future__ import annotations

import argparse
import math
import json
import sys
from pathlib import Path

import numpy as np

from rvn_data.dataset.floors import floor_heights
from rvn_data.navmesh.islands import wide_islands


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", nargs="?", default="procedural:train/0",
                   help="mesh path (GLB/glTF/OBJ/PLY) or procedural:<split>/<index> (default: procedural:train/0)")
    p.add_argument("--up-axis", choices=("y", "z"), default="y", help="up axis of the file (HM3D: z)")
    p.add_argument("--unit-scale", type=float, default=1.0, help="metres per file unit (mm: 0.001)")
    p.add_argument("--level", action="store_true", help="rotate so the dominant floor normal is +y")
    p.add_argument("--agent-radius", type=float, default=0.18, help="navmesh agent radius (m)")
    p.add_argument("--agent-height", type=float, default=1.0, help="navmesh agent height (m)")
    p.add_argument("--navmesh", metavar="FILE", default=None,
                   help="read the navmesh from this Habitat/Recast .navmesh instead of building it")
    p.add_argument("--navmesh-source", choices=("auto", "build", "file"), default="auto",
                   help="auto: --navmesh, else a .navmesh beside the scene file, else build")
    p.add_argument("--profile", choices=("rvn", "habitat"), default="rvn",
                   help="how a built navmesh erodes: rvn (exact radius) or habitat (Recast's whole cells)")
    p.add_argument("--islands", choices=("main", "all"), default="main",
                   help="where points are drawn (views; info marks them): main (the largest island) or all "
                        "(Habitat's rule: also every island of radius >= 1.5 m, e.g. a scan's other floors)")


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="rvn-scene", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("info", help="triangles, bounds, walkable islands, navigable area")
    _add_scene_args(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p = sub.add_parser("map", help="write a top-down map of the navmesh (PNG)")
    _add_scene_args(p)
    p.add_argument("-o", "--output", required=True, help="PNG path")
    p = sub.add_parser("views", help="render sample views from random navigable poses")
    _add_scene_args(p)
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("-n", "--n", type=int, default=8, help="number of views")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--backend", choices=("auto", "gl", "raycast"), default="auto")
    p = sub.add_parser("navmesh", help="write the navmesh as a Habitat/Recast .navmesh file")
    _add_scene_args(p)
    p.add_argument("-o", "--output", required=True, help=".navmesh path")
    p.add_argument("--tile-cells", type=int, default=64, help="tile size in cells")
    return ap


def _check_output(args) -> None:
    """-o can be written (a folder for views, a file in an existing folder otherwise)."""
    from rvn_data.cli.common import ConfigError, check_writable_dir

    out = Path(args.output).expanduser()
    if args.command == "views":
        check_writable_dir(out, "-o ")
        return
    if out.is_dir():
        raise ConfigError(f"-o {out} is a folder; give the path of the {args.command} file to write")
    parent = out.absolute().parent
    if not parent.is_dir():
        what = "is not a folder" if parent.exists() else "does not exist"
        raise ConfigError(f"-o {out}: {parent} {what}; create that folder or choose another path")
    check_writable_dir(out.absolute().parent, "-o ")


def _load(args):
    from rvn_data.navmesh import NavMeshSettings
    from rvn_data.navmesh.source import open_navmesh
    from rvn_data.scenes import load_scene

    settings = NavMeshSettings(agent_radius=args.agent_radius, agent_height=args.agent_height,
                               source=args.navmesh_source, file=args.navmesh, profile=args.profile,
                               islands=args.islands)
    scene = load_scene(args.scene, up_axis=args.up_axis, unit_scale=args.unit_scale, level=args.level)
    return scene, settings, open_navmesh


def material_summary(scene) -> dict:
    """How the scene's parts (one a material) are coloured: by a texture, by vertex colours, or by their base colour
    alone (a scan whose textures were not read shows here), with the texture megapixels and the textured share of
    the surface."""
    kinds, area, textured_area, pixels = {"textured": 0, "vertex_colored": 0, "base_color": 0}, 0.0, 0.0, 0
    for part in scene.parts:
        tri = part.vertices[part.faces].astype(np.float64)
        a = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
        area += a
        if part.texture is not None and part.uv is not None:
            kinds["textured"] += 1
            textured_area += a
            pixels += part.texture.shape[0] * part.texture.shape[1]
        else:
            kinds["vertex_colored" if part.colors is not None else "base_color"] += 1
    return {**kinds, "texture_megapixels": round(pixels / 1e6, 3),
            "textured_area_share": round(textured_area / area, 4) if area > 0 else 0.0}


def cmd_info(args) -> None:
    scene, settings, open_navmesh = _load(args)
    nm = open_navmesh(scene, settings)
    info = {
        "scene": scene.scene_id,
        "source": scene.source,
        "triangles": scene.num_triangles,
        "parts": len(scene.parts),
        "materials": material_summary(scene),
        "bounds": np.round(scene.bounds, 4).tolist(),
        "islands": [round(a, 4) for a in nm.island_areas],
        "island_radii": [round(r, 4) for r in nm.island_shapes.radii],
        "island_heights": [round(h, 4) for h in nm.island_shapes.heights],
        "sampled_islands": nm.sampled_islands,
        "narrow_islands": _narrow(nm, wide_islands(nm, settings.min_island_radius)),
        "floors": [round(h, 4) for h in floor_heights(nm)],
        "navigable_area_m2": round(nm.navigable_area, 4),
        "layers": len(nm.layers),
        "navmesh": settings.to_dict(),
        "navmesh_source": "build" if nm.source_file is None else "file",
        "navmesh_file": nm.source_file,
    }
    if args.json:
        print(json.dumps(info))
        return
    lo, hi = scene.bounds
    print(f"scene      {info['scene']}  ({info['source'] or 'generated'})")
    print(f"triangles  {info['triangles']:,} in {info['parts']} part(s)")
    m = info["materials"]
    print(f"materials  {m['textured']} textured ({m['texture_megapixels']:.1f} megapixels), {m['vertex_colored']} "
          f"vertex-coloured, {m['base_color']} in a base colour alone; {m['textured_area_share']:.0%} of the surface "
          f"textured")
    print(f"bounds     x {lo[0]:.2f}..{hi[0]:.2f}  y {lo[1]:.2f}..{hi[1]:.2f}  z {lo[2]:.2f}..{hi[2]:.2f} m"
          f"  (size {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} x {hi[2] - lo[2]:.2f})")
    print(f"islands    {len(nm.island_areas)} (>= {settings.min_island_area} m², agent radius "
          f"{settings.agent_radius} m, height {settings.agent_height} m)")
    for i, a in enumerate(nm.island_areas):
        radius, y = info["island_radii"][i], info["island_heights"][i]
        thin = "  (narrow: a ledge or wall top?)" if i in info["narrow_islands"] else ""
        print(f"  island {i}: {a:8.2f} m²  radius {radius:5.2f} m  floor y {y:6.2f} m" + ("  (main)" if i == 0 else thin))
    print(f"sampled    {_sampled_line(nm, settings)}")
    if info["narrow_islands"]:
        print(f"           islands=all would draw on narrow islands ({', '.join(map(str, info['narrow_islands']))}): "
              f"to leave them out, raise navmesh.min_island_area above their area (it drops islands from the navmesh)")
    floors = info["floors"]
    print(f"floors     {', '.join(f'{h:.2f}' for h in floors)} m (heights of the sampled islands' floors"
          + ("; a goal stays on its start's floor, maps draw a panel a floor)" if len(floors) > 1 else ")"))
    what = ("the area of the file's polygons" if nm.source_file is not None else
            "its boundary placed inside the cells; a .navmesh written from it holds whole cells")
    print(f"navigable  {nm.navigable_area:.2f} m² on the main island ({what})")
    built = f"built from the scene (profile {settings.profile})"
    print(f"navmesh    {built if nm.source_file is None else 'read from ' + nm.source_file}")


NARROW = 0.15  # an island whose area is under this share of the circle of its radius: a strip (docs/SCANS.md)


def _narrow(nm, islands: list[int]) -> list[int]:
    """Those of ``islands`` (what islands=all adds: `wide_islands`) that are strips: a ledge, a wall's top."""
    radii = nm.island_shapes.radii
    return [i for i in islands if nm.island_areas[i] < NARROW * math.pi * radii[i] ** 2]


def _sampled_line(nm, settings) -> str:
    """Which islands starts and goals are drawn on, and what navmesh.islands=all would add."""
    if settings.islands == "all":
        return (f"islands {', '.join(map(str, nm.sampled_islands))} (navmesh.islands=all: the main island and every "
                f"island of radius >= {settings.min_island_radius:g} m)")
    others = wide_islands(nm, settings.min_island_radius)
    more = (f"; --islands all (navmesh.islands=all) adds island{'s' if len(others) > 1 else ''} "
            f"{', '.join(map(str, others))}, of radius >= {settings.min_island_radius:g} m" if others else "")
    return f"the main island (navmesh.islands=main){more}"


def cmd_map(args) -> None:
    from rvn_data.cli.topdown_map import write_map

    scene, settings, open_navmesh = _load(args)
    nm = open_navmesh(scene, settings)
    write_map(scene, nm, args.output)
    print(f"wrote {args.output}")


def cmd_views(args) -> None:
    from rvn_data.render.views import write_views  # lazy: pulls in the renderer

    if args.n <= 0:
        raise ValueError(f"-n {args.n}: the number of views must be positive")
    scene, settings, open_navmesh = _load(args)
    navmesh = open_navmesh(scene, settings)  # poses honour --agent-radius / --agent-height
    write_views(scene, args.output, args.n, args.seed, args.backend, navmesh=navmesh)
    print(f"wrote {args.n} view(s) to {args.output}")


def cmd_navmesh(args) -> None:
    """Write the file, read it back, and give both main-island areas: the written polygons are the
    navigable cells, whole (a cell is in when its centre has the agent's clearance), while the
    navmesh built from the scene places the eroded boundary inside its cells, so the two differ
    by up to half a cell along the boundary."""
    from rvn_data.navmesh.detour_write import write_navmesh_file
    from rvn_data.navmesh.source import load_navmesh_file

    scene, settings, open_navmesh = _load(args)
    nm = open_navmesh(scene, settings)
    path = write_navmesh_file(nm, args.output, tile_cells=args.tile_cells)
    back = load_navmesh_file(path, settings, scene)
    print(f"wrote {args.output} ({path.stat().st_size:,} bytes)")
    print(f"  main island {back.navigable_area:.2f} m² in the file: its polygons are the navigable cells, whole "
          "(what rvn-scene info --navmesh reads back)")
    if nm.source_file is None:
        print(f"  main island {nm.navigable_area:.2f} m² as built: the boundary placed inside the cells "
              "(what rvn-scene info builds)")


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    from rvn_data.cli.common import BAD_INPUT

    from rvn_data.warning_lines import said_once

    try:
        with said_once(f"rvn-scene {args.command}"):  # a scan's warnings in one line, named by the command
            if getattr(args, "output", None) is not None:
                _check_output(args)
            {"info": cmd_info, "map": cmd_map, "views": cmd_views, "navmesh": cmd_navmesh}[args.command](args)
    except (ValueError, OSError, RuntimeError) as exc:  # SceneError is a ValueError; RuntimeError: no EGL for gl
        msg = " ".join(str(exc).split())
        print(f"rvn-scene {args.command}: error: {msg}", file=sys.stderr)
        return BAD_INPUT  # a scene, setting, path or renderer this machine cannot use
    return 0


if __name__ == "__main__":
    sys.exit(main())
