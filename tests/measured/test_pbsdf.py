"""The ``.pbsdf`` format (mitsuba_pbrdf.measured.pbsdf): round trips with
Mitsuba's own ``tensor_io``, hostile files refused with one line before
anything large is allocated, atomic writes, and ``pbrdf export``'s tables
read back by Mitsuba's ``measured_polarized`` exactly as the NumPy emulation
of its lookup predicts."""

import os
import struct
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from mitsuba_pbrdf.measured import export, lookup, pbsdf, rusinkiewicz
from mitsuba_pbrdf.reference.params import PBRDFParams

ROOT = os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)
PARAMS = PBRDFParams(eta=0.9, k=2.4, sigma=0.15, kdd=0.1, sigma_dd=0.5, kid=0.02)
SMALL = export.Grid(9, 12, 14)


@pytest.fixture(scope="module")
def table_path(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("pbsdf") / "small.pbsdf")
    export.export_pbsdf(path, PARAMS, SMALL)
    return path


def test_round_trip_with_mitsuba_tensor_io(table_path, tmp_path):
    """Mitsuba's reader reads our file field by field, and ours reads a file
    written by Mitsuba's writer."""
    from mitsuba.python import tensor_io

    theirs = tensor_io.read(table_path)
    ours = pbsdf.read_pbsdf(table_path)
    assert theirs["M"].shape == (9, 12, 14, 5, 4, 4) and theirs["wvls"].dtype == np.uint16
    np.testing.assert_array_equal(theirs["M"], ours.M)
    np.testing.assert_array_equal(theirs["theta_h"][0], ours.theta_h.astype(np.float32))
    other = str(tmp_path / "theirs.pbsdf")
    tensor_io.write(other, **theirs)
    again = pbsdf.read_pbsdf(other, mmap=False)
    np.testing.assert_array_equal(again.M, ours.M)
    assert again.renderable and list(again.wavelengths) == [450, 500, 550, 600, 650]


def test_table_nodes_hold_the_model(table_path):
    """At a grid node the emulated lookup returns the reference's matrix up to
    float32 rounding (1e-6 of M00 per element)."""
    t = pbsdf.read_pbsdf(table_path)
    ip, id_, ih = np.meshgrid([1, 4, 7], [2, 5, 8], [1, 6, 10], indexing="ij")
    L, V = rusinkiewicz.directions(t.phi_d[ip], t.theta_d[id_], t.theta_h[ih])
    above = (L[..., 2] > 0.05) & (V[..., 2] > 0.05)
    M = lookup.lookup(t, L[above], V[above], 550.0)
    R = PARAMS.evaluate(*rusinkiewicz.angles(L[above], V[above]), [550.0])[:, 0]
    np.testing.assert_allclose(M, R, rtol=0, atol=2e-6 * R[:, 0, 0].max())


