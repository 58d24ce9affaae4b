"""Shape from polarization: the normal map of a ``polarized_normalmap`` (and
optionally the roughness map of the ``pbrdf`` it wraps) fitted to target
images with polarized path replay (``stokes_prb``), :func:`recover_normals`.

Frames and units: normals are unit vectors in the shape's tangent frame
(x along the shading tangent ``dp_du``, y along ``n x x``, z along the
unperturbed normal), as ``polarized_normalmap`` decodes its texels
(colour = (n + 1) / 2); arrays are (rows, columns, 3), row = v, column = u.
Heights (the ``"height"`` parametrization) are in texel widths: the normal of
a height field ``h`` is ``normalize(-dh/du, -dh/dv, 1)`` with central
differences between texels, so the map is integrable by construction.

Observables: ``"intensity"`` (S0 of every band), ``"stokes"`` (S0, S1, S2 of
every band; :func:`~.losses.stokes_loss`) or ``"polcam"`` (the raw frame of
a monochrome IMX250MZR, one number per pixel: the luminance Stokes vector
behind the pixel's polarizer, Malus's law, exactly the linear map of
:func:`mitsuba_pbrdf.camera.polcam.mono_mosaic`; targets are frames such as
``polcam_outputs(...)["mosaic"]["Y"]``, noise and quantization included,
and the render is compared with them noise-free). A polarized variant with
``stokes_prb`` registered must be set; the scene's integrator is replaced by
``stokes_prb`` for the fit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

from ..errors import ParameterError
from .driver import LR_END, learning_rates, run_adam
from .fit_steps import summed_gradients
from .normal_inputs import check_max_depth, check_normal_field, check_seed, check_targets

OBSERVABLES = ("intensity", "stokes", "polcam")
PARAMETRIZATIONS = ("normals", "height")
#: Bounds of a fitted roughness map (pbrdf's sigma; as inverse.svbrdf).
SIGMA_BOUNDS = (0.03, 0.6)
#: Smallest z of a fitted normal (about 87° from the unperturbed normal).
MIN_Z = 0.05


@dataclass
class NormalRecovery:
    """What :func:`recover_normals` returns.

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


def find_normalmap(scene):
    """``(key, bsdf)``: the ``mi.traverse`` key of the one ``polarized_normalmap``'s
    texels (``<...>.normalmap.data``) and that BSDF. ParameterError ``scene``
    when there is none, or more than one."""
    import mitsuba as mi

    found = []
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        if type(bsdf).__name__ == "PolarizedNormalMap" and all(bsdf is not b for b in found):
            found.append(bsdf)
    if len(found) != 1:
        raise ParameterError("scene", f"needs exactly one shape whose BSDF is a "
                                      f"polarized_normalmap, found {len(found)}")
    bsdf = found[0]
    params = mi.traverse(scene)
    keys = [k for k in params.keys()
            if k.endswith("normalmap.data") and params.properties[k][2] is bsdf.normalmap]
    if len(keys) != 1:
        raise ParameterError("scene", "the polarized_normalmap's 'normalmap' must be a bitmap "
                                      "texture (raw = true)")
    return keys[0], bsdf


def _load(scene):
    import mitsuba as mi

    if isinstance(scene, mi.Scene):
        return scene
    if isinstance(scene, dict):
        return mi.load_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        if not os.path.isfile(scene):
            raise ParameterError("scene", f"no such file: {scene}")
        return mi.load_file(os.fspath(scene))
    raise ParameterError("scene", f"must be a file name, a dict or a mitsuba Scene, "
                                  f"got {type(scene).__name__}")


def polcam_weights(film_channels, height, width):
    """(H, W, C) float32 weights w with ``raw = sum_c w[..., c] * image[..., c]``
    the mono IMX250MZR frame of a rendered image (channels *film_channels*):
    :func:`~mitsuba_pbrdf.camera.polcam.mono_mosaic` applied to unit images
    (it is linear), so the fit sees exactly the project's camera model."""
    from ..camera.polcam import mono_mosaic
    from ..stokes.image import from_mitsuba

    channels = list(film_channels)
    weights = np.zeros((height, width, len(channels)), np.float32)
    for c, name in enumerate(channels):
        if not name.startswith("S"):
            continue
        unit = np.zeros((height, width, len(channels)), np.float32)
        unit[..., c] = 1.0
        weights[..., c] = mono_mosaic(from_mitsuba(unit, channels))
    return weights


def film_channels(scene, sensor=0) -> list:
    """The channel names of the tensor ``mi.render`` returns for *sensor*."""
    from ..stokes.image import channel_names

    film = scene.sensors()[sensor].film()
    try:
        return channel_names(film)
    except RuntimeError:  # nothing rendered yet: allocate the film's storage
        film.prepare(scene.integrator().aov_names())
        return channel_names(film)


