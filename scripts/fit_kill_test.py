#!/usr/bin/python3
"""SIGKILL of `omni_fit fit` at random moments (issue #13, "Transactional outputs").

Fits the dataset twice into reference folders (OLD: --breakpoints 3, NEW: the default), then
N times: puts a copy of OLD at OUT, starts `omni_fit fit DATASET -o OUT` (the NEW fit), kills it
(SIGKILL) after a random delay within the fit's duration, and classifies OUT: "old" (the same
files, byte for byte, as OLD), "new" (as NEW) or "MIX" (anything else: files of both, files
missing). Exit 1 when any trial is a MIX.

  scripts/fit_kill_test.py [--build build/release] [--dataset data/omni_yaw_sim] [--trials 20]
"""
import argparse, filecmp, os, random, shutil, signal, subprocess, sys, tempfile, time

ap = argparse.ArgumentParser()
ap.add_argument("--build", default="build/release")
ap.add_argument("--dataset", default="data/omni_yaw_sim")
ap.add_argument("--trials", type=int, default=20)
ap.add_argument("--seed", type=int, default=1)
a = ap.parse_args()
fit = os.path.join(a.build, "apps/omni_fit/omni_fit")
rng = random.Random(a.seed)
work = tempfile.mkdtemp(prefix="alphainv_kill_fit_")
args = ["--no-plots", "-q"]  # figures are files too, but gnuplot's time would dominate


def run_fit(out, extra):
    t0 = time.monotonic()
    subprocess.run([fit, "fit", a.dataset, "-o", out] + args + extra, check=True)
    return time.monotonic() - t0


old, new = os.path.join(work, "old"), os.path.join(work, "new")
run_fit(old, ["--breakpoints", "3"])
duration = run_fit(new, [])


def tree(d):
    out = []
    for root, _, files in os.walk(d):
        out += [os.path.relpath(os.path.join(root, f), d) for f in files]
    return sorted(out)


def same(d, ref):
    if tree(d) != tree(ref):
        return False
    # dataset_path in model.json names the dataset, the same for all: compare whole files.
    return all(filecmp.cmp(os.path.join(d, f), os.path.join(ref, f), shallow=False)
               for f in tree(ref))


assert not same(old, new), "the two reference fits must differ"
counts = {"old": 0, "new": 0, "MIX": 0}
for i in range(a.trials):
    out = os.path.join(work, "out%02d" % i)
    shutil.copytree(old, out)
    delay = rng.uniform(0.0, duration * 1.1)
    p = subprocess.Popen([fit, "fit", a.dataset, "-o", out] + args,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(delay)
    p.send_signal(signal.SIGKILL)
    rc = p.wait()
    kind = "old" if same(out, old) else "new" if same(out, new) else "MIX"
    counts[kind] += 1
    siblings = [n for n in os.listdir(work) if n.startswith(".out%02d." % i)]
    print("trial %2d: killed at %5.2f s of %.2f s (rc %d): %s%s" %
          (i, delay, duration, rc, kind,
           "" if kind != "MIX" else " files %s" % tree(out)) +
          (" (a killed fit's sibling %s is left, removed by the next fit)" % siblings[0]
           if siblings else ""))
print("%d trials: old %d, new %d, mix %d; data in %s" % (a.trials, counts["old"], counts["new"],
                                                      counts["MIX"], work))
sys.exit(1 if counts["MIX"] else 0)
