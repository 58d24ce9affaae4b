"""The scene gallery: renders ``scenes/gallery/*.xml`` and draws README's pictures.

::

    python -m mitsuba_pbrdf gallery                # all of it, into out/gallery/
    python -m mitsuba_pbrdf gallery --update-repo-pictures   # README's pictures, gallery/
    python -m mitsuba_pbrdf gallery --only polarizer --spp 64

Pictures (PNG, palette-quantized to stay small enough to commit):

* ``materials.png``: the same sphere (``scenes/gallery/sphere.xml``) in
  aluminium, copper, gold and silver; intensity, DoLP and AoLP.
* ``roughness.png``: the copper sphere from polished to rough.
* ``polarizer.png``: the sphere through a linear polarizer at 0°, 45°, 90° and
  135° (``scenes/gallery/polarizer.xml``), as the four channels of a
  polarization camera, and the DoLP and AoLP computed from them; with the
  check of Malus's law against the Stokes render
  (:mod:`mitsuba_pbrdf.visualization.polarizer_figure`).
* ``polcam.png``: what a polarization camera records of the copper sphere:
  the four polarizer images and the raw mono and colour sensor frames
  (:mod:`mitsuba_pbrdf.visualization.polcam_figure`; ``pbrdf polcam``).
* ``normalmap.png``: a hammered plate (``scenes/gallery/plate.xml``) with
  Mitsuba's ``normalmap`` and with ``polarized_normalmap``
  (its normal map: :mod:`mitsuba_pbrdf.visualization.normalmap_plate`).
* ``stokes_sheet.png``: every Stokes panel of ``scenes/default.xml`` (what
  ``pbrdf view --panels all`` draws).
* ``pbrdf_plot.png``: the model's lobes and DoP (what ``pbrdf plot`` draws).
* ``brushed.png``: brushed aluminium (``scenes/gallery/brushed.xml``): a
  lathe-turned disc and an axially brushed cylinder, isotropic beside
  anisotropic (Beckmann and GGX); intensity, DoLP and AoLP.
* ``sky.png``: a copper sphere and a brushed aluminium tube outdoors
  (``scenes/gallery/sky.xml``) under ``polarized_sky`` and under Mitsuba's
  unpolarized ``sunsky`` of the same intensity, the sun at each of
  :data:`SUN_ELEVATIONS`; intensity, DoLP and AoLP (docs/polarized-light.md).

The pictures and the Stokes EXRs go to ``out/gallery/`` (not committed). Each render is also
one command of its own, e.g. ``pbrdf render scenes/gallery/sphere.xml -D
material=Au``.
"""

from __future__ import annotations

import inspect
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from ..camera.polcam import ANGLES
from ..reference.params import PBRDFParams
from ..rendering.render import render_scene
from ..stokes.exr import write_stokes_exr
from ..stokes.image import StokesImage
from .panels import DRAWERS, overview_figure, save_png
from .pbrdf_plots import save_pbrdf_plot
from .polarizer_figure import polarizer_check, polarizer_figure
from .tonemap import shared_exposure

__all__ = [
    "MATERIALS",
    "ROUGHNESS",
    "GALLERY_ITEMS",
    "RENDERED_ITEMS",
    "find_scenes",
    "montage_figure",
    "render_materials",
    "render_roughness",
    "render_polarizer",
    "render_polcam",
    "render_stokes_sheet",
    "render_pbrdf_plot",
    "render_brushed",
    "BRUSHED",
    "SUN_ELEVATIONS",
    "render_sky",
    "sun_direction",
    "run_gallery",
    "studio_envmap",
    "write_studio_envmap",
]

