#!/usr/bin/env python3
"""A straightforward NumPy implementation of `mtcal identify --json` (joint method,
polynomial basis of order 3, default topology), for the whole-process comparison in
BENCHMARKS.md.

Usage: python3 bench/identify_numpy.py SESSION_DIR > result.json

The model is the one of crates/solver/src/design.rs and docs/conventions.md, written
the way a NumPy user would write it:

* each plane CSV is read with ``np.loadtxt`` (run, t_s, x_mm, y_mm, z_mm, du_um, dv_um);
* the linearised volumetric error e = sum_k [delta_k(q_k) + eps_k(q_k) x a_k] +
  squareness terms, with (q/h)^k monomials (straightness: powers 2..N), is assembled
  as a dense design matrix of two rows per sample (readings along u and v), plus one
  plate rotation column per mounting;
* the run zero offsets are eliminated by centring every column and reading within each
  (run, direction) group, file by file;
* the column-scaled system is reduced by one Householder QR (``np.linalg.qr``), and
  everything else (solution, rank, condition number, covariance, null space) comes
  from the SVD of the small triangular factor;
* values on the 5 mm grid with their standard uncertainties, straightness about its
  least-squares line (8-point Gauss-Legendre), squareness between the least-squares
  axis lines, the residual RMS overall and per file, and the spectral noise floor
  (crates/solver/src/noise.rs) are reported as JSON.

Not included (so the reference does less than mtcal): the ISO 230-2/230-4 figures,
the circle plots, the residuals per test, the advice on extra tests and the noise
from pass differences. A check against mtcal's own document on the same session is
`python3 bench/identify_numpy.py DIR --compare mtcal.json`.
"""

import json
import os
import sys

import numpy as np

AXES = "XYZ"
ORDER = 3
GRID_MM = 5.0
PARKED_MM = 1e-3
RANK_RTOL = 1e-9
NULL_TOL = 1e-6
PLANE_AXES = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}
# Default topology: workpiece [X, Y] (bed outward), tool [Z].
WORKPIECE = [0, 1]
TOOL = [2]


def term_list():
    """The 18 terms in the solver's order: per axis, translations along X, Y, Z, then
    rotations about X, Y, Z."""
    out = []
    for axis in range(3):
        for rot in (False, True):
            for d in range(3):
                name = "E" + ("ABC"[d] if rot else AXES[d]) + AXES[axis]
                straight = (not rot) and d != axis
                out.append((name, axis, rot, d, straight))
    return out


TERMS = term_list()


def powers(straight):
    return list(range(2 if straight else 1, ORDER + 1))


def abbe_arm(axis, q, t):
    """Arm from axis `axis`'s frame to the tool point, per sample (n x 3)."""
    arm = np.broadcast_to(np.asarray(t, float), q.shape).copy()
    if axis in TOOL:
        for k in TOOL[TOOL.index(axis) + 1 :]:
            arm[:, k] += q[:, k]
    else:
        for k in TOOL:
            arm[:, k] += q[:, k]
        for k in WORKPIECE[: WORKPIECE.index(axis) + 1]:
            arm[:, k] += q[:, k]
    return arm


def term_gradient(term, q, t):
    """d e / d term (n x 3), µm per µm or per µrad."""
    _, axis, rot, d, _ = term
    g = np.zeros_like(q)
    if not rot:
        g[:, d] = 1.0
        return g
    u = np.zeros(3)
    u[d] = 1.0
    return np.cross(u, abbe_arm(axis, q, t)) * 1e-3


def read_session(folder):
    with open(os.path.join(folder, "session.json")) as f:
        spec = json.load(f)
    planes = []
    for p in spec["planes"]:
        a = np.loadtxt(
            os.path.join(folder, p["file"]),
            delimiter=",",
            skiprows=1,
            usecols=range(7),
            comments="#",
        )
        planes.append((p, a))
    return spec, planes


def measured_travel(planes):
    travel = [None, None, None]
    for _, a in planes:
        runs = a[:, 0]
        for r in np.unique(runs):
            q = a[runs == r, 2:5]
            lo, hi = q.min(axis=0), q.max(axis=0)
            for k in range(3):
                if hi[k] - lo[k] > PARKED_MM:
                    if travel[k] is None:
                        travel[k] = (lo[k], hi[k])
                    else:
                        travel[k] = (min(travel[k][0], lo[k]), max(travel[k][1], hi[k]))
    return travel


