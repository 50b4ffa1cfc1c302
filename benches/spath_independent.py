#!/usr/bin/env python3
"""Independent brute-force check of ``synthcam detect --target s-path`` on painted discs (caps).

What: re-implements, without any of the repository's Rust code, the course's S-path target in the
``style = "disc"`` look and measures synthcam's detector against exact blob centroids. Geometry:
the planar S (assets/s_path/planar_s.csv) centred, half-scaled, mapped onto the sphere
c = (0, 0, 0.5) m, r = 0.5 m by inverse stereographic projection, resampled to 101 points equally
spaced in chord length by not-a-knot cubic splines (shared/spec/course-scenario.md 3.4). Each path
point P carries a flat dark cap, the sphere points within CHORD distance 6 mm of P (first dot
10 mm; crates/core/src/target/s_path_dots.rs). Greys as synthcam's defaults: dots 20, sphere 225, background
90. Poses: the course's desired cam_from_target (R rows [[0,-1,0],[0,0,1],[-1,0,0]], t
[0,-0.55,1.8] m) orbited about the sphere centre by 0-15 deg about a random axis, then moved in
the camera frame by 0.1-0.2 m in a random direction; poses whose sphere outline leaves the image
(3 px margin) are redrawn. Camera A: 1280x1024, f 1500, c (640, 512); camera B: f 1200, k1 -0.1
(radial r_d = r (1 + k1 r^2 + k2 r^4 + k3 r^6), inverted per sample by Newton on the radius).
``--deviate-mm D`` adds a set whose cap centres move on the sphere by a tangential offset uniform
in a disc of radius D mm (redrawn if it would touch the previous cap); the detector still assumes
the nominal path (default 7 mm). Both sets use the same poses and noise seeds. Wide poses (default;
--narrow gives the ones above): orbited 0-35 deg, rolled -45..45 deg about the optical axis, 0.6-1.6 times
the course's distance, the sphere centre anywhere in the middle 70 % of the image, the outline free to leave
it (at least 40 caps facing the camera inside the image); see sample_poses. A fresh seed is drawn per run
and printed (--seed reproduces it). Dots the image border cuts (any coverage on its outermost row or
column) are left out of the recall; those reported anyway are counted with their error against the
visible part's centroid.

How exact: a pixel is the area average over its square of the grey of each ray's first hit,
90 + 135 cov_sphere - 205 sum_i cov_i (caps are disjoint), each cov the area fraction of one binary
region. Pixels outside the limb band (|angle to the sphere centre - angular radius| < 2x the
pixel's angular half-diagonal) and outside every dot window (projected cube around the cap, + 2 px)
take one sample. Candidates are probed at 8 x 8 points (edges included), neighbours of mixed ones
again at 16 x 16. Mixed pixels are integrated by scan lines across the boundary (rows, or columns
where the boundary runs closer to horizontal): n lines at (k + 0.5)/n, 17 samples per line, every
crossing bisected 20 times (6e-8 px), so each line's inside length is exact and only n is a
discretisation: n = 32 and 64, then 128, 256, 512 where the last two differ by > 1e-4 (0.02 grey).
Exact centroid of dot i: sum_p cov_i(p) centre(p) / sum_p cov_i(p) (OpenCV pixels, top-left pixel
centre (0, 0)); equivalent radius sqrt(sum_p cov_i(p) / pi). Noise N(0, 1) grey (seeded), rounded,
clamped, 8-bit PNG (Pillow). --validate checks the path, face-on caps against the analytic circle,
convergence on boundary pixels and the distortion inverse.

Run (repository root; numpy + Pillow):
    python3 benches/spath_independent.py --validate
    python3 benches/spath_independent.py                 # fresh seed: 20 views x cameras A, B x 2 sets
    python3 benches/spath_independent.py --views 10 --seed 497783 --binary /tmp/old/synthcam   # rescore
    python3 benches/spath_independent.py --views 5 --seed 3 --deviate-mm 2 --out /tmp/si
Writes --out (default /work/scratch/spath_indep/{wide,narrow}_sSEED)/SET/CAM_VV.png, .truth.json, .det.json, results.md (and
results_BINARYHASH.md), validation.md; waits up to --wait-min minutes for --binary, then runs `detect IMAGE --target s-path`.
"""
import argparse, hashlib, itertools, json, math, os, subprocess, sys, time
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
DARK, LIGHT, BACKGROUND = 20.0, 225.0, 90.0
CENTRE, RADIUS = np.array([0.0, 0.0, 0.5]), 0.5
DOT_R, START_R, MIN_EQ_R = 0.006, 0.010, 1.5
PLANAR_CENTRE = (1.869430, -0.017589)
R_DESIRED, T_DESIRED = np.array([[0.0, -1, 0], [0, 0, 1], [-1, 0, 0]]), np.array([0.0, -0.55, 1.8])
CAMERAS = {"A": dict(w=1280, h=1024, f=1500.0, cx=640.0, cy=512.0, k=(0.0, 0.0, 0.0)),
           "B": dict(w=1280, h=1024, f=1200.0, cx=640.0, cy=512.0, k=(-0.1, 0.0, 0.0))}


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def radii(n):
    return np.where(np.arange(n) == 0, START_R, DOT_R)


