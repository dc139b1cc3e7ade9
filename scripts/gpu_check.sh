#!/bin/bash
# The GPU checks of the mapping core on a machine with an NVIDIA GPU and CUDA but without ROS,
# OpenCV or Eigen installed: builds dypho_mapping/standalone, runs the CUDA parity tests, runs them
# again under compute-sanitizer (memcheck, racecheck), and runs the GPU benchmark.
#
#   scripts/gpu_check.sh prepare        # on this machine: copies Eigen headers and GoogleTest
#                                       # sources into third_party/ (git-ignored) to travel along
#   scripts/gpu_check.sh run [OUT_DIR]  # on the GPU machine: build, tests, sanitizers, benchmark;
#                                       # logs go to OUT_DIR (default build-gpu/out)
#   DYPHO_CUDA_ARCHITECTURES=90 scripts/gpu_check.sh run ...   # build for that GPU only (faster)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
case "${1:-}" in
  prepare)
    mkdir -p "$ROOT/third_party"
    rm -rf "$ROOT/third_party/eigen3" "$ROOT/third_party/googletest"
    cp -r /usr/include/eigen3 "$ROOT/third_party/eigen3"
    cp -r /usr/src/googletest "$ROOT/third_party/googletest"
    # The shared Bonn crowd frames (20, 320x240, ground-truth poses) for the training benchmark,
    # in a file the GPU machine reads without OpenCV (needs a build: scripts/build.sh).
    BONN="$ROOT/../shared/data/rgbd_bonn_crowd_frames200to399"
    EXPORT="${DYPHO_BUILD_DIR:-$ROOT/build}/devel/lib/dypho_slam/export_training_frames"
    if [ -d "$BONN" ] && [ -x "$EXPORT" ]; then
      "$EXPORT" --dataset "$BONN" --trajectory "$BONN/groundtruth.txt" --bonn-correction \
        --out "$ROOT/third_party/bonn_frames.bin" --frames 20
    else
      echo "gpu_check: no $BONN or no $EXPORT: the benchmark will train on the synthetic room only"
    fi
    echo "gpu_check: third_party/ ready ($(du -sh "$ROOT/third_party" | cut -f1))"
    ;;
  run)
    OUT="${2:-$ROOT/build-gpu/out}"
    mkdir -p "$OUT"
    BUILD="$ROOT/build-gpu"
    EIGEN="$ROOT/third_party/eigen3"; [ -d "$EIGEN" ] || EIGEN=/usr/include/eigen3
    GTEST="$ROOT/third_party/googletest"; [ -d "$GTEST" ] || GTEST=/usr/src/googletest
    export PATH="/usr/local/cuda/bin:$PATH"
    GEN=(); if command -v ninja > /dev/null; then GEN=(-G Ninja); fi
    nvidia-smi > "$OUT/nvidia-smi.txt" 2>&1 || true
    cmake -S "$ROOT/dypho_mapping/standalone" -B "$BUILD" "${GEN[@]}" -DDYPHO_EIGEN_INCLUDE_DIR="$EIGEN" \
      -DDYPHO_GTEST_SOURCE_DIR="$GTEST" ${DYPHO_CUDA_ARCHITECTURES:+-DCMAKE_CUDA_ARCHITECTURES="$DYPHO_CUDA_ARCHITECTURES"} \
      > "$OUT/configure.log" 2>&1
    cmake --build "$BUILD" -j "$(nproc)" > "$OUT/build.log" 2>&1
    status=0
    (cd "$BUILD" && ctest --output-on-failure) > "$OUT/ctest.log" 2>&1 || status=1
    "$BUILD/test_cuda_parity" > "$OUT/parity.log" 2>&1 || status=1
    for tool in memcheck racecheck; do
      compute-sanitizer --tool "$tool" --error-exitcode 1 "$BUILD/test_cuda_parity" \
        --gtest_filter='CudaParity.EdgeCaseScenes:CudaParity.ReuseAfterALargerSceneIsExact' \
        > "$OUT/sanitizer_$tool.log" 2>&1 || status=1
    done
    FRAMES=(); if [ -f "$ROOT/third_party/bonn_frames.bin" ]; then FRAMES=(--frames "$ROOT/third_party/bonn_frames.bin"); fi
    "$BUILD/mapping_bench_cuda" "${FRAMES[@]}" > "$OUT/bench.log" 2>&1 || status=1
    tail -n 3 "$OUT"/ctest.log "$OUT"/sanitizer_*.log; cat "$OUT/bench.log"
    exit "$status"
    ;;
  *)
    echo "usage: $0 prepare | run [OUT_DIR]" >&2
    exit 2
    ;;
esac
