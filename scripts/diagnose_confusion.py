#!/usr/bin/python3
"""The figures of issue #15 for `omni_fit diagnose` on generated data, as Markdown tables.

1. Single effects: `omni_fit sweep --json` over every named effect of the catalogue (the table's
   two sweep magnitudes, noise 5e-5 and 2e-4 rad; `--quick`: the larger magnitude, 5e-5 rad) and
   the effect-free cases: a confusion matrix, the share named right, and the effect-free cases
   named `none` with the verdict "explained" (goal >= 95 %).
2. Pairs: for each pair of catalogue effects the two cases' `omni_gen` commands of the sweep (the
   larger magnitude, the same seed and noise) merged into one dataset, then `omni_fit diagnose
   --json` (default --max-effects): both named (goal >= 80 %).

The seeds default to ones no test uses (tests use 1-14 and the bench 3). Cases run side by side
(--jobs, one thread each). Example (the numbers in docs/diagnose.md):

    /usr/bin/python3 scripts/diagnose_confusion.py --build build/release --seeds 31 --quick \
        --pairs 10 -o out/confusion.md

--effects a,b,... restricts the cases (and the pairs) to those effects; --free-seeds N sets the
number of effect-free datasets (seeds from the first of --seeds; default one per seed).
"""

import argparse
import itertools
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor


def run_json(cmd):
    """Runs cmd, returns the last stdout line parsed as JSON (None on failure)."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.stderr.write(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr[-2000:]}\n")
        return None
    lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
    return json.loads(lines[-1]) if lines else None


def matrix_md(title, rows, cols, counts):
    out = [title, "", "| hidden \\ named | " + " | ".join(cols) + " |",
           "|---|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            n = counts.get((r, c), 0)
            cells.append(f"**{n}**" if r == c and n else str(n))
        out.append(f"| {r} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def sweep(args, bins, seeds, effects):
    """`omni_fit sweep --json` on `seeds` (the hidden `effects`; None: the whole catalogue)."""
    cmd = [bins["omni_fit"], "sweep", "--json", "--threads", str(args.jobs), "--seeds",
           *[str(s) for s in seeds]]
    if effects:
        cmd += ["--effects", *effects]
    if args.quick:
        cmd.append("--quick")
    j = run_json(cmd)
    if j is None:
        sys.exit("omni_fit sweep failed: " + " ".join(cmd))
    return j["cases"]


def singles(args, bins):
    """The single-effect cases (--effects; default the catalogue) on --seeds, and the effect-free
    ones: one per seed of --seeds, or --free-seeds N seeds from the first one."""
    t0 = time.time()
    effects = [e for e in args.effects if e != "none"] if args.effects else None
    if args.free_seeds is None and not effects:
        cases = sweep(args, bins, args.seeds, None)  # the catalogue with `none`
    else:
        if effects is None:  # the catalogue without `none`: the effect-free cases come after
            cases = [c for c in sweep(args, bins, args.seeds, None) if c["effect"] != "none"]
        else:
            cases = sweep(args, bins, args.seeds, effects)
        n_free = len(args.seeds) if args.free_seeds is None else args.free_seeds
        if n_free > 0:
            cases += sweep(args, bins, [args.seeds[0] + k for k in range(n_free)], ["none"])
    return cases, time.time() - t0


def pair_case(args, bins, a, b, tmp):
    """One dataset with cases a and b's effects (same seed, pose and noise), diagnosed."""
    ga, gb = shlex.split(a["generate"]), shlex.split(b["generate"])
    folder = os.path.join(tmp, f"{a['effect']}+{b['effect']}_{a['seed']}")
    gen = [bins["omni_gen"]] + [folder if x == "DIR" else x for x in ga[1:]]
    # b's effects: --effect X, --disturbance-pulses X, --unrecorded-disturbance; b with the
    # bundled Coulomb friction (no --no-coulomb) turns it back on.
    i = 0
    while i < len(gb):
        if gb[i] in ("--effect", "--disturbance-pulses") and i + 1 < len(gb):
            if gb[i] == "--effect" or "--disturbance-pulses" not in gen:
                gen += gb[i:i + 2]
            i += 2
            continue
        if gb[i] == "--unrecorded-disturbance" and gb[i] not in gen:
            gen.append(gb[i])
        i += 1
    if "--no-coulomb" not in gb:
        gen = [x for x in gen if x != "--no-coulomb"]
    p = subprocess.run(gen, capture_output=True, text=True)
    if p.returncode != 0:
        sys.stderr.write(f"omni_gen failed ({p.returncode}): {' '.join(gen)}\n{p.stderr[-2000:]}\n")
    t0 = time.time()
    j = run_json([bins["omni_fit"], "diagnose", folder, "--json", "--threads", "1", "--no-plots"])
    named = [n["effect"] for n in (j or {}).get("named", [])]
    # candidates the data cannot tell from the named effects (separability.hpp)
    not_separable = {n["effect"]: n["from"] for n in (j or {}).get("not_separable", [])}
    return {"hidden": [a["effect"], b["effect"]], "named": named, "not_separable": not_separable,
            "verdict": (j or {}).get("verdict"), "seconds": time.time() - t0,
            "error_before": (j or {}).get("error_before"), "error_after": (j or {}).get("error_after"),
            "generate": " ".join("DIR" if x == folder else x for x in gen)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build/release", help="the build folder (apps/omni_fit, apps/omni_gen)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[31, 32])
    ap.add_argument("--quick", action="store_true", help="one magnitude and one noise level per effect")
    ap.add_argument("--pairs", type=int, default=10, help="catalogue pairs to diagnose (0: none)")
    ap.add_argument("--jobs", type=int, default=2, help="cases side by side")
    ap.add_argument("--effects", type=lambda t: [e for e in t.split(",") if e], default=None,
                    help="a,b,...: only these hidden effects (catalogue names; pairs among them)")
    ap.add_argument("--free-seeds", type=int, default=None,
                    help="effect-free datasets, seeds from the first of --seeds (default: one per seed)")
    ap.add_argument("-o", "--out", help="write the Markdown here too")
    ap.add_argument("--keep", help="keep the pairs' datasets in this folder (default: a temporary one)")
    args = ap.parse_args()
    bins = {b: os.path.join(args.build, "apps", b, b) for b in ("omni_fit", "omni_gen")}
    for b in bins.values():
        if not os.access(b, os.X_OK):
            sys.exit(f"not found: {b} (build the omni_fit and omni_gen targets)")

    cases, t_single = singles(args, bins)
    kinds = []
    for c in cases:
        if c["effect"] not in kinds:
            kinds.append(c["effect"])
    counts = {}
    for c in cases:
        counts[(c["effect"], c["named"])] = counts.get((c["effect"], c["named"]), 0) + 1
    cols = kinds + sorted({c["named"] for c in cases} - set(kinds))
    eff = [c for c in cases if c["effect"] != "none"]
    free = [c for c in cases if c["effect"] == "none"]
    right = sum(c["named"] == c["effect"] for c in eff)
    free_ok = sum(c["named"] == "none" and c["verdict"] == "explained" for c in free)
    md = [matrix_md(f"Single effects: {len(cases)} cases, seeds {' '.join(map(str, args.seeds))}, "
                    f"{len(free)} effect-free; "
                    f"{'one magnitude, noise 5e-5 rad' if args.quick else 'two magnitudes, noise 5e-5 and 2e-4 rad'}; "
                    f"{t_single:.0f} s.", kinds, cols, counts), "",
          f"Right effect named: {right}/{len(eff)} ({100.0 * right / max(len(eff), 1):.0f} %; goal >= 90 %). "
          f"Effect-free named `none` with the verdict explained: {free_ok}/{len(free)} "
          f"({100.0 * free_ok / max(len(free), 1):.0f} %; goal >= 95 %)."]

    if args.pairs > 0:
        # The larger magnitude (first listed) of each effect at the lowest noise, first seed.
        first = {}
        for c in eff:
            if c["seed"] == args.seeds[0] and c["noise_std_rad"] == min(x["noise_std_rad"] for x in eff):
                first.setdefault(c["effect"], c)
        pairs = list(itertools.combinations(sorted(first), 2))
        # Spread over the catalogue: every k-th pair.
        step = max(1, len(pairs) // args.pairs)
        chosen = pairs[::step][: args.pairs]
        t0 = time.time()
        with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.jobs) as pool:
            where = tmp
            if args.keep:
                os.makedirs(args.keep, exist_ok=True)
                where = args.keep
            res = list(pool.map(lambda p: pair_case(args, bins, first[p[0]], first[p[1]], where), chosen))
        both = stated = 0
        rows = ["| hidden | named (in order) | not separable (from) | verdict | RMS before → after [rad] | s |",
                "|---|---|---|---|---|---|"]
        for r in res:
            ok = set(r["hidden"]) <= set(r["named"])
            both += ok
            # not named, but said to be not separable from a named effect (not counted as named)
            missing = set(r["hidden"]) - set(r["named"])
            stated += (not ok) and set(r["hidden"]) & set(r["named"]) != set() and \
                missing <= set(r["not_separable"])
            ns = "; ".join(f"{e} ({' + '.join(f)})" for e, f in r["not_separable"].items()) or "–"
            fmt = lambda x: f"{x:.3g}" if isinstance(x, (int, float)) else "?"
            rows.append(f"| {' + '.join(r['hidden'])} | {', '.join(r['named']) or 'none'}{'' if ok else ' ✗'} | {ns} | "
                        f"{r['verdict']} | {fmt(r['error_before'])} → {fmt(r['error_after'])} | {r['seconds']:.0f} |")
        md += ["", f"Pairs: {len(res)} datasets (seed {args.seeds[0]}, the larger magnitudes, noise "
                   f"{min(x['noise_std_rad'] for x in eff):g} rad); {time.time() - t0:.0f} s.", ""] + rows
        md += ["", f"Both effects named: {both}/{len(res)} ({100.0 * both / max(len(res), 1):.0f} %; goal >= 80 %). "
                   f"Of the others, {stated} named one and said the other is not separable from it on these data."]
        # each pair's dataset, to look at one closely (omni_gen, then omni_fit diagnose DIR)
        md += ["", "Datasets:", ""] + [f"- {' + '.join(r['hidden'])}: `{r['generate']}`" for r in res]
    text = "\n".join(md) + "\n"
    print(text)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        tmp = args.out + ".tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, args.out)  # atomic


if __name__ == "__main__":
    main()
