#!/usr/bin/env python3
"""Diagnose a joint: which effect of the catalogue explains where the model and the data disagree.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/02_diagnose.py --out out/py02

Generates one pose's 10 runs of the virtual Omni with an effect hidden in the plant (default a
0.01 V deadzone, `omni_gen paper --seed 4 --pose 4 --no-coulomb --effect deadzone=0.01`), fits
the alpha-model, diagnoses it, and compares what was found with the hidden truth. Writes the
diagnosed model.json and report.md into --out. --dataset DIR diagnoses a dataset folder instead.
"""

import argparse
import pathlib
import sys

import alphainv


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dataset", help="a dataset folder (default: generate one)")
    ap.add_argument("--effect", default="deadzone=0.01", help="the hidden effect (generated data)")
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--out", default="out/python_diagnose")
    ap.add_argument("--quick", action="store_true", help="(CI) fewer candidates")
    args = ap.parse_args()
    if args.dataset:
        ds, hidden = alphainv.Dataset.read(args.dataset), None
    else:
        hidden = alphainv.Effects.parse(args.effect)
        ds = alphainv.Dataset.generate(args.seed, pose=args.seed % 9, effects=hidden)
        print(f"generated {len(ds)} runs with the hidden effect {hidden}")
    options = {}
    if args.quick and hidden is not None:  # the hidden one, a rival and none: a shorter search
        options["candidates"] = sorted(set(hidden.active) | {"offset_torque"})
        options["max_effects"] = len(hidden.active)  # no round after the hidden ones
        options["discover"] = False  # nor the discovered term's fit
    d = alphainv.diagnose(ds, **options)
    print(d.brief_report)
    if not d.ok:
        print(d.report, file=sys.stderr)
        return 3
    for finding in d.before["findings"]:
        print(f"  before: {finding}")
    for c in d.rounds[0]["candidates"]:
        print(f"  {c['effect']:<17} score {c['score'] or float('nan'):.4g}  {c['parameters']}  {c['message']}")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    d.model.write(out / "model.json")
    (out / "report.md").write_text(d.report_markdown)
    print(f"wrote {out / 'model.json'}, {out / 'report.md'}")
    if hidden is not None:
        right = d.effects_named == hidden.active
        for name in hidden.active:
            for p in next(s for s in alphainv.EFFECTS if s.name == name).parameters:
                print(f"  {p.name}: hidden {getattr(hidden, p.name):.4g}, found {getattr(d.effects, p.name):.4g} [{p.unit}]")
        print("named the hidden effect" if right else f"named {d.effects_named}, hidden {hidden.active}")
        return 0 if right else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
