#!/usr/bin/python3
"""Helpers of scripts/closed-loop.sh (docs/compensation.md): merge omni_ctl recordings into one
dataset, scale a model's effects, and the figures: tracking RMS per run and mode, hold
peak-to-peak, free-motion push, gnuplot tracking plots. numpy only (Debian python3)."""
import json
import math
import os
import subprocess
import sys

import numpy as np


def read_run(folder):
    """The columns of folder/run.csv as a dict of numpy arrays, and dataset.json."""
    with open(os.path.join(folder, "dataset.json")) as f:
        meta = json.load(f)
    path = os.path.join(folder, meta["runs"][0]["file"])
    with open(path) as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}, meta


def merge(out, folders):
    """One alphainv-dataset/1 folder `out` from single-run recordings (runs renamed)."""
    os.makedirs(out, exist_ok=True)
    merged = None
    for i, folder in enumerate(folders):
        with open(os.path.join(folder, "dataset.json")) as f:
            meta = json.load(f)
        run = meta["runs"][0]
        name = "run%02d_%s.csv" % (i, os.path.basename(os.path.normpath(folder)))
        with open(os.path.join(folder, run["file"])) as src, open(os.path.join(out, name), "w") as dst:
            dst.write(src.read())
        run["file"] = name
        if merged is None:
            merged = {k: v for k, v in meta.items() if k != "runs"}
            merged["runs"] = []
            merged["merged_from"] = []
        merged["runs"].append(run)
        merged["merged_from"].append(folder)
    tmp = os.path.join(out, "dataset.json.part")
    with open(tmp, "w") as f:
        json.dump(merged, f, indent=1)
    os.replace(tmp, os.path.join(out, "dataset.json"))


def scale(model_in, factor, model_out):
    """model.json with every effect's size scaled by `factor`: each parameter in command units
    (NAME_v, NAME_v_s, NAME_v_per_rad: Coulomb, offset, gravity, cogging, deadzone, Stribeck,
    asymmetric and position-dependent friction levels, the discovered term's coefficients), not
    the saturation limit, smoothing widths, periods, phases or delays. Exits non-zero when an
    effect has none (a robustness run that scaled nothing would look robust)."""
    with open(model_in) as f:
        m = json.load(f)
    sizes = ("_v", "_v_s", "_v_per_rad")
    for entry in m.get("effects", []):  # [{"effect": NAME, "parameters": {...}}, ...]
        scaled = 0
        for key, value in entry.get("parameters", {}).items():
            if (key.endswith(sizes) and key not in ("saturation_v", "disturbance_rms_v")
                    and isinstance(value, (int, float))):
                entry["parameters"][key] = value * factor
                scaled += 1
        # (No size: a delay, a limit, a torque of time the tick does not compensate.)
        if scaled == 0 and entry.get("effect") not in ("time_delay", "saturation",
                                                       "external_disturbance"):
            sys.exit(f"scale: {model_in}: effect {entry.get('effect')!r} has no size parameter "
                     f"to scale ({sorted(entry.get('parameters', {}))})")
    with open(model_out, "w") as f:
        json.dump(m, f, indent=1)


def tracking_rms(folder, settle_s):
    cols, meta = read_run(folder)
    keep = cols["t"] >= settle_s
    e = cols["r"][keep] - cols["theta"][keep]
    return math.sqrt(float(np.mean(e * e))), meta


def tracking(eval_root, modes, names, settle_sine_s, settle_step_s):
    """Table: tracking RMS |r − θ| per run (rows) and mode (columns), and the cut vs none."""
    rows = []
    for label in names:  # NAME or NAME@SETTLE (the same run from SETTLE seconds on)
        name, _, at = label.partition("@")
        settle = float(at) if at else (settle_step_s if name.startswith("step") else settle_sine_s)
        row = [name if not at else "%s (t >= %s s)" % (name, at)]
        for mode in modes:
            row.append(tracking_rms(os.path.join(eval_root, mode, name), settle)[0])
        rows.append(row)
    head = "| run | " + " | ".join("%s [mrad]" % m for m in modes) + " | " + " | ".join(
        "cut %s" % m for m in modes[1:]) + " |"
    print(head)
    print("|" + "---|" * (1 + 2 * len(modes) - 1))
    worst = {m: 1e9 for m in modes[1:]}
    for row in rows:
        base = row[1]
        cuts = []
        for j, m in enumerate(modes[1:]):
            cut = 100.0 * (1.0 - row[2 + j] / base)
            worst[m] = min(worst[m], cut)
            cuts.append("%.0f %%" % cut)
        print("| %s | " % row[0] + " | ".join("%.3f" % (1e3 * x) for x in row[1:]) + " | " +
              " | ".join(cuts) + " |")
    print("\nsmallest cut over the runs: " + ", ".join("%s %.0f %%" % (m, worst[m]) for m in modes[1:]))


def hold(folder, counts_per_rad=1.0 / 1.5e-4, settle_s=1.0):
    cols, _ = read_run(folder)
    keep = cols["t"] >= settle_s
    th = cols["theta"][keep]
    pp = float(th.max() - th.min())
    print("%s: %.1f s, theta peak-to-peak %.3g mrad = %.1f encoder steps; |v| max %.4f V" % (
        folder, cols["t"][-1] - settle_s, 1e3 * pp, pp * counts_per_rad,
        float(np.max(np.abs(cols["v"][keep])))))


