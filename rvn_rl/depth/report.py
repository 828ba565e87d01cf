"""What a depth run shows: a PNG of val frames (RGB, true depth, predicted depth, relative
error) and the one-screen summary the CLI prints."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rvn_data.atomic import atomic_path


def write_predictions_png(path: str | Path, rgb: np.ndarray, depth: np.ndarray, pred: np.ndarray,
                          rows: int = 4) -> Path:
    """One row per val frame (evenly spread over the set): RGB, true depth, prediction
    (same colour scale, metres) and |pred - true| / true (0..0.5; black where depth is 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    picks = np.unique(np.linspace(0, len(rgb) - 1, min(rows, len(rgb))).round().astype(int))
    fig, axes = plt.subplots(len(picks), 4, figsize=(10, 2.6 * len(picks)), squeeze=False)
    for r, k in enumerate(picks):
        d, p = depth[k], pred[k]
        vmax = float(max(d.max(), 1e-3))
        rel = np.where(d > 0, np.abs(p - d) / np.maximum(d, 1e-6), np.nan)
        panels = [(rgb[k], None, "RGB"), (d, (0, vmax), "true depth (m)"), (p, (0, vmax), "predicted (m)"),
                  (rel, (0, 0.5), f"|err|/true, mean {np.nanmean(rel):.3f}")]
        for ax, (img, lim, title) in zip(axes[r], panels):
            if lim is None:
                ax.imshow(img)
            else:
                im = ax.imshow(img, cmap="magma" if title != panels[3][2] else "viridis", vmin=lim[0], vmax=lim[1])
                fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
            ax.set_title(title if r == 0 or lim is None or title.startswith("|") else "", fontsize=8)
            ax.axis("off")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80)
    plt.close(fig)
    return path


def summary(metrics: dict, out_dir: Path) -> str:
    """The CLI's closing screen: pairs, training, val metrics beside the baselines, files."""
    p, t, v, b = metrics["pairs"], metrics["train"], metrics["val"], metrics["baselines"]
    sub = metrics["train_subset"]
    lines = [
        f"depth model: {metrics['params']:,} parameters, {metrics['image_size']}x{metrics['image_size']} frames",
        f"pairs: train {p['train']} ({p['train_scenes']} scenes), val {p['val']} ({p['val_scenes']} scenes), "
        f"renderer {p['renderer']}",
        f"training: {t['steps']} steps x batch {t['batch_size']} in {t['seconds']:.0f} s "
        f"({t['steps_per_s']:.2f} steps/s), final loss {t['final_loss']:.3f}",
        f"train frames AbsRel: {sub['init']['absrel']:.3f} at init -> {sub['final']['absrel']:.3f} trained",
        "",
        f"{'val (' + str(v['frames']) + ' frames)':<26}{'AbsRel':>8}{'delta1':>8}{'RMSE m':>8}",
        f"{'depth model':<26}{v['absrel']:>8.3f}{v['delta1']:>8.3f}{v['rmse']:>8.3f}",
    ]
    for name, label in (("constant_median", "constant train median"), ("pixel_median", "per-pixel train median")):
        m = b[name]
        lines.append(f"{label:<26}{m['absrel']:>8.3f}{m['delta1']:>8.3f}{m['rmse']:>8.3f}")
    shared = metrics.get("shared_scenes")
    if shared:  # rvn_rl.depth.cli.shared_scenes
        lines += ["", f"warning: {shared['in_train']} of the {shared['val_scenes']} val scenes are train scenes too "
                  f"({shared['folder']} gives both splits the same meshes): the val metrics are not on held-out scenes"]
    lines += ["", f"wrote {out_dir / 'model.safetensors'}, model.json, metrics.json, predictions.png"]
    return "\n".join(lines)
