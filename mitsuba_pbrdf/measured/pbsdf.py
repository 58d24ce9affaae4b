"""The ``.pbsdf`` file format of measured polarimetric BRDFs: reading (memory
mapped, validated before anything is allocated) and writing (atomic).

A ``.pbsdf`` file is Mitsuba's ``tensor_file`` container (the format of
``mitsuba/python/tensor_io.py``), as the KAIST polarimetric BRDF database
(Baek et al. 2020) and Mitsuba's ``measured_polarized`` plugin use it:

* bytes 0-11 ``b"tensor_file\\0"``, then version ``(1, 0)`` (two uint8) and
  the number of fields (uint32); then per field: name length (uint16), name
  (UTF-8), number of dimensions (uint16), dtype code (uint8, Mitsuba's
  ``Struct::Type``: 3 = uint16, 10 = float32, ...), the data's byte offset
  (uint64) and the shape (uint64 each); all little-endian. Each field's data
  is C-ordered at its offset.
* Fields of a pBRDF table: ``M`` float32 ``(phi_d, theta_d, theta_h,
  wavelengths, 4, 4)`` (Mueller BRDF in 1/sr, no cosine factor; NaN marks an
  unmeasured entry), ``phi_d``, ``theta_d``, ``theta_h`` float32 ``(1, N)``
  (radians, strictly increasing: the Rusinkiewicz angles of
  :mod:`mitsuba_pbrdf.measured.rusinkiewicz`) and ``wvls`` uint16 ``(W,)``
  (nm). ``measured_polarized`` reads exactly 5 wavelengths (it copies 5
  ``wvls`` values but sizes its interpolator from the field's length), so a
  file meant for rendering must have W = 5 (:func:`check_renderable`);
  hyperspectral files with other W are read and fitted all the same.

Files come from the internet: :func:`read_header` parses the header with
bounded reads and refuses a header that claims more data than the file holds,
absurd shapes, counts or offsets, overlapping fields and truncated files with
a :class:`PbsdfError` (one line naming the file and what is wrong) before any
array is allocated; :func:`read_pbsdf` then maps ``M`` from the file
(``numpy.memmap``) so that only the entries used are read.
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass
from typing import Dict

import numpy as np

from ..outputs import atomic_path

__all__ = ["PbsdfError", "Field", "PbsdfTable", "read_header", "read_pbsdf", "write_pbsdf",
           "check_renderable", "FIELDS", "MAGIC"]

MAGIC = b"tensor_file\0"
VERSION = (1, 0)
#: Mitsuba's Struct::Type codes of the container (``tensor_io.py``).
DTYPES = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
          9: "<f2", 10: "<f4", 11: "<f8"}
CODES = {np.dtype(v).str: k for k, v in DTYPES.items()}
#: The fields of a pBRDF table.
FIELDS = ("M", "phi_d", "theta_d", "theta_h", "wvls")
#: Limits past which a header is refused as absurd (a KAIST file has 5
#: fields, M has 6 dimensions).
MAX_FIELDS = 64
MAX_NAME = 256
MAX_NDIM = 8
MAX_GRID = 1 << 20
_TOL = 1e-4            # radians of slack on the grids' ranges (float32 pi)


class PbsdfError(ValueError):
    """A ``.pbsdf`` file that cannot be used; the message names the file."""


@dataclass(frozen=True)
class Field:
    """One field of the container: dtype (NumPy string), shape, byte offset."""
    name: str
    dtype: str
    shape: tuple
    offset: int

    @property
    def nbytes(self) -> int:
        return math.prod(self.shape) * np.dtype(self.dtype).itemsize


class _Reader:
    """Bounded reads of a header, each failing with a message naming the file."""

    def __init__(self, f, path, size):
        self.f, self.path, self.size = f, path, size

    def take(self, n, what):
        data = self.f.read(n)
        if len(data) != n:
            raise PbsdfError(f"{self.path}: truncated header (ends inside {what})")
        return data

    def unpack(self, fmt, what):
        return struct.unpack(fmt, self.take(struct.calcsize(fmt), what))


def read_header(path) -> Dict[str, Field]:
    """Parse and check the container's header: every field's dtype, shape and
    offset, with its data inside the file and no two fields overlapping.
    Nothing larger than the header is read or allocated."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise PbsdfError(f"{path}: no such file")
    if not os.path.isfile(path):
        raise PbsdfError(f"{path}: not a file")
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        r = _Reader(f, path, size)
        if f.read(len(MAGIC)) != MAGIC:
            raise PbsdfError(f"{path}: not a tensor_file/.pbsdf file (its first bytes are "
                             f"not 'tensor_file')")
        version = r.unpack("<BB", "the version")
        if version != VERSION:
            raise PbsdfError(f"{path}: unsupported tensor_file version {version[0]}.{version[1]} "
                             f"(expected 1.0)")
        (count,) = r.unpack("<I", "the field count")
        if not 1 <= count <= MAX_FIELDS:
            raise PbsdfError(f"{path}: header claims {count} fields (expected 1 to {MAX_FIELDS})")
        fields = {}
        for i in range(count):
            (length,) = r.unpack("<H", f"field {i}'s name length")
            if not 1 <= length <= MAX_NAME:
                raise PbsdfError(f"{path}: field {i} has a name of {length} bytes")
            try:
                name = r.take(length, f"field {i}'s name").decode("utf-8")
            except UnicodeDecodeError:
                raise PbsdfError(f"{path}: field {i}'s name is not UTF-8") from None
            if name in fields:
                raise PbsdfError(f"{path}: field {name!r} appears twice")
            ndim, code, offset = r.unpack("<HBQ", f"field {name!r}'s description")
            if ndim > MAX_NDIM:
                raise PbsdfError(f"{path}: field {name!r} claims {ndim} dimensions")
            if code not in DTYPES:
                raise PbsdfError(f"{path}: field {name!r} has unknown dtype code {code}")
            shape = r.unpack(f"<{ndim}Q", f"field {name!r}'s shape") if ndim else ()
            fields[name] = Field(name, DTYPES[code], tuple(int(s) for s in shape), int(offset))
        header_end = f.tell()
    spans = []
    for fd in fields.values():
        # Python integers: a product of absurd dimensions cannot overflow
        if fd.offset < header_end or fd.offset + fd.nbytes > size:
            raise PbsdfError(
                f"{path}: field {fd.name!r} of shape {fd.shape} needs bytes {fd.offset}..{fd.offset + fd.nbytes} but the file "
                f"has {size} bytes (header ends at {header_end}): truncated or corrupt")
        spans.append((fd.offset, fd.offset + fd.nbytes, fd.name))
    spans.sort()
    for (a0, a1, a), (b0, b1, b) in zip(spans, spans[1:]):
        if b0 < a1 and b1 > b0 and a1 > a0:  # empty fields overlap nothing
            raise PbsdfError(f"{path}: fields {a!r} and {b!r} overlap in the file")
    return fields


