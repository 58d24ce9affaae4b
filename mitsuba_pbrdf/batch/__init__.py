"""Many renders at once: parameter sweeps and datasets built from Stokes renders
(``pbrdf batch``, docs/batch.md).

::

    from mitsuba_pbrdf.batch import load_sweep, run_sweep
    summary = run_sweep(load_sweep("scenes/sweeps/materials.toml"), workers=2)

:mod:`.sweep` reads and checks sweep files, :mod:`.job` renders one job on a
worker, :mod:`.manifest` keeps ``out/manifest.csv``, :mod:`.cluster` starts or
joins a Dask cluster, :mod:`.slurm` starts the workers as Slurm jobs (settings:
:mod:`.slurm_options`), :mod:`.lost` tells which jobs lost their worker and why,
:mod:`.runner` runs a sweep without losing work. Single
renders live in :mod:`mitsuba_pbrdf.rendering`. Importing this package does not
import Dask; running a sweep needs it (a dependency of the package)."""

from .runner import SweepSummary, run_sweep
from .sweep import Job, Sweep, SweepError, load_sweep

__all__ = ["Job", "Sweep", "SweepError", "SweepSummary", "load_sweep", "run_sweep"]
