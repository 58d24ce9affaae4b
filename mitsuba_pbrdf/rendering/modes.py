"""The three render modes, one object each with one interface, chosen once by
:func:`render_mode` (from :func:`~mitsuba_pbrdf.rendering.render.check_render`'s
``wavelength`` and ``bands``); :func:`~mitsuba_pbrdf.rendering.render.render_request`
runs any of them the same way:

* :class:`RgbMode`: the scene as it is, ``mi.render`` per pass; the R, G, B Stokes
  bands of Mitsuba's ``stokes`` integrator (in RGB, mono and spectral variants);
* :class:`PassbandMode` (``wavelength``): the sensor given the passband's spectral
  response, rendered as :class:`RgbMode` does, then one Stokes band read off R, G
  or B (:mod:`.narrowband`);
* :class:`CubeMode` (``bands``): the integrator inside ``stokes`` run by the cube's
  own pass; one Stokes band per passband (:mod:`.cube`).

The interface, in the order a render uses it:

* ``check_spp(total_spp)``: the samples per pixel the mode needs (a cube: a
  wavelength in every passband), a :class:`~mitsuba_pbrdf.errors.ParameterError`;
* ``scene_setup(size, auto_stokes)``: how the mode loads a scene
  (:class:`~.scene_setup.SceneSetup`: the integrator inside ``stokes``, or the one it
  wraps for a cube; a passband's sensor response), which
  :func:`~mitsuba_pbrdf.rendering.render.check_render` checks before anything loads;
* ``load(scene_path, params, setup)``: the scene, loaded with that setup (the variant set);
* ``render_pass(scene, spp, seed, first, total_spp)``: one pass of *spp* of the
  pixel's *total_spp* samples (*first* of them rendered before) as a float64
  array; the passes' arrays add up;
* ``assemble(total, film)``: the :class:`~mitsuba_pbrdf.stokes.StokesImage` of the
  passes' sum;

and for whoever names the outputs first (``pbrdf render`` checks ``--band`` and
titles its picture before rendering): ``band_names``, the Stokes image's bands
(those of the EXR, ``S0.<band>``), and ``describe()``, a few words for a title
("" for :class:`RgbMode`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Tuple

import numpy as np

from ..errors import ParameterError
from ..stokes.image import StokesImage, from_mitsuba
from .bands import PassbandList, parse_bands, require_spectral_bands
from .cube import check_cube_spp, cube_image, cube_pass
from .narrowband import (Passband, PassbandResponse, parse_wavelength, passband_image,
                         passband_response, passband_srf, require_spectral)
from .scene_setup import SceneSetup, load_scene_setup

__all__ = ["RenderMode", "RgbMode", "PassbandMode", "CubeMode", "render_mode"]


class RenderMode:
    """The interface of the render modes (see the module docstring)."""

    @property
    def band_names(self) -> Tuple[str, ...]:
        """The Stokes image's bands, in order (those of the EXR: ``S0.<band>``)."""
        raise NotImplementedError

    def describe(self) -> str:
        """A few words for a title ("": nothing to add to the scene's name)."""
        return ""

    def check_spp(self, total_spp: int) -> None:
        """A :class:`~mitsuba_pbrdf.errors.ParameterError` if *total_spp* is too few."""

    def scene_setup(self, size=None, auto_stokes: bool = True) -> SceneSetup:
        """How this mode loads a scene: its integrator inside ``stokes`` (wrapped
        there if need be, unless *auto_stokes* is False), its films *size*
        (width, height) pixels if given."""
        return SceneSetup(size=size, auto_stokes=auto_stokes)

    def load(self, scene_path, params, setup: SceneSetup):
        """The scene, loaded with *setup* (:meth:`scene_setup`; the variant set)."""
        return load_scene_setup(scene_path, params, setup)

    def render_pass(self, scene, spp: int, seed: int, first: int, total_spp: int) -> np.ndarray:
        """One pass (see the module docstring); the passes' arrays add up."""
        raise NotImplementedError

    def assemble(self, total: np.ndarray, film) -> StokesImage:
        """The Stokes image of the passes' summed arrays."""
        raise NotImplementedError


