"""Complex index of refraction n + ik of named conductors: Mitsuba's tabulated
spectra (``<mitsuba package>/data/ior/<Name>.{eta,k}.spd``), read as text
files without importing Mitsuba. Wavelengths in nm, n and k dimensionless.
"""

import functools
import importlib.machinery
import importlib.util
import os

import numpy as np


def _ior_directory():
    """``<mitsuba package>/data/ior``, found without importing Mitsuba.

    ``PathFinder`` searches ``sys.path`` directly: once Mitsuba has been imported,
    ``importlib.util.find_spec("mitsuba")`` returns the spec of its alias
    extension module, which has no package directory."""
    for find in (importlib.machinery.PathFinder.find_spec, importlib.util.find_spec):
        spec = find("mitsuba")
        if spec is not None and spec.submodule_search_locations:
            directory = os.path.join(list(spec.submodule_search_locations)[0], "data", "ior")
            if os.path.isdir(directory):
                return directory
    raise RuntimeError("the mitsuba package is not installed: its data/ior spectra are needed")


def available_materials():
    """Sorted names of the conductors with both ``.eta.spd`` and ``.k.spd`` tables."""
    directory = _ior_directory()
    files = set(os.listdir(directory))
    names = {f[: -len(".eta.spd")] for f in files if f.endswith(".eta.spd")}
    return sorted(name for name in names if name + ".k.spd" in files)


def _read_spd(path):
    """Two columns (wavelength in nm, value); '#' starts a comment."""
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                wavelength, value = line.split()[:2]
                rows.append((float(wavelength), float(value)))
    table = np.array(rows, dtype=np.float64)
    order = np.argsort(table[:, 0], kind="stable")
    return table[order, 0], table[order, 1]


@functools.lru_cache(maxsize=None)
def _ior_tables(material):
    names = available_materials()
    if material not in names:
        raise ValueError(
            f"unknown conductor material {material!r}; available materials: {', '.join(names)}"
        )
    directory = _ior_directory()
    return (_read_spd(os.path.join(directory, material + ".eta.spd")),
            _read_spd(os.path.join(directory, material + ".k.spd")))


def conductor_ior(material, wavelengths_nm):
    """Real and imaginary parts ``(n, k)`` of the complex index ``n + i k``.

    Linear interpolation of Mitsuba's tables ``data/ior/<material>.{eta,k}.spd``
    (what Mitsuba's ``irregular`` spectrum does in spectral variants). Raises
    ``ValueError`` for an unknown material or a wavelength outside the table.
    """
    (wl_n, n_table), (wl_k, k_table) = _ior_tables(material)
    wavelengths = np.asarray(wavelengths_nm, dtype=np.float64)
    lo, hi = max(wl_n[0], wl_k[0]), min(wl_n[-1], wl_k[-1])
    if np.any(wavelengths < lo) or np.any(wavelengths > hi):
        raise ValueError(
            f"wavelengths outside the {material!r} table range [{lo:g}, {hi:g}] nm"
        )
    return np.interp(wavelengths, wl_n, n_table), np.interp(wavelengths, wl_k, k_table)