def not_a_knot(x, y):
    """Second derivatives at the knots of MATLAB's spline(x, y) (third derivative continuous at x[1], x[n-2])."""
    n, h = len(x), np.diff(x)
    A, b = np.zeros((n, n)), np.zeros(n)
    for i in range(1, n - 1):
        A[i, i - 1:i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        b[i] = 6 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1])
    A[0, :3], A[-1, -3:] = (h[1], -(h[0] + h[1]), h[0]), (h[-1], -(h[-2] + h[-1]), h[-2])
    return np.linalg.solve(A, b)


def spline_eval(x, y, M, q):
    i = np.clip(np.searchsorted(x, q, side="right") - 1, 0, len(x) - 2)
    h, a, b = x[i + 1] - x[i], x[i + 1] - q, q - x[i]
    return ((M[i] * a**3 + M[i + 1] * b**3) / (6 * h) + (y[i] / h - M[i] * h / 6) * a
            + (y[i + 1] / h - M[i + 1] * h / 6) * b)


def s_path(n_out=101):
    """The course's pS (n_out x 3, frame 0, metres)."""
    s = np.loadtxt(REPO / "assets/s_path/planar_s.csv", delimiter=",", skiprows=1)
    u, v = 0.5 * (s[:, 0] - PLANAR_CENTRE[0]), 0.5 * (s[:, 1] - PLANAR_CENTRE[1])
    q = u * u + v * v
    p = np.stack([0.5 * (1 - q), u, 0.5 * (1 + q) + v], 1) / (1 + q)[:, None]     # z = 0.5 + v t
    lam = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    lk = np.arange(n_out) * lam[-1] / (n_out - 1)
    return np.stack([spline_eval(lam, p[:, j], not_a_knot(lam, p[:, j]), lk) for j in range(3)], 1)


class Camera:
    """Pinhole, OpenCV pixel convention, radial distortion (k1, k2, k3)."""

    def __init__(self, name, w, h, f, cx, cy, k):
        self.name, self.w, self.h, self.f, self.cx, self.cy, self.k = name, w, h, f, cx, cy, k

    def distort(self, x, y):
        k1, k2, k3 = self.k
        r2 = x * x + y * y
        s = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return self.f * x * s + self.cx, self.f * y * s + self.cy

    def project(self, p):
        return self.distort(p[..., 0] / p[..., 2], p[..., 1] / p[..., 2])

    def undistort(self, u, v):
        """Pixels -> undistorted normalised coordinates (Newton on the radius, 8 steps)."""
        xd, yd = (u - self.cx) / self.f, (v - self.cy) / self.f
        if not any(self.k):
            return xd, yd
        (k1, k2, k3), rd = self.k, np.sqrt(xd * xd + yd * yd)
        r = rd.copy()
        for _ in range(8):
            r2 = r * r
            r = r - (r * (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) - rd) / (1 + r2 * (3 * k1 + r2 * (5 * k2 + 7 * k3 * r2)))
        s = np.where(rd > 0, r / np.where(rd > 0, rd, 1.0), 1.0)
        return xd * s, yd * s


class Scene:
    """One view: the sphere and caps of radii r around dots_m (frame 0), seen by cam with cam_from_target (R, t)."""

    def __init__(self, cam, R, t, dots_m, r):
        self.cam, self.r, self.C, self.P = cam, r, R @ CENTRE + t, dots_m @ R.T + t
        self.cc = self.C @ self.C - RADIUS**2

    def first_hit(self, u, v):
        """Does the ray through pixel point (u, v) hit the sphere, and where first (camera frame)."""
        x, y = self.cam.undistort(u, v)
        a, b = x * x + y * y + 1, x * self.C[0] + y * self.C[1] + self.C[2]
        disc = b * b - a * self.cc
        hit = (disc >= 0) & (b > 0)
        t = (b - np.sqrt(np.where(hit, disc, 0.0))) / a
        return hit, t * x, t * y, t

    def in_sphere(self, u, v, lab):
        return self.first_hit(u, v)[0]

    def in_dot(self, u, v, lab):
        """Does the ray see cap lab (chord distance of the first hit to its centre < its radius)."""
        hit, hx, hy, hz = self.first_hit(u, v)
        p = self.P[lab]
        return hit & ((hx - p[..., 0])**2 + (hy - p[..., 1])**2 + (hz - p[..., 2])**2 < self.r[lab]**2)

    def view_angle_deg(self):
        """Angle between each cap's outward normal and its direction to the camera."""
        return np.degrees(np.arccos(np.clip(np.sum(unit(self.P - self.C) * unit(-self.P), 1), -1, 1)))


