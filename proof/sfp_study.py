"""One case of the shape-from-polarization study: render targets of the bumpy
metal plate (mitsuba_pbrdf.inverse.normals.scenes) at high spp, turn them into
the chosen observables (polcam: the mono IMX250MZR frame through the sensor
model, 16 bits, shot and read noise), and recover the normals from a flat
start (mitsuba_pbrdf.inverse.normals.recover_normals). Used by
validation/shape_from_polarization.py (full size) and
tests/inverse/test_normals.py (small size). A polarized variant must be set.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

#: Sensor of the polcam cases: IMX250MZR-like full well and read noise (electrons).
FULL_WELL = 10_500.0
READ_NOISE = 2.3
#: Exposure levels: the radiance at full well as a multiple of the brightest
#: pixel of the ideal frame ("bright": the brightest pixel fills the well;
#: "dim": 16 times less light, four stops under).
EXPOSURES = {"bright": 1.0, "dim": 16.0}


@dataclass
class Case:
    metal: str = "Cu"
    observables: str = "stokes"      # intensity, stokes, polcam-bright, polcam-dim
    views: int = 1
    texels: int = 16
    size: int = 48
    iterations: int = 40
    spp: int = 16
    target_spp: int = 256
    lr: float = 0.05
    lr_end: float = 0.1              # the learning rate of the last iteration / lr
    lr_decay: Optional[float] = None  # if given: lr x lr_decay^iteration instead
    parametrization: str = "normals"
    start: str = "flat"              # flat, or truth (the noise floor: how far the fit drifts)
    seed: int = 0

    @property
    def label(self):
        return (f"{self.metal}, {self.views} view{'s' * (self.views > 1)}, {self.observables}"
                + (", from the truth" if self.start == "truth" else ""))

    @property
    def schedule(self):
        """The learning-rate schedule in words."""
        if self.lr_decay is not None:
            return f"{self.lr} x {self.lr_decay}^it"
        return f"{self.lr} to {self.lr * self.lr_end:.3g}"


class PeakMemory:
    """Peak resident memory (bytes) of this process above its level at start,
    sampled every 20 ms from /proc/self/statm (Linux)."""

    def __init__(self):
        self.page = os.sysconf("SC_PAGE_SIZE")
        self.peak = 0
        self._stop = threading.Event()

    def _rss(self):
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * self.page

    def __enter__(self):
        self.base = self._rss()
        self.peak = self.base
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def _run(self):
        while not self._stop.wait(0.02):
            self.peak = max(self.peak, self._rss())

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self._rss())

    @property
    def above_start(self):
        return self.peak - self.base


def polcam_frames(images, scene, exposure_factor, seed):
    """The noisy 16-bit mono mosaic frames (radiance units) of rendered images."""
    from mitsuba_pbrdf.camera.polcam import SensorModel, mono_mosaic
    from mitsuba_pbrdf.stokes.image import from_mitsuba

    frames = []
    for i, image in enumerate(images):
        raw = mono_mosaic(from_mitsuba(image, scene.sensors()[i].film()))
        model = SensorModel(exposure=float(raw.max()) * exposure_factor, full_well=FULL_WELL,
                            read_noise=READ_NOISE, bits=16, seed=seed + i)
        frames.append(model.apply(raw)[0])
    return frames


def run_case(case: Case, callback=None) -> dict:
    """Targets, fit and figures of one case: a dict with the recovery
    (``result``), the truth, the error statistics, seconds and peak memory."""
    import mitsuba as mi

    from mitsuba_pbrdf.inverse.normals import scenes as ns
    from mitsuba_pbrdf.inverse.normals import recover_normals

    truth = ns.true_normals(case.texels)
    scene = mi.load_dict(ns.plate_scene(truth, metal=case.metal, views=case.views,
                                        size=case.size))
    targets = ns.render_targets(scene, spp=case.target_spp, seed=10_000 + case.seed)
    from mitsuba_pbrdf.stokes.image import dolp, from_mitsuba, luminance_stokes

    lum = luminance_stokes(from_mitsuba(targets[0], scene.sensors()[0].film()))
    plate_dolp = dolp(lum, axis=-1)
    plate_dolp = float(np.median(plate_dolp[plate_dolp > 1e-4]))  # the sky's is 0
    observables = case.observables
    if observables.startswith("polcam"):
        targets = polcam_frames(targets, scene, EXPOSURES[observables.split("-")[1]],
                                seed=case.seed)
        observables = "polcam"
    flat = np.zeros_like(truth)
    flat[..., 2] = 1.0
    if case.start not in ("flat", "truth") or (case.start == "truth"
                                              and case.parametrization != "normals"):
        raise ValueError(f"start {case.start!r} with {case.parametrization!r}")
    start = ns.plate_scene(flat, metal=case.metal, views=case.views, size=case.size)
    t0 = time.perf_counter()
    with PeakMemory() as memory:
        result = recover_normals(start, targets, observables=observables,
                                 parametrization=case.parametrization,
                                 iterations=case.iterations, spp=case.spp, lr=case.lr,
                                 lr_end=case.lr_end, lr_decay=case.lr_decay, truth=truth,
                                 start=truth if case.start == "truth" else None, seed=case.seed,
                                 callback=callback)
    return {"case": case, "result": result, "truth": truth,
            "error": result.error_stats(), "start": result.error_stats("start_error"),
            "seconds": time.perf_counter() - t0, "peak_bytes": memory.above_start,
            "peak_rss": memory.peak,
            "dolp": plate_dolp}
