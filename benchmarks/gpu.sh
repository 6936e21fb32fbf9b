#!/usr/bin/env bash
# The GPU figures of the README, in one run on a machine with an NVIDIA GPU and JAX's CUDA
# plugin (the package's own dependencies otherwise; no MuJoCo needed):
#   1. bipedlab bench --no-mujoco --batch 65536, float64 (bipedlab's default);
#   2. robustness five-link at 100,000 trials (uniform draws, 20 steps), timed.
# Run from the repository root: `bash benchmarks/gpu.sh` (installed package) or
# `PYTHONPATH=src bash benchmarks/gpu.sh` (a source tree). Prints what it measured; a copy of
# each JSON record goes to $OUT (default ./gpu-bench).
set -euo pipefail
OUT="${OUT:-gpu-bench}"
BATCH="${BATCH:-65536}"     # smaller values make a quick check of the script on a CPU
TRIALS="${TRIALS:-100000}"
CHUNK="${CHUNK:-16384}"
mkdir -p "$OUT"
export JAX_PLATFORMS="${JAX_PLATFORMS:-cuda}"
export BIPEDLAB_CACHE_DIR="${BIPEDLAB_CACHE_DIR:-$OUT/cache}"
py="${PYTHON:-python3}"
bl() { "$py" -m bipedlab.cli "$@"; }

echo "== device"
"$py" -c 'import bipedlab, jax; print(jax.devices(), "float64:", jax.config.jax_enable_x64)'
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true

echo "== bench --no-mujoco --batch $BATCH (float64)"
start=$(date +%s.%N)
bl bench --no-mujoco --batch "$BATCH" --json > "$OUT/bench.json"
end=$(date +%s.%N)
"$py" - "$OUT/bench.json" "$start" "$end" <<'PY'
import json, sys
rec = json.load(open(sys.argv[1]))
print(json.dumps(rec, indent=1)[:4000])
print(f"bench wall: {float(sys.argv[3]) - float(sys.argv[2]):.1f} s")
PY

echo "== robustness five-link --trials $TRIALS"
start=$(date +%s.%N)
bl robustness five-link --trials "$TRIALS" --chunk "$CHUNK" --json > "$OUT/robustness.json"
end=$(date +%s.%N)
"$py" - "$OUT/robustness.json" "$start" "$end" "$TRIALS" <<'PY'
import json, sys
rec = json.load(open(sys.argv[1]))
wall = float(sys.argv[3]) - float(sys.argv[2])
keep = {k: v for k, v in rec.items() if not isinstance(v, (list, dict))}
print(json.dumps(keep, indent=1))
print(f"robustness wall: {wall:.1f} s, {int(sys.argv[4]) / wall:.0f} trials/s including compilation")
PY