def probe(f, px, py, lab, k):
    """Inside flags (pixel, row, column) at k x k points spread over each pixel square, edges included."""
    o = np.linspace(-0.5, 0.5, k)
    return f(px[:, None, None] + o[None, None, :], py[:, None, None] + o[None, :, None], lab[:, None, None])


def mixed(ins):
    return ins.any((1, 2)) & ~ins.all((1, 2))


def row_coverage(f, px, py, lab, n, m=16, steps=20):
    """Area fraction inside f: n rows at (k + 0.5)/n, each row's inside length exact up to the bisection."""
    out = np.empty(len(px))
    for s in range(0, len(px), 256):
        X, Y, L = px[s:s + 256], py[s:s + 256], lab[s:s + 256]
        xs = X[:, None, None] - 0.5 + np.arange(m + 1)[None, None, :] / m
        ins = f(xs, Y[:, None, None] - 0.5 + (np.arange(n)[None, :, None] + 0.5) / n, L[:, None, None])
        a, b = ins[..., :-1], ins[..., 1:]
        pi, ri, si = np.nonzero(a != b)                   # segments with one crossing: bisect it
        lo = x0 = X[pi] - 0.5 + si / m
        hi, yv, lv, alo = lo + 1.0 / m, Y[pi] - 0.5 + (ri + 0.5) / n, L[pi], a[pi, ri, si]
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            same = f(mid, yv, lv) == alo
            lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        xc = 0.5 * (lo + hi)
        part = np.bincount(pi, np.where(alo, xc - x0, x0 + 1.0 / m - xc), minlength=len(X))
        out[s:s + 256] = ((a & b).sum((1, 2)) / m + part) / n
    return out


def scan_coverage(f, px, py, lab, n, cols):
    """row_coverage, by columns (u and v swapped) where cols."""
    out = np.empty(len(px))
    out[~cols] = row_coverage(f, px[~cols], py[~cols], lab[~cols], n)
    out[cols] = row_coverage(lambda a, b, l: f(b, a, l), py[cols], px[cols], lab[cols], n)
    return out


def grid_coverage(f, px, py, lab, k):
    """Plain k x k point sampling of each pixel (validation only)."""
    o = (np.arange(k) + 0.5) / k - 0.5
    return np.array([f(x + o[None, :], y + o[:, None], l).mean() for x, y, l in zip(px, py, lab)])


def region_coverage(f, px, py, lab, stats, contrast):
    """Coverage of region f over candidate pixels (integer centres px, py; region label lab per pixel)."""
    ins = probe(f, px, py, lab, 8)
    cov, mix = ins.all((1, 2)).astype(float), mixed(ins)
    key = (lab.astype(np.int64) * 8192 + py) * 8192 + px
    near = np.isin(key, (key[mix][:, None] + (np.arange(-1, 2)[:, None] * 8192 + np.arange(-1, 2)).ravel()).ravel())
    re = np.flatnonzero(near & ~mix)
    mix[re[mixed(probe(f, px[re], py[re], lab[re], 16))]] = True
    i = np.flatnonzero(mix)
    ins = probe(f, px[i], py[i], lab[i], 8).astype(float)   # scan by columns where top and bottom differ more
    cols = np.abs(ins[:, :4].mean((1, 2)) - ins[:, 4:].mean((1, 2))) > np.abs(ins[..., :4].mean((1, 2)) - ins[..., 4:].mean((1, 2)))
    c_prev, c = (scan_coverage(f, px[i], py[i], lab[i], n, cols) for n in (32, 64))
    stats["mixed"] = stats.get("mixed", 0) + len(i)
    stats["d64"] = max(stats.get("d64", 0.0), contrast * float(np.abs(c - c_prev).max(initial=0)))
    at, n = np.arange(len(i)), 64                         # halve the line spacing where two levels differ
    while n < 512 and len(at := at[np.abs(c[at] - c_prev[at]) > 1e-4]):
        n, c_prev = 2 * n, c.copy()
        c[at] = scan_coverage(f, px[i[at]], py[i[at]], lab[i[at]], n, cols[at])
        stats[f"n{n}"] = stats.get(f"n{n}", 0) + len(at)
        stats[f"d{n}"] = max(stats.get(f"d{n}", 0.0), contrast * float(np.abs(c[at] - c_prev[at]).max()))
    cov[i] = c
    return cov


_RAYS = {}


def pixel_rays(cam):
    """Unit centre rays (h, w, 3) and each pixel's angular half-diagonal (largest angle to a corner ray)."""
    if cam.name not in _RAYS:
        def rays(v, u):
            x, y = cam.undistort(u.astype(float), v.astype(float))
            return unit(np.stack([x, y, np.ones_like(x)], -1))
        d, dc = rays(*np.mgrid[0:cam.h, 0:cam.w]), rays(*(np.mgrid[0:cam.h + 1, 0:cam.w + 1] - 0.5))
        rho = np.max([np.arccos(np.clip(np.sum(d * dc[i:cam.h + i, j:cam.w + j], -1), -1, 1))
                      for i in (0, 1) for j in (0, 1)], 0)
        _RAYS[cam.name] = (d, rho)
    return _RAYS[cam.name]


