#!/usr/bin/env python3
"""The Python module's figures against C++ (issue #17), medians of repeated runs in one process:

    PYTHONPATH=build/release/python /usr/bin/python3 bench/bench_python.py [--dataset data/omni_yaw_sim]

1. alphainv.alpha on 10^6 samples (numpy in, numpy out) vs bench_alpha_array (the same loop in
   C++, Google Benchmark), run here one after the other;
2. alphainv.fit on the bundled set (read included) vs `omni_fit fit --no-plots` (a process).
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import time

import numpy as np

import alphainv

ROOT = pathlib.Path(__file__).resolve().parents[1]


def median_time(f, repeat):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=str(ROOT / "build" / "release"))
    ap.add_argument("--dataset", default=str(ROOT / "data" / "omni_yaw_sim"))
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    build = pathlib.Path(args.build)

    n = 1_000_000
    v = 0.2 * np.sin(2 * np.pi * 3.0 * 1e-3 * np.arange(n))
    t_py = median_time(lambda: alphainv.alpha(v, 1e-3), args.repeat)
    out = subprocess.run([str(build / "bench" / "bench_alpha_array"), f"--benchmark_repetitions={args.repeat}",
                          "--benchmark_report_aggregates_only=true", "--benchmark_format=json"],
                         capture_output=True, text=True, check=True)
    med = next(b for b in json.loads(out.stdout)["benchmarks"] if b["aggregate_name"] == "median")
    t_cpp = med["real_time"] / 1e3  # ms -> s
    print(f"alpha on 1e6 samples: Python {t_py * 1e3:.2f} ms, C++ {t_cpp * 1e3:.2f} ms, "
          f"ratio {t_py / t_cpp:.3f} (medians of {args.repeat})")

    omni_fit = build / "apps" / "omni_fit" / "omni_fit"
    t_fit = median_time(lambda: alphainv.fit(args.dataset), 3)
    t_cli = median_time(lambda: subprocess.run([str(omni_fit), "fit", args.dataset, "-o", "/tmp/bench_python_fit",
                                                "--no-plots", "-q"], check=True), 3)
    print(f"fit of {args.dataset}: alphainv.fit {t_fit:.3f} s, omni_fit fit --no-plots {t_cli:.3f} s, "
          f"ratio {t_fit / t_cli:.3f} (medians of 3)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
