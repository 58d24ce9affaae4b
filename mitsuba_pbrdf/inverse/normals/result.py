"""What :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` returns
(:class:`NormalRecovery`), its files (:meth:`NormalRecovery.save`: what
``pbrdf recover-normals`` writes), and the angular error between normal
fields."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import List, Mapping, Optional

import numpy as np

__all__ = ["RECOVERY_FILES", "recovery_paths", "NormalRecovery", "angular_error"]

#: The files of a recovery (:meth:`NormalRecovery.save`, ``pbrdf recover-normals --out``).
RECOVERY_FILES = ("normals.exr", "normals.png", "recovery.png", "recovery.json")


def recovery_paths(folder_or_paths) -> dict:
    """{file name: path} of the :data:`RECOVERY_FILES`: in a folder, or as
    given by a mapping from each of those names to its path (ValueError when
    one is missing or another name is there)."""
    if isinstance(folder_or_paths, Mapping):
        paths = {name: os.fspath(path) for name, path in folder_or_paths.items()}
        if set(paths) != set(RECOVERY_FILES):
            raise ValueError(f"the paths must name exactly {', '.join(RECOVERY_FILES)}; got "
                             f"{', '.join(sorted(paths)) or 'none'}")
        return {name: paths[name] for name in RECOVERY_FILES}
    folder = os.fspath(folder_or_paths)
    return {name: os.path.join(folder, name) for name in RECOVERY_FILES}


@dataclass
class NormalRecovery:
    """What :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` returns.

    ``normals`` (H, W, 3) unit vectors in the tangent frame; ``loss`` the data
    loss per iteration (sum over views, before the smoothness term);
    ``visible`` (H, W) texels that received a gradient; ``angular_error``
    (H, W) degrees against ``truth`` (None without one) and ``start_error``
    the same for the starting map; ``roughness`` the fitted map or None;
    ``seconds`` the fit's wall time; ``info`` per iteration: ``view_loss``
    and ``view_gradient_norm`` (iterations, views), ``learning_rates``;
    ``truth`` the true normals given (or None); ``options`` the fit's options
    as ``recovery.json`` lists them; ``source`` the scene file's name (None
    when the scene was a dict or a loaded scene)."""

    normals: np.ndarray
    loss: List[float]
    visible: np.ndarray
    seconds: float
    angular_error: Optional[np.ndarray] = None
    start_error: Optional[np.ndarray] = None
    roughness: Optional[np.ndarray] = None
    heights: Optional[np.ndarray] = None
    info: dict = field(default_factory=dict)
    truth: Optional[np.ndarray] = None
    options: dict = field(default_factory=dict)
    source: Optional[str] = None

    def error_stats(self, which: str = "angular_error") -> dict:
        """Median and 90th percentile (degrees) over the visible texels ({}
        without a truth or a visible texel: never NaN, which JSON cannot hold)."""
        err = getattr(self, which)
        if err is None or not np.any(self.visible):
            return {}
        values = err[self.visible]
        return {"median": float(np.median(values)), "p90": float(np.percentile(values, 90))}

    def summary(self) -> dict:
        """``recovery.json``: the options, ``seconds``, ``loss`` per iteration,
        ``visible_texels``; with a truth ``angular_error_deg`` and
        ``start_error_deg`` (:meth:`error_stats`); the fitted ``roughness``
        map, if any."""
        out = dict(self.options)
        out.update(seconds=self.seconds, loss=list(self.loss),
                   visible_texels=int(self.visible.sum()))
        if self.angular_error is not None:
            out["angular_error_deg"] = self.error_stats()
            out["start_error_deg"] = self.error_stats("start_error")
        if self.roughness is not None:
            out["roughness"] = self.roughness.tolist()
        return out

    def save(self, folder_or_paths, *, source: Optional[str] = None) -> dict:
        """Write what ``pbrdf recover-normals`` writes, all four or none
        (:func:`mitsuba_pbrdf.outputs.together`), each replacing its file:
        ``normals.exr`` (channels X, Y, Z: the normals), ``normals.png`` (the
        (n + 1) / 2 texture, one pixel per texel), ``recovery.png`` (true and
        recovered normals, angular error, loss:
        :mod:`mitsuba_pbrdf.visualization.normal_recovery`) and
        ``recovery.json`` (:meth:`summary`). folder_or_paths: a folder
        (created if missing) or {file name: path} (:func:`recovery_paths`).
        source: the scene's name in the EXR's header and the picture's title
        (default: :attr:`source`). Returns {file name: path}."""
        from ...outputs import together, write_json
        from ...stokes.exr import write_exr
        from ...visualization.normal_recovery import save_recovery_png
        from ...visualization.png import write_pixels_png

        paths = recovery_paths(folder_or_paths)
        source = self.source if source is None else source
        normals = self.normals.astype(np.float32)
        header = {"source": source} if source else {}
        header["frame"] = "tangent (x = dp_du, z = n)"
        title = "recover-normals" + (f" {source}" if source else "")
        if self.options:
            title += (f": {self.options['observables']}, {self.options['iterations']} "
                      f"iterations x {self.options['spp']} spp")
        with together():
            write_exr(paths["normals.exr"], {c: normals[..., i] for i, c in enumerate("XYZ")},
                      header)
            write_pixels_png(paths["normals.png"], (normals + 1.0) / 2.0)
            save_recovery_png(paths["recovery.png"], normals, self.loss, truth=self.truth,
                              error=self.angular_error, visible=self.visible, title=title)
            write_json(paths["recovery.json"], self.summary())
        return paths


def angular_error(a, b) -> np.ndarray:
    """Angle in degrees between unit-vector fields a and b, (..., 3)."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))
