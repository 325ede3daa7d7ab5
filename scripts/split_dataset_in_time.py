#!/usr/bin/python3
"""Splits every run of an alphainv-dataset/1 folder in time, for fitting on one part and
validating on the other (docs/benchmarks.md): rows with t < T go to OUT_A, the others to OUT_B.
The dataset.json of each part is the original's with a `split` note; the runs keep their names.

    scripts/split_dataset_in_time.py DATASET T_SPLIT_S OUT_A OUT_B

Standard library only. Refuses to write into an existing folder."""
import csv
import json
import os
import sys


def main(argv):
    if len(argv) != 5:
        sys.exit(__doc__)
    src, t_split, out_a, out_b = argv[1], float(argv[2]), argv[3], argv[4]
    with open(os.path.join(src, "dataset.json"), encoding="utf-8") as f:
        index = json.load(f)
    for out in (out_a, out_b):
        if os.path.exists(out):
            sys.exit(f"split_dataset_in_time: {out} exists; give a new folder")
    for out, part in ((out_a, f"t < {t_split} s"), (out_b, f"t >= {t_split} s")):
        os.makedirs(out)
        part_index = dict(index)
        part_index["split"] = f"rows with {part} of {os.path.abspath(src)}"
        with open(os.path.join(out, "dataset.json"), "w", encoding="utf-8") as f:
            json.dump(part_index, f, indent=1)
            f.write("\n")
    for run in index["runs"]:
        with open(os.path.join(src, run["file"]), newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header, body = rows[0], rows[1:]
        t_col = [h.strip() for h in header].index("t")
        for out, keep in ((out_a, lambda t: t < t_split), (out_b, lambda t: t >= t_split)):
            path = os.path.join(out, run["file"])
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f, lineterminator="\n")
                w.writerow(header)
                w.writerows(r for r in body if r and keep(float(r[t_col])))


if __name__ == "__main__":
    main(sys.argv)