def film_target(image, channels) -> np.ndarray:
    """A :class:`~mitsuba_pbrdf.stokes.image.StokesImage` (e.g. a Stokes EXR
    written by ``pbrdf render``) laid out as a render with *channels*
    (``S<k>.<band>``; R, G, B get S0 of their band): (H, W, C) float32.
    ParameterError ``targets`` when a band is missing."""
    out = np.zeros((image.height, image.width, len(channels)), np.float32)
    for c, name in enumerate(channels):
        k, band = (0, name) if not name.startswith("S") else (int(name[1]), name.split(".", 1)[1])
        if band not in image.bands:
            raise ParameterError("targets", f"the target has bands {', '.join(image.bands)}; "
                                            f"the scene renders band {band}")
        out[..., c] = image.stokes[:, :, k, image.bands.index(band)]
    return out


def observable_loss(scene, target, observables, sensor=0):
    """``loss(image) -> mi.Float`` of one view: squared error divided by the
    target's mean square (brightness-free), see the module docstring."""
    import drjit as dr
    import mitsuba as mi

    from .losses import stokes_loss

    if observables != "polcam":
        expected = tuple(np.array(scene.sensors()[sensor].film().crop_size())[::-1])
        channels = len(film_channels(scene, sensor))
        if np.ndim(target) != 3 or tuple(np.shape(target)) != (*expected, channels):
            raise ParameterError("targets", f"target {sensor} must be an (H, W, C) image of "
                                            f"{expected[0]} x {expected[1]} pixels and {channels} "
                                            f"channels, got shape "
                                            f"{np.shape(target)}")
    if observables == "intensity":
        return stokes_loss(scene, target, components=(0,))
    if observables == "stokes":
        return stokes_loss(scene, target, components=(0, 1, 2))
    film = scene.sensors()[sensor].film()
    names = film_channels(scene, sensor)
    h, w = film.crop_size()[1], film.crop_size()[0]
    target = np.asarray(target, np.float32)
    if target.shape != (h, w):
        raise ParameterError("targets", f"a polcam target must be the raw frame ({h}, {w}), "
                                        f"got shape {target.shape}")
    weights = mi.TensorXf(polcam_weights(names, h, w))
    norm = float(np.mean(target.astype(np.float64) ** 2))
    target = mi.TensorXf(target)

    def loss(image):
        raw = dr.sum(image * weights, axis=2)
        return dr.mean(dr.square(raw - target), axis=None).array / norm

    return loss


class _Texels:
    """The fitted variables and the normal-map tensor they make (Dr.Jit)."""

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


