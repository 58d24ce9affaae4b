"""The render modes (mitsuba_pbrdf.rendering.modes) as units: what each says it
writes is what its render and its EXR hold, and each check runs once per render
(a cube's samples per pixel: in check_render when given, after loading when they
are the scene's)."""

import numpy as np
import pytest

from mitsuba_pbrdf.errors import ParameterError
from mitsuba_pbrdf.rendering.modes import CubeMode, PassbandMode, RgbMode
from mitsuba_pbrdf.rendering.render import check_render, render_request
from mitsuba_pbrdf.stokes import read_stokes_exr, write_stokes_exr
from tests.rendering.test_render import SCENE

pytestmark = pytest.mark.usefixtures("restore_variant")
VARIANT = "llvm_ad_spectral_polarized"
TINY = {"width": 8, "height": 6}
#: check_render's options -> the mode it chooses, the bands its image has
MODES = [({}, RgbMode, ("R", "G", "B")),
         ({"wavelength": "632.8"}, PassbandMode, ("632.8nm",)),
         ({"bands": "600:680:20"}, CubeMode, ("610nm", "630nm", "650nm", "670nm"))]


@pytest.mark.parametrize("options, kind, names", MODES, ids=["rgb", "passband", "cube"])
def test_each_mode_writes_the_bands_it_names(options, kind, names, tmp_path):
    """band_names (what pbrdf render checks --band against before rendering)
    are the rendered image's bands and, read back, the EXR's."""
    request = check_render(SCENE, spp=4, variant=VARIANT, params=TINY, **options)
    assert type(request.mode) is kind and request.mode.band_names == names
    image, _ = render_request(request, seed=3)
    assert tuple(image.bands) == names and np.all(np.isfinite(image.stokes))
    assert image.stokes.shape == (6, 8, 4, len(names))
    path = write_stokes_exr(tmp_path / "modes.exr", image)
    assert tuple(read_stokes_exr(path).bands) == names


def test_the_cube_checks_its_samples_per_pixel_once(monkeypatch):
    """A given spp is checked by check_render and not again; the scene's own
    spp (here 2, too few for 10 passbands) is checked after loading."""
    calls = []
    check = CubeMode.check_spp
    monkeypatch.setattr(CubeMode, "check_spp", lambda self, spp: calls.append(spp)
                        or check(self, spp))
    request = check_render(SCENE, spp=3, variant=VARIANT, params=TINY, bands="600:620:2")
    render_request(request)
    assert calls == [3]
    calls.clear()
    scene_spp = check_render(SCENE, variant=VARIANT, params=dict(TINY, spp=2),
                             bands="600:620:2")
    with pytest.raises(ParameterError, match="10 bands need at least 3 samples per pixel"):
        render_request(scene_spp)
    assert calls == [2]