@dataclass
class PbsdfTable:
    """A tabulated pBRDF. ``M``: float32 array (possibly a read-only memory map
    of the file) ``(P, D, H, W, 4, 4)`` in 1/sr, NaN where unmeasured, in the
    frames of :mod:`mitsuba_pbrdf.measured.rusinkiewicz`; the grids in radians
    (float64 copies of the float32 values), wavelengths in nm."""
    M: np.ndarray
    phi_d: np.ndarray
    theta_d: np.ndarray
    theta_h: np.ndarray
    wavelengths: np.ndarray
    source: str = "<memory>"

    @property
    def shape(self):
        return self.M.shape

    @property
    def renderable(self) -> bool:
        """Whether Mitsuba's ``measured_polarized`` reads it correctly (W = 5)."""
        return self.M.shape[3] == 5

    def cells(self, ip, id_, ih) -> np.ndarray:
        """The entries ``(n, W, 4, 4)`` (float32) of cells ``(ip[i], id_[i],
        ih[i])``. From a memory-mapped file each cell is read with one
        ``pread``: gathering scattered cells through the map would make the
        kernel map tens of KiB around each 320-byte cell (3000 cells of a
        KAIST file held 650 MiB resident)."""
        ip, id_, ih = (np.asarray(a, dtype=np.intp).ravel() for a in (ip, id_, ih))
        if not isinstance(self.M, np.memmap):
            return np.asarray(self.M[ip, id_, ih])
        flat = np.ravel_multi_index((ip, id_, ih), self.M.shape[:3])
        size = math.prod(self.M.shape[3:]) * self.M.itemsize
        out = np.empty((flat.size, size), dtype=np.uint8)
        with open(self.M.filename, "rb") as f:
            fd = f.fileno()
            for row, cell in enumerate(flat.tolist()):
                data = os.pread(fd, size, self.M.offset + cell * size)
                if len(data) != size:
                    raise PbsdfError(f"{self.source}: truncated while reading cell {cell}")
                out[row] = np.frombuffer(data, dtype=np.uint8)
        return out.view(self.M.dtype).reshape((flat.size,) + self.M.shape[3:])

    def describe(self) -> str:
        P, D, H, W = self.M.shape[:4]
        return (f"{self.source}: phi_d {P} x theta_d {D} x theta_h {H} x {W} wavelengths "
                f"({', '.join(f'{w:g}' for w in self.wavelengths)} nm), "
                f"{self.M.nbytes / 2**20:.1f} MiB")