#: Metals of ``materials.png`` (Mitsuba conductor names) and their labels.
MATERIALS = (("Al", "aluminium"), ("Cu", "copper"), ("Au", "gold"), ("Ag", "silver"))
#: Columns of ``roughness.png``: label and ``-D`` parameters of sphere.xml.
ROUGHNESS = (
    ("polished, σ = 0.02", dict(sigma=0.02, kdd=0.0, kid=0.0)),
    ("σ = 0.08 (default)", dict(sigma=0.08, kdd=0.05, kid=0.01)),
    ("rough, σ = 0.25, kdd = 0.3", dict(sigma=0.25, kdd=0.3, sigma_dd=0.6, kid=0.03)),
)
#: Columns of ``brushed.png``: label and ``-D`` parameters of brushed.xml.
BRUSHED = (
    ("isotropic, σ = 0.1", dict(sigma_u=0.1, sigma_v=0.1)),
    ("brushed, σu = 0.3, σv = 0.03", dict(sigma_u=0.3, sigma_v=0.03)),
    ("brushed, GGX", dict(sigma_u=0.3, sigma_v=0.03, distribution="ggx")),
)
#: Sun elevations of ``sky.png`` (degrees), and its azimuth: 120 degrees from
#: sky.xml's viewing direction (+Y), behind the camera on the left.
SUN_ELEVATIONS = (15.0, 35.0, 60.0)
SUN_AZIMUTH = 210.0
#: The skies of ``sky.png``: sky.xml's ``sky`` and the column label.
SKIES = (("polarized_sky", "polarized_sky"), ("sunsky", "sunsky (unpolarized)"))
#: Everything ``run_gallery`` makes, in order.
GALLERY_ITEMS = ("materials", "roughness", "polarizer", "polcam", "normalmap", "sheet", "plot",
                 "brushed", "sky")
#: The items that render scenes (the others need neither scenes nor a variant).
RENDERED_ITEMS = ("materials", "roughness", "polarizer", "polcam", "normalmap", "sheet", "brushed",
                  "sky")

#: Colour quantization of committed PNGs (see pictures.panels.save_png).
_PNG_COLOURS = 256


def find_scenes(scenes_dir=None) -> Path:
    """The folder holding the gallery scenes: *scenes_dir* if given, else
    ``scenes/gallery`` under the current directory, else the packaged one
    (:func:`mitsuba_pbrdf.rendering.scene_files.scenes_dir`). Raises
    ``FileNotFoundError`` saying where it looked."""
    from ..rendering.scene_files import scenes_dir as packaged

    if scenes_dir is not None:
        candidates = [Path(scenes_dir)]
    else:
        candidates = [Path.cwd() / "scenes" / "gallery"]
        try:
            candidates.append(packaged() / "gallery")
        except FileNotFoundError:
            pass
    for c in candidates:
        if (c / "sphere.xml").is_file():
            return c
    raise FileNotFoundError(
        "gallery scenes (sphere.xml, polarizer.xml) not found in "
        + " or ".join(str(c) for c in candidates)
        + "; pass --scenes DIR"
    )


def studio_envmap(width: int = 256, height: int = 128, supersample: int = 4) -> np.ndarray:
    """The gallery's environment map, linear RGB (height, width, 3) float32
    in Mitsuba's lat-long convention (y up; u = atan2(x, −z) / 2π,
    v = acos(y) / π): a sky graded from the horizon to a blue zenith, a dark
    ground, and two soft boxes seen from the sphere: a key light high on the
    front left (20° × 14°) and a wide rim light behind on the right
    (36° × 12°)."""
    n = supersample
    u = (np.arange(width * n) + 0.5) / (width * n)
    v = (np.arange(height * n) + 0.5) / (height * n)
    theta, phi = np.meshgrid(v * np.pi, u * 2.0 * np.pi, indexing="ij")
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
    y = d[..., 1]
    zenith, horizon = np.array([0.12, 0.2, 0.42]), np.array([0.5, 0.55, 0.6])
    ground = np.array([0.06, 0.06, 0.065])
    t = np.sqrt(np.clip(y, 0.0, 1.0))[..., None]
    rgb = np.where((y >= 0)[..., None], horizon * (1 - t) + zenith * t, ground)
    up = np.array([0.0, 1.0, 0.0])
    for direction, half_w, half_h, radiance in (
        ((-4.0, 4.0, 3.5), 10.0, 7.0, (9.0, 8.6, 8.0)),    # key light
        ((4.5, 3.5, -4.0), 18.0, 6.0, (6.0, 6.0, 6.5)),    # rim light
    ):
        c = np.array(direction) / np.linalg.norm(direction)
        e1 = np.cross(up, c)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(c, e1)
        dc = d @ c
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = (d @ e1) / dc, (d @ e2) / dc
        inside = ((dc > 0) & (np.abs(a) < np.tan(np.radians(half_w)))
                  & (np.abs(b) < np.tan(np.radians(half_h))))
        rgb = np.where(inside[..., None], np.array(radiance), rgb)
    return rgb.reshape(height, n, width, n, 3).mean(axis=(1, 3)).astype(np.float32)


