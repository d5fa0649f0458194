#!/usr/bin/python3
"""A third opinion on ground truth: depth-only ICP between consecutive keyframes of a run.

Usage: scripts/check_ground_truth.py RUN_DIR --dataset DIR [--worst N]
       [--fx 585 --fy 585 --cx 320 --cy 240 --depth-scale 0.001 --rate 30]

For a 7-Scenes layout (frame-NNNNNN.depth.png, frame-NNNNNN.pose.txt; frame i at i / rate s).
For each pair of consecutive keyframes of RUN_DIR/keyframes.tum it compares three relative
poses: the run's estimate, the ground truth, and point-to-plane ICP on the two depth images
alone (started from the ground truth, using only the range camera's intrinsics: no colour, no
features, nothing of ieslam). Where ICP agrees with the estimate and both disagree with the
ground truth by centimetres, the error that ATE charges to the estimate is in the ground truth.
Prints the N pairs with the largest estimate-vs-ground-truth translation difference and the
medians over all pairs. Needs numpy and matplotlib (python3-matplotlib).
"""
import argparse
import os
import sys

import matplotlib.image as mpimg
import numpy as np


def load_tum(path):
    poses = {}
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            x, y, z, w = v[4:8]
            T = np.eye(4)
            T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
            T[:3, 3] = v[1:4]
            poses[v[0]] = T
    return poses


def rotation_deg(R):
    return np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))


def exp_so3(w):
    theta = np.linalg.norm(w)
    if theta < 1e-12:
        return np.eye(3)
    k = w / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


class RangeCamera:
    def __init__(self, args):
        self.fx, self.fy, self.cx, self.cy = args.fx, args.fy, args.cx, args.cy
        self.scale = args.depth_scale

    def depth(self, path):
        raw = mpimg.imread(path)  # 16-bit PNGs come back as floats in [0, 1]
        d = raw.astype(np.float64) * 65535.0 * self.scale
        d[(raw <= 0) | (raw >= 1)] = 0.0  # 0 and 65535: no measurement
        return d

    def points(self, d):
        v, u = np.mgrid[0:d.shape[0], 0:d.shape[1]]
        return np.stack([(u - self.cx) * d / self.fx, (v - self.cy) * d / self.fy, d], axis=2)

    def surface(self, d):
        """Points, unit normals and a validity mask (no depth edges) per pixel."""
        X = self.points(d)
        N = np.zeros_like(X)
        dx = X[1:-1, 2:] - X[1:-1, :-2]
        dy = X[2:, 1:-1] - X[:-2, 1:-1]
        n = np.cross(dx, dy)
        N[1:-1, 1:-1] = n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-12)
        valid = np.zeros(d.shape, bool)
        valid[1:-1, 1:-1] = ((d[1:-1, 1:-1] > 0) & (d[1:-1, 2:] > 0) & (d[1:-1, :-2] > 0) &
                             (d[2:, 1:-1] > 0) & (d[:-2, 1:-1] > 0) &
                             (np.abs(dx[..., 2]) < 0.03) & (np.abs(dy[..., 2]) < 0.03))
        return X, N, valid


def icp(camera, d_a, d_b, T_b_a, iterations=30, gate_m=0.02):
    """Point-to-plane ICP with projective association: the pose of frame a in frame b."""
    P = camera.points(d_a)[::2, ::2].reshape(-1, 3)
    P = P[P[:, 2] > 0]
    X_b, N_b, valid_b = camera.surface(d_b)
    h, w = d_b.shape
    R, t = T_b_a[:3, :3].copy(), T_b_a[:3, 3].copy()
    for _ in range(iterations):
        X = P @ R.T + t
        z = np.where(X[:, 2] > 0.1, X[:, 2], 1.0)
        u = np.round(camera.fx * X[:, 0] / z + camera.cx).astype(int)
        v = np.round(camera.fy * X[:, 1] / z + camera.cy).astype(int)
        ok = (X[:, 2] > 0.1) & (u >= 0) & (u < w) & (v >= 0) & (v < h)
        u, v = np.where(ok, u, 0), np.where(ok, v, 0)
        ok &= valid_b[v, u]
        Q, N = X_b[v, u], N_b[v, u]
        r = np.einsum('ij,ij->i', Q - X, N)
        ok &= np.abs(r) < gate_m
        A = np.hstack([np.cross(X[ok], N[ok]), N[ok]])
        x = np.linalg.lstsq(A, r[ok], rcond=None)[0]
        dR = exp_so3(x[:3])
        R, t = dR @ R, dR @ t + x[3:]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def difference(A, B):
    """(degrees, millimetres) between two relative poses."""
    return rotation_deg(A[:3, :3].T @ B[:3, :3]), 1000 * np.linalg.norm(A[:3, 3] - B[:3, 3])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('run')
    parser.add_argument('--dataset', required=True)
    parser.add_argument('--worst', type=int, default=10)
    parser.add_argument('--fx', type=float, default=585.0)
    parser.add_argument('--fy', type=float, default=585.0)
    parser.add_argument('--cx', type=float, default=320.0)
    parser.add_argument('--cy', type=float, default=240.0)
    parser.add_argument('--depth-scale', type=float, default=0.001)
    parser.add_argument('--rate', type=float, default=30.0)
    args = parser.parse_args()
    camera = RangeCamera(args)
    estimate = load_tum(os.path.join(args.run, 'keyframes.tum'))
    frames = sorted(int(round(t * args.rate)) for t in estimate)
    by_frame = {int(round(t * args.rate)): T for t, T in estimate.items()}

    def path(i, kind):
        return os.path.join(args.dataset, 'frame-%06d.%s' % (i, kind))

    for i in frames:
        for kind in ('depth.png', 'pose.txt'):
            if not os.path.isfile(path(i, kind)):
                sys.exit('check_ground_truth: %s: no such file' % path(i, kind))
    rows = []
    for a, b in zip(frames, frames[1:]):
        G = np.linalg.inv(np.loadtxt(path(b, 'pose.txt'))) @ np.loadtxt(path(a, 'pose.txt'))
        E = np.linalg.inv(by_frame[b]) @ by_frame[a]
        rows.append((a, b, G, E, difference(E, G)))
    rows.sort(key=lambda row: -row[4][1])
    print('consecutive keyframes a->b: ground-truth motion | estimate-gt | icp-gt | icp-estimate')
    for a, b, G, E, est_gt in rows[:args.worst]:
        T = icp(camera, camera.depth(path(a, 'depth.png')), camera.depth(path(b, 'depth.png')), G)
        print('%4d->%-4d %5.1f deg %4.0f mm | %.2f deg %5.1f mm | %.2f deg %5.1f mm | '
              '%.2f deg %5.1f mm' % ((a, b, rotation_deg(G[:3, :3]), 1000 * np.linalg.norm(G[:3, 3]))
                                     + est_gt + difference(T, G) + difference(T, E)))
    print('median estimate-gt over %d pairs: %.2f deg %.1f mm' %
          (len(rows), np.median([r[4][0] for r in rows]), np.median([r[4][1] for r in rows])))


if __name__ == '__main__':
    main()