def _grid(path, name, values, lo, hi):
    v = np.asarray(values, dtype=np.float64).ravel()
    if not np.all(np.isfinite(v)):
        raise PbsdfError(f"{path}: grid {name!r} has non-finite values")
    if v.size > 1 and not np.all(np.diff(v) > 0):
        raise PbsdfError(f"{path}: grid {name!r} is not strictly increasing")
    if v[0] < lo - _TOL or v[-1] > hi + _TOL:
        raise PbsdfError(f"{path}: grid {name!r} spans [{v[0]:.4g}, {v[-1]:.4g}], outside "
                         f"[{lo:.4g}, {hi:.4g}] radians")
    return v


def _check_fields(path, fields):
    missing = [n for n in FIELDS if n not in fields]
    if missing:
        raise PbsdfError(f"{path}: missing field(s) {', '.join(missing)} (a pBRDF table has "
                         f"{', '.join(FIELDS)}; found {', '.join(fields) or 'none'})")
    sizes = []
    for name in ("phi_d", "theta_d", "theta_h"):
        fd = fields[name]
        if fd.dtype != "<f4":
            raise PbsdfError(f"{path}: field {name!r} is {np.dtype(fd.dtype).name}, expected float32")
        if len(fd.shape) != 2 or fd.shape[0] != 1 or not 1 <= fd.shape[1] <= MAX_GRID:
            raise PbsdfError(f"{path}: field {name!r} has shape {fd.shape}, expected (1, N) "
                             f"with 1 <= N <= {MAX_GRID}")
        sizes.append(fd.shape[1])
    w = fields["wvls"]
    if np.dtype(w.dtype).kind not in "uif" or len(w.shape) != 1 or not 1 <= w.shape[0] <= MAX_GRID:
        raise PbsdfError(f"{path}: field 'wvls' is {np.dtype(w.dtype).name} {w.shape}, "
                         f"expected a 1-D list of wavelengths (uint16)")
    m = fields["M"]
    if m.dtype != "<f4":
        raise PbsdfError(f"{path}: field 'M' is {np.dtype(m.dtype).name}, expected float32")
    expected = tuple(sizes) + (w.shape[0], 4, 4)
    if m.shape != expected:
        raise PbsdfError(f"{path}: field 'M' has shape {m.shape}, expected (phi_d, theta_d, "
                         f"theta_h, wavelengths, 4, 4) = {expected} from the grids")


def read_pbsdf(path, mmap=True) -> PbsdfTable:
    """Read a ``.pbsdf`` pBRDF table. ``M`` is a read-only memory map of the
    file when ``mmap`` (only the entries used are read), else loaded. The
    grids are checked (float32, (1, N), finite, strictly increasing, phi_d in
    [-pi, pi], theta_d and theta_h in [0, pi/2]); wavelengths > 0."""
    path = os.fspath(path)
    fields = read_header(path)
    _check_fields(path, fields)

    def small(name):
        fd = fields[name]
        return np.fromfile(path, dtype=fd.dtype, count=math.prod(fd.shape),
                           offset=fd.offset).reshape(fd.shape)

    phi_d = _grid(path, "phi_d", small("phi_d"), -math.pi, math.pi)
    theta_d = _grid(path, "theta_d", small("theta_d"), 0.0, math.pi / 2)
    theta_h = _grid(path, "theta_h", small("theta_h"), 0.0, math.pi / 2)
    wavelengths = small("wvls").astype(np.float64)
    if not np.all(np.isfinite(wavelengths) & (wavelengths > 0)):
        raise PbsdfError(f"{path}: field 'wvls' has wavelengths that are not > 0")
    if wavelengths.size > 1 and not np.all(np.diff(wavelengths) > 0):
        raise PbsdfError(f"{path}: field 'wvls' is not strictly increasing")
    m = fields["M"]
    if mmap:
        M = np.memmap(path, dtype=m.dtype, mode="r", offset=m.offset, shape=m.shape)
    else:
        M = np.fromfile(path, dtype=m.dtype, count=math.prod(m.shape),
                        offset=m.offset).reshape(m.shape)
    return PbsdfTable(M, phi_d, theta_d, theta_h, wavelengths, path)