def write_studio_envmap(path) -> str:
    """Write :func:`studio_envmap` as a half-float RGB EXR (how
    ``scenes/gallery/studio.exr`` was made). Returns the path."""
    import OpenEXR

    rgb = studio_envmap()
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    channels = {c: np.ascontiguousarray(rgb[..., i].astype(np.float16)) for i, c in enumerate("RGB")}
    with OpenEXR.File(header, channels) as f:
        f.write(os.fspath(path))
    return os.fspath(path)


# ---------------------------------------------------------------------------
# Figures


def montage_figure(
    columns: Sequence[tuple],
    rows: Sequence[str] = ("intensity", "dolp", "aolp"),
    title: Optional[str] = None,
    dolp_limit: float = 0.5,
    min_dolp: float = 0.02,
    panel_width: float = 2.7,
    exposure: Optional[float] = None,
):
    """A grid with one column per ``(label, StokesImage)`` and one row per
    panel of :data:`~mitsuba_pbrdf.visualization.panels.DRAWERS` (``intensity``,
    ``dolp``, ``aolp``, ``hsv``, ...), all columns on the same scales (one
    exposure, one DoLP range) with one colour bar per row."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    unknown = [r for r in rows if r not in DRAWERS]
    if unknown:
        raise ValueError(f"unknown row(s) {', '.join(unknown)}; choose from {', '.join(DRAWERS)}")
    images = [im for _, im in columns]
    if exposure is None:
        exposure = shared_exposure(images)
    shared = dict(exposure=exposure, dolp_limit=dolp_limit, min_dolp=min_dolp)
    first = images[0]
    aspect = first.height / first.width
    fig = Figure(figsize=(panel_width * len(columns) + 1.3,
                          panel_width * aspect * len(rows) + 0.5 + (0.3 if title else 0.0)),
                 layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(rows), len(columns), squeeze=False)
    for r, row in enumerate(rows):
        draw = DRAWERS[row]
        accepted = inspect.signature(draw).parameters
        options = {k: v for k, v in shared.items() if k in accepted}
        for c, (label, image) in enumerate(columns):
            ax = axes[r, c]
            drawing = draw(ax, image, **options)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(label, fontsize=9)
            if c == 0:
                ax.set_ylabel(drawing.short, fontsize=8)
        if drawing.mappable is not None:
            cb = fig.colorbar(drawing.mappable, ax=list(axes[r, :]), fraction=0.02, pad=0.01,
                              ticks=drawing.ticks)
            cb.ax.tick_params(labelsize=7)
            cb.set_label(drawing.label, fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


# ---------------------------------------------------------------------------
# Rendering


@dataclass
class _Settings:
    scenes: Optional[Path]
    out: Path
    exr_dir: Optional[Path]
    spp: Optional[int]
    scale: float
    variant: Optional[str]
    progress: bool
    seed: int = 0


def _size_params(scale: float, width: int = 240, height: int = 180) -> dict:
    return dict(width=max(8, int(round(width * scale))), height=max(6, int(round(height * scale))))


def _render(settings: _Settings, scene: str, name: str, **params) -> StokesImage:
    params = {**_size_params(settings.scale), **params}
    image = render_scene(settings.scenes / scene, spp=settings.spp, variant=settings.variant,
                         seed=settings.seed, params=params, progress=settings.progress)
    if settings.exr_dir is not None:
        write_stokes_exr(settings.exr_dir / f"{name}.exr", image)
    return image


def _subtitle(image: StokesImage) -> str:
    return f"{image.metadata.get('variant', '')}, {image.metadata.get('spp', '?')} spp"


def render_materials(settings: _Settings) -> str:
    """``materials.png``: sphere.xml in each of :data:`MATERIALS`."""
    columns = [(f"{label} ({m})", _render(settings, "sphere.xml", f"sphere_{m}", material=m))
               for m, label in MATERIALS]
    fig = montage_figure(columns, title="One sphere, four metals (scenes/gallery/sphere.xml, "
                         f"σ = 0.08; {_subtitle(columns[0][1])})")

    return save_png(fig, settings.out / "materials.png", dpi=100, colors=_PNG_COLOURS)


def render_roughness(settings: _Settings) -> str:
    """``roughness.png``: sphere.xml in copper with each of :data:`ROUGHNESS`."""
    columns = []
    for k, (label, params) in enumerate(ROUGHNESS):
        columns.append((label, _render(settings, "sphere.xml", f"sphere_rough{k}", material="Cu",
                                       **params)))
    fig = montage_figure(columns, title="Polished to rough copper (scenes/gallery/sphere.xml; "
                         f"{_subtitle(columns[0][1])})")

    return save_png(fig, settings.out / "roughness.png", dpi=100, colors=_PNG_COLOURS)


def render_brushed(settings: _Settings) -> str:
    """``brushed.png``: brushed.xml with each of :data:`BRUSHED`."""
    columns = [(label, _render(settings, "brushed.xml", f"brushed{k}", **params))
               for k, (label, params) in enumerate(BRUSHED)]
    fig = montage_figure(columns, dolp_limit=0.15, min_dolp=0.01,
                         title="Brushed aluminium: a lathe-turned disc (σu radial) and a "
                         "cylinder brushed along its axis (σu around it)\n"
                         f"scenes/gallery/brushed.xml, {_subtitle(columns[0][1])}")
    return save_png(fig, settings.out / "brushed.png", dpi=100, colors=_PNG_COLOURS)


def sun_direction(elevation: float, azimuth: float = SUN_AZIMUTH) -> tuple:
    """The direction towards the sun, +Z up, azimuth from +X towards +Y
    (degrees): sky.xml's ``sun_x``, ``sun_y``, ``sun_z``."""
    e, a = np.radians(elevation), np.radians(azimuth)
    return (float(np.cos(e) * np.cos(a)), float(np.cos(e) * np.sin(a)), float(np.sin(e)))


