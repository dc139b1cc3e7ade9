#!/usr/bin/env bash
# session_graph.sh DATASET OUT CAMERA [--bonn-correction]
#
# Sessions through the ROS graph at 1x (tum_bag.launch, bench/realtime_graph.sh), on a TUM-layout
# DATASET cut in two at its middle frame:
#   uncut      the whole sequence, one run;
#   first      the first half, output_dir OUT/first/run (its shutdown writes run/session);
#   second     the second half with session:=OUT/first/run: relocalised in the first half's map,
#              then mapping goes on in its frame;
#   localise   the whole sequence again with session:=OUT/second/run localization_only:=true.
# Prints, per run, frames answered and posed and the ATE; then the ATE of first + second
# concatenated (aligned once) against the uncut run, how long after its first frame the second
# run was found in the loaded map, the session's size, and whether the localisation run left the
# map byte-identical. CAMERA: the dataset's camera (tum_fr1, bonn, ... as dypho_dataset_to_bag
# --camera; the halves' folder names do not tell it). Needs the catkin build and its environment (source build/devel/setup.bash).
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0; fi
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="$(dirname "$(command -v dypho_run_dataset 2>/dev/null || echo "$ROOT/build/devel/lib/dypho_slam/x")")"
usage="usage: session_graph.sh DATASET OUT CAMERA [--bonn-correction]"
dataset="$(realpath "${1:?$usage}")"
out="$(realpath -m "${2:?$usage}")"
camera="${3:?$usage}"
evaluate_args=()
[[ "${4:-}" == --bonn-correction ]] && evaluate_args=(--bonn-correction)
mkdir -p "$out"

# The two halves as datasets (links to the images) and every sequence as a bag.
python3 - "$dataset" "$out" <<'PY'
import os, sys
src, out = sys.argv[1], sys.argv[2]
def entries(name):
    lines = [l for l in open(os.path.join(src, name)) if l.strip() and not l.startswith('#')]
    return [(float(l.split()[0]), l) for l in lines]
rgb, depth = entries('rgb.txt'), entries('depth.txt')
cut = rgb[len(rgb) // 2][0]
for half, keep in (('first', lambda t: t < cut), ('second', lambda t: t >= cut)):
    d = os.path.join(out, half + '_data')
    os.makedirs(d, exist_ok=True)
    for name, rows in (('rgb.txt', rgb), ('depth.txt', depth)):
        with open(os.path.join(d, name), 'w') as f:
            f.writelines(l for t, l in rows if keep(t))
    for name in os.listdir(src):
        if name not in ('rgb.txt', 'depth.txt') and not os.path.exists(os.path.join(d, name)):
            os.symlink(os.path.join(src, name), os.path.join(d, name))
PY
for part in first second; do
  [[ -f "$out/$part.bag" ]] || "$BIN/dypho_dataset_to_bag" --dataset "$out/${part}_data" --camera "$camera" --out "$out/$part.bag" > /dev/null
done
[[ -f "$out/whole.bag" ]] || "$BIN/dypho_dataset_to_bag" --dataset "$dataset" --camera "$camera" --out "$out/whole.bag" > /dev/null

graph() {  # NAME BAG [realtime_graph.sh args]
  local name="$1" bag="$2"
  shift 2
  bash "$ROOT/bench/realtime_graph.sh" "$bag" --out "$out/$name" --groundtruth "$dataset/groundtruth.txt" \
    --no-map-views "${evaluate_args[@]}" "$@" > "$out/$name.txt" 2>&1 || true
  echo "$name: $(grep -E '^(statuses|ATE):' "$out/$name/summary.txt" | tr -s ' ' | tr '\n' ' ')"
}
graph uncut "$out/whole.bag"
graph first "$out/first.bag"
graph second "$out/second.bag" --launch-arg session:="$out/first/run"
graph localise "$out/whole.bag" --launch-arg session:="$out/second/run" --launch-arg localization_only:=true

cat "$out/first/run/trajectory.txt" <(grep -v '^#' "$out/second/run/trajectory.txt") > "$out/concatenated.txt"
echo "concatenated: $("$BIN/dypho_evaluate" --groundtruth "$dataset/groundtruth.txt" --estimate "$out/concatenated.txt" \
  "${evaluate_args[@]}" 2>&1 | grep -m1 rmse | xargs) (uncut: $(grep '^ATE:' "$out/uncut/summary.txt" | cut -d: -f2 | xargs))"
first_frame="$(awk '!/^#/ {print $1; exit}' "$out/second_data/rgb.txt")"
first_pose="$(awk '!/^#/ {print $1; exit}' "$out/second/run/trajectory.txt")"
echo "second run found in the loaded map $(python3 -c "print(f'{$first_pose - $first_frame:.3f}')") s after its first frame"
echo "session of the first half: $(du -sb "$out/first/run/session" | cut -f1) bytes ($(grep -E '^(keyframes|gaussians):' "$out/first/run/session/session.yaml" | tr '\n' ' '))"
if cmp -s "$out/second/run/session/map.ply" "$out/localise/run/map.ply"; then
  echo "localisation only: map.ply byte-identical to the loaded session's"
else
  echo "localisation only: map.ply DIFFERS from the loaded session's"
fi
