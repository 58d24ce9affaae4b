"""One job of a sweep, as a worker runs it: render the scene with the job's
``-D`` values and seed through :func:`mitsuba_pbrdf.rendering.render.render_scene_timed`
(the path ``pbrdf render`` takes), write the Stokes EXR and, if asked, the AOV
EXR (normals and depth) and a polarization camera's images (the files of
``pbrdf polcam``, :mod:`mitsuba_pbrdf.camera.polcam`; the sensor noise is
seeded with the job's seed), each atomically (:mod:`mitsuba_pbrdf.outputs`).

:func:`run_job` never raises for a job that fails (bad value, scene error,
unwritable file): it returns a result with ``status="failed"`` and the
one-line error, so the other jobs go on. ``KeyboardInterrupt`` still stops
it. Jobs in one process run one at a time (a lock): Mitsuba's variant and
Dr.Jit's thread pool are per process.

The AOV file holds Mitsuba's ``aov`` integrator's ``depth`` (distance along
the camera ray, scene units; 0 where the ray leaves the scene) and
``sh_normal`` (shading normal, world coordinates) as float32 channels
``depth.T``, ``normal.X``, ``normal.Y``, ``normal.Z``: averaged over each
pixel's samples with the film's filter, so silhouette pixels mix object and
background.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import asdict, dataclass
from typing import Dict, Optional

__all__ = ["JobTask", "JobResult", "run_job", "set_drjit_threads", "AOV_CHANNELS",
           "MIN_DRJIT_THREADS"]

#: Mitsuba ``aov`` integrator setting and the EXR channel names it gives.
AOV_SPEC = "depth:depth,normal:sh_normal"
AOV_CHANNELS = ("depth.T", "normal.X", "normal.Y", "normal.Z")

_LOCK = threading.Lock()


@dataclass(frozen=True)
class JobTask:
    """What a worker needs to run one job (plain data: it travels to the worker)."""

    name: str
    scene: str
    params: Dict[str, str]
    seed: int
    spp: Optional[int]
    variant: Optional[str]
    out: str
    outputs: tuple = ("stokes",)
    #: ``[polcam]`` options as ``((key, value), ...)`` (sensor, band, sensor model)
    polcam: tuple = ()


@dataclass
class JobResult:
    """What a job reports back: status ``done`` or ``failed``, wall-clock
    seconds on the worker, files relative to the output folder."""

    name: str
    status: str
    seconds: float
    seed: int
    spp: str = ""
    file: str = ""
    aov: str = ""
    polcam: str = ""
    error: str = ""
    pid: int = 0

    def as_dict(self) -> dict:
        return asdict(self)


#: Fewest Dr.Jit threads a worker gets: with Mitsuba 3.9.1 / Dr.Jit 1.5, a pool
#: of 0 or 1 thread hangs loading a scene with an ``envmap`` (the gallery's).
MIN_DRJIT_THREADS = 2


def set_drjit_threads(count: Optional[int]):
    """Set Dr.Jit's thread pool size in this process (None: leave it; at
    least :data:`MIN_DRJIT_THREADS`)."""
    if count:
        import drjit as dr

        count = max(MIN_DRJIT_THREADS, int(count))
        if dr.thread_count() != count:
            dr.set_thread_count(count)


def _one_line(error: BaseException) -> str:
    from ..errors import describe_error

    text = describe_error(error)
    known = (ValueError, RuntimeError, OSError, MemoryError)
    return text if isinstance(error, known) else f"{type(error).__name__}: {text}"


def _write_aov(path: str, scene_path: str, params: Dict[str, str], spp: int, seed: int):
    """Render the AOVs of the scene with the job's values and write them."""
    import numpy as np

    import mitsuba as mi

    from ..stokes.exr import write_exr
    from ..rendering.render import load_scene

    scene = load_scene(scene_path, params)
    integrator = mi.load_dict({"type": "aov", "aovs": AOV_SPEC})
    data = np.array(mi.render(scene, integrator=integrator, spp=spp, seed=seed),
                    dtype=np.float32)
    write_exr(path, {name: data[:, :, i] for i, name in enumerate(AOV_CHANNELS)})


def _write_polcam(task: JobTask, image) -> str:
    """Write the job's polarization-camera files; returns their names, ``;``-separated."""
    from ..camera.polcam import SensorModel, polcam_outputs, write_polcam_files

    options = dict(task.polcam)
    sensor, band = options.pop("sensor", "mono"), options.pop("band", None)
    model = SensorModel(seed=task.seed, **options)
    outputs = polcam_outputs(image, sensor=sensor, band=band, model=model)
    metadata = {k: v for k, v in image.metadata.items() if not k.startswith("time_")}
    return ";".join(write_polcam_files(outputs, task.out, task.name, metadata))


def run_job(task: JobTask, drjit_threads: Optional[int] = None) -> JobResult:
    """Run one job (see the module docstring); returns its :class:`JobResult`."""
    from ..stokes.exr import write_stokes_exr
    from ..rendering.render import render_scene_timed

    with _LOCK:
        start = time.perf_counter()
        result = JobResult(name=task.name, status="failed", seconds=0.0, seed=task.seed,
                           pid=os.getpid())
        try:
            set_drjit_threads(drjit_threads)
            image, _ = render_scene_timed(task.scene, spp=task.spp, variant=task.variant,
                                          seed=task.seed, params=task.params, progress=False)
            result.spp = image.metadata.get("spp", "")
            image.metadata["job"] = task.name
            stokes = f"{task.name}.exr"
            write_stokes_exr(os.path.join(task.out, stokes), image)
            result.file = stokes
            if "aov" in task.outputs:
                aov = f"{task.name}_aov.exr"
                _write_aov(os.path.join(task.out, aov), task.scene, task.params,
                           spp=int(result.spp), seed=task.seed)
                result.aov = aov
            if "polcam" in task.outputs:
                result.polcam = _write_polcam(task, image)
            result.status = "done"
        except KeyboardInterrupt:
            raise
        except Exception as e:  # the job fails; the sweep goes on
            result.error = _one_line(e)
        result.seconds = time.perf_counter() - start
        return result
