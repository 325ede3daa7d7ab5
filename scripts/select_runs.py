#!/usr/bin/python3
"""Copies the runs of an alphainv-dataset/1 folder whose file name matches a regular expression
into a new dataset folder (dataset.json with those runs only), for fitting on some runs and
validating on others (docs/benchmarks.md).

    scripts/select_runs.py DATASET REGEX OUT

Standard library only. Refuses to write into an existing folder."""
import json
import os
import re
import shutil
import sys


def main(argv):
    if len(argv) != 4:
        sys.exit(__doc__)
    src, pattern, out = argv[1], re.compile(argv[2]), argv[3]
    if os.path.exists(out):
        sys.exit(f"select_runs: {out} exists; give a new folder")
    with open(os.path.join(src, "dataset.json"), encoding="utf-8") as f:
        index = json.load(f)
    runs = [r for r in index["runs"] if pattern.search(r["file"])]
    if not runs:
        sys.exit(f"select_runs: no run of {src} matches {argv[2]}")
    os.makedirs(out)
    for r in runs:
        os.makedirs(os.path.dirname(os.path.join(out, r["file"])), exist_ok=True)
        shutil.copyfile(os.path.join(src, r["file"]), os.path.join(out, r["file"]))
    index["runs"] = runs
    index["selected"] = f"runs of {os.path.abspath(src)} matching {argv[2]}"
    with open(os.path.join(out, "dataset.json"), "w", encoding="utf-8") as f:
        json.dump(index, f, indent=1)
        f.write("\n")
    print(f"select_runs: {len(runs)} runs -> {out}")


if __name__ == "__main__":
    main(sys.argv)
