#!/usr/bin/env bash
# The figures to take the first time a GPU is at hand (docs/performance.md#on-a-gpu).
# Run from the repository root on a machine with an NVIDIA GPU, after ./install.sh --test:
#     bash benchmarks/device_check.sh            # about 3-5 minutes on one GPU
# Prints each figure after the command that produced it:
#   1. the fast tests in the cuda_ad_* variants (PBRDF_TEST_BACKEND=cuda maps the suite's
#      llvm_* variants to their cuda_* twins; tests/conftest.py);
#   2. the render-time ratio pbrdf / roughconductor (sphere in an environment, 512x512,
#      64 spp, wall time of interleaved renders in one process, median of 7 pairs);
#   3. the stokes_prb cost rows at 512x512, 64 spp, depth 4, 7 parameters, then with the
#      pbrdf in a polarized_normalmap whose 64x64x3 texels are differentiated too
#      (validation/inverse_memory.py: time and memory against a primal render).
set -uo pipefail
cd "$(dirname "$0")/.."
PY="${PY:-.venv/bin/python}"
VARIANT="${VARIANT:-cuda_ad_spectral_polarized}"
status=0

run() {   # print the command, run it, remember a failure but go on
    echo "\$ $*"
    "$@" || { echo "(exit status $?)"; status=1; }
    echo
}

echo "== 1. fast tests in the cuda_ad_* variants"
run env PBRDF_TEST_BACKEND=cuda "$PY" -m pytest -q -m "not slow" -p no:cacheprovider \
    tests/test_schema.py tests/test_bsdf_vs_reference.py tests/test_roughconductor.py \
    tests/test_sampling.py tests/test_mixture_sampling.py tests/test_stokes_prb.py \
    tests/test_rotators.py

echo "== 2. render time, pbrdf / roughconductor ($VARIANT)"
run "$PY" - "$VARIANT" <<'PYTHON'
import math, statistics, sys
sys.path.insert(0, "benchmarks")
import benchmark, render_one
mi = benchmark.set_variant(sys.argv[1])
scenes = {name: mi.load_dict(benchmark.scene_dict(mi, "sphere_environment", render_one.BSDFS[name], 512))
          for name in ("pbrdf", "roughconductor")}
for scene in scenes.values():
    benchmark.timed_render(mi, scene, 64)                  # compile
ratios = []
for rep in range(7):
    t = {name: benchmark.timed_render(mi, scene, 64, seed=rep)[0] for name, scene in scenes.items()}
    ratios.append(t["pbrdf"] / t["roughconductor"])
    print(f"pair {rep}: pbrdf {t['pbrdf'] * 1e3:.1f} ms, roughconductor {t['roughconductor'] * 1e3:.1f} ms")
print(f"pbrdf / roughconductor, median of 7 interleaved pairs: {statistics.median(ratios):.3f} "
      f"(min {min(ratios):.3f}, max {max(ratios):.3f})")
PYTHON

echo "== 3. stokes_prb gradient cost at 512x512, 64 spp ($VARIANT)"
run "$PY" validation/inverse_memory.py --methods primal,prb --sizes 512 --spps 64 \
    --variant "$VARIANT" --out /tmp/device_inverse_memory.md
cat /tmp/device_inverse_memory.md 2>/dev/null | grep -E "^\|" || true
run "$PY" validation/inverse_memory.py --methods primal,prb --sizes 512 --spps 64 --normalmap \
    --variant "$VARIANT" --out /tmp/device_inverse_memory_normalmap.md
cat /tmp/device_inverse_memory_normalmap.md 2>/dev/null | grep -E "^\|" || true

exit $status
