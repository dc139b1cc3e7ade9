#!/bin/bash
# The whole system on a machine with an NVIDIA GPU but without ROS, OpenCV or Eigen: the
# in-process runner (dypho_run_dataset: mask, tracking, mapping; the mapping on CUDA when
# `device: auto` finds a GPU) on the synthetic room, deterministic and --realtime.
#
#   scripts/gpu_system.sh prepare        # on this machine: builds dypho_run_dataset and dypho_synth
#                                        # with plain CMake (no ROS, CUDA for sm_80 and sm_90) in
#                                        # build-gpu-system/ and packs them, the libraries they load
#                                        # and config/ into third_party/gpu_system_portable.tar.xz
#   scripts/gpu_system.sh run [OUT_DIR]  # on the GPU machine: unpacks, generates the synthetic room,
#                                        # runs it deterministic and --realtime; logs, outputs and
#                                        # summary.txt go to OUT_DIR (default build-gpu-system/out)
#   DYPHO_GPU_FRAMES=60 scripts/gpu_system.sh run ...   # frames to generate (default 300: the
#                                        # README's room, halfsphere, 2 people, seed 1)
#   DYPHO_JOBS=1 scripts/gpu_system.sh prepare          # compile jobs and xz threads (default: all)
#   DYPHO_CUDA_ARCHITECTURES=90 scripts/gpu_system.sh prepare   # other GPUs (default "80;90")
#
# The pack has no OpenCV image codecs: Debian's libopencv_imgcodecs loads GDAL, poppler, HDF5 and
# more (about 180 MB). The two programs are linked again with tools/portable/png_imgcodecs.cpp
# (PNG only, on libpng) in its place; `prepare` checks that its pixels equal OpenCV's.
# The CPU run of the same command (no GPU: the mapper says so and trains on the CPU) is the
# reference for the GPU's figures.
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="$ROOT/build-gpu-system"
PORTABLE="$ROOT/third_party/gpu_system_portable.tar.xz"
PROGRAMS=(dypho_run_dataset dypho_synth)
# Libraries every Linux machine has in its own version: never packed.
SYSTEM_LIBS='/(libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt|libresolv|libutil)\.so|ld-linux'

# "name<TAB>path" of each library `ldd` resolves for the programs in $1 (paths may hold spaces).
resolved_libs() {
  local exe
  for exe in "${PROGRAMS[@]}"; do ldd "$1/$exe"; done \
    | sed -n 's/^[[:space:]]*\([^[:space:]]*\) => \(.*\) (0x[0-9a-f]*)$/\1\t\2/p' | sort -u
}