def push(folder, speed, stiffness, start_s, window_s):
    """Free motion with a hand profile: mean push K·(θ_h − θ) while the hand moves at `speed`,
    over the last `window_s` of the run, and the joint's mean speed there.

    The hand moves in the virtual device's time, ticks stepped × T (device/sim_push.hpp), not in
    the recording's t: a late tick that skips deadlines advances t by several periods and the
    device by one, so a hand rebuilt from t runs ahead of the real one and reads a larger push
    (a loaded machine once read 0.0215 V for 0.0119 V). One recorded row = one device step."""
    cols, _ = read_run(folder)
    t, th = cols["t"], cols["theta"]
    period_s = float(np.median(np.diff(t)))
    t_dev = t[0] + period_s * np.arange(len(t))
    skipped = int(round((t[-1] - t_dev[-1]) / period_s))
    # the hand takes hold where the joint is at start_s (device time ≈ run time + 1 tick)
    k0 = int(np.searchsorted(t_dev, start_s - 1e-3))
    hand = th[k0] + speed * (t_dev - t_dev[k0])
    keep = (t_dev >= t_dev[-1] - window_s) & (t_dev >= t_dev[k0])
    d = stiffness * (hand[keep] - th[keep])
    mean_speed = float(np.polyfit(t_dev[keep], th[keep], 1)[0])
    print("%s: push at %+.2f rad/s: mean %+.4f V (min %+.4f, max %+.4f); joint speed %+.3f rad/s"
          "; %d ticks skipped" % (folder, speed, float(np.mean(d)), float(d.min()), float(d.max()),
                                  mean_speed, skipped))
    return float(np.mean(d))


def transparency(speed, stiffness, start_s, window_s, root, modes):
    """The push needed at +speed and −speed per mode (ROOT/MODE_pos, ROOT/MODE_neg), their mean
    magnitude — an offset or gravity helps one direction as much as it hinders the other, so one
    direction alone measures the friction plus or minus the offset — and the cut against modes[0]."""
    mean_abs = {}
    for mode in modes:
        plus = push(os.path.join(root, mode + "_pos"), speed, stiffness, start_s, window_s)
        minus = push(os.path.join(root, mode + "_neg"), -speed, stiffness, start_s, window_s)
        mean_abs[mode] = 0.5 * (abs(plus) + abs(minus))
    print("\n| mode | mean |push| at ±%.2f rad/s [V] | cut |" % speed)
    print("|---|---|---|")
    for mode in modes:
        cut = 100.0 * (1.0 - mean_abs[mode] / mean_abs[modes[0]])
        print("| %s | %.4f | %.0f %% |" % (mode, mean_abs[mode], cut))


def plot(eval_root, modes, name, out_png, last_s=0.6):
    """gnuplot: r and θ over the last `last_s` of run `name`, one line per mode."""
    data_files = []
    for mode in modes:
        cols, _ = read_run(os.path.join(eval_root, mode, name))
        # a step: its first last_s seconds (the transition), else the last ones
        keep = (cols["t"] <= last_s) if name.startswith("step") else (
            cols["t"] >= cols["t"][-1] - last_s)
        path = out_png + "." + mode + ".dat"
        np.savetxt(path, np.column_stack([cols["t"][keep], cols["r"][keep], cols["theta"][keep]]))
        data_files.append((mode, path))
    script = ["set terminal pngcairo size 900,420 font ',10'", "set output '%s'" % out_png,
              "set xlabel 't [s]'", "set ylabel 'theta [rad]'", "set key outside right",
              "set title '%s: reference and measured angle by --compensate'" % name.replace("_", " ")]
    parts = ["'%s' using 1:2 with lines lw 2 lc rgb 'black' title 'r'" % data_files[0][1]]
    for mode, path in data_files:
        parts.append("'%s' using 1:3 with lines lw 1.5 title '%s'" % (path, mode))
    script.append("plot " + ", ".join(parts))
    subprocess.run(["gnuplot"], input="\n".join(script), text=True, check=True)
    for _, path in data_files:
        os.remove(path)


if __name__ == "__main__":
    cmd = sys.argv[1]
    if cmd == "merge":
        merge(sys.argv[2], sys.argv[3:])
    elif cmd == "scale":
        scale(sys.argv[2], float(sys.argv[3]), sys.argv[4])
    elif cmd == "tracking":
        # tracking EVAL_ROOT "none effects ..." "names ..." SETTLE_SINE SETTLE_STEP
        tracking(sys.argv[2], sys.argv[3].split(), sys.argv[4].split(), float(sys.argv[5]),
                 float(sys.argv[6]))
    elif cmd == "hold":
        for folder in sys.argv[2:]:
            hold(folder)
    elif cmd == "push":
        # push SPEED STIFFNESS START WINDOW FOLDER...
        for folder in sys.argv[6:]:
            push(folder, float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]))
    elif cmd == "transparency":
        # transparency SPEED STIFFNESS START WINDOW ROOT "none effects ..."
        transparency(float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]),
                     float(sys.argv[5]), sys.argv[6], sys.argv[7].split())
    elif cmd == "plot":
        plot(sys.argv[2], sys.argv[3].split(), sys.argv[4], sys.argv[5])
    else:
        sys.exit("unknown command " + cmd)
