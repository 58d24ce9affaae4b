"""What :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` returns
(:class:`NormalRecovery`), and the angular error between normal fields."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

__all__ = ["NormalRecovery", "angular_error"]


@dataclass
class NormalRecovery:
    """What :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` returns.

    ``normals`` (H, W, 3) unit vectors in the tangent frame; ``loss`` the data
    loss per iteration (sum over views, before the smoothness term);
    ``visible`` (H, W) texels that received a gradient; ``angular_error``
    (H, W) degrees against ``truth`` (None without one) and ``start_error``
    the same for the starting map; ``roughness`` the fitted map or None;
    ``seconds`` the fit's wall time; ``info`` per iteration: ``view_loss``
    and ``view_gradient_norm`` (iterations, views), ``learning_rates``."""

    normals: np.ndarray
    loss: List[float]
    visible: np.ndarray
    seconds: float
    angular_error: Optional[np.ndarray] = None
    start_error: Optional[np.ndarray] = None
    roughness: Optional[np.ndarray] = None
    heights: Optional[np.ndarray] = None
    info: dict = field(default_factory=dict)

    def error_stats(self, which: str = "angular_error") -> dict:
        """Median and 90th percentile (degrees) over the visible texels ({}
        without a truth or a visible texel: never NaN, which JSON cannot hold)."""
        err = getattr(self, which)
        if err is None or not np.any(self.visible):
            return {}
        values = err[self.visible]
        return {"median": float(np.median(values)), "p90": float(np.percentile(values, 90))}


def angular_error(a, b) -> np.ndarray:
    """Angle in degrees between unit-vector fields a and b, (..., 3)."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))
