"""NIST's layout of Mueller-matrix BRDF files (``measured/nist_layout.py``):
the conversion into the project's conventions checked against SCATMECH, the
PTFE measurement read as published, the ``--wavelength`` and
``--observables`` selections.

The SCATMECH check: SCATMECH's ``Shadowed_Facet_BRDF_Model`` (Gaussian
slopes, Torrance-Sparrow shadowing: the reference's specular lobe with
``shadowing="vgroove"``, ``tests/bsdfs/test_scatmech.py``) computes Mueller BRDFs in
its own frame (source at azimuth 180 deg, ``psps`` bases, its circular sign).
They are written in NIST's layout exactly as a lab would (lambda in um, signed
in-plane ``thetai``, out-of-plane ``phi``, ``f_r11`` and 1-indexed elements
normalized by it), read back by ``read_measurements`` and compared with the
reference evaluator element by element at the angles the reader reports. The
psps bases are symmetric about the normal, so a geometry rotated in azimuth
(the file's source azimuth against SCATMECH's 180 deg) keeps its matrix.
"""

import csv
import os

import numpy as np
import pytest

from mitsuba_pbrdf import reference as ref
from mitsuba_pbrdf.measured import MeasurementError, read_measurements
from mitsuba_pbrdf.choices import layout_of
from mitsuba_pbrdf.measured.selection import select_observables, select_wavelengths

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
PTFE = os.path.join(ROOT, "tests", "data", "nist_ptfe_subset.csv")
HEADER = (["lambda", "thetai", "phi", "thetar", "phir", "f_r11"]
          + [f"f_r{i}{j}/f_r11" for i in range(1, 5) for j in range(1, 5) if (i, j) != (1, 1)])

#: Rows (thetai signed, phi, thetar, phir), degrees, as a lab writes them:
#: in plane (phi = 0, signed thetai, either side of the normal), out of plane
#: (thetai >= 0, any phi), exact normal incidence and exact normal viewing
#: (where SCATMECH's basis is the limit along the azimuth and the project's
#: the surface x-axis).
ROWS = ([(ti, 0.0, tr, pr) for ti in (-60.0, -30.0, -0.001, 20.0, 45.0)
         for tr in (5.0, 25.0, 50.0, 70.0) for pr in (0.0, 180.0, 170.0, -15.0)]
        + [(ti, phi, tr, (pr + 180.0) % 360.0 - 180.0) for ti in (15.0, 40.0)
           for phi in (37.0, -120.0, 200.0) for tr in (10.0, 35.0, 60.0)
           for pr in (phi + 180.0, phi + 150.0, phi - 160.0, 12.0)]
        + [(0.0, phi, tr, pr) for phi in (0.0, 37.0, -100.0) for tr in (10.0, 30.0)
           for pr in (20.0, 130.0, -70.0)]
        + [(ti, phi, 0.0, pr) for ti, phi in ((-30.0, 0.0), (25.0, 0.0), (35.0, 70.0))
           for pr in (0.0, 30.0, 110.0, -140.0)])
N, K, SIGMA = 1.2, 7.26, 0.25      # Al-like; a wide lobe so that every row has a value


def scatmech_rows(rows):
    """SCATMECH's Mueller BRDF (1/sr, its psps bases and circular sign) of each
    row of NIST's layout."""
    from pySCATMECH.brdf import BRDF_Model

    model = BRDF_Model("Shadowed_Facet_BRDF_Model", sdf="Gaussian_Slope_Distribution_Function")
    model.setParameters({"lambda": 0.633, "substrate": f"({N!r},{K!r})",
                         "sdf.s": repr(float(np.sqrt(2.0) * SIGMA)), "type": "0"})
    out = []
    for ti, phi, tr, pr in rows:
        source = phi + (180.0 if ti < 0 else 0.0)           # azimuth of the source
        # SCATMECH's frame has its source at azimuth 180 deg: rotate the geometry
        phis = np.radians(pr - source + 180.0)
        out.append(np.array(model.MuellerBRDF(np.radians(abs(ti)), np.radians(tr), phis,
                                              0.0, "psps")))
    return np.array(out)


