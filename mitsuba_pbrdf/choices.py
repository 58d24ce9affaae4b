"""The named choices of the fit's and the readers' options, as records that
know their behaviour: the fit's models (:data:`MODELS`, and the formats of its
picture) and the layouts of a measurement CSV file (:data:`LAYOUTS`). The library reads its options through
them and ``pbrdf fit`` takes its ``choices`` and help from them.

Standard library and :mod:`mitsuba_pbrdf.schema` only, so that building the
command line's parser loads neither NumPy nor the readers (which import this
module: :mod:`mitsuba_pbrdf.measured.formats`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import FrozenSet, Mapping, Optional, Sequence, Tuple, TypeVar

from . import schema

__all__ = ["Model", "MODELS", "BOTH", "model_names", "preferred", "PLOT_FORMATS", "Layout",
           "LAYOUTS", "AUTO", "LAYOUT_CHOICES", "layout_of"]

T = TypeVar("T")


@dataclass(frozen=True)
class Model:
    """A model the fit can fit: its *name* (``model=``, ``--model``), the
    report's *title*, the lobe it lacks (*off_lobe*: that lobe's weight is
    held at 0 and its parameters are neither fitted nor reported; None: every
    lobe) and the line style of its curves in the fit's plots."""
    name: str
    title: str
    off_lobe: Optional[str]
    line_style: str

    @property
    def fixed(self) -> Tuple[str, ...]:
        """The parameters the model holds fixed, the lobe's weight first
        (``("kdd", "sigma_dd")``; empty for a model with every lobe)."""
        if self.off_lobe is None:
            return ()
        return tuple(name for name in schema.LOBES[self.off_lobe] if name)

    @property
    def why_fixed(self) -> str:
        """Why the model lacks the parameters of :attr:`fixed`."""
        return f"it is the three-component model with {self.fixed[0]} = 0" if self.fixed else ""


#: Model name -> :class:`Model`, richest first (the one :func:`preferred` keeps).
MODELS = {m.name: m for m in (
    Model("three", "three-component (specular + directional diffuse + ideal diffuse)", None, "-"),
    Model("two", "two-component (specular + ideal diffuse, kdd = 0)", "directional_diffuse",
          "--"),
)}

#: ``--model both``: every model of :data:`MODELS`.
BOTH = "both"


def model_names(choice: str) -> Tuple[str, ...]:
    """The models ``--model`` *choice* fits: one of :data:`MODELS`, or all for :data:`BOTH`."""
    return tuple(MODELS) if choice == BOTH else (choice,)


def preferred(results: Mapping[str, T]) -> T:
    """Of fits by model name, the fit of the richest model present (the
    three-component one, else the one fitted): the one a scene or a table's
    hemisphere map shows."""
    return next(results[name] for name in (*MODELS, *results) if name in results)


#: The formats of the fit's picture (``FileFit.save(plot=...)``, ``pbrdf fit
#: --plot``), told by the file's extension (Matplotlib's writers).
PLOT_FORMATS = ("png", "pdf", "svg")


@dataclass(frozen=True)
class Layout:
    """A layout of measurement CSV files: its *name* (``layout=``,
    ``--layout``), a *summary* for ``--help``, the *columns* its header names
    (for the message about a file without a header), and the column sets
    that tell it (*signatures*: a header holding all of one of them is in this
    layout; none: the layout of a file that no other layout's signature
    fits). Its reader is :data:`mitsuba_pbrdf.measured.formats.READERS`."""
    name: str
    summary: str
    columns: str
    signatures: Tuple[FrozenSet[str], ...] = ()

    def detects(self, header: Sequence[str]) -> bool:
        """Whether a header (names stripped, lower case) is in this layout."""
        return any(signature <= set(header) for signature in self.signatures)


#: Layout name -> :class:`Layout`: this project's goniometer CSV
#: (:mod:`mitsuba_pbrdf.measured.measurements`) and NIST's published
#: Mueller-matrix BRDF layout (:mod:`mitsuba_pbrdf.measured.nist_layout`: its
#: angle columns ``thetai`` and ``thetar``, or its 1-indexed ``f_r11``).
LAYOUTS = {lay.name: lay for lay in (
    Layout("goniometer", "this project's", "theta_i, phi_i, theta_r, phi_r, wavelength, m00 ..."),
    Layout("nist", "NIST's Mueller BRDF files: lambda in um, signed thetai, f_r11 and "
                   "f_rIJ/f_r11", "NIST's lambda, thetai, phi, thetar, phir, f_r11 ...",
           (frozenset({"thetai", "thetar"}), frozenset({"f_r11"}))),
)}

#: ``layout="auto"``: the layout told by the header (:func:`layout_of`).
AUTO = "auto"
#: The values of a reader's ``layout`` parameter and of ``--layout``.
LAYOUT_CHOICES = (AUTO,) + tuple(LAYOUTS)


def layout_of(header: Sequence[str], layout: str = AUTO) -> Layout:
    """The :class:`Layout` of a file with *header* (names stripped, lower
    case): *layout* where one is named, else the first that detects the
    header, else the one that detects none."""
    if layout != AUTO:
        return LAYOUTS[layout]
    return (next((lay for lay in LAYOUTS.values() if lay.detects(header)), None)
            or next(lay for lay in LAYOUTS.values() if not lay.signatures))
