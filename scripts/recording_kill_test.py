#!/usr/bin/python3
"""SIGKILL of a recorded run at random moments (issue #13, "Durability of recordings").

Starts `omni_ctl --local --device sim --sine 3Hz --duration 60s --record DIR` N times, kills it
(SIGKILL) after a random delay, and compares the rows on disk with the ticks elapsed since the
process started (an upper bound on the run's ticks: the run starts after the set-up). Each
dataset left behind must say "ended": "interrupted" and read back (the CSV's complete lines, as
the library's reader takes them); every --fit-every'th is fitted by `omni_fit fit` (exit 0 or 3:
read; 2: refused).

  scripts/recording_kill_test.py [--build build/release] [--trials 20] [--seed 1]
Prints one line per trial and a summary; exit 1 when a trial misses rows >= elapsed - 1000.
"""
import argparse, json, os, random, signal, subprocess, sys, tempfile, time

ap = argparse.ArgumentParser()
ap.add_argument("--build", default="build/release")
ap.add_argument("--trials", type=int, default=20)
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--max-delay", type=float, default=12.0)
ap.add_argument("--fit-every", type=int, default=5)
a = ap.parse_args()
ctl = os.path.join(a.build, "apps/omni_ctl/omni_ctl")
fit = os.path.join(a.build, "apps/omni_fit/omni_fit")
rng = random.Random(a.seed)
work = tempfile.mkdtemp(prefix="alphainv_kill_rec_")
worst = None
failures = 0
for i in range(a.trials):
    rec = os.path.join(work, "r%02d" % i)
    delay = rng.uniform(0.05, a.max_delay)
    t0 = time.monotonic()
    p = subprocess.Popen([ctl, "--local", "--device", "sim", "--sine", "3Hz", "--duration", "60s",
                          "--record", rec, "--rt-priority", "0", "--no-mlock"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(max(0.0, delay - (time.monotonic() - t0)))
    p.send_signal(signal.SIGKILL)
    t1 = time.monotonic()
    p.wait()
    elapsed = int((t1 - t0) * 1000)
    rows, ended = 0, "(no dataset.json)"
    if os.path.exists(os.path.join(rec, "dataset.json")):
        with open(os.path.join(rec, "dataset.json")) as f:
            ended = json.load(f).get("ended")
        with open(os.path.join(rec, "run.csv"), "rb") as f:
            text = f.read()
        rows = text[: text.rfind(b"\n") + 1].count(b"\n") - 1  # complete lines after the header
    ok = rows >= elapsed - 1000 and (rows == 0 or ended == "interrupted")
    fitted = ""
    if a.fit_every > 0 and i % a.fit_every == 0 and rows >= 1000:  # a sine period or more
        r = subprocess.run([fit, "fit", rec, "-o", os.path.join(work, "fit%02d" % i), "--no-plots", "-q"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        fitted = " omni_fit fit rc %d%s" % (r.returncode, "" if r.returncode in (0, 3) else
                                            " " + r.stderr.strip()[:200])
        ok = ok and r.returncode in (0, 3)
    failures += 0 if ok else 1
    margin = rows - (elapsed - 1000)
    worst = margin if worst is None else min(worst, margin)
    print("trial %2d: killed at %6.3f s: elapsed ticks <= %5d, rows on disk %5d (lost <= %4d), "
          "ended %s%s%s" % (i, delay, elapsed, rows, max(0, elapsed - rows), ended, fitted,
                            "" if ok else "  FAIL"))
print("%d/%d trials kept rows >= elapsed - 1000 (worst margin %d rows); data in %s" %
      (a.trials - failures, a.trials, worst, work))
sys.exit(1 if failures else 0)