def check_options(observables, parametrization, iterations, spp, smoothness, lr, lr_end=LR_END,
                  lr_decay=None, seed=0, max_depth=3):
    """ParameterError naming the first bad option of :func:`recover_normals`
    (checked before any scene is loaded; the command line calls it first)."""
    if observables not in OBSERVABLES:
        raise ParameterError("observables", f"must be one of {', '.join(OBSERVABLES)}, "
                                            f"got {observables!r}")
    if parametrization not in PARAMETRIZATIONS:
        raise ParameterError("parametrization", f"must be one of {', '.join(PARAMETRIZATIONS)}, "
                                                f"got {parametrization!r}")
    for name, value in (("iterations", iterations), ("spp", spp)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ParameterError(name, f"must be an integer >= 1, got {value!r}")
    for name, value in (("smoothness", smoothness), ("lr", lr)):
        if not (np.isfinite(value) and value >= 0) or (name == "lr" and value == 0):
            raise ParameterError(name, f"must be a finite number {'> 0' if name == 'lr' else '>= 0'}"
                                       f", got {value!r}")
    for name, value in (("lr_end", lr_end), ("lr_decay", lr_decay)):
        if value is not None and not (np.isfinite(value) and 0 < value <= 1):
            raise ParameterError(name, f"must be a number in (0, 1], got {value!r}")
    check_seed(seed)
    check_max_depth(max_depth)



def recover_normals(scene, targets, *, observables: str = "stokes",
                    parametrization: str = "normals", smoothness: float = 0.0,
                    iterations: int = 100, spp: int = 16, lr: float = 0.02,
                    lr_end: float = LR_END, lr_decay: Optional[float] = None,
                    fit_roughness: bool = False, truth=None,
                    start=None, max_depth: int = 3, seed: int = 0,
                    callback: Optional[Callable[[int, float], None]] = None) -> NormalRecovery:
    """Fit the normal map of *scene*'s ``polarized_normalmap`` to *targets*.

    scene: an XML file name, a scene dict or a loaded scene with exactly one
    shape whose BSDF is a ``polarized_normalmap`` over a raw bitmap. targets:
    one image per sensor of the scene, in sensor order: (H, W, C) arrays laid
    out as ``mi.render`` returns them ("intensity", "stokes") or (H, W) raw
    frames ("polcam"). parametrization: "normals" (free unit normal per texel)
    or "height" (a height field; needs a normal map of at least 2 x 2).
    smoothness: weight of the mean squared difference of neighbouring normals
    added to the loss. Starts from *start* (H, W, 3 unit normals; default
    flat). fit_roughness: also fit the wrapped ``pbrdf``'s ``sigma``, which
    must then be a bitmap (kept within SIGMA_BOUNDS). truth: (H, W, 3) unit
    normals, for the angular errors. callback(iteration, loss) after each step.
    Adam (``mi.ad.Adam``), one render and one ``dr.backward`` per view per
    iteration; learning rate from *lr* down to ``lr * lr_end`` at the last
    iteration, geometrically (or ``lr * lr_decay**iteration`` when *lr_decay*
    is given): :func:`learning_rates`. ``info["view_loss"]`` and
    ``info["view_gradient_norm"]``: (iterations, views) data loss of each view
    and the norm of its texel gradient.
    """
    import drjit as dr
    import mitsuba as mi

    check_options(observables, parametrization, iterations, spp, smoothness, lr, lr_end, lr_decay,
                  seed, max_depth)
    rates = learning_rates(lr, iterations, lr_end, lr_decay)
    scene = _load(scene)
    key, _ = find_normalmap(scene)
    sensors = scene.sensors()
    targets = check_targets(targets, len(sensors), observables,
                            lambda i: film_channels(scene, i))
    integrator = mi.load_dict({"type": "stokes_prb", "max_depth": int(max_depth)})
    params = mi.traverse(scene)
    shape = tuple(params[key].shape)
    if len(shape) != 3 or shape[2] != 3 or min(shape[:2]) < 2:
        raise ParameterError("scene", f"the normal map must be an RGB bitmap of at least 2 x 2, "
                                      f"got shape {shape}")
    losses = [observable_loss(scene, t, observables, sensor=i) for i, t in enumerate(targets)]
    start_normals = np.zeros(shape, np.float32)
    start_normals[..., 2] = 1.0
    if start is not None:
        start_normals = check_normal_field(start, "start", shape).astype(np.float32)
    if truth is not None:
        truth = check_normal_field(truth, "truth", shape)
    texels = _Texels(parametrization, start_normals)
    sigma_key = None
    if fit_roughness:
        sigma_key = key[: -len("normalmap.data")] + "nested_bsdf.sigma.data"
        if sigma_key not in params.keys():
            raise ParameterError("fit_roughness", "needs the wrapped pbrdf's sigma to be a "
                                                  "bitmap texture")

    variables = {"texels": texels.start}
    if sigma_key:
        variables["sigma"] = params[sigma_key]

    def apply(opt):
        normals = texels.normals(opt["texels"])
        params[key] = texels.texels(normals)
        if sigma_key:
            params[sigma_key] = opt["sigma"]
        params.update()
        return normals

    view_loss, view_grad, touched = [], [], np.zeros(shape[:2], bool)

    def gradient(opt, it, seeds):  # seeds: one per view
        penalty = [0.0]

        def view_value(view):
            normals = apply(opt)
            image = mi.render(scene, params, sensor=view, integrator=integrator, spp=spp,
                              seed=seeds[view])
            value = losses[view](image)
            if smoothness > 0 and view == 0:
                penalty[0] = smoothness * float(texels.smoothness(dr.detach(normals))[0])
                value = value + smoothness * texels.smoothness(normals)
            return value

        values, grad_norms = summed_gradients(
            [lambda v=v: view_value(v) for v in range(len(losses))],
            [opt[name] for name in variables])
        per_view = [values[0] - penalty[0]] + values[1:]
        before = np.array(dr.grad(opt["texels"]), np.float64)
        touched[...] |= (np.abs(before).reshape(*shape[:2], -1).sum(axis=2) != 0)
        view_loss.append(per_view)
        view_grad.append(grad_norms)
        return float(sum(per_view))

    def clamp(opt):
        opt["texels"] = texels.project(opt["texels"])
        if sigma_key:
            opt["sigma"] = dr.clip(opt["sigma"], *SIGMA_BOUNDS)

    run = run_adam(variables, gradient, rates, seed=seed, renders=len(losses), clamp=clamp,
                   callback=callback)
    opt, history = run.optimizer, run.loss
    normals = np.array(texels.normals(dr.detach(opt["texels"])), np.float64).T.reshape(shape)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    apply(opt)
    out = NormalRecovery(normals=normals, loss=history, visible=touched, seconds=run.seconds,
                         info={"view_loss": np.array(view_loss),
                               "view_gradient_norm": np.array(view_grad),
                               "learning_rates": rates})
    if parametrization == "height":
        out.heights = np.array(opt["texels"], np.float64)
    if sigma_key:
        out.roughness = np.array(opt["sigma"], np.float64)[..., 0]
    if truth is not None:
        out.angular_error = angular_error(normals, truth)
        out.start_error = angular_error(start_normals, truth)
    return out
