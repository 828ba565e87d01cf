"""Top-down map of a navmesh: islands in colour (each with its floor height where the navmesh has several layers;
an upper floor is drawn over a lower one), eroded walkable margin, obstacles, scale bar."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rvn_data.atomic import atomic_path
from rvn_data.navmesh.build import scene_heightfield


def map_image(scene, navmesh) -> tuple[np.ndarray, list[tuple[str, tuple]]]:
    """RGB float image [rows, cols, 3] (row 0 = -z side, +x to the right) and legend entries."""
    import matplotlib

    st = navmesh.settings
    v, f = scene.triangles()
    hf, _, _ = scene_heightfield(v, f, st)
    geometry = (np.diff(hf.start) > 0).reshape(hf.nz, hf.nx)
    island, free = navmesh.topdown()
    img = np.ones(island.shape + (3,))
    img[geometry] = (0.25, 0.25, 0.28)
    img[free] = (0.78, 0.78, 0.78)
    cmap = matplotlib.colormaps["tab10"]
    legend = [("obstacle / non-walkable", (0.25, 0.25, 0.28)),
              (f"walkable, < {st.agent_radius} m from obstacles", (0.78, 0.78, 0.78))]
    sampled = navmesh.sampled_islands
    for i, area in enumerate(navmesh.island_areas):
        color = cmap(i % 10)[:3]
        img[island == i] = color
        if i < 8:
            where = f", floor y {navmesh.island_shapes.heights[i]:.2f} m" if len(navmesh.layers) > 1 else ""
            tag = " (main)" if i == 0 else " (sampled: navmesh.islands=all)" if i in sampled else ""
            legend.append((f"island {i}: {area:.1f} m²{where}{tag}", color))
    return img, legend


def write_map(scene, navmesh, path: str | Path) -> None:
    """Write the map as PNG atomically (temporary file, then os.replace)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    path = Path(path)
    if path.parent and not path.parent.exists():
        raise OSError(f"output folder {str(path.parent)!r} does not exist")
    img, legend = map_image(scene, navmesh)
    cs = navmesh.settings.cell_size
    x0, z0 = navmesh.x0, navmesh.z0
    rows, cols = img.shape[:2]
    extent = (x0, x0 + cols * cs, z0 + rows * cs, z0)  # image row 0 (-z) at the top
    fig, ax = plt.subplots(figsize=(8, 8 * rows / max(cols, 1) + 0.8), dpi=110)
    ax.imshow(img, extent=extent, interpolation="nearest")
    width = cols * cs
    bar = max(1.0, float(np.round(width / 5)))
    bx, bz = x0 + 0.05 * width, z0 + rows * cs * 0.96
    ax.plot([bx, bx + bar], [bz, bz], color="k", lw=3)
    ax.text(bx + bar / 2, bz - 0.02 * rows * cs, f"{bar:g} m", ha="center", va="bottom")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_title(f"{scene.scene_id}: main island {navmesh.navigable_area:.1f} m²")
    ax.legend(handles=[Patch(color=c, label=t) for t, c in legend], loc="upper left",
              bbox_to_anchor=(1.01, 1.0), fontsize=8)
    try:
        with atomic_path(path) as tmp:  # removes its temporary file on error
            fig.savefig(tmp, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)
