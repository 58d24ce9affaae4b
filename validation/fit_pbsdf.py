"""Study: fitting ``.pbsdf`` tables (the KAIST database's format).

    python validation/fit_pbsdf.py [--quick] [--no-full-size]
        (-> fit_pbsdf.md, figures/fit_pbsdf_cu.png)

1. **Exported tables with noise**: copper (Mitsuba's tabulated n, k at the 5
   KAIST bands) with all three lobes, exported by ``pbrdf export`` on a
   25 x 40 x 40 grid, then every entry perturbed by Gaussian noise of standard
   deviation ``2 % |M_ij| + 0.2 % M00`` (a polarimeter's errors scale with the
   intensity). Fitted with ``pbrdf fit`` (3000 cells, n and k per band):
   recovered versus true parameters, residuals per Mueller element.
2. **SCATMECH-computed data**: NIST SCATMECH's ``Shadowed_Facet_BRDF_Model``
   (Gaussian slopes, Torrance-Sparrow shadowing; mapping in
   ``tests/bsdfs/test_scatmech.py``) at goniometer geometries (incidence 20, 45,
   70 deg, in plane and out of plane), 633 nm, all 16 elements with 1 %
   noise; fitted with the three-component model: does an independent code's
   data give back its parameters?
3. **A full-size KAIST table** (361 x 91 x 91 x 5 wavelengths, 0.96 GB):
   exported, then fitted by ``pbrdf fit`` in a separate process; peak resident
   memory (``getrusage``) and wall time of each.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from validation import common  # noqa: E402

CU = dict(material="Cu", sigma=0.12, ks=1.0, kdd=0.15, sigma_dd=0.45, kid=0.03)
SCATMECH = dict(n=1.2, k=7.26, sigma=0.1)


def noisy_table(folder, grid="25x40x40", seed=0):
    from mitsuba_pbrdf.measured import export, pbsdf
    from mitsuba_pbrdf.reference.params import PBRDFParams
    clean = os.path.join(folder, "cu_clean.pbsdf")
    export.export_pbsdf(clean, PBRDFParams(**CU), export.parse_grid(grid))
    t = pbsdf.read_pbsdf(clean, mmap=False)
    rng = np.random.default_rng(seed)
    M = np.asarray(t.M, dtype=np.float64)
    sd = 0.02 * np.abs(M) + 0.002 * np.abs(M[..., :1, :1])
    noisy = (M + rng.normal(size=M.shape) * sd).astype(np.float32)
    path = os.path.join(folder, "cu_noisy.pbsdf")
    pbsdf.write_pbsdf(path, noisy, t.phi_d, t.theta_d, t.theta_h, t.wavelengths)
    return path, t.wavelengths


def run(cmd):
    """Run a command; (stdout, seconds, peak resident memory of that process in
    MiB, the kernel's accounting of the child from ``os.wait4``)."""
    import tempfile
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(cmd, stdout=out, stderr=err, text=True, cwd=common.ROOT,
                             env=dict(os.environ, PYTHONPATH=common.ROOT))
        _, status, usage = os.wait4(p.pid, 0)
        seconds = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {stderr}")
    return stdout, seconds, usage.ru_maxrss / 1024


def scatmech_data(seed=1):
    """SCATMECH Mueller BRDFs at goniometer geometries as Measurements."""
    from pySCATMECH.brdf import BRDF_Model

    from mitsuba_pbrdf.measured.measurements import ELEMENTS, Measurements
    model = BRDF_Model("Shadowed_Facet_BRDF_Model", sdf="Gaussian_Slope_Distribution_Function")
    model.setParameters({"lambda": 0.633, "substrate": f"({SCATMECH['n']},{SCATMECH['k']})",
                         "sdf.s": repr(float(np.sqrt(2) * SCATMECH["sigma"])), "type": "0"})
    rows = []
    for ti in (20.0, 45.0, 70.0):
        # no theta_r = 0: there SCATMECH's psps frame is the limit along phis while
        # the CSV convention takes the surface x-axis (tests/bsdfs/test_scatmech.py)
        for tr in np.arange(-78.0, 78.1, 4.0):
            rows.append((ti, abs(tr), 0.0 if tr >= 0 else 180.0))
        for tr in (20.0, 40.0, 60.0):
            for ps in (30.0, 60.0, 90.0, 150.0):
                rows.append((ti, tr, ps))
    rows = np.array(rows)
    D = np.diag([1.0, 1.0, 1.0, -1.0])        # SCATMECH's S3 sign (tests/bsdfs/test_scatmech.py)
    M = np.array([D @ np.array(model.MuellerBRDF(*np.radians(r))) @ D for r in rows])
    rng = np.random.default_rng(seed)
    scale = M[:, :1, :1]
    noisy = M + rng.normal(size=M.shape) * (0.01 * np.abs(M) + 0.001 * scale)
    # SCATMECH's incidence azimuth is pi, its phis is 0 at the specular direction
    data = Measurements(rows[:, 0], np.full(len(rows), 180.0), rows[:, 1], rows[:, 2],
                        np.full(len(rows), 633.0),
                        {q: noisy[:, int(q[1]), int(q[2])] for q in ELEMENTS}, {}, "SCATMECH",
                        row_scale=np.abs(noisy[:, 0, 0]))
    return data


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller tables, no full-size table")
    ap.add_argument("--no-full-size", action="store_true")
    ap.add_argument("--folder", default=os.path.join(common.ROOT, "out", "fit_pbsdf"))
    args = ap.parse_args(argv)
    os.makedirs(args.folder, exist_ok=True)
    from mitsuba_pbrdf import fitting
    from mitsuba_pbrdf.reference import conductor_ior

    # 1. noisy exported table, through the command line
    path, wavelengths = noisy_table(args.folder, "13x20x20" if args.quick else "25x40x40")
    out_json = os.path.join(args.folder, "cu_fit.json")
    plot = common.figure_path("fit_pbsdf_cu")
    cells = "600" if args.quick else "3000"
    cmd = [sys.executable, "-m", "mitsuba_pbrdf", "fit", path, "--cells", cells, "--json",
           out_json, "--plot", plot]
    stdout, seconds, peak = run(cmd)
    results = json.load(open(out_json))
    n_true, k_true = conductor_ior("Cu", wavelengths)
    rows = []
    for m in ("three", "two"):
        r = results[m]
        for j, w in enumerate(wavelengths):
            rows.append([m, f"n ({w:g} nm)", n_true[j], r["values"]["n"][j],
                         _error(r["errors"]["n"][j])])
            rows.append([m, f"k ({w:g} nm)", k_true[j], r["values"]["k"][j],
                         _error(r["errors"]["k"][j])])
        for p in ("sigma", "ks", "kdd", "sigma_dd", "kid"):
            if m == "two" and p in ("kdd", "sigma_dd"):
                continue
            rows.append([m, p, CU[p], r["values"][p], _error(r["errors"][p])])
    rms_rows = [[m, results[m]["reduced_chi2"]] + [results[m]["rms"][q] for q in
                ("m00", "m01", "m11", "m22", "m23", "m33")] + [results[m]["relative_rms"]["m00"]]
                for m in ("three", "two")]

    # 2. SCATMECH data
    data = scatmech_data()
    sc = fitting.fit_model(data, "three", init={"n": 1.5, "k": 5.0, "sigma": 0.2}, starts=3)
    sc_rows = [[p, truth, np.ravel(sc.values[p])[0], _error(float(np.ravel(sc.errors[p])[0]))]
               for p, truth in (("n", SCATMECH["n"]), ("k", SCATMECH["k"]),
                                ("sigma", SCATMECH["sigma"]), ("ks", 1.0), ("kdd", 0.0),
                                ("sigma_dd", "-"), ("kid", 0.0))]

    # 3. full-size table
    full_rows = []
    if not (args.quick or args.no_full_size):
        big = os.path.join(args.folder, "kaist_size.pbsdf")
        if os.path.exists(big):
            os.unlink(big)
        _, t_export, rss_export = run([sys.executable, "-m", "mitsuba_pbrdf", "export",
                                       "--material", "Cu", "--sigma", "0.12", "--kdd", "0.15",
                                       "--sigma-dd", "0.45", "--kid", "0.03", "--grid", "kaist",
                                       "--out", big])
        size = os.path.getsize(big) / 2**30
        fit_cmd = [sys.executable, "-m", "mitsuba_pbrdf", "fit", big, "--json",
                   os.path.join(args.folder, "kaist_fit.json")]
        _, t_fit, rss_fit = run(fit_cmd)
        full = json.load(open(os.path.join(args.folder, "kaist_fit.json")))["three"]
        full_rows = [[f"pbrdf export --material Cu ... --grid kaist ({size * 2**30 / 1e9:.2f} GB)", t_export,
                      rss_export],
                     ["pbrdf fit kaist_size.pbsdf (3000 cells, both models, 3 starts each)", t_fit,
                      rss_fit]]
        full_fit = full
        os.unlink(big)

    text = ["# Fitting .pbsdf tables", "",
            f"Generated by `python validation/fit_pbsdf.py{' --quick' if args.quick else ''}` "
            "on the project's 2-core, 24 GiB machine.", "",
            "## 1. An exported table with noise", "",
            f"Copper (Mitsuba's n, k at the five bands), sigma = {CU['sigma']}, kdd = {CU['kdd']}, "
            f"sigma_dd = {CU['sigma_dd']}, kid = {CU['kid']}; every entry perturbed by "
            "N(0, (2 % |M_ij| + 0.2 % M00)^2). `" + " ".join(
                ["pbrdf", "fit", os.path.relpath(path, common.ROOT), "--cells", cells])
            + f"`: {seconds:.0f} s, peak RSS {peak:.0f} MiB.", "",
            common.table(["model", "parameter", "true", "fitted", "+/-"], rows, digits=4), "",
            common.table(["model", "reduced chi2", "RMS m00", "RMS m01", "RMS m11", "RMS m22",
                          "RMS m23", "RMS m33", "M00 relative RMS"], rms_rows), "",
            "Uncertainties are from the assumed uncertainty model (5 % + 0.5 % of the entry's "
            "M00), scaled by the reduced chi-square where it exceeds 1.", "",
            f"![measured vs fitted slices]({os.path.relpath(plot, common.HERE)})", "",
            "## 2. Data computed by NIST SCATMECH", "",
            f"`Shadowed_Facet_BRDF_Model`, Gaussian slopes s = sqrt(2) sigma, Torrance-Sparrow "
            f"shadowing, n + ik = {SCATMECH['n']} + {SCATMECH['k']}i, 633 nm; {len(data)} "
            "geometries x 16 elements, 1 % + 0.1 % M00 noise; three-component fit from "
            "n = 1.5, k = 5, sigma = 0.2.", "",
            common.table(["parameter", "true", "fitted", "+/-"], sc_rows, digits=4), "",
            f"Reduced chi-square {sc.reduced_chi2:.3g}; undetermined: "
            f"{', '.join(sc.undetermined) or 'none'}.", ""]
    if full_rows:
        text += ["## 3. A full-size KAIST table", "",
                 "Peak resident memory of each process (`os.wait4`'s ru_maxrss) and wall time, one run:", "",
                 common.table(["command", "seconds", "peak RSS (MiB)"], full_rows), "",
                 f"The fit reads only the {3000} chosen cells from the memory-mapped file; "
                 f"recovered sigma = {full_fit['values']['sigma']:.4g} (true {CU['sigma']}), "
                 f"kdd = {full_fit['values']['kdd']:.4g} ({CU['kdd']}), "
                 f"kid = {full_fit['values']['kid']:.4g} ({CU['kid']}).", ""]
    common.write_markdown("fit_pbsdf", "\n".join(text))


def _error(e):
    """An uncertainty for the tables: ``undetermined`` for None (JSON) or inf."""
    return "undetermined" if e is None or (isinstance(e, float) and np.isinf(e)) else e


if __name__ == "__main__":
    main()
