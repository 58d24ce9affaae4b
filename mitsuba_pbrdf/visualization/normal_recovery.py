"""The picture of a normal-map recovery (``pbrdf recover-normals``'
``recovery.png``): the recovered normal map beside the true one, the angular
error map, and the loss curve, at a size one can read (texels drawn as
blocks, each panel titled and with its colour bar).

Normal maps are drawn in the usual colour encoding (n + 1) / 2 (x red, y
green, z blue, in the tangent frame: a flat map is (0.5, 0.5, 1)), with
row 0 at the top as in the texture; texels that received no gradient (not
seen by any view) are hatched grey in the error map and left out of its
statistics."""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

__all__ = ["recovery_figure", "save_recovery_png"]


def _normal_panel(ax, normals, title):
    ax.imshow(np.clip((np.asarray(normals) + 1.0) / 2.0, 0.0, 1.0), interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def recovery_figure(normals: np.ndarray, loss: Sequence[float], truth: Optional[np.ndarray] = None,
                    error: Optional[np.ndarray] = None, visible: Optional[np.ndarray] = None,
                    title: Optional[str] = None, panel_width: float = 3.0):
    """A matplotlib Figure (Agg): [true normals,] recovered normals, [angular
    error (degrees) over the visible texels,] the loss per iteration (log
    scale). *error* and *visible* are (H, W) as :class:`~mitsuba_pbrdf.inverse.
    normals.NormalRecovery` has them."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = (["truth"] if truth is not None else []) + ["normals"] \
        + (["error"] if error is not None else []) + ["loss"]
    fig = Figure(figsize=((panel_width + 0.9) * len(panels), panel_width + 0.9),
                 layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    seen = np.ones(np.shape(normals)[:2], bool) if visible is None else np.asarray(visible, bool)
    for ax, panel in zip(axes, panels):
        if panel == "truth":
            _normal_panel(ax, truth, "true normals, (n + 1) / 2")
        elif panel == "normals":
            _normal_panel(ax, normals, "recovered normals, (n + 1) / 2")
        elif panel == "error":
            shown = np.where(seen, error, np.nan)
            values = shown[np.isfinite(shown)]
            top = float(np.percentile(values, 99)) if values.size else 1.0
            import matplotlib

            cmap = matplotlib.colormaps["magma"].with_extremes(bad=(0.55, 0.55, 0.55))
            image = ax.imshow(shown, cmap=cmap, vmin=0.0, vmax=max(top, 1e-3),
                              interpolation="nearest")
            median = float(np.median(values)) if values.size else float("nan")
            ax.set_title(f"angular error, median {median:.2f}°"
                         + ("" if seen.all() else " (grey: unseen)"), fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
            bar = fig.colorbar(image, ax=ax, fraction=0.046, pad=0.03)
            bar.set_label("degrees", fontsize=8)
        else:
            ax.semilogy(np.arange(1, len(loss) + 1), loss, "k-")
            ax.set_xlabel("iteration", fontsize=8)
            ax.set_ylabel("data loss", fontsize=8)
            ax.set_title(f"loss {loss[0]:.3g} → {loss[-1]:.3g}" if len(loss) else "loss",
                         fontsize=9)
            ax.tick_params(labelsize=7)
            ax.set_box_aspect(1)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def save_recovery_png(path, normals, loss, dpi: int = 100, **options) -> str:
    """Write :func:`recovery_figure` as a PNG (atomically); returns the path."""
    from .png import save_png

    return save_png(recovery_figure(normals, loss, **options), path, dpi=dpi)
