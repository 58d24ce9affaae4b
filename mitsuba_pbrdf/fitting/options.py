"""The fit's options, checked in one place before any work, for the Python API
(:func:`~.solver.fit_model`, :func:`~.solver.fit_models`) and ``pbrdf fit``
alike: the model and backend, the assumed uncertainties, the measured columns,
the values given to ``init`` and ``fix`` (each model's share of them:
:func:`assignments_by_model`), and the index from a material or a table (an
in-memory :class:`~mitsuba_pbrdf.measured.IndexTable` is checked as a file is).
Errors name the parameter (:class:`~mitsuba_pbrdf.errors.ParameterError`;
the command line names its option instead)."""

from __future__ import annotations

import math

import numpy as np

from .. import reference as ref
from ..errors import ParameterError
from ..measured.index_table import IndexTable, read_index_table
from .backends import BACKENDS
from ..choices import MODELS
from .vector import absent_parameters, parse_assignments

__all__ = ["check_model", "check_arguments", "check_data", "assignments_by_model", "index_from",
           "with_index"]


def check_data(data):
    """Every measured column holds a value, and m00 (where measured) a positive one."""
    for q, y in data.observed.items():
        if not np.isfinite(y).any():
            raise ValueError(f"{data.source}: the {q} column has no values")
    if "m00" in data.observed:
        y = data.observed["m00"]
        if not (y[np.isfinite(y)] > 0).any():
            raise ValueError(f"{data.source}: m00 is 0 or negative in every row: no "
                             f"reflectance to fit")


def check_arguments(data, model, backend, starts, rel_uncertainty, abs_uncertainty,
                    start_rows=None):
    """The options of one fit, and the data (:func:`check_data`)."""
    check_model(model)
    if backend not in BACKENDS:
        raise ParameterError("backend", f"must be one of {', '.join(BACKENDS)}, not {backend!r}")
    for name, v in (("starts", starts), ("start_rows", start_rows)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer))
                              or v < 1):
            raise ParameterError(name, f"must be a whole number >= 1, got {v!r}")
    for name, v in (("rel_uncertainty", rel_uncertainty), ("abs_uncertainty", abs_uncertainty)):
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ParameterError(name, f"must be a finite number >= 0, got {v!r}")
    if rel_uncertainty == 0 and abs_uncertainty == 0 and set(data.observed) - set(data.uncertainty):
        raise ValueError("rel_uncertainty and abs_uncertainty are both 0: the measurements "
                         "without given uncertainties would have none")
    check_data(data)


def check_model(model):
    """A :class:`ParameterError` unless *model* is one of :data:`mitsuba_pbrdf.choices.MODELS`."""
    if model not in MODELS:
        raise ParameterError("model", f"must be one of {', '.join(MODELS)}, not {model!r}")


def assignments_by_model(models, init, fix):
    """``{model: (init, fix, notes)}``: each of *models*' share of the values
    ``init`` and ``fix`` give (parsed, :func:`.layout.parse_assignments`). A
    value of a parameter that a model lacks (:func:`.layout.absent_parameters`)
    is dropped from that model's share with a note saying so; one that every
    model lacks is refused."""
    for m in models:
        check_model(m)
    init, fix = parse_assignments(init, "init"), parse_assignments(fix, "fix")
    absent = {m: absent_parameters(m, fix) for m in models}
    for what, source in (("init", init), ("fix", fix)):
        for key in source:
            name = key.partition("@")[0]
            if models and all(name in absent[m] for m in models):
                m = models[0]
                raise ParameterError(what, f"{key}: the {m}-component model has no {name} "
                                           f"({absent[m][name]})")
    out = {}
    for m in models:
        shares, notes = [], []
        for what, source in (("init", init), ("fix", fix)):
            kept = {}
            for key, v in source.items():
                name = key.partition("@")[0]
                if name in absent[m]:
                    notes.append(f"{what} {key}={v:g} not used in the {m}-component fit: it has "
                                 f"no {name} ({absent[m][name]})")
                else:
                    kept[key] = v
            shares.append(kept)
        out[m] = (shares[0], shares[1], notes)
    return out


def index_from(material, nk, wavelengths):
    """(n, k, source) at *wavelengths* from a named material or an index table
    (a file or an :class:`~mitsuba_pbrdf.measured.IndexTable`, checked alike), or None."""
    if nk is not None and material is not None:
        raise ValueError("give material or nk (an index table), not both")
    if material is not None:
        try:
            n0, k0 = ref.conductor_ior(material, wavelengths)
        except ValueError as e:
            raise ParameterError("material", f"{material!r}: {e}") from None
        return n0, k0, f"material {material}"
    if nk is not None:
        table = nk if isinstance(nk, IndexTable) else read_index_table(nk)
        table.check()
        n0, k0 = table.at(wavelengths)
        return n0, k0, f"index table {table.source}"
    return None


def with_index(data, init, fix, material, nk, absent=()):
    """``(init, fix, note)``: the named material's (or table's) n, k at the
    data's wavelengths as starting values, or, for unpolarized data whose
    n, k ``init``/``fix`` do not name, as fixed values (the note says why);
    unchanged where the model lacks n and k (*absent*: its specular lobe is off)."""
    index = index_from(material, nk, data.wavelengths)
    if index is None or {"n", "k"} & set(absent):
        return init, fix, ""
    n0, k0, source = index
    per_wavelength = {f"n@{w:g}": v for w, v in zip(data.wavelengths, n0)}
    per_wavelength.update({f"k@{w:g}": v for w, v in zip(data.wavelengths, k0)})
    named = {key.partition("@")[0] for key in list(init) + list(fix)}
    polarized = any(q != "m00" for q in data.observed)
    if not polarized and not named & {"n", "k"}:
        return init, dict(per_wavelength, **fix), (
            f"n, k fixed from {source} at the data's wavelengths: unpolarized data (m00 alone) "
            f"cannot determine the index")
    return dict(per_wavelength, **init), fix, ""