def test_measured_polarized_reads_as_emulated(table_path, restore_variant):
    """Mitsuba's measured_polarized (scalar variant: compiled C++, no JIT) on
    our table against the NumPy emulation at 300 random direction pairs, all
    16 elements at 4 wavelengths. A frame or sign convention read wrongly
    would differ at order 1.

    Tolerance per element: ``1e-4 M00 + 1e-5 max(M00)`` (float32 interpolation
    and frame rotation) plus the change of the emulated value when the angles
    move by Mitsuba's float32 rounding: ``theta = acos(c)`` in float32 is off by
    up to ~1.2e-7 / sin(theta) (two ulps of c near 1), which near the specular
    peak (theta_h -> 0, where the square-spaced grid's first cell is 8 mrad
    wide and neighbouring nodes differ by orders of magnitude at grazing
    angles) moves the interpolation weight by up to ~1e-3."""
    import mitsuba as mi

    from mitsuba_pbrdf import frames, use_variant

    use_variant("scalar_spectral_polarized")
    bsdf = mi.load_dict({"type": "measured_polarized", "filename": table_path})
    rng = np.random.default_rng(3)
    wi_hat, wo_hat = frames.random_directions(300, rng, min_cos=0.05)
    wl = np.array([470.0, 520.0, 580.0, 630.0])
    M = frames.eval_global(bsdf, wi_hat, wo_hat, wl)
    t = pbsdf.read_pbsdf(table_path)
    E = lookup.lookup(t, wo_hat[:, None], wi_hat[:, None], wl[None, :])
    pd, td, th = (a[:, None] for a in rusinkiewicz.rusinkiewicz(wo_hat, wi_hat))
    base = lookup.lookup_facet(t, pd, td, th, wl[None, :])
    spread = np.zeros_like(base)
    for dp, dd, dh in ((1e-6, 0, 0), (-1e-6, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)):
        moved = lookup.lookup_facet(t, pd + dp, td + dd * 1.2e-7 / np.maximum(np.sin(td), 1e-4),
                                    th + dh * 1.2e-7 / np.maximum(np.sin(th), 1e-4), wl[None, :])
        spread = np.maximum(spread, np.abs(moved - base))
    m00 = E[..., :1, :1]
    bound = 1e-4 * m00 + 1e-5 * m00.max() + np.abs(rusinkiewicz.facet_to_global(
        spread, wo_hat[:, None], wi_hat[:, None]))
    bound += spread[..., :1, :1]                  # the rotation mixes elements 1 and 2
    assert np.all(np.abs(M - E) <= bound)


# ------------------------------------------------------------------ hostile files

def _header(fields):
    """A container header from (name, code, offset, shape) tuples."""
    out = pbsdf.MAGIC + struct.pack("<BBI", 1, 0, len(fields))
    for name, code, offset, shape in fields:
        label = name.encode()
        out += struct.pack("<H", len(label)) + label + struct.pack("<HBQ", len(shape), code, offset)
        out += struct.pack(f"<{len(shape)}Q", *shape)
    return out


def _valid_bytes(table_path):
    with open(table_path, "rb") as f:
        return f.read()