class Model:
    def __init__(self, travel):
        self.travel = travel
        self.params = []  # (term index or None, power or squareness index)
        self.half = {}
        for i, term in enumerate(TERMS):
            axis = term[1]
            if travel[axis] is None:
                continue
            lo, hi = travel[axis]
            self.half[i] = max(abs(lo), abs(hi), 1.0)
            for k in powers(term[4]):
                self.params.append((i, k))
        for s in range(3):
            self.params.append((None, s))

    def term_value_gradient(self, i, q):
        """Gradient of term i's value at position q with respect to the parameters."""
        g = np.zeros(len(self.params))
        for j, (ti, k) in enumerate(self.params):
            if ti == i:
                g[j] = (q / self.half[i]) ** k
        return g

    def design(self, q, t, dirs):
        """Error-parameter columns (n x len(params)) for the readings along `dirs`."""
        n = q.shape[0]
        out = np.zeros((n, len(self.params)))
        grads = {}
        for j, (ti, k) in enumerate(self.params):
            if ti is None:
                y, z = q[:, 1] * 1e-3, q[:, 2] * 1e-3
                sq = [(-y, 0 * y, 0 * y), (z, 0 * z, 0 * z), (0 * z, -z, 0 * z)][k]
                out[:, j] = np.choose(dirs, sq)
                continue
            if ti not in grads:
                g = term_gradient(TERMS[ti], q, t)
                grads[ti] = g[np.arange(n), dirs]
            s = q[:, TERMS[ti][1]] / self.half[ti]
            out[:, j] = grads[ti] * s**k
        return out


def centre_by_group(m, groups, ngroups):
    """Subtracts each (run, direction) group's mean from every column of m."""
    counts = np.bincount(groups, minlength=ngroups)
    if m.ndim == 1:
        return m - (np.bincount(groups, m, ngroups) / counts)[groups]
    means = np.stack(
        [np.bincount(groups, m[:, c], ngroups) for c in range(m.shape[1])], axis=1
    ) / counts[:, None]
    return m - means[groups]


def assemble(spec, planes, model):
    """The centred design matrix [plate rotations | error parameters] and readings of
    every file, stacked; the run offsets eliminated file by file (a run belongs to one
    file)."""
    mountings = []
    for p, _ in planes:
        if p.get("mounting", p["file"]) not in mountings:
            mountings.append(p.get("mounting", p["file"]))
    blocks, rhs, files = [], [], []
    ngroups = 0
    for f, (p, a) in enumerate(planes):
        iu, iv = PLANE_AXES[p["plane"]]
        t = np.asarray(p["head_offset_mm"], float)
        q = a[:, 2:5]
        n = q.shape[0]
        _, run_idx = np.unique(a[:, 0], return_inverse=True)
        nruns = run_idx.max() + 1
        head = q + t
        rot = np.zeros((2 * n, len(mountings)))
        m = mountings.index(p.get("mounting", p["file"]))
        rot[:n, m] = head[:, iv] * 1e-3
        rot[n:, m] = -head[:, iu] * 1e-3
        dirs = np.concatenate([np.full(n, iu), np.full(n, iv)])
        err = model.design(np.vstack([q, q]), t, dirs)
        groups = np.concatenate([run_idx, nruns + run_idx])
        blocks.append(centre_by_group(np.hstack([rot, err]), groups, 2 * nruns))
        rhs.append(centre_by_group(np.concatenate([a[:, 5], a[:, 6]]), groups, 2 * nruns))
        files.append(np.full(2 * n, f))
        ngroups += 2 * nruns
    return mountings, np.vstack(blocks), np.concatenate(rhs), ngroups, np.concatenate(files)


def block_rank(r, cols):
    if len(cols) == 0:
        return 0
    s = np.linalg.svd(r[:, cols], compute_uv=False)
    return int(np.sum((s > s[0] * RANK_RTOL) & (s > 0)))