def dot_truth(sc, stats, ids=None):
    """Per dot: visible area px^2 and exact centroid (px); and the windows' (px, py, coverage)."""
    n, D, cube = len(sc.P), np.linalg.norm(sc.C), 1.05 * np.array(list(itertools.product((-1, 0, 1), repeat=3)))
    gamma = np.arccos(np.clip(np.sum(unit(sc.P - sc.C) * (-sc.C / D), 1), -1, 1))
    windows = []
    for i in range(n) if ids is None else ids:
        if gamma[i] - 2 * math.asin(sc.r[i] / (2 * RADIUS)) > math.acos(RADIUS / D) + 1e-3:
            continue                                      # the whole cap is on the far side
        u, v = sc.cam.project(sc.P[i] + sc.r[i] * cube)
        if u.max() < -3 or v.max() < -3 or u.min() > sc.cam.w + 2 or v.min() > sc.cam.h + 2:
            continue                                      # wholly outside the image
        yy, xx = np.mgrid[max(math.floor(v.min()) - 2, 0):min(math.ceil(v.max()) + 2, sc.cam.h - 1) + 1,
                          max(math.floor(u.min()) - 2, 0):min(math.ceil(u.max()) + 2, sc.cam.w - 1) + 1]
        windows.append((xx.ravel(), yy.ravel(), np.full(xx.size, i)))
    px, py, lab = (np.concatenate(c) for c in zip(*windows))
    cov = region_coverage(sc.in_dot, px.astype(float), py.astype(float), lab, stats, LIGHT - DARK)
    area = np.bincount(lab, cov, minlength=n)
    edge = (px == 0) | (py == 0) | (px == sc.cam.w - 1) | (py == sc.cam.h - 1)
    cut = np.bincount(lab, edge * cov, minlength=n) > 0           # the image border cuts the cap
    with np.errstate(invalid="ignore", divide="ignore"):
        cen = np.stack([np.bincount(lab, cov * px, minlength=n), np.bincount(lab, cov * py, minlength=n)], 1) / area[:, None]
    return area, cen, (px, py, cov), cut


def render(sc, stats):
    """Noise-free box-filtered grey image (float) and the dots' truth (area, centroid)."""
    d, rho = pixel_rays(sc.cam)
    D = np.linalg.norm(sc.C)
    theta, alpha = np.arccos(np.clip(d @ (sc.C / D), -1, 1)), math.asin(RADIUS / D)
    img = np.where(theta < alpha, LIGHT, BACKGROUND)
    py, px = np.nonzero(np.abs(theta - alpha) < 2 * rho)  # the limb band
    img[py, px] = BACKGROUND + (LIGHT - BACKGROUND) * region_coverage(
        sc.in_sphere, px.astype(float), py.astype(float), np.zeros(len(px), int), stats, LIGHT - BACKGROUND)
    area, cen, (qx, qy, cov), cut = dot_truth(sc, stats)
    np.subtract.at(img, (qy, qx), (LIGHT - DARK) * cov)
    return img, area, cen, cut


def sphere_in_view(cam, C, margin=3.0):
    """The projected outline (720 points of the tangency circle) is inside the image by margin px."""
    D, e = np.linalg.norm(C), C / np.linalg.norm(C)
    a = unit(np.cross(e, [1.0, 0, 0]))
    phi = np.linspace(0, 2 * math.pi, 720, endpoint=False)[:, None]
    rim = e * (D - RADIUS**2 / D) + RADIUS * math.sqrt(1 - RADIUS**2 / D**2) * (np.cos(phi) * a + np.sin(phi) * np.cross(e, a))
    u, v = cam.project(rim)
    return min(u.min(), v.min()) >= margin and u.max() <= cam.w - 1 - margin and v.max() <= cam.h - 1 - margin