def hostile_cases(table_path):
    good = _valid_bytes(table_path)
    fields = pbsdf.read_header(table_path)
    m = fields["M"]
    n_head = min(fd.offset for fd in fields.values())
    huge = _header([("M", 10, 200, (10**6, 10**6, 10**6, 5, 4, 4))])
    return {
        "empty": (b"", "not a tensor_file"),
        "not-a-tensor-file": (b"theta_i,phi_i\n1,2\n", "not a tensor_file"),
        "truncated-header": (good[:40], "truncated header"),
        "truncated-data": (good[: m.offset + m.nbytes // 2], "truncated or corrupt"),
        "claims-more-data": (huge + b"\0" * 64, "truncated or corrupt"),
        "absurd-field-count": (pbsdf.MAGIC + struct.pack("<BBI", 1, 0, 10**9), "fields"),
        "absurd-ndim": (_header([("M", 10, 0, ())])[:-8] + struct.pack("<H", 60000), "truncated"),
        "unknown-dtype": (_header([("M", 99, 64, (1,))]) + b"\0" * 64, "dtype code 99"),
        "bad-version": (pbsdf.MAGIC + struct.pack("<BBI", 2, 0, 1), "version 2.0"),
        "overlap": (_header([("a", 10, 80, (4,)), ("b", 10, 84, (4,))]) + b"\0" * 64, "overlap"),
        "missing-fields": (_header([("M", 10, 64, (1,))]) + b"\0" * 64, "missing field"),
        "header-offset-inside-header": (good[:n_head].replace(
            struct.pack("<Q", m.offset), struct.pack("<Q", 8), 1) + good[n_head:],
            "truncated or corrupt"),
    }


@pytest.mark.parametrize("case", ["empty", "not-a-tensor-file", "truncated-header",
                                  "truncated-data", "claims-more-data", "absurd-field-count",
                                  "absurd-ndim", "unknown-dtype", "bad-version", "overlap",
                                  "missing-fields", "header-offset-inside-header"])
def test_hostile_files_are_refused_before_allocating(case, table_path, tmp_path):
    """Each bad file: a PbsdfError on one line naming the file and the fault,
    and less than 1 MiB allocated while refusing it (a header claiming 10^18
    entries allocates nothing)."""
    data, expected = hostile_cases(table_path)[case]
    path = str(tmp_path / f"{case}.pbsdf")
    with open(path, "wb") as f:
        f.write(data)
    tracemalloc.start()
    with pytest.raises(pbsdf.PbsdfError) as err:
        pbsdf.read_pbsdf(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    message = str(err.value)
    assert path in message and expected in message and "\n" not in message, message
    assert peak < 2**20, peak


@pytest.mark.parametrize("fault,expected", [
    ("nan-grid", "non-finite"), ("decreasing-grid", "strictly increasing"),
    ("wide-grid", "outside"), ("int-M", "expected float32"), ("shape", r"expected \(phi_d")])
def test_bad_structure_is_named(fault, expected, tmp_path):
    from mitsuba.python import tensor_io

    grids = dict(phi_d=np.linspace(-3.14, 3.14, 3, dtype=np.float32)[None],
                 theta_d=np.linspace(0, 1.5, 4, dtype=np.float32)[None],
                 theta_h=np.linspace(0, 1.5, 5, dtype=np.float32)[None],
                 wvls=np.array([450, 500, 550, 600, 650], np.uint16))
    M = np.zeros((3, 4, 5, 5, 4, 4), np.float32)
    if fault == "nan-grid":
        grids["theta_d"][0, 1] = np.nan
    elif fault == "decreasing-grid":
        grids["theta_h"] = grids["theta_h"][:, ::-1].copy()
    elif fault == "wide-grid":
        grids["phi_d"] = grids["phi_d"] * 3
    elif fault == "int-M":
        M = M.astype(np.int32)
    elif fault == "shape":
        M = M[:, :3]
    path = str(tmp_path / "bad.pbsdf")
    tensor_io.write(path, M=M, **grids)
    with pytest.raises(pbsdf.PbsdfError, match=expected):
        pbsdf.read_pbsdf(path)


def test_nan_entries_read_and_renderability(tmp_path):
    """NaN marks unmeasured entries (read as they are); a table of 3
    wavelengths reads and fits but is not renderable by measured_polarized."""
    grid = export.Grid(3, 4, 5)
    axes = grid.axes()
    M = export.tabulate(PARAMS, *axes, [500, 550, 600]).astype(np.float32)
    M[1, 2, 3] = np.nan
    path = pbsdf.write_pbsdf(str(tmp_path / "nan.pbsdf"), M, *axes, [500, 550, 600])
    t = pbsdf.read_pbsdf(path)
    assert np.isnan(t.M[1, 2, 3]).all() and not t.renderable
    with pytest.raises(pbsdf.PbsdfError, match="exactly 5"):
        pbsdf.check_renderable(t)


def test_write_is_atomic(tmp_path, monkeypatch):
    """An error while tabulating (or Ctrl-C) leaves neither the output nor a
    temporary file."""
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    real = export.tabulate
    monkeypatch.setattr(export, "tabulate", failing)
    path = tmp_path / "out.pbsdf"
    with pytest.raises(KeyboardInterrupt):
        pbsdf_path = export.export_pbsdf(str(path), PARAMS, export.Grid(400, 40, 40))
        del pbsdf_path
    assert os.listdir(tmp_path) == []


def test_large_sparse_file_is_mapped_not_loaded(tmp_path):
    """A KAIST-size table of 0.96 GB (a sparse file: the data region is a hole) is opened and
    sampled with a few MiB allocated: M stays on disk."""
    from mitsuba_pbrdf.measured.table_sampling import table_cells

    shape = (361, 91, 91, 5, 4, 4)
    axes = export.KAIST_GRID.axes()
    header, where = pbsdf._header_bytes({"M": ("<f4", shape), "phi_d": ("<f4", (1, 361)),
                                         "theta_d": ("<f4", (1, 91)), "theta_h": ("<f4", (1, 91)),
                                         "wvls": ("<u2", (5,))})
    path = str(tmp_path / "sparse.pbsdf")
    m_offset = (len(header) + 7) // 8 * 8
    pos = m_offset + int(np.prod(shape)) * 4
    with open(path, "wb") as f:
        f.write(header)
        offsets = {"M": m_offset}
        for name, values in (("phi_d", axes[0]), ("theta_d", axes[1]), ("theta_h", axes[2])):
            offsets[name] = pos
            f.seek(pos)
            f.write(np.asarray(values, "<f4").tobytes())
            pos += 4 * len(values)
        offsets["wvls"] = pos
        f.seek(pos)
        f.write(np.array(export.KAIST_WAVELENGTHS, "<u2").tobytes())
        for name, at in where.items():
            f.seek(at)
            f.write(struct.pack("<Q", offsets[name]))
    tracemalloc.start()
    t = pbsdf.read_pbsdf(path)
    cells = table_cells(t, cells=500)
    values = t.cells(*cells)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert os.path.getsize(path) > 9 * 10**8 and values.shape == (500, 5, 4, 4)
    assert peak < 100 * 2**20, peak / 2**20       # the (P, D, H) cell masks, not M


# ------------------------------------------------------------------ pbrdf export

def run_cli(*args):
    env = dict(os.environ, PYTHONPATH=os.path.abspath(ROOT))
    return subprocess.run([sys.executable, "-m", "mitsuba_pbrdf", *args], capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=300)


def test_export_command(tmp_path):
    out = str(tmp_path / "cu.pbsdf")
    r = run_cli("export", "--material", "Cu", "--sigma", "0.2", "--kdd", "0.1",
                "--grid", "7x8x9", "--out", out)
    assert r.returncode == 0, r.stderr
    t = pbsdf.read_pbsdf(out)
    assert t.shape == (7, 8, 9, 5, 4, 4) and t.renderable and "wrote" in r.stdout


@pytest.mark.parametrize("args,expected", [
    (["--sigma", "-1"], "sigma"),
    (["--sigma", "nan"], "sigma"),
    (["--material", "Unobtainium"], "unknown material"),
    (["--grid", "1x2"], "--grid"),
    (["--grid", "1x9x9"], "phi_d"),
    (["--wavelengths", "450,500"], "exactly 5"),
    (["--wavelengths", "450,500,550,600,650.5"], "whole nm"),
    (["--material", "Cu", "--eta", "1"], "not both"),
    (["--out", "{tmp}/x.png"], ".pbsdf"),
    (["--out", "{tmp}/missing-folder/x.pbsdf"], "does not exist"),
    (["--out", "{file}/x.pbsdf"], "does not exist"),
    (["--ks", "abc"], "invalid float"),
])
def test_export_bad_input(args, expected, tmp_path):
    """One line, exit 2, no traceback, no output file."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    args = [a.format(tmp=tmp_path, file=blocker) for a in args]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "x.pbsdf")]
    r = run_cli("export", "--grid", "5x5x5", *args) if "--grid" not in args else run_cli(
        "export", *args)
    assert r.returncode == 2, r.stdout + r.stderr
    # one error line (argparse prints its usage above it)
    assert expected in r.stderr.strip().splitlines()[-1] and "Traceback" not in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["file"]


def test_explicit_index_wins_over_the_default_material():
    """PBRDFParams(eta=..., k=...) evaluates with that n + ik even before
    validate() (the default material is Al)."""
    p = PBRDFParams(eta=0.9, k=2.4)
    assert p.ior([550.0])[0][0] == 0.9 and p.label().startswith("n=0.9")


def test_horizon_nodes_hold_zero(table_path):
    """Nodes on the horizon (theta_d = 90 deg at theta_h = 0: cos = 6e-17 in
    floating point) hold 0, not the model's 1/cos blow-up (up to 1e29), which
    would leak into every lookup near the horizon as fireflies."""
    t = pbsdf.read_pbsdf(table_path)
    assert np.all(t.M[:, -1, 0] == 0)
    assert np.isfinite(t.M).all() and np.abs(t.M).max() < 1e5
