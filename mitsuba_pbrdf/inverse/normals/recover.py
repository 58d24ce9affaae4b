"""The fit of :func:`recover_normals`: each iteration renders every view
with the variables' normals, sums the views' gradients
(:func:`~mitsuba_pbrdf.inverse.gradients.summed_gradients`) and lets the one
Adam loop (:func:`~mitsuba_pbrdf.inverse.driver.run_adam`) step;
:func:`recover_from_files` is the same fit from the files ``pbrdf
recover-normals`` reads. A polarized variant with ``stokes_prb`` registered
must be set; the scene's integrator is replaced by ``stokes_prb`` for the fit.
"""

from __future__ import annotations

import inspect
import os
from typing import Callable, Optional

import numpy as np

from ...errors import ParameterError
from ..driver import LR_END, learning_rates, run_adam
from ..gradients import summed_gradients
from .inputs import (as_scene, check_normal_field, check_normal_map, check_options, check_targets,
                     find_normalmap, roughness_key)
from .result import NormalRecovery, angular_error
from .targets import film_channels, observable_loss
from .texels import NormalTexels

__all__ = ["SIGMA_BOUNDS", "recover_normals", "recover_from_files"]

#: Bounds of a fitted roughness map (pbrdf's sigma; as inverse.svbrdf).
SIGMA_BOUNDS = (0.03, 0.6)


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
    is given): :func:`~mitsuba_pbrdf.inverse.driver.learning_rates`.
    ``info["view_loss"]`` and ``info["view_gradient_norm"]``: (iterations,
    views) data loss of each view and the norm of its texel gradient.
    ``result.save(folder)`` writes what ``pbrdf recover-normals`` writes.
    """
    import mitsuba as mi

    source = os.path.basename(os.fspath(scene)) if isinstance(scene, (str, os.PathLike)) else None
    check_options(observables, parametrization, iterations, spp, smoothness, lr, lr_end, lr_decay,
                  seed, max_depth)
    rates = learning_rates(lr, iterations, lr_end, lr_decay)
    scene = as_scene(scene)
    key, _ = find_normalmap(scene)
    targets = check_targets(targets, len(scene.sensors()), observables,
                            lambda i: film_channels(scene, i))
    integrator = mi.load_dict({"type": "stokes_prb", "max_depth": int(max_depth)})
    params = mi.traverse(scene)
    shape = check_normal_map(params[key])
    losses = [observable_loss(scene, t, observables, sensor=i) for i, t in enumerate(targets)]
    start_normals = np.zeros(shape, np.float32)
    start_normals[..., 2] = 1.0
    if start is not None:
        start_normals = check_normal_field(start, "start", shape).astype(np.float32)
    if truth is not None:
        truth = check_normal_field(truth, "truth", shape)
    fit = _NormalFit(scene, params, key, roughness_key(params, key) if fit_roughness else None,
                     NormalTexels(parametrization, start_normals), losses, integrator,
                     spp=spp, smoothness=smoothness)
    run = run_adam(fit.variables(), fit.gradient, rates, seed=seed, renders=len(losses),
                   clamp=fit.clamp, callback=callback)
    out = fit.result(run)
    out.info["learning_rates"] = rates
    out.source, out.truth = source, truth
    out.options = {"observables": observables, "parametrization": parametrization,
                   "iterations": int(iterations), "spp": int(spp), "smoothness": float(smoothness),
                   "lr": float(lr), "lr_end": float(lr_end)}
    if lr_decay is not None:
        out.options["lr_decay"] = float(lr_decay)
    if truth is not None:
        out.angular_error = angular_error(out.normals, truth)
        out.start_error = angular_error(start_normals, truth)
    return out


#: recover_normals' keyword options and defaults (what recover_from_files passes on).
_OPTIONS = {name: p for name, p in inspect.signature(recover_normals).parameters.items()
            if p.kind is p.KEYWORD_ONLY and name != "truth"}


def recover_from_files(scene, targets, *, truth=None, **options) -> NormalRecovery:
    """:func:`recover_normals` from files, read as ``pbrdf recover-normals``
    reads them.

    Parameters
    ----------
    scene : str or os.PathLike
        Mitsuba scene XML; one shape's BSDF a ``polarized_normalmap`` over a raw bitmap.
    targets : sequence of str or os.PathLike
        One EXR per sensor, in sensor order: Stokes EXRs (``pbrdf render``) for
        ``observables`` "intensity" or "stokes", raw mono mosaic EXRs
        (``pbrdf polcam``'s ``_mosaic.exr``, channel ``Y``) for "polcam".
    truth : str or os.PathLike, optional
        True normals for the angular errors: channels X, Y, Z (as
        ``normals.exr``) or a normal-map texture's R, G, B = (n + 1) / 2.
    **options
        :func:`recover_normals`' keywords (``observables``, ``iterations``,
        ``spp``, ``callback``...).

    Returns
    -------
    NormalRecovery
        Its ``source`` is the scene file's name; ``result.save(folder)``
        writes what the command writes.

    Raises
    ------
    ParameterError
        Naming ``targets``, ``truth`` or the option, before the fit.

    Example
    -------
    >>> result = recover_from_files("out/plate/plate.xml", ["out/target.exr"],
    ...                             truth="out/plate/plate_normals.exr", iterations=40)
    >>> result.save("out/recovered")
    """
    from ...interrupts import release
    from ...rendering.scene_loading import load_scene
    from ...stokes.exr import read_exr_channels, read_stokes_exr
    from .scenes import read_normal_map
    from .targets import film_target

    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise TypeError(f"recover_from_files: unknown keyword {unknown[0]!r}; "
                        f"recover_normals takes {', '.join(_OPTIONS)}")
    o = {name: p.default for name, p in _OPTIONS.items()} | options
    check_options(o["observables"], o["parametrization"], o["iterations"], o["spp"],
                  o["smoothness"], o["lr"], o["lr_end"], o["lr_decay"], o["seed"], o["max_depth"])
    targets = [os.fspath(t) for t in targets]
    loaded = load_scene(scene)
    find_normalmap(loaded)  # the scene's own error before the targets'
    if len(targets) != len(loaded.sensors()):
        raise ParameterError("targets", f"{len(targets)} given, the scene has "
                                        f"{len(loaded.sensors())} sensors (one target per sensor)")
    images = []
    for i, path in enumerate(targets):
        if o["observables"] == "polcam":
            channels = read_exr_channels(path)
            if "Y" not in channels:
                raise ParameterError("targets", f"{path}: no channel Y (a raw mosaic written by "
                                                f"pbrdf polcam)")
            images.append(channels["Y"])
        else:
            images.append(film_target(read_stokes_exr(path), film_channels(loaded, i)))
    if truth is not None:
        try:
            truth = read_normal_map(truth)
        except ValueError as e:
            raise ParameterError("truth", str(e)) from None
    release()  # loaded and checked: Ctrl-C from here on stops the fit (mitsuba_pbrdf.interrupts)
    out = recover_normals(loaded, images, truth=truth, **options)
    out.source = os.path.basename(os.fspath(scene))
    return out


class _NormalFit:
    """One fit of :func:`recover_normals`: what the optimizer's variables set
    in the scene (:meth:`apply`), an iteration's loss and gradient summed over
    the views (:meth:`gradient`), the projection after each step
    (:meth:`clamp`) and the result (:meth:`result`)."""

    def __init__(self, scene, params, key, sigma_key, texels, losses, integrator, *, spp,
                 smoothness):
        self.scene, self.params, self.key, self.sigma_key = scene, params, key, sigma_key
        self.texels, self.losses, self.integrator = texels, losses, integrator
        self.spp, self.smoothness = spp, smoothness
        self.shape = (*texels.shape, 3)
        self.view_loss, self.view_grad = [], []
        self.visible = np.zeros(texels.shape, bool)

    def variables(self) -> dict:
        out = {"texels": self.texels.start}
        if self.sigma_key:
            out["sigma"] = self.params[self.sigma_key]
        return out

    def apply(self, opt):
        """Set the normal map (and roughness map) from *opt*'s variables;
        returns the normals (Dr.Jit, with their graph)."""
        normals = self.texels.normals(opt["texels"])
        self.params[self.key] = self.texels.texels(normals)
        if self.sigma_key:
            self.params[self.sigma_key] = opt["sigma"]
        self.params.update()
        return normals

    def gradient(self, opt, it, seeds):
        """The data loss of iteration *it* (sum over views), the gradient of
        data loss plus smoothness left on *opt*'s variables; seeds: one per view."""
        import drjit as dr
        import mitsuba as mi

        penalty = 0.0

        def view_value(view):
            nonlocal penalty
            normals = self.apply(opt)
            image = mi.render(self.scene, self.params, sensor=view, integrator=self.integrator,
                              spp=self.spp, seed=seeds[view])
            value = self.losses[view](image)
            if self.smoothness > 0 and view == 0:
                penalty = self.smoothness * float(self.texels.smoothness(dr.detach(normals))[0])
                value = value + self.smoothness * self.texels.smoothness(normals)
            return value

        values, grad_norms = summed_gradients(
            [lambda v=v: view_value(v) for v in range(len(self.losses))],
            list(opt.values()))
        per_view = [values[0] - penalty] + values[1:]
        grad = np.array(dr.grad(opt["texels"]), np.float64)
        self.visible |= np.abs(grad).reshape(*self.shape[:2], -1).sum(axis=2) != 0
        self.view_loss.append(per_view)
        self.view_grad.append(grad_norms)
        return float(sum(per_view))

    def clamp(self, opt):
        """Back onto the feasible set: unit normals (z >= MIN_Z), sigma within SIGMA_BOUNDS."""
        import drjit as dr

        opt["texels"] = self.texels.project(opt["texels"])
        if self.sigma_key:
            opt["sigma"] = dr.clip(opt["sigma"], *SIGMA_BOUNDS)

    def result(self, run) -> NormalRecovery:
        """The recovery of a finished *run* (its last iterate left in the scene)."""
        import drjit as dr

        opt = run.optimizer
        normals = np.array(self.texels.normals(dr.detach(opt["texels"])), np.float64)
        normals = normals.T.reshape(self.shape)
        normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
        self.apply(opt)
        out = NormalRecovery(normals=normals, loss=run.loss, visible=self.visible,
                             seconds=run.seconds,
                             info={"view_loss": np.array(self.view_loss),
                                   "view_gradient_norm": np.array(self.view_grad)})
        if self.texels.kind == "height":
            out.heights = np.array(opt["texels"], np.float64)
        if self.sigma_key:
            out.roughness = np.array(opt["sigma"], np.float64)[..., 0]
        return out