def sample_poses(cam, rng, n, wide=True):
    """cam_from_target (R, t). Narrow (--narrow, the earlier sessions' set): the camera orbited about the
    sphere centre by 0-15 deg about a random axis, then moved in its own frame by 0.1-0.2 m in a random
    direction, the whole outline in the image (3 px margin). Wide (default): orbited by 0-35 deg, rolled
    about its optical axis by -45..45 deg, its distance to the sphere centre scaled by 0.6-1.6 (1.1-3.0 m
    from the course's 1.87 m), moved sideways in its own frame so that the sphere centre lands anywhere in
    the middle 70 % of the image; the outline may leave the image, but at least 40 caps must face the
    camera with their centres in the image."""
    poses = []
    while len(poses) < n:
        k, angle = unit(rng.normal(size=3)), math.radians(rng.uniform(0, 35.0 if wide else 15.0))
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        Q = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
        R = R_DESIRED @ Q.T
        t = R_DESIRED @ (CENTRE - Q.T @ CENTRE) + T_DESIRED
        if not wide:
            t = t + unit(rng.normal(size=3)) * rng.uniform(0.1, 0.2)
            if sphere_in_view(cam, R @ CENTRE + t):
                poses.append((R, t))
            continue
        roll = math.radians(rng.uniform(-45.0, 45.0))
        Rz = np.array([[math.cos(roll), -math.sin(roll), 0], [math.sin(roll), math.cos(roll), 0], [0, 0, 1.0]])
        R, t = Rz @ R, Rz @ t
        C = R @ CENTRE + t
        depth = np.linalg.norm(C) * rng.uniform(0.6, 1.6)
        u, v = rng.uniform(0.15, 0.85) * cam.w, rng.uniform(0.15, 0.85) * cam.h
        x, y = cam.undistort(np.array([u]), np.array([v]))
        t = t + depth * unit(np.array([x[0], y[0], 1.0])) - C
        P = s_path() @ R.T + t
        C = R @ CENTRE + t
        pu, pv = cam.project(P)
        facing = np.sum(unit(P - C) * unit(-P), 1) > 0.05
        inside = (pu > 0) & (pv > 0) & (pu < cam.w - 1) & (pv < cam.h - 1)
        if (facing & inside).sum() >= 40:
            poses.append((R, t))
    return poses


def deviate(pts, rng, mm):
    """Cap centres moved on the sphere by tangential offsets uniform in a disc of radius mm."""
    r, out = radii(len(pts)), pts.copy()
    for i, p in enumerate(pts):
        a = unit(np.cross(p - CENTRE, [0, 0, 1.0]))
        b = unit(np.cross(p - CENTRE, a))
        while True:
            rr, phi = mm * 1e-3 * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
            out[i] = CENTRE + RADIUS * unit(p - CENTRE + rr * (math.cos(phi) * a + math.sin(phi) * b))
            if i == 0 or np.linalg.norm(out[i] - out[i - 1]) > r[i] + r[i - 1] + 1e-4:
                break
    return out


