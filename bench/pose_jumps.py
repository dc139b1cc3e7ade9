#!/usr/bin/python3
"""Where a run's poses leave the camera's smooth path: each frame's deviation from the
constant-velocity prediction of the two frames before it, in the poses published at frame time.

A hand-held camera at 30 Hz leaves its constant-velocity path by about a millimetre per frame
(1 m/s^2); a deviation of centimetres is the pose estimate's own error. A keyframe made on such a
pose anchors the next frames to it (docs/journal/2026-12-07-bonn-pose-jumps.md).

Usage: bench/pose_jumps.py [--min-cm X] RUN_DIR [RUN_DIR ...]
  RUN_DIR   a dypho_run_dataset output folder (trajectory_online.txt, keyframes.txt)
  --min-cm  list the frames that deviate more than this [cm] (default 5)
Prints per run the deviations' median / 90th / 99th percentile / max [cm] over all frames and
over the keyframes' frames, then each frame above --min-cm: its index in the run, its stamp, the
deviation's translation [cm] and rotation [deg] in the predicted camera's frame (x right, y down,
z forward), and K for a keyframe. A last line pools all runs.
"""
import math
import os
import sys

import numpy as np


def quaternion_to_matrix(qx, qy, qz, qw):
    return np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ])


def load_tum(path):
    """[(stamp string, 4x4 T_world_camera)] of a TUM trajectory file."""
    poses = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0].startswith('#'):
                continue
            values = [float(v) for v in fields[1:8]]
            T = np.eye(4)
            T[:3, :3] = quaternion_to_matrix(*values[3:7])
            T[:3, 3] = values[0:3]
            poses.append((fields[0], T))
    return poses


def rotation_vector(R):
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))
    if angle < 1e-12:
        return np.zeros(3)
    return angle / (2.0 * math.sin(angle)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


def deviations(poses):
    """[(index, stamp, translation [m] in the predicted camera, rotation vector [rad])]."""
    out = []
    for i in range(2, len(poses)):
        (s2, T2), (s1, T1), (s0, T0) = poses[i - 2], poses[i - 1], poses[i]
        dt_last, dt_now = float(s1) - float(s2), float(s0) - float(s1)
        if dt_last <= 0 or dt_now <= 0:
            continue
        step = np.linalg.inv(T2) @ T1  # the last step, scaled to this frame's interval
        ratio = dt_now / dt_last
        scaled = np.eye(4)
        scaled[:3, :3] = quaternion_step(step[:3, :3], ratio)
        scaled[:3, 3] = step[:3, 3] * ratio
        D = np.linalg.inv(T1 @ scaled) @ T0
        out.append((i, s0, D[:3, 3], rotation_vector(D[:3, :3])))
    return out


def quaternion_step(R, ratio):
    """R's rotation scaled by `ratio` about its own axis."""
    v = rotation_vector(R) * ratio
    angle = np.linalg.norm(v)
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def percentiles(values):
    if not values:
        return 'none'
    v = sorted(values)
    pick = lambda q: v[min(len(v) - 1, int(q * len(v)))]
    return 'median %.2f, p90 %.2f, p99 %.2f, max %.2f (%d)' % (pick(0.5), pick(0.9), pick(0.99), v[-1], len(v))


def main(argv):
    min_cm = 5.0
    if len(argv) >= 2 and argv[0] == '--min-cm':
        min_cm = float(argv[1])
        argv = argv[2:]
    if not argv or argv[0] in ('-h', '--help'):
        print(__doc__)
        return 0 if argv else 2
    pooled, pooled_kf = [], []
    for run in argv:
        online = os.path.join(run, 'trajectory_online.txt')
        if not os.path.isfile(online):
            print('pose_jumps: no %s' % online, file=sys.stderr)
            return 1
        keyframes_file = os.path.join(run, 'keyframes.txt')
        keyframes = {s for s, _ in load_tum(keyframes_file)} if os.path.isfile(keyframes_file) else set()
        rows = deviations(load_tum(online))
        all_cm = [100 * np.linalg.norm(t) for _, _, t, _ in rows]
        kf_cm = [100 * np.linalg.norm(t) for _, s, t, _ in rows if s in keyframes]
        pooled += all_cm
        pooled_kf += kf_cm
        print('%s: all frames %s; keyframes %s' % (run, percentiles(all_cm), percentiles(kf_cm)))
        for i, s, t, r in rows:
            if 100 * np.linalg.norm(t) > min_cm:
                print('  %4d %s  t [cm] %6.1f %6.1f %6.1f  rot [deg] %6.2f %6.2f %6.2f %s' %
                      ((i, s) + tuple(100 * t) + tuple(np.degrees(r)) + ('K' if s in keyframes else '',)))
    if len(argv) > 1:
        print('all runs: all frames %s; keyframes %s' % (percentiles(pooled), percentiles(pooled_kf)))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
