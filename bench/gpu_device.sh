#!/usr/bin/env bash
# The GPU measurements of BENCHMARKS.md (*CNN training on a GPU: the cuDNN route*), run on a
# machine with an NVIDIA GPU, PyTorch and cuDNN 9 (e.g. its nvidia-cudnn wheel), from the
# repository root, with the test and bench binaries built elsewhere and copied into BIN:
#
#   cargo test --release --features "isar-clutter/mat73 isar-clutter/cuda" --test cuda --no-run
#   cargo bench --features "isar-clutter/mat73 isar-clutter/cuda" --bench cnn --no-run
#   cargo build --release --features "isar-clutter/mat73 isar-clutter/cuda"
#   mkdir -p .devbin && cp <the three executables> .devbin/cuda .devbin/cnn .devbin/isar-clutter
#   BIN=.devbin bench/gpu_device.sh
#
# Prints the GPU, driver, CUDA, PyTorch and cuDNN versions, runs tests/cuda.rs (the cuDNN route
# against the CPU), the CNN bench's GPU part, bench/cnn_torch.py on the GPU with and without
# TF32, and experiments/cnn_classification.yaml end to end with `device: cuda` and on the CPU,
# all in one run on the same machine.
set -u
BIN=${BIN:-.devbin}
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv
python3 -c 'import torch; print("torch", torch.__version__, "cuda", torch.version.cuda, "cudnn", torch.backends.cudnn.version())'
# The CUDA libraries of the Python wheels (cuDNN, NVRTC) and of the toolkit, for dlopen.
site=$(python3 -c 'import site; print(site.getsitepackages()[0])')
libs=$(ls -d "$site"/nvidia/*/lib "$site"/nvidia/cu*/lib 2>/dev/null | sort -u | tr '\n' ':')
export LD_LIBRARY_PATH="${libs}/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}"
for l in libcudnn.so.9 libnvrtc.so.13 libnvrtc.so.12; do
  printf '%s: ' "$l"; (ldconfig -p | grep -q "$l" && echo system) || (ls ${libs//:/ } 2>/dev/null | grep -m1 "^$l" || echo missing)
done
echo "== tests/cuda.rs"
ISAR_CLUTTER_CUDA_VERBOSE=1 timeout 240 "$BIN/cuda" --nocapture --test-threads=1 2>&1 | tail -60
echo "== CNN bench, GPU part"
CNN_BENCH_DEVICE=cuda CNN_BENCH_BATCHES=64 timeout 240 "$BIN/cnn" 2>&1
echo "== PyTorch"
timeout 120 python3 bench/cnn_torch.py --device cuda --batches 300 --warmup 20
timeout 120 python3 bench/cnn_torch.py --device cuda --batches 300 --warmup 20 --no-tf32
echo "== experiments/cnn_classification.yaml end to end, GPU then CPU ($(nproc) cores)"
sed 's/epochs: 30}/epochs: 30, device: cuda}/' experiments/cnn_classification.yaml > /tmp/cnn_classification_cuda.yaml
grep -c "device: cuda" /tmp/cnn_classification_cuda.yaml
for spec in /tmp/cnn_classification_cuda.yaml experiments/cnn_classification.yaml; do
  out=/tmp/run_$(basename "$spec" .yaml)
  /usr/bin/time -f "%e s wall, %M KB" timeout 300 "$BIN/isar-clutter" run "$spec" --out "$out" --no-report -q 2>&1 | tail -3
done
python3 - <<'PY'
import pyarrow.parquet as pq
a = pq.read_table("/tmp/run_cnn_classification_cuda/classification.parquet").to_pandas()
b = pq.read_table("/tmp/run_cnn_classification/classification.parquet").to_pandas()
cols = [c for c in a.columns if "accuracy" in c]
print("rows", len(a), len(b), "accuracy columns", cols)
for c in cols:
    print(c, "gpu mean", a[c].mean(), "cpu mean", b[c].mean(), "max |diff|", (a[c] - b[c]).abs().max())
PY