def validate(out):
    L, pts, cam = [], s_path(), Camera("A", **CAMERAS["A"])
    ref = {0: (0.199174, -0.303941, 0.156562), 100: (0.209461, 0.244966, 0.882254),          # course, 6 decimals
           13: (0.30183846633281747, 0.0027659897876157057, 0.10139507388416846),              # SciPy
           50: (0.4957229507673621, 0.06384011885514905, 0.5135342540475754),
           87: (0.2820768122048407, -0.07431998216067146, 0.9060901457920347)}
    off = np.linalg.norm(pts - CENTRE, axis=1) - RADIUS
    L.append(f"- path: max |p - reference| at points 0, 13, 50, 87, 100 (course 6 decimals; SciPy CubicSpline) "
             f"{max(np.abs(pts[i] - p).max() for i, p in ref.items()):.1e} m; |p - c| - r in [{off.min():.1e}, {off.max():.1e}] m")
    L.append("- face-on caps (camera axis = inward cap normal; image = projected rim circle of radius f rho / Z, "
             "rho = r sqrt(1 - r^2/4R^2), Z = depth of the rim plane):")
    for i, dist, lat in [(50, 0.4, (0, 0)), (0, 0.4, (0.0513, -0.0377)), (37, 1.8, (0.1117, 0.0731)), (80, 1.8, (-0.2031, 0.1573))]:
        r, n = radii(101)[i], unit(pts[i] - CENTRE)
        x = unit(np.cross(-n, [0, 0, 1.0]))
        Rv = np.stack([x, np.cross(-n, x), -n])
        sc = Scene(cam, Rv, -Rv @ (CENTRE + (RADIUS + dist) * n + lat[0] * x + lat[1] * Rv[1]), (CENTRE + RADIUS * n)[None], np.array([r]))
        area, cen, (qx, qy, cov), _ = dot_truth(sc, {})
        Z = dist + r * r / (2 * RADIUS)
        rpx, u0, v0 = cam.f * r * math.sqrt(1 - r * r / (4 * RADIUS**2)) / Z, cam.cx - cam.f * lat[0] / Z, cam.cy - cam.f * lat[1] / Z
        dcov = region_coverage(lambda u, v, l: (u - u0)**2 + (v - v0)**2 < rpx**2, qx.astype(float), qy.astype(float), 0 * qx, {}, 1)
        L.append(f"  - dot {i} (r {r*1e3:.0f} mm at {dist} m, centre ({u0:.3f}, {v0:.3f}), radius {rpx:.4f} px): coverage {area[0]:.6f} px^2 "
                 f"vs pi rpx^2 {math.pi*rpx**2:.6f} (rel {area[0]/(math.pi*rpx**2)-1:+.1e}; pi (f r/dist)^2 = {math.pi*(cam.f*r/dist)**2:.3f}); "
                 f"centroid - centre ({cen[0,0]-u0:+.1e}, {cen[0,1]-v0:+.1e}) px; per pixel max |cap - analytic disc| {np.abs(cov - dcov).max():.1e}")
    sc = Scene(cam, R_DESIRED, T_DESIRED, pts, radii(101))
    ang, picks = sc.view_angle_deg(), []
    L.append("- convergence on boundary pixels (desired pose, camera A), grey levels (205 or 135 x coverage): rows n = 32 / 64 / "
             "128 / 256 (exact along each row) | columns, same | plain point grid 32^2 / 64^2 / 128^2 / 512^2")
    for i in (0, 50, 1 + int(np.argmax(np.where(ang[1:] < 89, ang[1:], 0)))):
        px, py, _ = dot_truth(sc, {}, [i])[2]
        m = np.flatnonzero(mixed(probe(sc.in_dot, px.astype(float), py.astype(float), np.full(len(px), i), 8)))
        picks += [(f"dot {i} ({ang[i]:.0f} deg)", px[j], py[j], i, sc.in_dot, 205) for j in m[::7][:2]]
    d, rho = pixel_rays(cam)
    th = np.arccos(np.clip(d @ unit(sc.C), -1, 1)) - math.asin(RADIUS / np.linalg.norm(sc.C))
    picks += [("limb", px, py, 0, sc.in_sphere, 135) for py, px in np.argwhere(np.abs(th) < 0.3 * rho)[::400][:2]]
    for name, px, py, lab, f, k in picks:
        a = [np.array([float(px)]), np.array([float(py)]), np.array([lab])]
        g = ([row_coverage(f, *a, n)[0] for n in (32, 64, 128, 256)], [row_coverage(lambda x, y, l: f(y, x, l), a[1], a[0], a[2], n)[0]
             for n in (32, 64, 128, 256)], [grid_coverage(f, *a, n)[0] for n in (32, 64, 128, 512)])
        L.append(f"  - {name} pixel ({px}, {py}): " + " | ".join(" / ".join(f"{k * c:.4f}" for c in row) for row in g))
    camb = Camera("B", **CAMERAS["B"])
    v, u = np.mgrid[0:1024:7, 0:1280:7].astype(float)
    ub, vb = camb.distort(*camb.undistort(u, v))
    L.append(f"- camera B: max |distort(undistort(q)) - q| over a 7 px grid {np.hypot(ub - u, vb - v).max():.1e} px")
    for c in (cam, camb):
        st, t0 = {}, time.time()
        area = render(Scene(c, R_DESIRED, T_DESIRED, pts, radii(101)), st)[1]
        L.append(f"- full render, desired pose, camera {c.name}: {time.time()-t0:.1f} s, {int((area > 0).sum())} dots visible, "
                 f"{stats_text(st)}")
    text = "## Validation\n\n" + "\n".join(L) + "\n"
    print(text)
    (out / "validation.md").write_text(text)


def stats_text(st):
    return (f"{st['mixed']} mixed pixels, max |n64 - n32| {st['d64']:.3f} grey; {st.get('n128', 0)} at n = 128, max |n128 - n64| "
            f"{st.get('d128', 0):.3f}; {st.get('n256', 0)} at 256, max |n256 - n128| {st.get('d256', 0):.3f}; "
            f"{st.get('n512', 0)} at 512, max |n512 - n256| {st.get('d512', 0):.3f}")


def render_set(args, cam, poses, folder, dev_mm):
    """Render (or reuse) every view of a set; returns the per-view truth records."""
    (args.out / folder).mkdir(parents=True, exist_ok=True)
    recs, nominal, ci = [], s_path(), list(CAMERAS).index(cam.name)
    for k, (R, t) in enumerate(poses):
        stem = args.out / folder / f"{cam.name}_{k:02d}"
        if not args.force and stem.with_suffix(".png").exists() and stem.with_suffix(".truth.json").exists():
            recs.append(json.loads(stem.with_suffix(".truth.json").read_text()))
            continue
        dots = deviate(nominal, np.random.default_rng([args.seed, ci, k, 2]), dev_mm) if dev_mm > 0 else nominal
        sc, st, t0 = Scene(cam, R, t, dots, radii(101)), {}, time.time()
        img, area, cen, cut = render(sc, st)
        img += np.random.default_rng([args.seed, ci, k, 1]).normal(0.0, 1.0, img.shape)
        Image.fromarray(np.clip(np.round(img), 0, 255).astype(np.uint8)).save(stem.with_suffix(".png"))
        recs.append(dict(file=stem.name + ".png", R=R.tolist(), t_m=t.tolist(), dots_m=dots.tolist(), area_px=area.tolist(),
                         centroid_px=np.nan_to_num(cen, nan=-1).tolist(), cut=cut.tolist(), view_deg=sc.view_angle_deg().tolist(), stats=st))
        stem.with_suffix(".truth.json").write_text(json.dumps(recs[-1]))
        print(f"{folder}/{stem.name}: {time.time() - t0:.1f} s, {int((area > 0).sum())} dots visible, {stats_text(st)}", flush=True)
    return recs


