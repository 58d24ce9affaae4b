"""Stokes losses on rendered images, with channels found by name (``S0.R`` ...
``S3.B``, see :mod:`mitsuba_pbrdf.stokes.image`), never by position."""

import drjit as dr
import mitsuba as mi
import numpy as np

from ..stokes.image import channel_names


def _film_channels(scene_or_film):
    if not hasattr(scene_or_film, "sensors"):
        return channel_names(scene_or_film)
    film = scene_or_film.sensors()[0].film()
    try:
        return channel_names(film)
    except RuntimeError:  # nothing rendered yet: allocate the film's storage
        film.prepare(scene_or_film.integrator().aov_names())
        return channel_names(film)


def stokes_indices(scene_or_film, components=(0, 1, 2)):
    """Channel indices of the Stokes components ``components`` (0..3), all
    bands, in the tensor ``mi.render`` returns for this scene or film: a list
    of lists, one per component."""
    names = _film_channels(scene_or_film)
    out = []
    for c in components:
        idx = [i for i, n in enumerate(names) if n.startswith(f"S{int(c)}.")]
        if not idx:
            raise ValueError(f"no S{c}.* channels in {names}: render with the 'stokes' "
                             "integrator in a polarized variant")
        out.append(idx)
    return out


def stokes_loss(scene_or_film, target, components=(0, 1, 2), weights=None):
    """A loss function ``loss(image) -> mi.Float``: the squared error of the
    Stokes components ``components`` against ``target`` (a tensor or array
    (H, W, C) laid out as the scene's film), summed over components and bands,
    averaged over pixels and divided by the mean of the target's S0^2 (so the
    loss does not depend on the image's brightness).

    Equal ``weights`` (default) are what a polarimeter whose S0, S1, S2 carry
    the same absolute noise calls for (maximum likelihood)."""
    groups = stokes_indices(scene_or_film, components)
    weights = [1.0] * len(groups) if weights is None else [float(w) for w in weights]
    target = mi.TensorXf(np.asarray(target, dtype=np.float32))
    s0 = stokes_indices(scene_or_film, (0,))[0]
    norm = float(np.mean(np.asarray(target, dtype=np.float64)[..., s0] ** 2))
    if not norm > 0:
        raise ValueError("the target image is black (mean S0^2 = 0)")

    def loss(image):
        total = mi.Float(0.0)
        for w, idx in zip(weights, groups):
            for i in idx:
                total += w * dr.mean(dr.square(image[..., i] - target[..., i]), axis=None).array
        return total / norm

    return loss
