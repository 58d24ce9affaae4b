"""Differentiable inverse rendering with the ``pbrdf`` plugin: gradients of a
loss on rendered Stokes images with respect to scene parameters, an Adam fit
of BSDF parameters to target Stokes images, and the sensitivity (Jacobian /
Fisher information) analysis that tells which parameters an image
determines::

    import mitsuba_pbrdf
    mitsuba_pbrdf.use_variant("llvm_ad_spectral_polarized")
    import mitsuba as mi
    from mitsuba_pbrdf import inverse

    scene = mi.load_dict(inverse.sphere_scene(width=128, height=128))
    params = mi.traverse(scene)
    target = inverse.render(scene, spp=256, seed=1)
    loss = inverse.stokes_loss(scene, target, components=(0, 1, 2))
    value, grads, stats = inverse.loss_and_gradient(
        scene, params, ["object.bsdf.sigma.value", "object.bsdf.eta.value"], loss,
        spp=64)   # method="auto": polarized path replay (stokes_prb) for this scene

Modules: :mod:`.scenes` (a scene to invert), :mod:`.losses` (Stokes losses),
:mod:`.gradients` (gradients by polarized path replay, or by reverse
or forward mode in passes; Jacobians, Fisher information; the methods are
in its docstring), :mod:`.driver` (the one Adam
loop: seeds, learning rates, clamping, progress), :mod:`.optimize` (scalar
parameters), :mod:`.svbrdf` (texture maps recovered by polarized path
replay), :mod:`.normals` (shape from polarization, a subpackage: a
``polarized_normalmap``'s normals recovered from images or files). The
Mueller matrices of a BSDF with derivatives,
in the reference's frames, are :func:`mitsuba_pbrdf.frames.mueller_brdf`.
"""

from .gradients import (METHODS, REVERSE_BYTES_PER_SAMPLE_AND_DEPTH, GradientStats,
                        fisher_information, gradient_method, jacobian, loss_and_gradient, render,
                        reverse_passes)
from .losses import stokes_indices, stokes_loss
from .normals import NormalRecovery, recover_from_files, recover_normals
from .optimize import OptimizationResult, fit_parameters
from .scenes import sphere_scene

__all__ = [
    "sphere_scene",
    "render",
    "stokes_indices",
    "stokes_loss",
    "reverse_passes",
    "REVERSE_BYTES_PER_SAMPLE_AND_DEPTH",
    "GradientStats",
    "METHODS",
    "gradient_method",
    "loss_and_gradient",
    "jacobian",
    "fisher_information",
    "OptimizationResult",
    "fit_parameters",
    "NormalRecovery",
    "recover_normals",
    "recover_from_files",
]