def write_nist(path, rows, M, lam=0.633, header=HEADER):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for (ti, phi, tr, pr), m in zip(rows, M):
            norm = [m[i, j] / m[0, 0] for i in range(4) for j in range(4) if (i, j) != (0, 0)]
            w.writerow([repr(lam), repr(ti), repr(phi), repr(tr), repr(pr), repr(float(m[0, 0]))]
                       + [repr(float(v)) for v in norm])
    return str(path)


def test_scatmech_mueller_brdf_in_nist_layout_matches_the_reference(tmp_path):
    """Element by element, to 1e-9 of the largest M00: the two codes agree to
    rounding (~1e-14, tests/bsdfs/test_scatmech.py) and the file's 17-digit numbers
    and the normalization add ~1e-16; a wrong sign, index, azimuth or rotation
    shows at order 1 (the second half of the test shows it does)."""
    S = scatmech_rows(ROWS)
    path = write_nist(tmp_path / "scatmech.csv", ROWS, S)
    data = read_measurements(path)
    assert len(data) == len(ROWS) and data.wavelengths.tolist() == [633.0]
    assert sorted(data.observed) == sorted(f"m{i}{j}" for i in range(4) for j in range(4))
    R = ref.specular(*data.radians(), N, K, SIGMA, "vgroove")
    M = np.stack([np.stack([data.observed[f"m{i}{j}"] for j in range(4)], -1)
                  for i in range(4)], -2)
    scale = S[:, 0, 0].max()
    worst = np.abs(M - R).max(axis=0) / scale
    assert worst.max() <= 1e-9, worst
    # row by row too, so that rows far from the lobe count as much as the peak
    relative = np.abs(M - R).max(axis=(1, 2)) / S[:, 0, 0]
    assert relative.max() <= 1e-9, relative.max()

    # the test can fail: each step of the conversion left out shows at order 1
    plain = S.copy()                                  # no circular sign flip
    assert np.abs(plain[:, :3, 3] - R[:, :3, 3]).max() > 1e-2 * scale
    normal = np.array([r[2] == 0 for r in ROWS])      # no rotation at normal viewing
    D = np.diag([1.0, 1.0, 1.0, -1.0])
    assert np.abs((D @ S @ D)[normal] - R[normal]).max() > 1e-2 * scale
    unsigned = ref.specular(np.radians([abs(r[0]) for r in ROWS]),
                            np.radians([r[1] for r in ROWS]), *data.radians()[2:],
                            N, K, SIGMA, "vgroove")   # signed thetai ignored
    assert np.abs(unsigned - M).max() > 1e-2 * scale


def test_normalized_and_absolute_elements_read_the_same(tmp_path):
    """Elements in 1/sr (f_r12 ...) read as the normalized ones times f_r11."""
    rows = ROWS[:12]
    S = scatmech_rows(rows)
    a = read_measurements(write_nist(tmp_path / "n.csv", rows, S))
    header = HEADER[:6] + [h.split("/")[0] for h in HEADER[6:]]
    path = tmp_path / "a.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for (ti, phi, tr, pr), m in zip(rows, S):
            w.writerow([0.633, ti, phi, tr, pr] + [repr(float(v)) for v in m.ravel()])
    b = read_measurements(path)
    for q in a.observed:
        np.testing.assert_allclose(b.observed[q], a.observed[q], rtol=1e-12,
                                   atol=1e-15 * S[:, 0, 0].max())


def test_m_names_read_as_f_r_names(tmp_path):
    """1-indexed ``m11``, ``m12/m11`` ... read as ``f_r11``, ``f_r12/f_r11`` ...,
    told by the angle columns (a header without f_r11)."""
    rows = ROWS[:12]
    S = scatmech_rows(rows)
    a = read_measurements(write_nist(tmp_path / "f.csv", rows, S))
    header = [h.replace("f_r", "m") for h in HEADER]
    b = read_measurements(write_nist(tmp_path / "m.csv", rows, S, header=header))
    assert sorted(b.observed) == sorted(a.observed)
    for q in a.observed:
        np.testing.assert_array_equal(b.observed[q], a.observed[q])


