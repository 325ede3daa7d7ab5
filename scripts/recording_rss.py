#!/usr/bin/python3
"""RSS of a long recorded run (issue #13: memory bounded over any duration).

Runs `omni_ctl --local --device sim --sine 3Hz --duration D --record DIR` and samples the
process's VmRSS (/proc/PID/status) every --every seconds; prints start (first sample after 1 s),
peak and end, and the rows written.

  scripts/recording_rss.py [--build build/release] [--duration 300] [--every 1]
"""
import argparse, json, os, subprocess, tempfile, time

ap = argparse.ArgumentParser()
ap.add_argument("--build", default="build/release")
ap.add_argument("--duration", type=float, default=300.0)
ap.add_argument("--every", type=float, default=1.0)
a = ap.parse_args()
rec = os.path.join(tempfile.mkdtemp(prefix="alphainv_rss_rec_"), "run")
p = subprocess.Popen([os.path.join(a.build, "apps/omni_ctl/omni_ctl"), "--local", "--device", "sim",
                      "--sine", "3Hz", "--duration", "%gs" % a.duration, "--record", rec,
                      "--rt-priority", "0", "--no-mlock"],
                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
samples = []
t0 = time.monotonic()
while p.poll() is None:
    try:
        with open("/proc/%d/status" % p.pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    samples.append((time.monotonic() - t0, int(line.split()[1]) / 1024.0))
    except OSError:
        break
    time.sleep(a.every)
err = p.stderr.read()
after_1s = [s for s in samples if s[0] >= 1.0] or samples
peak = max(samples, key=lambda s: s[1])
print("RSS over a %g s recorded run: start %.1f MB (t = %.0f s), peak %.1f MB (t = %.0f s), "
      "end %.1f MB (t = %.0f s); %d samples" % (a.duration, after_1s[0][1], after_1s[0][0],
                                                peak[1], peak[0], samples[-1][1], samples[-1][0],
                                                len(samples)))
with open(os.path.join(rec, "dataset.json")) as f:
    ds = json.load(f)
print("exit %d, ended %s, rows %s, files %s" % (p.returncode, ds.get("ended"), ds.get("rows"),
                                               [r["file"] for r in ds["runs"]]))
print("rss_mb_by_minute:", " ".join("%.1f" % s[1] for s in samples[:: max(1, int(60 / a.every))]))
