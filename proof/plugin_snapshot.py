"""Record the ``pbrdf`` plugin's outputs on a fixed set of inputs, and compare
two recordings: the check that a refactoring of the plugin changed no number.

    python proof/plugin_snapshot.py record before.npz      # on the old code
    python proof/plugin_snapshot.py record after.npz       # on the new code
    python proof/plugin_snapshot.py compare before.npz after.npz

Inputs (fixed seeds): random direction pairs (half near the mirror
direction), grazing pairs (cos theta from 1e-2 down to 1e-6), normal
incidence, retro-reflection, exact mirror pairs and pairs below the horizon;
both transport modes; every non-empty combination of the three lobes; both
shadowing functions; both directional diffuse distributions; both sampling
strategies; every single-component context. Outputs: ``eval``, ``pdf``,
``eval_pdf`` and ``sample`` (direction, pdf, weight, component, type) in
``llvm_ad_spectral_polarized`` and, for the unpolarized path, ``llvm_ad_rgb``.
Only the plugin's public Mitsuba interface is used, so a recording made
before a refactoring stays valid after it.

``compare`` reports, per output, how many values differ and the largest
difference in float32 units in the last place (ULP); exit status 1 if any
differ.
"""

import argparse
import itertools
import sys

import numpy as np

VARIANTS = ("llvm_ad_spectral_polarized", "llvm_ad_rgb")
WAVELENGTHS = (450.0, 520.0, 600.0, 690.0)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def directions(seed=7):
    """(wi, wo, sample1, sample2) float32 arrays for every input group."""
    rng = np.random.default_rng(seed)
    n = 256
    wi = _unit(rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1] * np.abs(rng.normal(size=(n, 1))))
    wo = _unit(rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1] * np.abs(rng.normal(size=(n, 1))))
    h = _unit(rng.normal(size=(n // 2, 3)) * [0.1, 0.1, 0] + [0, 0, 1])
    wo[: n // 2] = 2 * np.sum(wi[: n // 2] * h, 1, keepdims=True) * h - wi[: n // 2]
    groups = {"random": (wi, wo)}

    cos = np.geomspace(1e-2, 1e-6, 32)
    phi = rng.uniform(0, 2 * np.pi, (2, 32))
    sin = np.sqrt(1 - cos**2)
    g_wi = np.stack([sin * np.cos(phi[0]), sin * np.sin(phi[0]), cos], -1)
    g_wo = np.stack([sin * np.cos(phi[1]), sin * np.sin(phi[1]), cos[::-1]], -1)
    groups["grazing"] = (g_wi, g_wo)

    normal = np.tile([0.0, 0.0, 1.0], (32, 1))
    groups["normal"] = (normal, _unit(rng.normal(size=(32, 3)) * [1, 1, 0] + [0, 0, 1]))
    groups["retro"] = (wi[:32], wi[:32].copy())
    groups["mirror"] = (wi[:32], wi[:32] * [-1, -1, 1])
    below = wi[:32] * [1, 1, -1]
    groups["below"] = (np.concatenate([below[:16], wi[16:32]]),
                       np.concatenate([wo[:16], below[16:]]))
    out = {}
    for name, (a, b) in groups.items():
        m = len(a)
        out[name] = (a.astype(np.float32), _unit(b).astype(np.float32),
                     rng.uniform(size=m).astype(np.float32),
                     rng.uniform(size=(m, 2)).astype(np.float32))
    return out


def configurations():
    """Plugin dicts: lobe combinations x shadowing x dd distribution x sampling."""
    lobes = {"ks": 0.8, "kdd": 0.3, "kid": 0.1}
    for r in (1, 2, 3):
        for combo in itertools.combinations(lobes, r):
            for shadowing, dd, sampling in itertools.product(("vgroove", "smith"),
                                                             ("beckmann", "ggx"),
                                                             ("mixture", "cosine")):
                if dd == "ggx" and "kdd" not in combo:
                    continue
                cfg = {"type": "pbrdf", "eta": 1.3, "k": 6.5, "sigma": 0.15, "sigma_dd": 0.45,
                       "shadowing": shadowing, "dd_distribution": dd, "sampling": sampling}
                cfg.update({w: (lobes[w] if w in combo else 0.0) for w in lobes})
                name = "+".join(combo) + f"/{shadowing}/{dd}/{sampling}"
                yield name, cfg
    yield "material Cu/narrow", {"type": "pbrdf", "material": "Cu", "sigma": 0.02, "kdd": 0.2,
                                 "sigma_dd": 0.3, "kid": 0.05}


def record(path):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(VARIANTS[0])
    import mitsuba_pbrdf

    result = {}
    inputs = directions()
    for variant in VARIANTS:
        mi.set_variant(variant)
        mitsuba_pbrdf.register()
        for name, cfg in configurations():
            bsdf = mi.load_dict(cfg)
            n_comp = bsdf.component_count()
            for group, (wi, wo, s1, s2) in inputs.items():
                si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
                si.wi = mi.Vector3f(*wi.T)
                si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
                si.n = mi.Normal3f(0, 0, 1)
                if mi.is_spectral:
                    si.wavelengths = mi.UnpolarizedSpectrum(*WAVELENGTHS)
                vo = mi.Vector3f(*wo.T)
                for mode in ("radiance", "importance"):
                    tm = mi.TransportMode.Radiance if mode == "radiance" else mi.TransportMode.Importance
                    for comp in [-1] + list(range(n_comp)):
                        ctx = mi.BSDFContext(tm)
                        if comp >= 0:
                            ctx.component = comp
                        key = f"{variant}|{name}|{group}|{mode}|c{comp}"
                        value = bsdf.eval(ctx, si, vo)
                        pdf = bsdf.pdf(ctx, si, vo)
                        v2, p2 = bsdf.eval_pdf(ctx, si, vo)
                        bs, weight = bsdf.sample(ctx, si, mi.Float(s1), mi.Point2f(*s2.T))
                        result[key + "|eval"] = np.array(value, dtype=np.float32)
                        result[key + "|pdf"] = np.array(pdf, dtype=np.float32)
                        result[key + "|eval_pdf.value"] = np.array(v2, dtype=np.float32)
                        result[key + "|eval_pdf.pdf"] = np.array(p2, dtype=np.float32)
                        result[key + "|sample.wo"] = np.array(bs.wo, dtype=np.float32)
                        result[key + "|sample.pdf"] = np.array(bs.pdf, dtype=np.float32)
                        result[key + "|sample.weight"] = np.array(weight, dtype=np.float32)
                        result[key + "|sample.component"] = np.array(bs.sampled_component,
                                                                     dtype=np.uint32)
                        result[key + "|sample.type"] = np.array(bs.sampled_type, dtype=np.uint32)
    np.savez_compressed(path, **result)
    print(f"recorded {len(result)} arrays to {path}")


def _ulp_distance(a, b):
    """Distance in float32 ULPs (ordered integer representation)."""
    ia = a.astype(np.float32).view(np.int32).astype(np.int64)
    ib = b.astype(np.float32).view(np.int32).astype(np.int64)
    ia = np.where(ia < 0, np.int64(-2**31) - ia, ia)
    ib = np.where(ib < 0, np.int64(-2**31) - ib, ib)
    return np.abs(ia - ib)


def compare(before, after):
    a, b = np.load(before), np.load(after)
    missing = sorted(set(a.files) ^ set(b.files))
    if missing:
        print(f"{len(missing)} arrays are in one recording only, e.g. {missing[:3]}")
    by_output = {}
    for key in sorted(set(a.files) & set(b.files)):
        x, y = a[key], b[key]
        output = key.rsplit("|", 1)[1]
        stats = by_output.setdefault(output, [0, 0, 0, ""])
        stats[0] += x.size
        if x.shape != y.shape:
            stats[1] += x.size
            stats[3] = key + " (shape)"
            continue
        if x.dtype.kind == "f":
            same = (x == y) | (np.isnan(x) & np.isnan(y)) | ((x == 0) & (y == 0))
            if not same.all():
                ulps = _ulp_distance(x[~same], y[~same])
                stats[1] += int((~same).sum())
                if ulps.max() > stats[2]:
                    stats[2], stats[3] = int(ulps.max()), key
        else:
            diff = int((x != y).sum())
            stats[1] += diff
            if diff:
                stats[3] = key
    print(f"{'output':<18} {'values':>10} {'differ':>8} {'max ULP':>8}  worst")
    for output, (total, differ, ulp, worst) in by_output.items():
        print(f"{output:<18} {total:>10} {differ:>8} {ulp:>8}  {worst}")
    return 1 if missing or any(s[1] for s in by_output.values()) else 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("record")
    r.add_argument("path")
    c = sub.add_parser("compare")
    c.add_argument("before")
    c.add_argument("after")
    args = p.parse_args(argv)
    if args.command == "record":
        record(args.path)
        return 0
    return compare(args.before, args.after)


if __name__ == "__main__":
    sys.exit(main())