def camera_file(args, cam):
    """The camera an image was rendered with, as OpenCV's YAML (for ``detect --camera``), written once."""
    c, path = CAMERAS[cam], args.out / f"camera_{cam}.yml"
    if path.exists():
        return path
    k1, k2, k3 = c["k"]
    path.write_text(f"%YAML:1.0\n---\nimage_width: {c['w']}\nimage_height: {c['h']}\n"
                    f"camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                    f"   data: [ {c['f']!r}, 0., {c['cx']!r}, 0., {c['f']!r}, {c['cy']!r}, 0., 0., 1. ]\n"
                    f"distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
                    f"   data: [ {k1!r}, {k2!r}, 0., 0., {k3!r} ]\n")
    return path


def detect(args, png):
    out = png.with_suffix(".det_camera.json" if args.calibrated else ".det.json")
    camera = ["--camera", str(camera_file(args, png.name.split("_")[0]))] if args.calibrated else []
    subprocess.run([str(args.binary), "detect", str(png), "--target", "s-path", "--json", str(out)] + camera, check=True,
                   stdout=subprocess.DEVNULL, env=dict(os.environ, RAYON_NUM_THREADS="1"), timeout=300)
    return json.loads(out.read_text())["images"][0]


def score(recs, dets, cam_name):
    """Figures of one camera's views: a detection > 1 px from its index's exact centroid is false."""
    s = dict(views=len(recs), found=0, eligible=0, cut=0, cut_reported=0, cut_errs=[], missed=[], recalled=0, false=0, wrong_index=0, order=0, errs=[], worst=[], notes=[])
    for k, (rec, det) in enumerate(zip(recs, dets)):
        area, cen = np.array(rec["area_px"]), np.array(rec["centroid_px"])
        eq, vis = np.sqrt(area / math.pi), area > 0
        cut = np.array(rec.get("cut", [False] * len(area)), bool)
        ok = (eq >= MIN_EQ_R) & ~cut
        s["eligible"] += int(ok.sum())
        s["cut"] += int(((eq >= MIN_EQ_R) & cut).sum())
        got = set(det.get("indices") or [])
        s["missed"] += [(cam_name, k, i, float(eq[i]), rec["view_deg"][i]) for i in np.flatnonzero(ok) if i not in got]
        s["found"] += bool(det["found"])
        s["notes"] += [] if det["found"] else [f"{cam_name}_{k:02d}: {det.get('note') or det.get('error')}"]
        false_here = 0
        for p, i in zip(det.get("points_px") or [], det.get("indices") or []):
            e = float(np.hypot(*(np.array(p) - cen[i]))) if vis[i] else math.inf
            if cut[i] and e <= 1.0:
                s["cut_reported"] += 1
                s["cut_errs"].append(e)
            elif e > 1.0:
                false_here += 1
                s["wrong_index"] += bool(vis.any() and np.hypot(*(cen[vis] - p).T).min() <= 1.0)
            elif ok[i]:
                s["recalled"] += 1
                s["errs"].append(e)
                s["worst"].append((e, cam_name, k, i, float(eq[i]), rec["view_deg"][i]))
        s["false"] += false_here
        s["order"] += bool(det["found"]) and false_here == 0
    return s


def merge(parts):
    return {k: sum((p[k] for p in parts), [] if isinstance(parts[0][k], list) else 0) for k in parts[0]}