def spectral_floor(planes):
    """The noise floor of crates/solver/src/noise.rs: per run and direction, clipped
    first differences, Hann-windowed (sin^2 of (t + 1/2)) segments of 64 (hop 32), periodogram bins 16..26
    normalised by the differenced-white-noise gain; median over segments per bin, median
    over bins, / ln 2."""
    seg, hop = 64, 32
    w = np.sin(np.pi * (np.arange(seg) + 0.5) / seg) ** 2
    sw2 = np.sum(w * w)
    lag1 = np.sum(w[:-1] * w[1:]) / sw2
    bins = np.arange(16, 27)
    gain = 2 - 2 * np.cos(2 * np.pi * bins / seg) * lag1
    per_bin = []
    for _, a in planes:
        runs = a[:, 0]
        for r in np.unique(runs):
            rows = a[runs == r]
            for c in (5, 6):
                if rows.shape[0] < seg + 1:
                    continue
                d = np.diff(rows[:, c])
                med = np.median(d)
                mad = 1.4826 * np.median(np.abs(d - med))
                if mad > 0:
                    d = np.clip(d, med - 5 * mad, med + 5 * mad)
                segs = np.lib.stride_tricks.sliding_window_view(d, seg)[::hop]
                spec = np.fft.rfft(segs * w, axis=1)[:, bins]
                per_bin.append(np.abs(spec) ** 2 / sw2 / gain)
    if not per_bin:
        return None
    j = np.vstack(per_bin)
    return float(np.sqrt(np.median(np.median(j, axis=0)) / np.log(2)))


def grid(lo, hi, step):
    g = [k * step for k in range(int(np.ceil(lo / step)), int(np.floor(hi / step)) + 1)]
    if 0.0 not in g:
        g = sorted(g + [0.0])
    return g


def ls_line(model, i, lo, hi):
    """Least-squares line a + b q of term i over [lo, hi] as functionals of the
    parameters (8-point Gauss-Legendre)."""
    s, w = np.polynomial.legendre.leggauss(8)
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    a = np.zeros(len(model.params))
    b = np.zeros(len(model.params))
    for sk, wk in zip(s, w):
        g = model.term_value_gradient(i, c + h * sk)
        wb = 1.5 * wk * sk / h
        a += (0.5 * wk - wb * c) * g
        b += wb * g
    return a, b


def rnd(v):
    return round(float(v) * 1e6) / 1e6


