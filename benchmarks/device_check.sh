#!/usr/bin/env bash
# The figures to take the first time a GPU is at hand (docs/performance.md#on-a-gpu).
# Run from the repository root after ./install.sh --test (or the offline install of
# benchmarks/gradient_profile.md, "On a machine without a package index"):
#     bash benchmarks/device_check.sh                 # NVIDIA GPU: about 3 minutes
#     bash benchmarks/device_check.sh --backend llvm  # the same on the CPU (a check of the
#         script; with SIZES="64 128" SPP=4 it takes a few minutes on 2 cores)
# Prints each figure after the command that produced it:
#   1. the fast tests in the BACKEND_ad_* variants (PBRDF_TEST_BACKEND=cuda maps the suite's
#      llvm_* variants to their cuda_* twins; tests/conftest.py);
#   2. render-time ratios, medians of 7 interleaved pairs in one process (sphere in an
#      environment, 512 wide, 64 spp): pbrdf / roughconductor, specular + ideal diffuse /
#      blendbsdf, three lobes / roughconductor;
#   3. the stokes_prb gradient / primal render at each of SIZES (default 512 1024), 64 spp,
#      depth 4, 7 parameters, then with the pbrdf in a polarized_normalmap whose 64x64x3 texels
#      are differentiated too, with the per-kernel table (benchmarks/gradient_profile.py);
#   4. the reference: Mitsuba's own prb, unpolarized (BACKEND_ad_rgb), on the same scene, with
#      roughconductor and with pbrdf on the sphere;
#   5. the first gradient in a fresh process with an empty kernel cache, then warm from the
#      disk cache, then at the second size (gradient_profile.py --cold).
# Variables: PY (python, default .venv/bin/python), SIZES, SPP (default 64), REPS (default 3),
# SKIP_TESTS=1 to leave out part 1.
set -uo pipefail
cd "$(dirname "$0")/.."
BACKEND=cuda
while [ $# -gt 0 ]; do
    case "$1" in
        --backend) BACKEND="${2:-}"; shift 2 ;;
        --backend=*) BACKEND="${1#--backend=}"; shift ;;
        *) echo "device_check.sh: unknown argument '$1' (expected --backend cuda|llvm)" >&2; exit 2 ;;
    esac
done
case "$BACKEND" in
    cuda|llvm) ;;
    *) echo "device_check.sh: --backend must be cuda or llvm, got '$BACKEND'" >&2; exit 2 ;;
esac
PY="${PY:-.venv/bin/python}"
SIZES="${SIZES:-512 1024}"
SPP="${SPP:-64}"
REPS="${REPS:-3}"
VARIANT="${BACKEND}_ad_spectral_polarized"
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
status=0

run() {   # print the command, run it, remember a failure but go on
    echo "\$ $*"
    "$@" || { echo "(exit status $?)"; status=1; }
    echo
}

if [ "${SKIP_TESTS:-0}" != 1 ]; then
    echo "== 1. fast tests in the ${BACKEND}_ad_* variants"
    # -n 4, not pyproject's -n auto: every xdist worker compiles its own kernels and, with
    # cuda, holds its own context on the one GPU; auto would start one per core (16 there)
    run env PBRDF_TEST_BACKEND="$BACKEND" "$PY" -m pytest -q -n 4 -m "not slow" \
        -p no:cacheprovider tests/test_schema.py tests/bsdfs/test_pbrdf_vs_reference.py tests/bsdfs/test_pbrdf_roughconductor.py \
        tests/bsdfs/test_sampling.py tests/bsdfs/test_mixture_sampling.py tests/integrators/test_stokes_prb.py \
        tests/test_mueller.py
fi

first_size="${SIZES%% *}"
echo "== 2. render time ratios ($VARIANT, ${first_size} wide, $SPP spp)"
run "$PY" - "$VARIANT" "$first_size" "$SPP" <<'PYTHON'
import statistics, sys
sys.path.insert(0, "benchmarks")
import benchmark, render_one
variant, res, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
mi = benchmark.set_variant(variant)
pairs = [("pbrdf / roughconductor", render_one.BSDFS["pbrdf"], render_one.BSDFS["roughconductor"]),
         ("specular + ideal diffuse / blendbsdf", benchmark.pbrdf_spec_kid(), benchmark.builtin_spec_kid()),
         ("three lobes / roughconductor", render_one.BSDFS["pbrdf3"], render_one.BSDFS["roughconductor"])]
for label, a, b in pairs:
    scenes = [mi.load_dict(benchmark.scene_dict(mi, "sphere_environment", bsdf, res)) for bsdf in (a, b)]
    for scene in scenes:
        benchmark.timed_render(mi, scene, spp)                  # compile
    ratios = []
    for rep in range(7):
        ta, tb = (benchmark.timed_render(mi, scene, spp, seed=rep)[0] for scene in scenes)
        ratios.append(ta / tb)
    print(f"{label}: median of 7 interleaved pairs {statistics.median(ratios):.3f} "
          f"(min {min(ratios):.3f}, max {max(ratios):.3f})")
PYTHON

echo "== 3. stokes_prb gradient / primal render ($VARIANT, $SPP spp, depth 4)"
for size in $SIZES; do
    run "$PY" benchmarks/gradient_profile.py --backend "$BACKEND" --size "$size" --spp "$SPP" \
        --reps "$REPS"
    run "$PY" benchmarks/gradient_profile.py --backend "$BACKEND" --size "$size" --spp "$SPP" \
        --reps "$REPS" --normalmap
done

echo "== 4. Mitsuba's prb, unpolarized (${BACKEND}_ad_rgb), the same scene"
for bsdf in roughconductor pbrdf; do
    run "$PY" benchmarks/gradient_profile.py --backend "$BACKEND" --size "$first_size" \
        --spp "$SPP" --reps "$REPS" --mitsuba-prb "$bsdf"
done

echo "== 5. first gradient: empty kernel cache, warm from disk, another size"
second_size="${SIZES##* }"
run "$PY" benchmarks/gradient_profile.py --backend "$BACKEND" --cold --spp "$SPP" \
    --sizes "$first_size,$first_size,$second_size"

exit $status
