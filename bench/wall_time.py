#!/usr/bin/env python3
"""Wall time of whole `mtcal` processes, interleaved, from spawn to exit.

Usage: chrt -f 50 python3 bench/wall_time.py --runs 15 SESSION BIN [BIN ...]

Each round runs every binary once as `BIN identify --json SESSION` (output discarded)
and times it with `time.perf_counter`; prints the median, least and largest per binary.
On a shared machine, start it at real-time priority (`chrt -f 50`, as root): the other
processes, at normal priority, cannot preempt it, so the figures are an idle machine's
(BENCHMARKS.md, "Identification as a whole process").
"""
import argparse
import statistics
import subprocess
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("session")
    ap.add_argument("bins", nargs="+")
    a = ap.parse_args()
    times = {b: [] for b in a.bins}
    for _ in range(a.runs):
        for b in a.bins:
            t = time.perf_counter()
            subprocess.run([b, "identify", "--json", a.session], stdout=subprocess.DEVNULL, check=True)
            times[b].append(time.perf_counter() - t)
    for b, v in times.items():
        print(f"{b}: median {statistics.median(v):.3f} s, min {min(v):.3f} s, max {max(v):.3f} s")


if __name__ == "__main__":
    main()
