#!/bin/bash
# The GPU checks of the mapping core on a machine with an NVIDIA GPU and CUDA but without ROS,
# OpenCV or Eigen installed: builds dypho_mapping/standalone, runs the CUDA parity tests, runs them
# again under compute-sanitizer (memcheck, racecheck), runs the whole mapper's CUDA tests packed by
# `prepare` (plainly and sanitized), and runs the GPU benchmark.
#
#   scripts/gpu_check.sh prepare        # on this machine: packs Eigen headers, GoogleTest sources,
#                                       # 20 Bonn frames and the whole-mapper test (linked from a
#                                       # plain CMake tree in build-gpu-pack/) into third_party/
#                                       # (git-ignored; about 15 MB) to travel along
#   scripts/gpu_check.sh run [OUT_DIR]  # on the GPU machine: build, tests, sanitizers, benchmark;
#                                       # logs go to OUT_DIR (default build-gpu/out)
#   DYPHO_CUDA_ARCHITECTURES=90 scripts/gpu_check.sh run ...   # build for that GPU only (faster)
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
case "${1:-}" in
  prepare)
    mkdir -p "$ROOT/third_party"
    rm -rf "$ROOT/third_party/eigen3" "$ROOT/third_party/googletest"
    # Eigen's headers and GoogleTest's sources, compressed for the trip (a device call takes 64 MB
    # with the tree); `run` unpacks them.
    tar -cf - -C /usr/include eigen3 -C /usr/src googletest | xz -T0 -6 > "$ROOT/third_party/sources.tar.xz"
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
    # The whole mapper on CUDA (test_dypho_cuda_parity, with the CudaTraining tests) needs OpenCV
    # core/imgproc/calib3d: linked here from object files without PCL and image codecs and packed
    # with the libraries it loads (about 10 MB), for a GPU machine without OpenCV. The objects come
    # from a plain CMake tree of their own (build-gpu-pack/: no ROS, one object per source; the
    # catkin build compiles eight sources to an object, PCL's among them).
    PACK_BUILD="$ROOT/build-gpu-pack"
    LAUNCHER=()
    if command -v ccache > /dev/null; then
      LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache)
    fi
    mkdir -p "$PACK_BUILD"
    if ! cmake -S "$ROOT" -B "$PACK_BUILD" -DDYPHO_WITH_ROS=OFF -DDYPHO_WITH_CUDA=ON -DDYPHO_BUILD_TESTS=ON \
         -DDYPHO_UNITY_LIBRARIES=OFF -DDYPHO_UNITY_TESTS=OFF -DCMAKE_BUILD_TYPE=Release \
         -DCMAKE_CUDA_ARCHITECTURES="${DYPHO_CUDA_ARCHITECTURES:-80;90}" "${LAUNCHER[@]}" > "$PACK_BUILD/configure.log" 2>&1 \
       || ! cmake --build "$PACK_BUILD" -j "${DYPHO_JOBS:-$(nproc)}" --target test_dypho_cuda_parity > "$PACK_BUILD/build.log" 2>&1; then
      tail -n 20 "$PACK_BUILD/configure.log" "$PACK_BUILD/build.log" 2>/dev/null
      echo "gpu_check: the plain CMake tree in $PACK_BUILD failed (logs there)" >&2
    fi
    OBJ="$PACK_BUILD/dypho_mapping/CMakeFiles"
    CUDA_LIB="$(find "$PACK_BUILD" -name libdypho_mapping_cuda.a | head -n 1)"
    if [ -n "$CUDA_LIB" ] && [ -d "$OBJ/test_dypho_cuda_parity.dir" ]; then
      PACK="$(mktemp -d)"
      mkdir -p "$PACK/lib"
      g++ -O2 -c "$ROOT/dypho_mapping/test/imwrite_unavailable.cpp" -I/usr/include/opencv4 -o "$PACK/imwrite_unavailable.o"
      # Every core object but the keyframe cloud and the stage (PCL); the mapper does not use them.
      mapfile -t CORE < <(ls "$OBJ"/dypho_mapping_core.dir/src/core/*.o | grep -v -E 'keyframe_cloud_map|mapping_stage')
      mapfile -t TEST_OBJECTS < <(find "$OBJ/test_dypho_cuda_parity.dir" -name '*.o' | sort)
      g++ -O3 -o "$PACK/test_dypho_cuda_parity" "${TEST_OBJECTS[@]}" "${CORE[@]}" \
        "$OBJ"/dypho_raster_tiles_*.dir/src/core/raster_tile_kernels.cpp.o "$PACK/imwrite_unavailable.o" \
        /usr/lib/x86_64-linux-gnu/libgtest.a "$CUDA_LIB" /usr/local/cuda/lib64/libcudart_static.a -Wl,--as-needed \
        -lopencv_calib3d -lopencv_imgproc -lopencv_core -ldl -lrt -lpthread
      ldd "$PACK/test_dypho_cuda_parity" | awk '{print $3}' | grep '^/' \
        | grep -v -E '/(libc|libm|libstdc\+\+|libgcc_s)\.so|ld-linux' | xargs -I{} cp -L {} "$PACK/lib/"
      tar -C "$PACK" -cf - test_dypho_cuda_parity lib | xz -T0 -6 > "$ROOT/third_party/cuda_parity_portable.tar.xz"
      rm -rf "$PACK"
    else
      echo "gpu_check: no CUDA objects in $PACK_BUILD: the whole-mapper CUDA tests will not travel"
    fi
    # The frames compressed too (about 7:1); `run` unpacks them.
    if [ -f "$ROOT/third_party/bonn_frames.bin" ]; then xz -f -T0 -6 "$ROOT/third_party/bonn_frames.bin"; fi
    echo "gpu_check: third_party/ ready ($(du -sh "$ROOT/third_party" | cut -f1))"
    ;;
  run)
    OUT="${2:-$ROOT/build-gpu/out}"
    mkdir -p "$OUT"
    BUILD="$ROOT/build-gpu"
    if [ -f "$ROOT/third_party/sources.tar.xz" ] && [ ! -d "$ROOT/third_party/eigen3" ]; then
      tar -xJf "$ROOT/third_party/sources.tar.xz" -C "$ROOT/third_party"
    fi
    if [ -f "$ROOT/third_party/bonn_frames.bin.xz" ] && [ ! -f "$ROOT/third_party/bonn_frames.bin" ]; then
      xz -dk "$ROOT/third_party/bonn_frames.bin.xz"
    fi
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
    PORTABLE="$ROOT/third_party/cuda_parity_portable.tar.xz"
    if [ -f "$PORTABLE" ]; then  # the whole mapper on CUDA (CudaTraining), plainly and sanitized
      mkdir -p "$BUILD/portable" && tar -xJf "$PORTABLE" -C "$BUILD/portable"
      T="$BUILD/portable/test_dypho_cuda_parity"
      LD_LIBRARY_PATH="$BUILD/portable/lib" "$T" > "$OUT/training.log" 2>&1 || status=1
      for tool in memcheck racecheck; do
        LD_LIBRARY_PATH="$BUILD/portable/lib" compute-sanitizer --tool "$tool" --error-exitcode 1 "$T" \
          --gtest_filter='CudaTraining.*' > "$OUT/training_$tool.log" 2>&1 || status=1
      done
    fi
    FRAMES=(); if [ -f "$ROOT/third_party/bonn_frames.bin" ]; then FRAMES=(--frames "$ROOT/third_party/bonn_frames.bin"); fi
    "$BUILD/mapping_bench_cuda" "${FRAMES[@]}" > "$OUT/bench.log" 2>&1 || status=1
    tail -n 3 "$OUT"/ctest.log "$OUT"/sanitizer_*.log "$OUT"/training*.log 2>/dev/null; cat "$OUT/bench.log"
    exit "$status"
    ;;
  *)
    echo "usage: $0 prepare | run [OUT_DIR]" >&2
    exit 2
    ;;
esac