case "${1:-}" in
  prepare)
    JOBS="${DYPHO_JOBS:-$(nproc)}"
    LAUNCHER=()
    if command -v ccache > /dev/null; then
      LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache)
    fi
    mkdir -p "$BUILD" "$ROOT/third_party"
    # --as-needed: the programs load only the OpenCV and PCL libraries they call, not all those
    # the targets list (videoio alone loads about 270 MB).
    cmake -S "$ROOT" -B "$BUILD" -DDYPHO_WITH_ROS=OFF -DDYPHO_WITH_CUDA=ON -DDYPHO_BUILD_TESTS=OFF \
      -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES="${DYPHO_CUDA_ARCHITECTURES:-80;90}" \
      -DCMAKE_EXE_LINKER_FLAGS=-Wl,--as-needed "${LAUNCHER[@]}" > "$BUILD/configure.log" 2>&1 \
      || { cat "$BUILD/configure.log"; exit 1; }
    if ! grep -q 'dypho: CUDA ON' "$BUILD/configure.log"; then
      echo "gpu_system: CMake found no nvcc (/usr/local/cuda/bin or CUDACXX): the pack would map on the CPU only" >&2
      exit 1
    fi
    cmake --build "$BUILD" -j "$JOBS" --target "${PROGRAMS[@]}" > "$BUILD/build.log" 2>&1 \
      || { tail -n 40 "$BUILD/build.log"; exit 1; }
    # Link both again with the PNG codec in place of libopencv_imgcodecs: CMake's own link
    # script, run where CMake runs it, with that library and the output name changed.
    LINK_DIR="$BUILD/tools"
    g++ -std=c++17 -O2 -Wall -Wextra -c "$ROOT/tools/portable/png_imgcodecs.cpp" -I/usr/include/opencv4 \
      -o "$LINK_DIR/png_imgcodecs.o"
    for exe in "${PROGRAMS[@]}"; do
      script="$LINK_DIR/CMakeFiles/$exe.dir/link.txt"
      if ! grep -q -- "-o $exe " "$script" || ! grep -q 'libopencv_imgcodecs\.so' "$script"; then
        echo "gpu_system: $script does not link $exe with libopencv_imgcodecs as expected" >&2
        exit 1
      fi
      sed -e "s| -o $exe | -o $exe.portable |" \
          -e 's|[^ ]*libopencv_imgcodecs\.so[^ ]*|png_imgcodecs.o -lpng16 -lz|' "$script" > "$script.portable"
      (cd "$LINK_DIR" && cmake -E cmake_link_script "CMakeFiles/$exe.dir/link.txt.portable")
    done
    # The codec against OpenCV's: the same generated frames, decoded by both.
    CHECK="$BUILD/png_check"
    rm -rf "$CHECK" && mkdir -p "$CHECK"
    g++ -std=c++17 -O2 "$ROOT/tools/portable/png_imgcodecs_check.cpp" -I/usr/include/opencv4 \
      -o "$CHECK/check_opencv" -lopencv_imgcodecs -lopencv_core
    g++ -std=c++17 -O2 "$ROOT/tools/portable/png_imgcodecs_check.cpp" "$LINK_DIR/png_imgcodecs.o" \
      -I/usr/include/opencv4 -o "$CHECK/check_portable" -lpng16 -lz -lopencv_core
    "$CHECK/check_opencv" write "$CHECK/by_opencv"
    "$CHECK/check_portable" write "$CHECK/by_portable"
    for reader in check_opencv check_portable; do
      for dir in by_opencv by_portable; do
        "$CHECK/$reader" read "$CHECK/$dir" > "$CHECK/$reader.$dir.txt"
      done
    done
    if ! cmp -s "$CHECK/check_opencv.by_opencv.txt" "$CHECK/check_portable.by_opencv.txt" \
       || ! cmp -s "$CHECK/check_opencv.by_opencv.txt" "$CHECK/check_portable.by_portable.txt" \
       || ! cmp -s "$CHECK/check_opencv.by_opencv.txt" "$CHECK/check_opencv.by_portable.txt"; then
      diff "$CHECK/check_opencv.by_opencv.txt" "$CHECK/check_portable.by_portable.txt" >&2 || true
      echo "gpu_system: tools/portable/png_imgcodecs.cpp decodes other pixels than OpenCV" >&2
      exit 1
    fi
    same_files=no; if diff -r -q "$CHECK/by_opencv" "$CHECK/by_portable" > /dev/null; then same_files=yes; fi
    echo "gpu_system: PNG codec checked against OpenCV's: same pixels in $(wc -l < "$CHECK/check_opencv.by_opencv.txt") reads; written files byte-identical: $same_files"
    # The pack: bin/, lib/ (what ldd resolves, but the C and C++ runtimes), config/.
    PACK="$BUILD/pack"
    rm -rf "$PACK" && mkdir -p "$PACK/bin" "$PACK/lib"
    for exe in "${PROGRAMS[@]}"; do
      cp "$LINK_DIR/$exe.portable" "$PACK/bin/$exe"
      strip "$PACK/bin/$exe"
    done
    if ldd "$PACK/bin/${PROGRAMS[0]}" | grep -q libopencv_imgcodecs; then
      echo "gpu_system: ${PROGRAMS[0]} still loads libopencv_imgcodecs" >&2
      exit 1
    fi
    resolved_libs "$PACK/bin" | cut -f2 | grep -v -E "$SYSTEM_LIBS" | while IFS= read -r lib; do
      cp -L "$lib" "$PACK/lib/"
    done
    cp -r "$ROOT/config" "$PACK/config"
    tar -C "$PACK" -cf - bin lib config | xz -T"$JOBS" -6 > "$PORTABLE.tmp"
    mv "$PORTABLE.tmp" "$PORTABLE"
    echo "gpu_system: $PORTABLE ($(du -h "$PORTABLE" | cut -f1); $(ls "$PACK/lib" | wc -l) libraries, $(du -sh "$PACK" | cut -f1) unpacked)"
    ;;
  run)
    OUT="${2:-$BUILD/out}"
    mkdir -p "$OUT"
    OUT="$(cd "$OUT" && pwd)"
    if [ ! -f "$PORTABLE" ]; then
      echo "gpu_system: no $PORTABLE: run 'scripts/gpu_system.sh prepare' first (on a machine with the build dependencies)" >&2
      exit 1
    fi
    P="$BUILD/portable"
    rm -rf "$P" && mkdir -p "$P"
    tar -xJf "$PORTABLE" -C "$P"
    export LD_LIBRARY_PATH="$P/lib"
    export DYPHO_CONFIG_DIR="$P/config"
    if nvidia-smi > "$OUT/nvidia-smi.txt" 2>&1; then
      nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$OUT/gpu.txt" 2>&1 || true
    else
      echo "none (nvidia-smi failed: $(tail -n 1 "$OUT/nvidia-smi.txt"))" > "$OUT/gpu.txt"
    fi
    { uname -a; nproc; grep -m1 'model name' /proc/cpuinfo || true; } > "$OUT/machine.txt"
    # Every library outside the C and C++ runtimes must come from the pack.
    resolved_libs "$P/bin" > "$OUT/ldd.txt"
    missing=0
    while IFS=$'\t' read -r name path; do
      if [ "$path" = "not found" ]; then
        echo "gpu_system: $name not found" >&2; missing=1
      elif [[ "$path" != "$P/lib/"* ]] && ! grep -q -E "$SYSTEM_LIBS" <<< "$path"; then
        echo "gpu_system: $name resolves outside the pack: $path" >&2; missing=1
      fi
    done < "$OUT/ldd.txt"
    [ "$missing" = 0 ] || exit 1
    SEQ="$OUT/synthetic_room"
    rm -rf "$SEQ"
    "$P/bin/dypho_synth" --out "$SEQ" --frames "${DYPHO_GPU_FRAMES:-300}" --motion halfsphere --people 2 --seed 1 \
      --no-bag > "$OUT/synth.log" 2>&1 || { cat "$OUT/synth.log"; exit 1; }
    final_refine=$("$P/bin/dypho_run_dataset" --print-config | sed -n 's/^ *final_refine_iterations: *\([0-9]*\).*/\1/p')
    status=0
    for mode in deterministic realtime; do
      FLAGS=(); if [ "$mode" = realtime ]; then FLAGS=(--realtime); fi
      rm -rf "${OUT:?}/$mode"
      start=$(date +%s.%N)
      "$P/bin/dypho_run_dataset" --dataset "$SEQ" --out "$OUT/$mode" "${FLAGS[@]}" \
        > "$OUT/$mode.txt" 2> "$OUT/$mode.log" || { status=1; tail -n 5 "$OUT/$mode.log"; }
      end=$(date +%s.%N)
      awk -v a="$start" -v b="$end" 'BEGIN {printf "%.1f\n", b - a}' > "$OUT/$mode.wall_s"
    done
    {
      echo "gpu:          $(head -n 1 "$OUT/gpu.txt"); $(nproc) CPU cores"
      grep -a -m1 'wrote' "$OUT/synth.log" || true
      for mode in deterministic realtime; do
        echo "== $mode: $(cat "$OUT/$mode.wall_s") s wall ($OUT/$mode.txt, $OUT/$mode.log)"
        grep -a -E '^dypho_run_dataset: (mapping on |end: )' "$OUT/$mode.log" || echo "(no device line in the log)"
        cat "$OUT/$mode.txt"
        # Derived: frames/s from the median ms/frame, from the frames' summed work (deterministic:
        # the frame loop, one frame after the other) and from the wall time; training iterations per
        # keyframe in the map, the final refinement (final_refine_iterations) not counted.
        work_s=$(awk -F, 'NR == 1 {for (i = 1; i <= NF; ++i) if ($i == "total_ms") c = i}
                          NR > 1 && c {s += $c} END {printf "%.1f", s / 1000}' "$OUT/$mode/timing.csv" 2> /dev/null || echo 0)
        awk -v wall="$(cat "$OUT/$mode.wall_s")" -v work="$work_s" -v mode="$mode" -v final="$final_refine" '
          /^frames:/ {processed = $2}
          /^time:/ {ms = $2}
          /^gaussians:/ {s = $0; sub(/.*\(/, "", s); split(s, f, " "); iterations = f[3]}
          /^map PSNR:/ {s = $0; sub(/.*\(/, "", s); split(s, f, " "); keyframes = f[1]}
          END {
            if (ms > 0) printf "derived:      %.1f frames/s (1000 / median ms/frame)", 1000 / ms
            if (mode == "deterministic" && work > 0) printf ", %.1f over the frame loop (%.1f s)", processed / work, work
            if (wall > 0) printf ", %.2f over the wall time (with the final refinement, scoring and files)", processed / wall
            if (keyframes > 0) printf "\n              %.1f iterations per keyframe ((%d - %d final) / %d keyframes in the map)", \
              (iterations - final) / keyframes, iterations, final, keyframes
            printf "\n"
          }' "$OUT/$mode.txt"
      done
    } | tee "$OUT/summary.txt"
    exit "$status"
    ;;
  *)
    echo "usage: $0 prepare | run [OUT_DIR]" >&2
    exit 2
    ;;
esac