def test_ptfe_file_reads_as_published():
    """The PTFE subset: its layout is recognised from the header; values are
    f_r11 and f_r11 times the normalized elements; the source of the signed
    (negative) thetai lies at azimuth 180 deg, and at grazing incidence the
    forward-scattering peak is on the side of the specular direction
    (|phi_r| < 90 deg), as the conversion predicts."""
    with open(PTFE) as f:
        header = [h.strip().lower() for h in f.readline().split(",")]
        first = [float(v) for v in f.readline().split(",")]
    assert layout_of(header).name == "nist"
    data = read_measurements(PTFE)
    assert len(data) == 325 and data.wavelengths.tolist() == [532.0, 633.0]
    assert np.all(data.phi_i == -180.0) and data.theta_i.min() == pytest.approx(0.001)
    assert data.observed["m00"][0] == first[5]
    # m01 is f_r12/f_r11 times f_r11 (not circular: no sign change)
    assert data.observed["m01"][0] == pytest.approx(first[6] * first[5], rel=1e-12)
    # m03 is f_r14: SCATMECH's circular sign flipped
    assert data.observed["m03"][0] == pytest.approx(-first[8] * first[5], rel=1e-12)
    grazing = np.flatnonzero(data.theta_i == 75.0)
    peak = grazing[np.argmax(data.observed["m00"][grazing])]
    assert abs(data.phi_r[peak]) < 90.0 and data.theta_r[peak] > 45.0


def test_wavelength_and_observable_selection():
    data = read_measurements(PTFE)
    at532 = select_wavelengths(data, [532])
    assert len(at532) == 304 and np.all(at532.wavelength == 532.0)
    assert at532.lines.min() > 1                    # errors still name the file's lines
    with pytest.raises(MeasurementError, match=r"no measurement at 500 nm .*532, 633 nm"):
        select_wavelengths(data, [500])
    chosen = select_observables(at532, ["m00", "m11", "dolp"])
    assert list(chosen.observed) == ["m00", "m11", "dolp"]
    dolp = np.hypot(at532.observed["m10"], at532.observed["m20"]) / at532.observed["m00"]
    np.testing.assert_array_equal(chosen.observed["dolp"], dolp)
    with pytest.raises(MeasurementError, match="unknown quantity 'm44'"):
        select_observables(at532, ["m44"])


@pytest.mark.parametrize("change, message", [
    (lambda h, r: (h.replace(",f_r11,", ",x,"), r), "missing column f_r11"),
    (lambda h, r: (h, r.replace(",0.0212992,", ",1.27079,", 1)),
     "f_r12/f_r11 = 1.27079 is above 1 in magnitude"),
    (lambda h, r: (h, "532" + r[r.index(","):]), "lambda = 532 is not a wavelength in µm"),
    (lambda h, r: (h.replace("f_r13/f_r11", "f_r13"), r), "mixed units"),
    (lambda h, r: (h.replace("f_r12/f_r11", "m00"), r), "'m00' is 0-indexed"),
    (lambda h, r: (h.replace("thetar", "theta"), r), "missing column(s) thetar"),
    (lambda h, r: (h, r.replace("-0.001,", "-95,", 1)), "thetai = -95 deg is out of range"),
    (lambda h, r: (h, r.replace(",2.65E-01,", ",,", 1)), "f_r11 is empty"),
])
def test_bad_nist_files_name_the_fault(tmp_path, change, message):
    with open(PTFE) as f:
        header, row = f.readline(), f.readline()
    header, row = change(header, row)
    path = tmp_path / "bad.csv"
    path.write_text(header + row)
    with pytest.raises(MeasurementError) as e:
        read_measurements(path, layout="nist")
    assert message in str(e.value) and str(path) in str(e.value)


def test_layout_can_be_forced():
    """--layout goniometer on a NIST file says which columns it misses."""
    with pytest.raises(MeasurementError, match="missing column.*theta_i"):
        read_measurements(PTFE, layout="goniometer")
    good = os.path.join(ROOT, "tests", "data", "fit_example.csv")
    with pytest.raises(MeasurementError, match="missing column.*lambda"):
        read_measurements(good, layout="nist")
    assert len(read_measurements(good)) > 0