def render_sky(settings: _Settings) -> str:
    """``sky.png``: sky.xml under each of :data:`SKIES` at each of
    :data:`SUN_ELEVATIONS` (the same seed: the same paths where the skies'
    intensities agree)."""
    columns = []
    for elevation in SUN_ELEVATIONS:
        sun = dict(zip(("sun_x", "sun_y", "sun_z"), sun_direction(elevation)))
        for sky, label in SKIES:
            image = _render(settings, "sky.xml", f"sky_{sky}_{elevation:g}", sky=sky, **sun)
            columns.append((f"sun {elevation:g}°: {label}", image))
    fig = montage_figure(columns, dolp_limit=0.8, panel_width=2.3,
                         title="Copper and brushed aluminium under a polarized clear sky and under "
                         "Mitsuba's unpolarized sunsky of the same intensity\n"
                         f"scenes/gallery/sky.xml, sun {SUN_AZIMUTH - 90:g}° of azimuth from the "
                         f"view, {_subtitle(columns[0][1])}")
    return save_png(fig, settings.out / "sky.png", dpi=100, colors=_PNG_COLOURS)


def render_polarizer_images(settings: _Settings, **params):
    """The four filtered renders and the clear one. With the same seed they
    trace the same paths (the filter changes no direction, Russian roulette is
    off and the scene has a single emitter, see polarizer.xml), so Malus's law
    holds pixel by pixel without Monte Carlo noise (to about 0.3 % of the
    largest S0 off axis, where rays cross the filter obliquely)."""
    filtered = {a: _render(settings, "polarizer.xml", f"polarizer_{a}", angle=a, **params)
                for a in ANGLES}
    clear = _render(settings, "polarizer.xml", "polarizer_clear", polarizing="false",
                    transmittance=2, **params)
    return filtered, clear


def render_polarizer(settings: _Settings):
    """``polarizer.png``; returns ``(path, polarizer_check(...))``."""
    filtered, clear = render_polarizer_images(settings)
    check = polarizer_check(filtered, clear)
    fig = polarizer_figure(
        filtered, clear,
        title="A polarization camera's four channels: scenes/gallery/polarizer.xml -D angle=0, "
              f"45, 90, 135 ({_subtitle(clear)}), one exposure\n"
              "Malus's law on the renders, worst pixel / max S0: "
              f"|I0 + I90 − S0| {check['sum_0_90']:.0e}, |I45 + I135 − S0| "
              f"{check['sum_45_135']:.0e}, |I0 − I90 − S1| {check['s1']:.0e}, "
              f"|I45 − I135 − S2| {check['s2']:.0e}")

    return save_png(fig, settings.out / "polarizer.png", dpi=100, colors=_PNG_COLOURS), check


def render_polcam(settings: _Settings) -> str:
    """``polcam.png``: sphere.xml in copper as a polarization camera records it."""
    from .polcam_figure import polcam_figure

    image = _render(settings, "sphere.xml", "sphere_polcam", material="Cu")
    fig = polcam_figure(image, title="What a polarization camera records of the copper sphere "
                        f"(pbrdf polcam; {_subtitle(image)})")
    return save_png(fig, settings.out / "polcam.png", dpi=100, colors=_PNG_COLOURS)


