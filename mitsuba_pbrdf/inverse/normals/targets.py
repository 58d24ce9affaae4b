"""What :func:`~mitsuba_pbrdf.inverse.normals.recover_normals` compares: the
targets laid out as the renders are, and each view's loss
(:func:`observable_loss`).

Observables (:data:`OBSERVABLES`): ``"intensity"`` (S0 of every band),
``"stokes"`` (S0, S1, S2 of every band; :func:`~.losses.stokes_loss`) or
``"polcam"`` (the raw frame of a monochrome IMX250MZR, one number per pixel:
the luminance Stokes vector behind the pixel's polarizer, Malus's law,
exactly the linear map of :func:`mitsuba_pbrdf.camera.polcam.mono_mosaic`;
targets are frames such as ``polcam_outputs(...)["mosaic"]["Y"]``, noise and
quantization included, and the render is compared with them noise-free).
Each view's loss is its squared error divided by the target's mean square
(brightness-free).
"""

from __future__ import annotations

import numpy as np

from ...errors import ParameterError

__all__ = ["OBSERVABLES", "film_channels", "film_target", "polcam_weights", "observable_loss"]

OBSERVABLES = ("intensity", "stokes", "polcam")


def film_channels(scene, sensor=0) -> list:
    """The channel names of the tensor ``mi.render`` returns for *sensor*."""
    from ...stokes.image import channel_names

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


def polcam_weights(film_channels, height, width):
    """(H, W, C) float32 weights w with ``raw = sum_c w[..., c] * image[..., c]``
    the mono IMX250MZR frame of a rendered image (channels *film_channels*):
    :func:`~mitsuba_pbrdf.camera.polcam.mono_mosaic` applied to unit images
    (it is linear), so the fit sees exactly the project's camera model."""
    from ...camera.polcam import mono_mosaic
    from ...stokes.image import from_mitsuba

    channels = list(film_channels)
    weights = np.zeros((height, width, len(channels)), np.float32)
    for c, name in enumerate(channels):
        if not name.startswith("S"):
            continue
        unit = np.zeros((height, width, len(channels)), np.float32)
        unit[..., c] = 1.0
        weights[..., c] = mono_mosaic(from_mitsuba(unit, channels))
    return weights


def observable_loss(scene, target, observables, sensor=0):
    """``loss(image) -> mi.Float`` of one view: squared error divided by the
    target's mean square (brightness-free), see the module docstring."""
    import drjit as dr
    import mitsuba as mi

    from ..losses import stokes_loss

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
