"""The fitted texels of :func:`~mitsuba_pbrdf.inverse.normals.recover_normals`:
how the optimizer's variables make a ``polarized_normalmap``'s normals
(:class:`NormalTexels`), and the normal map's colour encoding.

Frames and units: normals are unit vectors in the shape's tangent frame
(x along the shading tangent ``dp_du``, y along ``n x x``, z along the
unperturbed normal), as ``polarized_normalmap`` decodes its texels
(colour = (n + 1) / 2); arrays are (rows, columns, 3), row = v, column = u.
Two parametrizations (:data:`PARAMETRIZATIONS`):

* ``"normals"``: a free unit normal per texel, projected back onto unit
  vectors with z >= :data:`MIN_Z` after each step;
* ``"height"``: a height field ``h`` in texel widths whose normal is
  ``normalize(-dh/du, -dh/dv, 1)`` with central differences between texels
  (:func:`normals_from_heights` is its NumPy twin), integrable by
  construction.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PARAMETRIZATIONS", "MIN_Z", "normals_from_heights", "normalmap_texture", "NormalTexels"]

PARAMETRIZATIONS = ("normals", "height")
#: Smallest z of a fitted normal (about 87° from the unperturbed normal).
MIN_Z = 0.05


def normals_from_heights(heights) -> np.ndarray:
    """Unit normals (H, W, 3) of a height field (H, W) in texel widths
    (NumPy twin of the fit's Dr.Jit version: central differences, clamped)."""
    h = np.asarray(heights, np.float64)
    du = (h[:, np.r_[1:h.shape[1], h.shape[1] - 1]] - h[:, np.r_[0, 0:h.shape[1] - 1]])
    dv = (h[np.r_[1:h.shape[0], h.shape[0] - 1], :] - h[np.r_[0, 0:h.shape[0] - 1], :])
    du /= _spans(h.shape[1])[None, :]
    dv /= _spans(h.shape[0])[:, None]
    n = np.stack([-du, -dv, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _spans(n):
    """Distance in texels between the neighbours used at each index (2, 1 at the border)."""
    s = np.full(n, 2.0)
    s[0] = s[-1] = 1.0
    return s


def normalmap_texture(normals, filter_type="bilinear"):
    """A raw bitmap texture dict encoding unit normals (H, W, 3)."""
    import mitsuba as mi

    colour = ((np.asarray(normals, np.float32) + 1.0) / 2.0).astype(np.float32)
    return {"type": "bitmap", "raw": True, "filter_type": filter_type,
            "bitmap": mi.Bitmap(colour)}


class NormalTexels:
    """The fitted variable of one parametrization and the normal-map tensor
    it makes (Dr.Jit): ``start`` (the variable's starting value),
    :meth:`normals`, :meth:`texels`, :meth:`smoothness`, :meth:`project`."""

    def __init__(self, parametrization, start_normals, start_heights=None):
        import mitsuba as mi

        self.kind = parametrization
        self.shape = start_normals.shape[:2]
        h, w = self.shape
        rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")

        def index(r, c):
            return mi.UInt32((np.clip(r, 0, h - 1) * w + np.clip(c, 0, w - 1)).ravel())

        self.right, self.left = index(rows, cols + 1), index(rows, cols - 1)
        self.down, self.up = index(rows + 1, cols), index(rows - 1, cols)
        self.du = mi.Float(np.broadcast_to(_spans(w)[None, :], (h, w)).ravel())
        self.dv = mi.Float(np.broadcast_to(_spans(h)[:, None], (h, w)).ravel())
        if parametrization == "height":
            heights = np.zeros(self.shape) if start_heights is None else start_heights
            self.start = mi.TensorXf(np.asarray(heights, np.float32))
        else:
            self.start = mi.TensorXf(np.asarray(start_normals, np.float32))

    def normals(self, variable):
        """Unit normals mi.Vector3f (one per texel, row-major) of *variable*."""
        import drjit as dr
        import mitsuba as mi

        flat = variable.array
        if self.kind == "height":
            g = lambda idx: dr.gather(mi.Float, flat, idx)  # noqa: E731
            du = (g(self.right) - g(self.left)) / self.du
            dv = (g(self.down) - g(self.up)) / self.dv
            return dr.normalize(mi.Vector3f(-du, -dv, 1.0))
        return dr.normalize(dr.unravel(mi.Vector3f, flat))

    def texels(self, normals):
        """The normal map's texel tensor (H, W, 3), colour = (n + 1) / 2."""
        import drjit as dr
        import mitsuba as mi

        return mi.TensorXf(dr.ravel((normals + 1.0) * 0.5), shape=(*self.shape, 3))

    def smoothness(self, normals):
        """Mean squared difference of neighbouring normals (right and down)."""
        import drjit as dr
        import mitsuba as mi

        total = mi.Float(0.0)
        for idx in (self.right, self.down):
            other = dr.gather(mi.Vector3f, normals, idx)
            total += dr.mean(dr.squared_norm(normals - other))
        return total

    def project(self, variable):
        """Back onto the feasible set after a step: unit normals with z >= MIN_Z."""
        import mitsuba as mi

        if self.kind == "height":
            return variable
        n = np.array(variable, np.float64).reshape(-1, 3)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        low = n[:, 2] < MIN_Z
        if np.any(low):
            tangential = n[low, :2] / np.maximum(np.linalg.norm(n[low, :2], axis=1,
                                                                keepdims=True), 1e-12)
            n[low, :2] = tangential * np.sqrt(1.0 - MIN_Z ** 2)
            n[low, 2] = MIN_Z
        return mi.TensorXf(n.reshape(*self.shape, 3).astype(np.float32))
