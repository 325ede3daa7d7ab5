#!/usr/bin/env python3
"""A fleet of 20 joints fitted on a Dask cluster, and the spread of their parameters.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/03_fleet.py
    ... 03_fleet.py --quick              # CI: one pose per joint, short runs
    ... 03_fleet.py --compare            # the same batch on 1 and on 2 workers: wall time, speed-up

Each joint is the virtual Omni with its own damping and inertia: every C_n1 of the paper's
alpha-model scaled by exp(N(0, 0.15^2)), the beta~_n1 by exp(N(0, 0.05^2)), the inertia model by
U(0.85, 1.15). The datasets are generated on the workers (alphainv.Dataset.generate options sent
as dicts), fitted there (alphainv.batch.fit_many on a dask.distributed LocalCluster), and the
fitted C(alpha) and beta~(alpha) at each joint's first pose compared with its truth inside the
alpha range its sine runs cover (beyond it the data say nothing about C).
"""

import argparse
import math
import statistics
import sys
import time

import numpy as np

import alphainv
import alphainv.batch


def fleet(n, quick, seed=2026):
    rng = np.random.default_rng(seed)
    paper_a, paper_i = alphainv.AlphaModel.paper(), alphainv.InertiaModel.paper()
    joints = []
    for k in range(n):
        a = alphainv.AlphaModel(paper_a.alpha, paper_a.c_n1 * np.exp(rng.normal(0.0, 0.15, 4)),
                                paper_a.beta_alpha, np.array(paper_a.beta_n1) * np.exp(rng.normal(0.0, 0.05, 2)))
        s = rng.uniform(0.85, 1.15)
        i = alphainv.InertiaModel(i_base=paper_i.i_base * s, i1=paper_i.i1 * s, i2=paper_i.i2 * s,
                                  i3=paper_i.i3 * s, gamma_offs_rad=paper_i.gamma_offs_rad)
        spec = dict(seed=100 + k, alpha_model=a, inertia=i, effects=alphainv.Effects())
        if quick:  # one pose's 10 runs, 2 s transients
            spec.update(pose=k % 9, sine_settle_s=2.0, sine_steady_s=1.0, square_duration_s=4.0)
        joints.append(spec)
    return joints


def run(joints, workers):
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.run(lambda: __import__("alphainv"))  # warm the workers before the clock starts
        t0 = time.perf_counter()
        result = alphainv.batch.fit_many(joints, client=client,
                                         names=[f"joint {k:02d}" for k in range(len(joints))])
        return result, time.perf_counter() - t0


def compare(joints, rows):
    """Fitted C and beta~ at each joint's first pose against its truth, at two alphas inside the
    range its sine runs cover (a quarter and three quarters of the way, on a log scale)."""
    table = []
    for spec, row in zip(joints, rows):
        if not row["ok"]:
            continue
        model = alphainv.Model.from_json(row["model_json"])
        pose = model.poses[0]
        g1, g2 = pose["gamma1_deg"], pose["gamma2_deg"]
        joint, _ = model.at_pose(g1, g2)
        inertia = spec["inertia"].inertia(math.radians(g1), math.radians(g2))
        truth = spec["alpha_model"]
        lo, hi = math.log(row["alpha_data_min"]), math.log(row["alpha_data_max"])
        entry = {"name": row["name"]}
        for q, f in (("lo", 0.25), ("hi", 0.75)):
            a = math.exp(lo + f * (hi - lo))
            entry[f"alpha_{q}"] = a
            entry[f"C_{q} truth"] = float(truth.damping(a, inertia))
            entry[f"C_{q} fit"] = float(joint.damping(a))
            entry[f"b~_{q} truth"] = float(truth.beta_tilde(a, inertia))
            entry[f"b~_{q} fit"] = float(joint.beta_tilde(a))
        table.append(entry)
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--joints", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one pose per joint, short runs (CI)")
    ap.add_argument("--compare", action="store_true", help="time the batch on 1 and on 2 workers")
    ap.add_argument("--out", help="(ignored; for the ctest runner)")
    args = ap.parse_args()
    joints = fleet(args.joints, args.quick)
    if args.compare:
        _, t1 = run(joints, 1)
        result, t2 = run(joints, 2)
        print(f"fit_many of {len(joints)} datasets: 1 worker {t1:.2f} s, 2 workers {t2:.2f} s, "
              f"speed-up {t1 / t2:.2f}x")
    else:
        result, _ = run(joints, args.workers)
    print(result.summary)
    table = compare(joints, result.rows)
    print(f"\n{'joint':<9}" + "".join(f"{k:>12}" for k in list(table[0])[1:]))
    for e in table:
        print(f"{e['name']:<9}" + "".join(f"{v:>12.4g}" for k, v in e.items() if k != "name"))
    print("\nspread over the fleet (CV %) and fit error (median, max |fit/truth - 1| %):")
    good = True
    for q in ("C_lo", "C_hi", "b~_lo", "b~_hi"):
        truth = [e[f"{q} truth"] for e in table]
        fitted = [e[f"{q} fit"] for e in table]
        err = [abs(f / t - 1.0) * 100 for f, t in zip(fitted, truth)]
        # usable: C within 5 % of the truth for the median joint, beta~ within 2 % for every one
        good = good and (statistics.median(err) < 5.0 if q.startswith("C") else max(err) < 2.0)
        print(f"  {q:<7} truth {100 * statistics.pstdev(truth) / statistics.fmean(truth):6.2f} %   "
              f"fit {100 * statistics.pstdev(fitted) / statistics.fmean(fitted):6.2f} %   "
              f"error median {statistics.median(err):5.2f} %, max {max(err):5.2f} %")
    if result.failed or len(table) != len(joints):
        print(f"{len(joints) - len(table)} joints without a usable fit", file=sys.stderr)
        return 1
    return 0 if good else 1


if __name__ == "__main__":
    sys.exit(main())
