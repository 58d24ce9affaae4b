"""Study: is NIST's PTFE Mueller-BRDF measurement reciprocal, read the project's way?

    python validation/ptfe_reciprocity.py   (-> ptfe_reciprocity.md; a few seconds, NumPy only)

The data: T. A. Germer's full Mueller-matrix BRDF of sintered PTFE (Applied
Optics 2017; ``validation/data/nist_ptfe/``), read by
``measured.read_measurements`` (NIST's layout, ``docs/fitting.md``) into the
project's global s/p frames. The checks (``proof/measured_reciprocity.py``):
Helmholtz reciprocity M_B = Q M_A^T Q, Q = diag(1, 1, -1, 1), on every pair of
rows (a, b, dphi) and (b, a, -dphi) of one wavelength (an isotropic sample:
only the azimuth difference counts); the data's noise in the same figures from
the mirror pairs (a, b, dphi) and (a, b, -dphi), M_B = E M_A E with
E = diag(1, 1, -1, -1), and from the elements that vanish in the plane of
incidence; then the same check on the file read six wrong ways, on the data
and on the float64 reference model at the pairs' geometries. The study
reports; its bounds are asserted in ``tests/measured/test_ptfe_reciprocity.py``.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402

from proof import measured_reciprocity as mr  # noqa: E402

DATA = os.path.join(common.HERE, "data", "nist_ptfe", "PTFE.data.csv")
TOLERANCES = (1e-4, 1e-3, 0.01, 0.1, 0.25, 0.5, 1.0, 2.0)
#: A strongly polarizing model (a conductor: every element of the matrix is
#: large) and the three-component fit of validation/fit_ptfe.md at 532 nm
#: (PTFE's own small polarization), both at the pairs' geometries.
MODELS = {
    "conductor n 1.2, k 7.26, sigma 0.2": dict(n=1.2, k=7.26, sigma=0.2, kid=0.05),
    "PTFE fit, 532 nm": dict(n=0.711, k=0.0832, sigma=0.329, ks=0.0562, kdd=0.037,
                             sigma_dd=0.33, kid=0.936),
}
LABELS = ("M00 rel. diff.", "whole matrix / M00", "normalized elements")


def pct(values, q):
    return float(np.percentile(values, q))


def by_wavelength(data, pairs, w):
    return pairs if w is None else pairs[data.wavelength[pairs[:, 0]] == w]


def geometry_table(data, pairs):
    d = mr.dphi(data)
    first = by_wavelength(data, pairs, data.wavelength[pairs[0, 0]])
    rows = []
    for a, b in first:
        rows.append((f"{data.theta_i[a]:g}", f"{data.theta_r[a]:g}", f"{d[a]:.2f}",
                     f"{data.theta_i[b]:g}", f"{data.theta_r[b]:g}", f"{d[b]:.2f}",
                     "itself" if a == b else "yes" if abs(np.sin(np.radians(d[a]))) < 1e-3
                     else "no (the mirror pair too)"))
    return common.table(["θi A (deg)", "θr A", "Δφ A", "θi B", "θr B", "Δφ B", "in plane"],
                        rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=DATA, help="the PTFE file (NIST's layout)")
    args = ap.parse_args(argv)
    from mitsuba_pbrdf.measured import read_measurements

    data = read_measurements(args.data)
    M = mr.mueller(data)
    N = mr.normalized(M)
    pairs, mirror = mr.reciprocal_pairs(data), mr.mirror_pairs(data)
    counts = mr.pair_counts_by_tolerance(data, TOLERANCES)
    wavelengths = [float(w) for w in data.wavelengths] + [None]
    name = lambda w: "all" if w is None else f"{w:g}"  # noqa: E731

    # 2. reciprocity against the noise, per wavelength
    noise_rows, recip_rows = [], []
    for w in wavelengths:
        p, m = by_wavelength(data, pairs, w), by_wavelength(data, mirror, w)
        r = mr.pair_errors(M[p[:, 0]], M[p[:, 1]], mr.reciprocal)
        n = mr.pair_errors(M[m[:, 0]], M[m[:, 1]], mr.mirrored)
        sub = data if w is None else _select(data, w)
        rms, peak, in_plane = mr.off_block_noise(sub)
        recip_rows.append([name(w), len(p)] + [v for x in r for v in (np.median(x), x.max())])
        noise_rows.append([name(w), len(m)] + [v for x in n for v in (np.median(x), pct(x, 95))]
                          + [rms, in_plane])

    # 3. readings: on the data (noise-scaled) and on the models
    variance = {w: mr.mirror_variance(data, by_wavelength(data, mirror, w)) for w in wavelengths}
    reading_rows = []
    for key in [None] + list(mr.MISREADINGS):
        Mx = M if key is None else mr.MISREADINGS[key][1](M, data)
        r = mr.pair_errors(Mx[pairs[:, 0]], Mx[pairs[:, 1]], mr.reciprocal)
        Nx = mr.normalized(Mx)
        chi = [mr.chi2_per_term(Nx, by_wavelength(data, pairs, w), variance[w])
               for w in wavelengths]
        models = [mr.model_errors(data, pairs, key, **p)[1].max() for p in MODELS.values()]
        label = "the project's (nist_layout)" if key is None else key
        how = "f_rIJ -> m(I-1)(J-1), D M D, s/p" if key is None else mr.MISREADINGS[key][0]
        reading_rows.append([label, how, np.median(r[1]), r[1].max()] + chi + models)

    # 4. which relation M_B = T M_A^T T the data prefer
    sign_rows = []
    for T in mr.SIGN_RELATIONS:
        t = "diag(" + ", ".join(f"{v:+.0f}" for v in np.diag(T)) + ")"
        note = (" = Q (reciprocity)" if np.array_equal(T, mr.Q) else
                " = D: Q with one side's S2, S3 flipped" if np.array_equal(
                    T, np.diag([1.0, 1, 1, -1])) else "")
        sign_rows.append([t + note] + [mr.chi2_per_term(N, by_wavelength(data, pairs, w),
                                                        variance[w], T) for w in wavelengths])

    # 5. rows with theta_i = theta_r out of the plane: reciprocity with mirror
    # symmetry makes each such matrix obey M = D M^T D (m_ij = d_i d_j m_ji)
    d = mr.dphi(data)
    same = np.flatnonzero((np.abs(data.theta_i - data.theta_r) < mr.TOL)
                          & (np.abs(np.sin(np.radians(d))) > 1e-3))
    noise_diff = float(np.sqrt(2 * np.mean(variance[None])))
    single_rows = []
    for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        sign = "+" if i != 3 and j != 3 else "−"
        minus = np.sqrt(np.mean((N[same, i, j] - N[same, j, i]) ** 2))
        plus = np.sqrt(np.mean((N[same, i, j] + N[same, j, i]) ** 2))
        single_rows.append([f"m{i}{j}, m{j}{i}", f"m{i}{j} = {sign}m{j}{i}", minus, plus,
                            noise_diff])

    # 6. the in-plane diagonal, which a one-sided flip of S2, S3 would change
    diag_rows = []
    in_plane = np.abs(np.sin(np.radians(d))) < 1e-3
    for w in wavelengths:
        rows = in_plane if w is None else in_plane & (data.wavelength == w)
        diag_rows.append([name(w), int(rows.sum()), np.mean(N[rows, 1, 1] > 0),
                          np.mean(N[rows, 2, 2] < 0)]
                         + [np.median(N[rows, i, i]) for i in (1, 2, 3)])

    geometry = geometry_table(data, pairs)
    text = _report(args, data, pairs, mirror, counts, geometry, recip_rows, noise_rows,
                   reading_rows, sign_rows, single_rows, same, wavelengths, diag_rows)
    common.write_markdown("ptfe_reciprocity", text)
    return 0


def _select(data, w):
    from mitsuba_pbrdf.measured.selection import select_wavelengths

    return select_wavelengths(data, [w])


def _report(args, data, pairs, mirror, counts, geometry, recip_rows, noise_rows, reading_rows,
            sign_rows, single_rows, same, wavelengths, diag_rows):
    per_w = len(by_wavelength(data, pairs, data.wavelength[0]))
    wl = [("all λ" if w is None else f"{w:g} nm") for w in wavelengths]
    recip_head = ["λ (nm)", "pairs"] + [f"{lab} {s}" for lab in LABELS for s in ("median", "max")]
    noise_head = (["λ (nm)", "mirror pairs"]
                  + [f"{lab} {s}" for lab in LABELS for s in ("median", "95 %")]
                  + ["off-block RMS in plane", "in-plane rows"])
    model_names = list(MODELS)
    reading_head = (["reading", "how it differs", "whole matrix median", "whole matrix max"]
                    + [f"χ² per term, {x}" for x in wl]
                    + [f"model max: {m}" for m in model_names])
    parts = [
        "# Is NIST's PTFE Mueller-BRDF measurement reciprocal, read the project's way?",
        "Generated by `python validation/ptfe_reciprocity.py` (NumPy, a few seconds). Data: "
        "T. A. Germer's full Mueller-matrix BRDF of sintered PTFE (Applied Optics 2017; "
        "`validation/data/nist_ptfe/`), read by `measured.read_measurements` into the "
        "project's global s/p frames (`docs/fitting.md`), 1,824 geometries at each of 351, 532, "
        "633, 1064 nm. Checks: `proof/measured_reciprocity.py`; bounds asserted in "
        "`tests/measured/test_ptfe_reciprocity.py`.",
        "## 1. The reciprocal pairs in the file",
        "Reciprocity pairs row A (θi = a, θr = b, Δφ) with row B (θi = b, θr = a, −Δφ) of one "
        "wavelength, Δφ = φr − φi the viewer's azimuth from the source's (an isotropic sample: "
        "a rotation about the normal carries every ray's s/p basis along, so only Δφ counts). "
        "The file's detector grid has sin θr cos φr and sin θr sin φr on multiples of 0.1, so "
        "an incidence angle θi can be a viewing angle only where sin θi is 0.1 √(i² + j²): "
        "0°, 30° (0.5) and 45° (0.707) are; 15°, 60° and 75° are not. "
        f"The file holds **{per_w} pairs per wavelength** ({len(pairs)} in all; one row, "
        "θi = θr = 30° in the plane, is its own reverse), all with θi, θr in {0, 30°, 45°}; "
        "none reaches between 30° and 45° (their grids' azimuths never meet: the nearest are "
        "8° apart). NIST writes normal incidence and viewing as 0.001°, which the reader keeps "
        "(s/p bases along the stated azimuth). Matched within 0.01° in θi, θr and Δφ; the "
        "count against the tolerance (deg):",
        common.table(["tolerance"] + [f"{t:g}" for t in TOLERANCES],
                     [["pairs"] + counts]),
        "Any tolerance from 1e-4° to 0.5° finds the same pairs (the file prints 6 significant "
        "digits; distinct grid angles are ≥ 0.5° apart); from 1° on, neighbouring grid points "
        "are taken for partners. The pairs at each wavelength:",
        geometry,
        "## 2. Reciprocity against the data's noise",
        "Per pair, with M00 the pair's mean: |M00_B − M00_A| / M00; the whole matrix, "
        "max_ij |M_B − Q M_A^T Q| / M00; and the normalized elements, max over the 15 "
        "polarization elements of |M_B / M00_B − Q M_A^T Q / M00_A| (the file's own unit, "
        "free of f_r11's error).",
        common.table(recip_head, recip_rows),
        "**The noise in the same figures.** An isotropic sample without handedness is "
        "mirror-symmetric about the plane of incidence: M(a, b, −Δφ) = E M(a, b, Δφ) E, "
        "E = diag(1, 1, −1, −1) (s → −s on both rays). Every row off the plane has its mirror "
        f"row in the file ({len(mirror)} pairs in all); the same figures over them, and the "
        "RMS of the 8 elements that the symmetry makes 0 in the plane of incidence (m02, m03, "
        "m12, m13, m20, m21, m30, m31, over M00):",
        common.table(noise_head, noise_rows),
        "## 3. Does the check tell readings of the file apart?",
        "The same check with the file read six wrong ways (`MISREADINGS` in "
        "`proof/measured_reciprocity.py`). On the data: the whole-matrix figure over the "
        f"{len(pairs)} pairs, and a noise-scaled one: the mean over the pairs and the 15 "
        "normalized polarization elements of (N_B − Q N_A^T Q)² / (2 σ²), σ² each element's "
        "variance from the mirror pairs of that wavelength (about 1 if the residual is that "
        "noise; its own statistical spread is about ±10 % per wavelength, 195 terms, and ±5 % "
        "over all, 780). On the float64 reference model evaluated at the pairs' geometries "
        "and read the same wrong ways: the largest whole-matrix figure.",
        common.table(reading_head, reading_rows),
        "Which relation M_B = T M_A^T T the data fit best, over the eight sign patterns "
        "T = diag(1, ±1, ±1, ±1) (the χ² per term as above): a reading off by one side's sign "
        "pattern L turns the project's test into T = L Q.",
        common.table(["T"] + [f"χ² per term, {x}" for x in wl], sign_rows),
        f"The {len(same)} rows with θi = θr off the plane of incidence (all wavelengths): "
        "reciprocity and mirror symmetry together make each obey M = D M^T D, "
        "D = diag(1, 1, 1, −1), in the project's frames. RMS over them of the normalized "
        "m_ij − m_ji and m_ij + m_ji, and of the difference of two measured elements "
        "(√2 σ, σ pooled from the mirror pairs):",
        common.table(["elements", "reciprocity + mirror demand", "RMS m_ij − m_ji",
                      "RMS m_ij + m_ji", "noise of a difference"], single_rows),
        "The diagonal of the rows in the plane of incidence (normalized by M00), which a "
        "reading with one side's S2 and S3 flipped would change in m22 and m33:",
        common.table(["λ (nm)", "in-plane rows", "share m11 > 0", "share m22 < 0",
                      "median m11", "median m22", "median m33"], diag_rows),
        "## Reading",
        _reading(recip_rows, noise_rows, reading_rows, sign_rows, diag_rows),
    ]
    return "\n\n".join(parts)


def _reading(recip_rows, noise_rows, reading_rows, sign_rows, diag_rows):
    r, n = recip_rows[-1], noise_rows[-1]
    ours = reading_rows[0]
    by = {row[0]: row for row in reading_rows}
    d_row = sign_rows[1]
    f = common.fmt
    return "\n".join([
        f"* **M00 is reciprocal within the noise.** Over the {r[1]} pairs, |ΔM00| / M00 has "
        f"median {f(r[2])} and max {f(r[3])}; the mirror pairs, which must agree as exactly, "
        f"differ by median {f(n[2])}, 95th percentile {f(n[3])}.",
        f"* **So is the whole matrix, in the figure the brief asks for.** max_ij |M_B − Q M_A^T "
        f"Q| / M00 has median {f(r[4])} and max {f(r[5])}, against {f(n[4])} and {f(n[5])} "
        f"(median, 95th percentile) for the mirror pairs. PTFE is nearly a depolarizer: its "
        f"polarization elements are a few per cent of M00 and the noise of one normalized "
        f"element is about 0.01 (the off-block RMS {f(n[8])}), so the largest of 15 differences "
        "of two noisy rows is 0.02-0.04 by noise alone.",
        "* **The check cannot see a sign convention applied to every row on both sides.** "
        "Conjugating every matrix by a diagonal of ±1 (the circular sign: D M D; s and p "
        "swapped: diag(1, −1, −1, 1)) or transposing every matrix commutes with "
        "M -> Q M^T Q, so reciprocity holds or fails exactly as before: the rows "
        "'circular sign flipped', 's and p swapped' and 'transposed' equal the project's "
        "reading on the data and on the models (to rounding). Reciprocity does not validate "
        "the circular sign or the s/p labels; `tests/bsdfs/test_scatmech.py` (against SCATMECH's own "
        "code) does.",
        "* **It sees readings that treat the two sides differently or depend on the geometry, "
        f"where the sample polarizes.** On the conductor model the project's reading gives "
        f"{f(ours[-2])} (rounding), and 'circular sign on one side', 'incident s from the "
        f"source', 'sample-fixed bases' give {f(by['circular sign on one side'][-2])}, "
        f"{f(by['incident s from the source'][-2])}, {f(by['sample-fixed bases'][-2])}. On the "
        "PTFE fit, whose polarization is PTFE's, the same misreadings move the figure by "
        f"{f(by['circular sign on one side'][-1])}, {f(by['incident s from the source'][-1])}, "
        f"{f(by['sample-fixed bases'][-1])}: below the data's noise ({f(n[4])} median). **On "
        "this file the whole-matrix figure does not tell the readings apart** (section 3's "
        "whole-matrix columns).",
        f"* **The noise-scaled figure does, and it does not favour the project's reading.** "
        f"The χ² per term of the project's reading is {f(ours[8])} over all wavelengths, near "
        f"the 1 that the mirror pairs' noise predicts, but {', '.join(f(x) for x in ours[4:8])} "
        f"at {', '.join(x[0] for x in recip_rows[:-1])} nm: at 532 and 633 nm well above the "
        "±10 % spread of noise alone. Reading the incident basis on the direction to the source "
        "(S2 and S3 of one side flipped) gives "
        f"{f(by['incident s from the source'][8])}, and the scan over T puts diag(1, 1, 1, −1) "
        f"first at every wavelength ({', '.join(f(x) for x in d_row[1:-1])}). The residual "
        "sits in m02/m20 and m13/m31 of the rows with θi = θr out of the plane: the data have "
        "m02 ≈ −m20 and m13 ≈ +m31 (section 3's last table but one), where reciprocity and "
        "mirror symmetry demand the opposite signs in the project's frames. Each of those RMS "
        "is 1.3-1.5 times the noise of a difference; the scan's preference holds at every "
        "wavelength.",
        f"* **The diagonal argues the other way.** Flipping S2 and S3 on one side also flips "
        f"m22 and m33. In the project's reading every in-plane row has m11 > 0 (share "
        f"{f(diag_rows[-1][2])}) and most have m22 < 0 (share {f(diag_rows[-1][3])}; median "
        f"m11, m22 {f(diag_rows[-1][4])}, {f(diag_rows[-1][5])}; m33 is near 0, median "
        f"{f(diag_rows[-1][6])}): a mirror's pattern in s/p bases (a mirror is "
        "diag(1, 1, −1, −1) there), which the fitted Fresnel lobe reproduces "
        "(`validation/fit_ptfe.md`). The flipped reading would make m22 > 0 where m11 > 0 in "
        "the plane of incidence, which no reflecting facet gives. So the off-plane residual is "
        "either a sign the project reads wrongly on one side only out of the plane (a "
        "convention of NIST's out-of-plane bases this study cannot settle), or a systematic "
        "error of the measurement in m02/m20 and m13/m31 (about 0.02 of M00). **Open**: "
        "Germer (2017) states the convention of the data's bases; checking it there, or "
        "against a second NIST file with strong out-of-plane polarization, would decide.",
    ])


if __name__ == "__main__":
    sys.exit(main())
