#!/usr/bin/python3
"""Does the reported pose covariance describe how much the poses jump? For each frame, the jump
of its camera centre from the constant-velocity prediction of the two frames before it (poses as
published at frame time) against the jump's standard deviation that the three frames' reported
position sigmas give (timing.csv's position_sigma_mm, the largest sigma of each frame:
sqrt(s0^2 + (1 + r)^2 s1^2 + r^2 s2^2), r the ratio of the frame intervals).

For a covariance that describes the frames' own noise, the median of jump / expected sigma lies
between 0.67 (all of the uncertainty along one axis: the median of |N(0, 1)|) and 1.54 (equal on
all three axes: the median of a chi with 3 degrees of freedom). Above that the covariance is too
small: the camera's true acceleration (about 1 mm per frame at 1 m/s^2 and 30 Hz) and the map's
own errors, which it leaves out, add to the jumps. The rank correlation says whether frames
reported less precise do jump more.

Usage: bench/covariance_calibration.py RUN_DIR [RUN_DIR ...]
  RUN_DIR   a dypho_run_dataset output folder (trajectory_online.txt, timing.csv)
Prints per run: frames used, median and 90th percentile of jump / expected sigma, the Spearman
rank correlation of the two, and the mean jump [mm] of the frames below and above the median
expected sigma. A last line pools all runs.
"""
import csv
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pose_jumps import load_tum  # noqa: E402


def jumps(run):
    """(jump [mm], expected sigma [mm]) per frame whose three frames all have a sigma."""
    with open(os.path.join(run, 'timing.csv')) as f:
        rows = list(csv.DictReader(f))
    if rows and 'position_sigma_mm' not in rows[0]:
        raise ValueError('%s/timing.csv has no position_sigma_mm column (an older build)' % run)
    sigma_mm = {'%.6f' % float(r['stamp_s']): float(r['position_sigma_mm']) for r in rows}
    poses = [(float(s), T[:3, 3]) for s, T in load_tum(os.path.join(run, 'trajectory_online.txt'))]
    out = []
    for i in range(2, len(poses)):
        (t2, c2), (t1, c1), (t0, c0) = poses[i - 2], poses[i - 1], poses[i]
        if t1 <= t2 or t0 <= t1:
            continue
        s = [sigma_mm.get('%.6f' % t, -1.0) for t in (t0, t1, t2)]
        if min(s) <= 0.0:
            continue
        r = (t0 - t1) / (t1 - t2)
        jump_mm = 1e3 * np.linalg.norm(c0 - (c1 + r * (c1 - c2)))
        out.append((jump_mm, np.sqrt(s[0] ** 2 + (1 + r) ** 2 * s[1] ** 2 + r ** 2 * s[2] ** 2)))
    return out


def summary(pairs):
    if len(pairs) < 3:
        return 'too few frames (%d)' % len(pairs)
    jump, expected = np.array(pairs).T
    ratio = jump / expected
    rank = lambda v: np.argsort(np.argsort(v))
    spearman = np.corrcoef(rank(jump), rank(expected))[0, 1]
    low = expected < np.median(expected)
    return ('%d frames; jump / expected sigma: median %.2f, p90 %.2f; rank correlation %.2f; '
            'mean jump %.1f mm (sigma below median) vs %.1f mm (above)' %
            (len(pairs), np.median(ratio), np.percentile(ratio, 90), spearman, jump[low].mean(), jump[~low].mean()))


def main(argv):
    if not argv or argv[0] in ('-h', '--help'):
        print(__doc__)
        return 0 if argv else 2
    pooled = []
    for run in argv:
        try:
            pairs = jumps(run)
        except (OSError, ValueError) as e:
            print('covariance_calibration: %s' % e, file=sys.stderr)
            return 1
        pooled += pairs
        print('%s: %s' % (run, summary(pairs)))
    if len(argv) > 1:
        print('all runs: %s' % summary(pooled))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
