"""``pbrdf polcam``'s files in one call: :func:`polcam_files` computes a
polarization camera's images of a Stokes EXR
(:func:`mitsuba_pbrdf.camera.polcam.polcam_outputs`) and the 8-bit previews
of its raw frames (:func:`mitsuba_pbrdf.camera.raw_frames.mosaic_previews`);
:meth:`PolcamFiles.write` writes them, all or none."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np

from ..camera.polcam import SensorModel, polcam_file_names, polcam_outputs
from ..camera.raw_frames import mosaic_previews

__all__ = ["PolcamFiles", "polcam_files"]


@dataclass(frozen=True)
class PolcamFiles:
    """What ``pbrdf polcam`` writes for one Stokes EXR, computed and not yet
    written (:func:`polcam_files`): the camera's images
    (:func:`~mitsuba_pbrdf.camera.polcam.polcam_outputs`)
    as ``<stem>_<suffix>`` files in *folder* with *metadata*, and the 8-bit
    previews of its raw frames (file name -> pixels,
    :func:`~mitsuba_pbrdf.camera.raw_frames.mosaic_previews`)."""
    folder: str
    stem: str
    outputs: dict
    previews: Dict[str, np.ndarray]
    metadata: dict

    @property
    def paths(self) -> List[str]:
        """Every file :meth:`write` writes: the images, then the previews."""
        return [os.path.join(self.folder, name) for name in
                [*polcam_file_names(self.outputs, self.stem).values(), *self.previews]]

    def write(self) -> List[str]:
        """Write every file of :attr:`paths`, or none (each atomically; the
        folder is created if missing). Returns :attr:`paths`."""
        # looked up when called, where the work starts (the tests stub it there)
        from ..camera.polcam import write_polcam_files
        from ..outputs import together
        from .png import write_pixels_png

        with together():  # all the files or none (mitsuba_pbrdf.outputs)
            write_polcam_files(self.outputs, self.folder, self.stem, self.metadata)
            for name, picture in self.previews.items():
                write_pixels_png(os.path.join(self.folder, name), picture)
        return self.paths


def polcam_files(path, folder, sensor: str = "mono", band: Optional[str] = None,
                 model: Optional[SensorModel] = None) -> PolcamFiles:
    """A polarization camera's images of a Stokes EXR, as ``pbrdf polcam`` writes them.

    Parameters
    ----------
    path : str or os.PathLike
        A Stokes EXR (``pbrdf render``'s).
    folder : str or os.PathLike
        Where the files go, named after *path*'s stem (``<stem>_I0.exr`` ...).
    sensor, band, model
        As :func:`~mitsuba_pbrdf.camera.polcam.polcam_outputs` takes them.

    Returns
    -------
    PolcamFiles
        Everything computed; :meth:`PolcamFiles.write` writes it.

    Raises
    ------
    ParameterError
        An option the image cannot take (``sensor``), naming it.
    ValueError
        The file is no usable Stokes image, naming it; or a bad *band*.

    Example
    -------
    >>> from mitsuba_pbrdf.visualization.polcam_files import polcam_files
    >>> from mitsuba_pbrdf.camera.polcam import SensorModel
    >>> files = polcam_files("out/default.exr", "out/cam",
    ...                      model=SensorModel(bits=12))  # doctest: +SKIP
    >>> files.write()  # doctest: +SKIP
    """
    from ..stokes.exr import read_stokes_exr

    image = read_stokes_exr(path)
    outputs = polcam_outputs(image, sensor=sensor, band=band, model=model)
    stem = os.path.splitext(os.path.basename(os.fspath(path)))[0]
    bits = model.bits if model is not None and model.enabled else None
    metadata = {k: v for k, v in image.metadata.items() if not k.startswith("time_")}
    metadata["source"] = os.path.basename(os.fspath(path))
    return PolcamFiles(os.fspath(folder), stem, outputs, mosaic_previews(outputs, stem, bits),
                       metadata)
