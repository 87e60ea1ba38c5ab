"""ISO 230-2:2014 figures of a positioning-run CSV, written from the standard's formulas
independently of mtcal's Rust code (NumPy only). The test
`crates/solver/tests/standards_iso230_2.rs` (`real_runs_against_the_reference_script`)
holds the figures this prints for the two files of `data/ecmccfg_iso230`.

    python3 crates/solver/tests/data/iso230_2_reference.py data/ecmccfg_iso230/*.csv

Per target i, readings x_ij of the approach with increasing command (+, "up") and
decreasing command (-, "down"), j = 1..n:
  mean  x_i = sum_j x_ij / n               s_i = sqrt(sum_j (x_ij - mean)^2 / (n - 1))
  B_i = mean_up - mean_down                R_i_up = 4 s_i_up
  R_i = max(2 s_i_up + 2 s_i_down + |B_i|, R_i_up, R_i_down)
Axis: B = max |B_i|, B_mean = mean B_i, R_up = max R_i_up, R = max R_i,
  E_up = max mean_up - min mean_up, E = max over both directions - min over both,
  M = max (mean_up + mean_down)/2 - min of the same,
  A_up = max(mean_up + 2 s_up) - min(mean_up - 2 s_up), A over both directions together.
"""
import csv
import sys

import numpy as np


def figures(path, drop=()):
    rows = [r for r in csv.DictReader(open(path))]
    keep = [r for k, r in enumerate(rows) if k not in drop]
    targets = sorted({float(r["target_mm"]) for r in keep})
    up, down = [], []
    for t in targets:
        for sign, out in (("+", up), ("-", down)):
            v = np.array([float(r["deviation_um"]) for r in keep
                          if float(r["target_mm"]) == t and r["direction"] == sign])
            out.append((v.mean(), v.std(ddof=1)))
    mu, su = np.array(up).T
    md, sd = np.array(down).T
    b = mu - md
    ri = np.maximum(2 * su + 2 * sd + np.abs(b), np.maximum(4 * su, 4 * sd))
    both_m = np.concatenate([mu, md])
    both_s = np.concatenate([su, sd])
    return {
        "B_um": np.abs(b).max(),
        "B_mean_um": b.mean(),
        "R_up_um": (4 * su).max(),
        "R_down_um": (4 * sd).max(),
        "R_um": ri.max(),
        "E_up_um": mu.max() - mu.min(),
        "E_down_um": md.max() - md.min(),
        "E_um": both_m.max() - both_m.min(),
        "M_um": ((mu + md) / 2).max() - ((mu + md) / 2).min(),
        "A_up_um": (mu + 2 * su).max() - (mu - 2 * su).min(),
        "A_down_um": (md + 2 * sd).max() - (md - 2 * sd).min(),
        "A_um": (both_m + 2 * both_s).max() - (both_m - 2 * both_s).min(),
        "B_i_um": list(np.round(b, 4)),
    }


if __name__ == "__main__":
    for path in sys.argv[1:]:
        print(path)
        for name, v in figures(path).items():
            print(f"  {name} = {v if isinstance(v, list) else round(float(v), 4)}")
        if "ess" in path:
            # Without the two readings of cycle 1's first approach at targets 1 and 2
            # (rows 0 and 1 of the file).
            print("  without rows 0, 1:")
            for name, v in figures(path, drop=(0, 1)).items():
                print(f"    {name} = {v if isinstance(v, list) else round(float(v), 4)}")
