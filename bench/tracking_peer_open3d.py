#!/usr/bin/python3
"""Peer for the tracking benchmark: Open3D 0.16 hybrid RGB-D odometry, frame to frame.

Usage: bench/tracking_peer_open3d.py --dataset DIR --out TRAJ.txt --camera config/cameras/NAME.yaml
Evaluate with dypho_evaluate (--bonn-correction for Bonn). Default OdometryOption, the hybrid
Jacobian (photometric + geometric), depth scale from the camera YAML, images as loaded (no
undistortion). A failed frame keeps the last pose; failures and the median time are printed.
"""
import argparse
import time

import numpy as np
import open3d as o3d
import yaml


def read_list(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            t, p = line.split()[:2]
            rows.append((float(t), p))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--dataset', required=True)
    ap.add_argument('--out', required=True)
    ap.add_argument('--camera', required=True, help='camera YAML (config/cameras/*.yaml)')
    args = ap.parse_args()
    cam = yaml.safe_load(open(args.camera))
    intr = o3d.camera.PinholeCameraIntrinsic(int(cam['width']), int(cam['height']), cam['fx'],
                                             cam['fy'], cam['cx'], cam['cy'])
    rgb = read_list(args.dataset + '/rgb.txt')
    depth = read_list(args.dataset + '/depth.txt')
    dts = np.array([d[0] for d in depth])
    option = o3d.pipelines.odometry.OdometryOption()
    jac = o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm()
    T_world_cam = np.eye(4)
    prev = None
    out, ms, failures = [], [], 0
    for t, path in rgb:
        j = int(np.argmin(np.abs(dts - t)))
        if abs(dts[j] - t) > 0.02:
            continue
        color = o3d.io.read_image(args.dataset + '/' + path)
        dep = o3d.io.read_image(args.dataset + '/' + depth[j][1])
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, dep, depth_scale=float(cam['depth_scale']), depth_trunc=6.0,
            convert_rgb_to_intensity=True)
        t0 = time.perf_counter()
        if prev is not None:
            ok, T_prev_cur_src, _ = o3d.pipelines.odometry.compute_rgbd_odometry(
                rgbd, prev, intr, np.eye(4), jac, option)
            # compute_rgbd_odometry(source=current, target=previous) gives T mapping source
            # points into the target frame: p_prev = T * p_cur.
            if ok and np.all(np.isfinite(T_prev_cur_src)):
                T_world_cam = T_world_cam @ T_prev_cur_src
            else:
                failures += 1
        ms.append(1000.0 * (time.perf_counter() - t0))
        prev = rgbd
        R = T_world_cam[:3, :3]
        q = quat_from_matrix(R)
        p = T_world_cam[:3, 3]
        out.append('%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f' % (t, p[0], p[1], p[2], *q))
    with open(args.out, 'w') as f:
        f.write('\n'.join(out) + '\n')
    print('open3d_hybrid_odometry frames %d failures %d median_ms %.2f trajectory %s'
          % (len(out), failures, float(np.median(ms)), args.out))


def quat_from_matrix(R):
    """(qx, qy, qz, qw) of a rotation matrix (Shepperd's method)."""
    tr = np.trace(R)
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        return ((R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s)
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * np.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (R[j, i] + R[i, j]) / s
    q[k] = (R[k, i] + R[i, k]) / s
    q[3] = (R[k, j] - R[j, k]) / s
    return tuple(q)


if __name__ == '__main__':
    main()
