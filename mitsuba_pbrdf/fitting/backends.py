"""Model backends of the fit: the model's observables at a parameter vector and
their Jacobian, from the float64 NumPy reference (lobe by lobe: exact weight
columns, forward differences of one lobe for the others) or from the Dr.Jit
plugin (forward-mode derivatives); and the measurements' assumed uncertainties."""

from __future__ import annotations

import numpy as np

from .vector import DEFAULTS, PER_WAVELENGTH, PLUGIN_NAMES
from .lobes import LobeModel

__all__ = ["weights", "ReferenceResiduals", "DrJitResiduals", "BACKENDS"]


def weights(data, rel, abs_):
    """(quantity names, observed vector, uncertainty vector, index arrays)."""
    names, obs, unc, index = [], [], [], []
    for q, y in data.observed.items():
        rows = np.flatnonzero(np.isfinite(y))
        if q in data.uncertainty:
            u = data.uncertainty[q][rows]
        else:
            if data.row_scale is not None and q != "dolp":
                # each element's floor is relative to its own entry's M00, with a
                # floor of 1e-6 of the largest M00 (float32 tables' denormal tails)
                scale = np.maximum(data.row_scale[rows], 1e-6 * np.nanmax(data.row_scale))
            else:
                scale = np.abs(y[rows]).max()
            u = rel * np.abs(y[rows]) + abs_ * scale
            u = np.where(u > 0, u, 1.0)
        names.append(q)
        obs.append(y[rows])
        unc.append(u)
        index.append(rows)
    return names, obs, unc, index


class ReferenceResiduals:
    """The float64 reference evaluator, lobe by lobe (:class:`.lobes.LobeModel`):
    a weight's Jacobian column is its lobe, a width's or an index's a forward
    difference of its own lobe. ``count``: lobe evaluations."""

    def __init__(self, data, layout, shadowing, dd, distribution="beckmann"):
        self.layout = layout
        self.model = LobeModel(data, list(data.observed), shadowing, dd, distribution)
        self.bounds = layout.bounds()

    @property
    def count(self):
        return self.model.evaluations

    def observables(self, x):
        return self.model.observables(self.layout.unpack(x))

    def jacobian_columns(self, x):
        """{free parameter: {quantity: derivative at every measurement}}."""
        return self.model.jacobian(self.layout.unpack(x), self.layout.free, self.bounds)


class DrJitResiduals:
    """The plugin evaluated on all measurements in one call. n and k are 1 x W
    bitmaps looked up with nearest filtering at each measurement's texel, so
    one BSDF serves every wavelength; derivatives by forward mode."""

    def __init__(self, data, layout, shadowing, dd, distribution="beckmann"):
        import drjit as dr
        import mitsuba as mi

        from ..registry import use_variant
        from ..variant import DEFAULT_VARIANT
        if mi.variant() is None or not mi.is_polarized or mi.variant().startswith("scalar"):
            use_variant(DEFAULT_VARIANT)
        self.dr, self.mi = dr, mi
        self.data, self.layout, self.names = data, layout, list(data.observed)
        v = layout.values
        # Mitsuba's bitmaps are at least 2 x 2: two equal rows, >= 2 columns
        self.columns = max(len(layout.wavelengths), 2)
        bitmap = lambda a: {"type": "bitmap", "raw": True, "filter_type": "nearest",
                            "data": self._texels(a)}
        # weights load as non-zero so that every lobe of the model exists
        shared = {name: (0.0 if name in layout.fixed and v[name] == 0 else DEFAULTS[name])
                  for name in layout.shared}     # a weight fixed at 0 drops its lobe
        self.bsdf = mi.load_dict({
            "type": "pbrdf", "eta": bitmap(v["n"]), "k": bitmap(np.maximum(v["k"], 1e-3)),
            **shared, "shadowing": shadowing, "dd_distribution": dd,
            "distribution": distribution})
        self.params = mi.traverse(self.bsdf)
        ti, pi_, tr, pr = data.radians()
        d = lambda t, p: np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
        self.wo_hat, self.wi_hat = d(ti, pi_), d(tr, pr)
        texel = np.searchsorted(layout.wavelengths, data.wavelength)
        self.uv = mi.Point2f(((texel + 0.5) / self.columns).astype(np.float32),
                             np.full(len(data), 0.25, np.float32))
        w = mi.Float(data.wavelength.astype(np.float32))
        self.wavelengths = mi.UnpolarizedSpectrum(w, w, w, w)
        self.count = 0

    def _texels(self, per_wavelength):
        t = np.zeros((2, self.columns, 1), np.float32)
        t[:, :len(per_wavelength), 0] = np.asarray(per_wavelength, np.float32)[None, :]
        t[:, len(per_wavelength):, 0] = t[:, :1, 0]
        return self.mi.TensorXf(t)

    def _set(self, x):
        values = self.layout.unpack(x)
        p = self.params
        for name in PER_WAVELENGTH:
            p[PLUGIN_NAMES[name] + ".data"] = self._texels(values[name])
        for name in self.layout.shared:
            key = name + ".value"
            if key in p:
                p[key] = float(values[name])
        return values

    def _evaluate(self):
        from ..frames import mueller_brdf
        M = mueller_brdf(self.bsdf, self.wi_hat, self.wo_hat, self.wavelengths, uv=self.uv)
        out = []
        for name in self.names:
            if name == "dolp":
                dr = self.dr
                m00 = M[0, 0][0]
                # ratios first (as observables.linear_ratios): the squares of
                # float32 values below ~1e-19 underflow to 0, their ratios do not
                m00s = dr.select(m00 > 0, m00, 1.0)
                r2 = dr.square(M[1, 0][0] / m00s) + dr.square(M[2, 0][0] / m00s)
                ok = (m00 > 0) & (r2 > 0)  # guard both branches: no NaN derivatives
                out.append(dr.select(ok, dr.sqrt(dr.select(ok, r2, 1.0)), 0.0))
            else:
                out.append(M[int(name[1]), int(name[2])][0])
        return out

    def observables(self, x):
        self.count += 1
        self._set(x)
        self.params.update()
        with self.dr.suspend_grad():
            out = self._evaluate()
        return {n: np.asarray(o, dtype=np.float64) for n, o in zip(self.names, out)}

    def jacobian_columns(self, x):
        """{free parameter: {quantity: derivative at every measurement}}."""
        dr, mi = self.dr, self.mi
        self._set(x)
        cols = {}
        for name in self.layout.free:
            p, _, j = name.partition("@")
            key = PLUGIN_NAMES[p] + (".data" if j else ".value")
            dr.enable_grad(self.params[key])
            self.params.update()
            out = self._evaluate()
            if j:
                t = np.zeros((2, self.columns, 1), np.float32)
                t[:, int(j), 0] = 1.0
                dr.set_grad(self.params[key], mi.TensorXf(t))
            else:
                dr.set_grad(self.params[key], 1.0)
            # keep interior gradients: an output (m00) may feed another (dolp)
            dr.forward_to(*out, flags=dr.ADFlag.ClearEdges | dr.ADFlag.ClearInput)
            cols[name] = {n: np.asarray(dr.grad(o), dtype=np.float64) for n, o in zip(self.names, out)}
            dr.disable_grad(self.params[key])
            self.params.update()
        self.count += 1
        return cols


#: Backends by name.
BACKENDS = {"reference": ReferenceResiduals, "drjit": DrJitResiduals}