def identify(folder):
    spec, planes = read_session(folder)
    travel = measured_travel(planes)
    model = Model(travel)
    mountings, A, b, ngroups, files = assemble(spec, planes, model)
    nrot = len(mountings)
    norms = np.linalg.norm(A, axis=0)
    norms[norms == 0] = 1.0
    r = np.linalg.qr(np.column_stack([A / norms, b]), mode="r")
    k = A.shape[1]
    R, qtb, rss_out = r[:k, :k], r[:k, k], r[k, k] ** 2 if r.shape[0] > k else 0.0
    u, s, vt = np.linalg.svd(R)
    rank = int(np.sum((s > s[0] * RANK_RTOL) & (s > 0)))
    v = vt.T
    coef = (u[:, :rank].T @ qtb) / s[:rank]
    x = (v[:, :rank] @ coef) / norms
    rss = rss_out + float(np.sum((u[:, rank:].T @ qtb) ** 2))
    rows = A.shape[0]
    dof = max(rows - rank - ngroups, 1)
    sigma2 = rss / dof
    cov = sigma2 * (v[:, :rank] / s[:rank] ** 2) @ v[:, :rank].T / np.outer(norms, norms)
    null = v[:, rank:]
    determined = np.all(np.abs(null) < NULL_TOL, axis=1)
    nerr = k - nrot
    rank_err = block_rank(R, list(range(k))) - block_rank(R, list(range(nrot)))
    xe, cove = x[nrot:], cov[nrot:, nrot:]
    null_e = null[nrot:]

    def estimable(w):
        scaled = w / norms[nrot:]
        scale = np.linalg.norm(scaled)
        return scale == 0 or bool(np.all(np.abs(null_e.T @ scaled) / scale < 10 * NULL_TOL))

    terms, lines = {}, {}
    for i, (name, axis, rot, d, straight) in enumerate(TERMS):
        idx = [j for j, (ti, _) in enumerate(model.params) if ti == i]
        ok = travel[axis] is not None and all(determined[nrot + j] for j in idx)
        rep = {"unit": "urad" if rot else "um", "positions_mm": [], "values": [],
               "std": [], "identifiable": bool(ok)}
        if ok:
            lo, hi = travel[axis]
            line = ls_line(model, i, lo, hi) if straight else None
            if line is not None:
                lines[name] = line
            for q in grid(lo, hi, GRID_MM):
                w = model.term_value_gradient(i, q)
                if line is not None:
                    w = w - line[0] - line[1] * q
                rep["positions_mm"].append(q)
                rep["values"].append(rnd(w @ xe))
                rep["std"].append(rnd(np.sqrt(max(w @ cove @ w, 0.0))))
        terms[name] = rep
    squareness = {}
    for si, (sname, pa, pb, sign) in enumerate(
        [("EC0Y", "EXY", "EYX", -1.0), ("EB0Z", "EXZ", "EZX", 1.0), ("EA0Z", "EYZ", "EZY", -1.0)]
    ):
        w = np.zeros(nerr)
        w[nerr - 3 + si] = 1.0
        for pname in (pa, pb):
            i = [t[0] for t in TERMS].index(pname)
            axis = TERMS[i][1]
            if pname in lines:
                w += sign * 1000.0 * lines[pname][1]
            elif travel[axis] is not None:
                w += sign * 1000.0 * ls_line(model, i, *travel[axis])[1]
        if not estimable(w):
            w = np.zeros(nerr)
            w[nerr - 3 + si] = 1.0
        ok = estimable(w)
        squareness[sname] = {
            "value_urad": rnd(w @ xe) if ok else None,
            "std_urad": rnd(np.sqrt(max(w @ cove @ w, 0.0))) if ok else None,
            "identifiable": bool(ok),
        }
    resid = b - A @ x
    by_file = {}
    for f, (p, _) in enumerate(planes):
        rf = resid[files == f]
        by_file[p["file"]] = rnd(np.sqrt(np.mean(rf**2)))
    noise = spectral_floor(planes)
    return {
        "kind": "identification",
        "machine_id": spec["machine_id"],
        "measured_at": spec["measured_at"],
        "model": {"basis": "polynomial", "order": ORDER,
                  "measured_travel_mm": {AXES[a]: list(map(float, travel[a]))
                                         for a in range(3) if travel[a] is not None}},
        "terms": terms,
        "squareness": squareness,
        "observability": {"parameters": nerr, "rank": rank_err,
                          "condition_number": float(s[0] / s[rank - 1])},
        "fit": {"samples": int(sum(a.shape[0] for _, a in planes)),
                "residual_rms_um": rnd(np.sqrt(rss / rows)),
                "noise_estimate_um": None if noise is None else rnd(noise)},
        "nuisance": {"mountings": {m: {"rotation_urad": rnd(x[j]),
                                       "std_urad": rnd(np.sqrt(cov[j, j]))}
                                   for j, m in enumerate(mountings)},
                     "runs": int(ngroups // 2)},
        "residuals_by_file_um": by_file,
    }


def compare(ours, theirs):
    """Largest differences against mtcal's document, in units of the reported std."""
    worst = 0.0
    for name, t in ours["terms"].items():
        o = theirs["terms"][name]
        assert t["identifiable"] == o["identifiable"], name
        for a, b, s in zip(t["values"], o["values"], o["std"]):
            worst = max(worst, abs(a - b) / max(s, 1e-6))
    for name, q in ours["squareness"].items():
        o = theirs["squareness"][name]
        if q["value_urad"] is not None:
            worst = max(worst, abs(q["value_urad"] - o["value_urad"]) / max(o["std_urad"], 1e-6))
    print(
        f"largest difference of a value: {worst:.2e} std; rank {ours['observability']['rank']}"
        f" vs {theirs['observability']['rank']}; condition {ours['observability']['condition_number']:.4e}"
        f" vs {theirs['observability']['condition_number']:.4e}; residual RMS"
        f" {ours['fit']['residual_rms_um']} vs {theirs['fit']['residual_rms_um']} um; noise"
        f" {ours['fit']['noise_estimate_um']} vs {theirs['fit']['noise_estimate_um']} um",
        file=sys.stderr,
    )


def main():
    result = identify(sys.argv[1])
    if len(sys.argv) == 4 and sys.argv[2] == "--compare":
        with open(sys.argv[3]) as f:
            compare(result, json.load(f))
    json.dump(result, sys.stdout, indent=2)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