def render_normalmap_plate(settings: _Settings) -> str:
    """``normalmap.png``: plate.xml with each of the normal-map wrappers of
    :mod:`.normalmap_plate` (Mitsuba's and the polarized one)."""
    from .normalmap_plate import WRAPPERS, aolp_difference

    images = {w: _render(settings, "plate.xml", f"plate_{w}", wrapper=w) for w, _ in WRAPPERS}
    worst, median = aolp_difference(images["normalmap"], images["polarized_normalmap"])
    fig = montage_figure(
        [(label, images[w]) for w, label in WRAPPERS],
        dolp_limit=0.3,
        title=f"Hammered plate (plate.xml; {_subtitle(images['normalmap'])}): same intensity\n"
              f"and DoLP, AoLP off by up to {worst:.0f}° (median {median:.0f}°) where DoLP ≥ 0.02")
    return save_png(fig, settings.out / "normalmap.png", dpi=100, colors=_PNG_COLOURS)


def render_stokes_sheet(settings: _Settings) -> str:
    """``stokes_sheet.png``: all panels of scenes/default.xml."""
    scene = settings.scenes.parent / "default.xml"
    image = render_scene(scene, spp=settings.spp, variant=settings.variant, seed=settings.seed,
                         params=_size_params(settings.scale, 320, 240),
                         progress=settings.progress)
    if settings.exr_dir is not None:
        write_stokes_exr(settings.exr_dir / "default.exr", image)
    fig = overview_figure(image, "all", panel_width=3.0, dolp_limit=0.5,
                          title=f"pbrdf view --panels all (scenes/default.xml; {_subtitle(image)})")
    return save_png(fig, settings.out / "stokes_sheet.png", dpi=90, colors=_PNG_COLOURS)


def render_pbrdf_plot(settings: _Settings) -> str:
    """``pbrdf_plot.png``: pbrdf plot --material Cu --sigma 0.1 --kdd 0.2 --kid 0.05 --theta-i 40."""
    return save_pbrdf_plot(settings.out / "pbrdf_plot.png",
                           PBRDFParams(material="Cu", sigma=0.1, kdd=0.2, kid=0.05), 40.0,
                           dpi=90, colors=_PNG_COLOURS)


def run_gallery(out="out/gallery", scenes_dir=None, exr_dir="out/gallery", spp=None,
                scale: float = 1.0, variant=None, only: Optional[Sequence[str]] = None,
                progress: bool = False, seed: int = 0, log=print) -> dict:
    """Render the gallery; returns {item: path} (and ``polarizer_check``).

    *only* selects items of :data:`GALLERY_ITEMS`; *spp* None keeps each
    scene's own; *scale* multiplies the image sizes (240×180, default.xml
    320×240); *exr_dir* None writes no EXRs."""
    items = list(only) if only else list(GALLERY_ITEMS)
    unknown = [i for i in items if i not in GALLERY_ITEMS]
    if unknown:
        raise ValueError(f"unknown gallery item(s) {', '.join(unknown)}; "
                         f"choose from {', '.join(GALLERY_ITEMS)}")
    renders = any(item in RENDERED_ITEMS for item in items)
    settings = _Settings(scenes=find_scenes(scenes_dir) if renders else None, out=Path(out),
                         exr_dir=Path(exr_dir) if exr_dir else None, spp=spp, scale=scale,
                         variant=variant, progress=progress, seed=seed)
    result = {}
    for item in items:
        if item == "materials":
            result[item] = render_materials(settings)
        elif item == "roughness":
            result[item] = render_roughness(settings)
        elif item == "polarizer":
            result[item], result["polarizer_check"] = render_polarizer(settings)
            log("polarizer check (max error / max S0): " + ", ".join(
                f"{k} {v:.1e}" for k, v in result["polarizer_check"].items()))
        elif item == "polcam":
            result[item] = render_polcam(settings)
        elif item == "normalmap":
            result[item] = render_normalmap_plate(settings)
        elif item == "sheet":
            result[item] = render_stokes_sheet(settings)
        elif item == "plot":
            result[item] = render_pbrdf_plot(settings)
        elif item == "brushed":
            result[item] = render_brushed(settings)
        elif item == "sky":
            result[item] = render_sky(settings)
        log(f"wrote {result[item]} ({os.path.getsize(result[item]) // 1024} KiB)")
    return result