def check_renderable(table: PbsdfTable):
    """Raise :class:`PbsdfError` unless Mitsuba's ``measured_polarized`` reads
    the table correctly: exactly 5 wavelengths (it copies 5 ``wvls`` values)
    that fit in uint16."""
    W = table.M.shape[3]
    if W != 5:
        raise PbsdfError(f"{table.source}: {W} wavelengths; Mitsuba's measured_polarized "
                         f"reads exactly 5 (the file can still be read and fitted)")
    if not np.all(table.wavelengths == np.round(table.wavelengths)) or table.wavelengths.max() > 65535:
        raise PbsdfError(f"{table.source}: wavelengths must be whole nm (uint16) for "
                         f"measured_polarized")


def _header_bytes(arrays):
    """Header of the container with zero offsets, and where each offset goes."""
    out, where = [MAGIC, struct.pack("<BB", *VERSION), struct.pack("<I", len(arrays))], {}
    pos = sum(len(b) for b in out)
    for name, (dtype, shape) in arrays.items():
        label = name.encode("utf-8")
        part = struct.pack("<H", len(label)) + label + struct.pack("<HB", len(shape), CODES[dtype])
        where[name] = pos + len(part)
        part += struct.pack("<Q", 0) + struct.pack(f"<{len(shape)}Q", *shape)
        out.append(part)
        pos += len(part)
    return b"".join(out), where


def write_pbsdf(path, M, phi_d, theta_d, theta_h, wavelengths, align=8, slab_bytes=16 << 20):
    """Write a pBRDF table as a ``.pbsdf`` file, atomically (a temporary file
    in the same folder, renamed over ``path`` once complete).

    ``M``: an array ``(P, D, H, W, 4, 4)`` (converted to float32), or a
    callable ``M(p0, p1)`` returning the float32 slab of ``phi_d`` indices
    ``p0:p1`` (so that a large table is written without holding it whole);
    grids in radians, wavelengths in nm (stored as uint16)."""
    path = os.fspath(path)
    grids = {n: np.asarray(v, dtype="<f4").reshape(1, -1)
             for n, v in (("phi_d", phi_d), ("theta_d", theta_d), ("theta_h", theta_h))}
    wvls = np.asarray(wavelengths)
    if np.any(wvls != np.round(wvls)) or np.any(wvls <= 0) or np.any(wvls > 65535):
        raise PbsdfError(f"{path}: wavelengths must be whole nm in 1..65535, got {wvls.tolist()}")
    wvls = wvls.astype("<u2")
    shape = tuple(g.shape[1] for g in grids.values()) + (wvls.size, 4, 4)
    if not callable(M):
        array = np.asarray(M)
        if array.shape != shape:
            raise PbsdfError(f"{path}: M has shape {array.shape}, expected {shape}")
        M = lambda p0, p1, a=array: a[p0:p1]
    arrays = {"M": ("<f4", shape), **{n: ("<f4", g.shape) for n, g in grids.items()},
              "wvls": ("<u2", wvls.shape)}
    header, where = _header_bytes(arrays)
    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            f.write(header)
            data = {"M": None, **grids, "wvls": wvls}
            for name, (dtype, shp) in arrays.items():
                pos = (f.tell() + align - 1) // align * align
                f.seek(where[name])
                f.write(struct.pack("<Q", pos))
                f.seek(pos)
                if name == "M":
                    step = max(1, slab_bytes // max(1, math.prod(shape[1:]) * 4))
                    for p0 in range(0, shape[0], step):
                        slab = np.ascontiguousarray(M(p0, min(p0 + step, shape[0])), dtype="<f4")
                        if slab.shape != (min(p0 + step, shape[0]) - p0,) + shape[1:]:
                            raise PbsdfError(f"{path}: slab {p0} of M has shape {slab.shape}")
                        slab.tofile(f)
                else:
                    data[name].tofile(f)
    except OSError as e:
        raise PbsdfError(f"{path}: cannot write ({e.strerror or e})") from None
    return path