@dataclass(frozen=True)
class RgbMode(RenderMode):
    """The scene's own render: Stokes bands R, G, B."""

    @property
    def band_names(self) -> Tuple[str, ...]:
        return ("R", "G", "B")

    def render_pass(self, scene, spp: int, seed: int, first: int, total_spp: int) -> np.ndarray:
        """``mi.render``'s tensor times spp / total_spp (reading it back runs the kernels)."""
        import mitsuba as mi

        tensor = mi.render(scene, spp=spp, seed=seed)
        return np.array(tensor, dtype=np.float64) * (spp / total_spp)

    def assemble(self, total: np.ndarray, film) -> StokesImage:
        return from_mitsuba(total.astype(np.float32), film)


@dataclass(frozen=True)
class PassbandMode(RgbMode):
    """One passband (``wavelength``): rendered as :class:`RgbMode` does with the
    sensor's spectral response set to the passband, then one Stokes band, named
    after it, read off R, G or B (:mod:`.narrowband`)."""

    passband: Passband

    @property
    def band_names(self) -> Tuple[str, ...]:
        return (self.passband.name,)

    def describe(self) -> str:
        return self.passband.describe()

    @cached_property
    def response(self) -> PassbandResponse:
        """The sensor response, computed once, at first use (in the variant the
        render sets: Mitsuba's colour tables)."""
        return passband_response(self.passband)

    def scene_setup(self, size=None, auto_stokes: bool = True) -> SceneSetup:
        """:class:`RgbMode`'s, with the sensors checked for a spectral response
        of their own (the passband's is set when the scene loads)."""
        low, high = self.passband.limits
        return SceneSetup(size=size, auto_stokes=auto_stokes, srf=(low, high, None),
                          error_parameter="wavelength")

    def load(self, scene_path, params, setup: SceneSetup):
        return load_scene_setup(scene_path, params, replace(setup, srf=passband_srf(self.response)))

    def assemble(self, total: np.ndarray, film) -> StokesImage:
        return passband_image(super().assemble(total, film), self.response)


@dataclass(frozen=True)
class CubeMode(RenderMode):
    """A Stokes cube (``bands``): one Stokes band per passband (:mod:`.cube`)."""

    passbands: PassbandList

    @property
    def band_names(self) -> Tuple[str, ...]:
        return tuple(self.passbands.names)

    def describe(self) -> str:
        return self.passbands.describe()

    def check_spp(self, total_spp: int) -> None:
        check_cube_spp(self.passbands, total_spp)

    def scene_setup(self, size=None, auto_stokes: bool = True) -> SceneSetup:
        """The integrator ``stokes`` wraps (or would wrap), which the cube runs itself."""
        return SceneSetup(integrator="nested", size=size, auto_stokes=auto_stokes,
                          error_parameter="bands")

    def render_pass(self, scene, spp: int, seed: int, first: int, total_spp: int) -> np.ndarray:
        return cube_pass(scene, self.passbands, spp, seed, first, total_spp)

    def assemble(self, total: np.ndarray, film) -> StokesImage:
        return cube_image(total, self.passbands)


def render_mode(variant: str, wavelength=None, bands=None) -> RenderMode:
    """The mode of a render with these ``wavelength`` (None, ``"632.8"``,
    ``"550:10"`` or a :class:`~.narrowband.Passband`) and ``bands`` (None,
    ``"450:650:20"`` or a :class:`~.bands.PassbandList`) in *variant* (spectral
    for either); :class:`~mitsuba_pbrdf.errors.ParameterError` naming the
    parameter, also for both at once."""
    passband = None
    if wavelength is not None:
        passband = parse_wavelength(wavelength)
        require_spectral(variant)
    if bands is None:
        return RgbMode() if passband is None else PassbandMode(passband)
    if passband is not None:
        raise ParameterError("bands", "renders a Stokes cube; give wavelength (one band) or "
                             "bands, not both")
    passbands = parse_bands(bands)
    require_spectral_bands(variant)
    return CubeMode(passbands)