def table(results):
    rows = ["| set | camera | views | found | recall (eq. radius >= 1.5 px, not cut) | false dots (wrong index) | order right | "
            "error vs exact centroid RMS / p99 / max px | cut by the border (reported) |", "|---|---|---|---|---|---|---|---|---|"]
    notes = []
    for set_name, cams in results:
        m = merge(list(cams.values()))
        for cam, s in list(cams.items()) + [("all", m)]:
            e = np.array(s["errs"])
            err = f"{math.sqrt((e**2).mean()):.4f} / {np.percentile(e, 99):.4f} / {e.max():.4f}" if len(e) else "-"
            cut_err = f", max {max(s['cut_errs']):.3f} px from the visible part's centroid" if s["cut_errs"] else ""
            rows.append(f"| {set_name} | {cam} | {s['views']} | {s['found']} | {s['recalled']}/{s['eligible']} "
                        f"({100 * s['recalled'] / max(s['eligible'], 1):.2f} %) | {s['false']} ({s['wrong_index']}) | {s['order']} | {err} | {s['cut']} ({s['cut_reported']}{cut_err}) |")
        notes.append(f"\nWorst 5 dots, {set_name} (error px, camera_view, index, eq. radius px, angle from cap normal):")
        notes += [f"- {w[0]:.4f}  {w[1]}_{w[2]:02d}  dot {w[3]}  r_eq {w[4]:.2f}  {w[5]:.1f} deg" for w in sorted(m["worst"], reverse=True)[:5]]
        if m["missed"]:
            notes += [f"\nMissed, {set_name}: {len(m['missed'])} dots (camera_view, index, eq. radius px, angle from cap normal)"]
            notes += [f"- {w[0]}_{w[1]:02d}  dot {w[2]}  r_eq {w[3]:.2f}  {w[4]:.1f} deg" for w in m["missed"][:12]]
            notes += [f"- ... {len(m['missed']) - 12} more"] if len(m["missed"]) > 12 else []
        if m["notes"]:
            notes += [f"\nNot found, {set_name}: {len(m['notes'])} views"] + [f"- {n}" for n in m["notes"][:6]]
            notes += [f"- ... {len(m['notes']) - 6} more"] if len(m["notes"]) > 6 else []
    return "\n".join(rows + notes) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--views", type=int, default=20, help="views per camera (default 20)")
    ap.add_argument("--seed", type=int, default=None, help="seeds poses, deviations and noise (default: a fresh one, printed)")
    ap.add_argument("--deviate-mm", type=float, default=7.0, help="second set's cap offsets, mm (default 7; 0: no second set)")
    ap.add_argument("--narrow", action="store_true", help="the earlier sessions' narrow poses (orbit 0-15 deg, 0.1-0.2 m, "
                    "whole outline in view) instead of the wide ones (sample_poses)")
    ap.add_argument("--cameras", default="A,B", help="subset of A,B")
    ap.add_argument("--out", type=Path, default=None, help="default /work/scratch/spath_indep/{wide,narrow}_sSEED")
    ap.add_argument("--binary", type=Path, default=REPO / "target/release/synthcam")
    ap.add_argument("--wait-min", type=float, default=40.0, help="minutes to wait for --binary, polled every 60 s (default 40)")
    ap.add_argument("--validate", action="store_true", help="run the validation only")
    ap.add_argument("--no-detect", action="store_true", help="render only")
    ap.add_argument("--force", action="store_true", help="re-render views that exist")
    ap.add_argument("--calibrated", action="store_true", help="detect with `--camera` (the camera the views were rendered "
                    "with, as OpenCV YAML): dots placed by the camera's pose instead of a projective camera")
    args = ap.parse_args()
    if args.seed is None:
        args.seed = int.from_bytes(os.urandom(4), "little") % 1_000_000
    print(f"seed {args.seed} (rerun with --seed {args.seed})", flush=True)
    if args.out is None:
        args.out = Path(f"/work/scratch/spath_indep/{'narrow' if args.narrow else 'wide'}_s{args.seed}")
    args.out.mkdir(parents=True, exist_ok=True)
    if args.validate:
        return validate(args.out)
    cams = [Camera(c, **CAMERAS[c]) for c in args.cameras.split(",")]
    sets = [("caps course-like", "caps", 0.0)]
    sets += [(f"caps, {args.deviate_mm:g} mm deviations", f"caps_dev{args.deviate_mm:g}mm", args.deviate_mm)] if args.deviate_mm > 0 else []
    poses = {c.name: sample_poses(c, np.random.default_rng([args.seed, list(CAMERAS).index(c.name), 0]), args.views, not args.narrow) for c in cams}
    truth = {(folder, c.name): render_set(args, c, poses[c.name], folder, dev) for _, folder, dev in sets for c in cams}
    if args.no_detect:
        return 0
    deadline = time.time() + 60 * args.wait_min
    while not args.binary.exists():
        if time.time() > deadline:
            sys.exit(f"{args.binary} did not appear within {args.wait_min:g} min; the renders are in {args.out}")
        print(f"waiting for {args.binary} ...", flush=True)
        time.sleep(60)
    stamp = f"sha256 {hashlib.sha256(args.binary.read_bytes()).hexdigest()[:12]}, built {time.ctime(args.binary.stat().st_mtime)}"
    results = [(label, {c.name: score(truth[(folder, c.name)], [detect(args, args.out / folder / r["file"]) for r in truth[(folder, c.name)]],
                                      c.name) for c in cams}) for label, folder, _ in sets]
    md = (f"Independent caps check: `benches/spath_independent.py --views {args.views} --seed {args.seed} --deviate-mm {args.deviate_mm:g} "
          f"--cameras {args.cameras}{' --narrow' if args.narrow else ''}{' --calibrated' if args.calibrated else ''}`, binary {args.binary} ({stamp}); camera A f 1500 no distortion, B f 1200 k1 -0.1; noise sigma 1 "
          f"grey.\n\n" + table(results))
    print(md)
    suffix = "_calibrated" if args.calibrated else ""
    (args.out / f"results{suffix}.md").write_text(md)
    (args.out / f"results_{stamp.split()[1].rstrip(',')}{suffix}.md").write_text(md)


if __name__ == "__main__":
    sys.exit(main())
