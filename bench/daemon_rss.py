#!/usr/bin/python3
"""The omni_ctl daemon's resident memory over many back-to-back runs (issue #13, finding 10).

Starts `omni_ctl --daemon --device sim` on a private socket, sends N short runs one after the
other over the protocol (docs/omni_ctl-protocol.md), each waited for to its run_done, and prints
the daemon's VmRSS after a warm-up, every 1000 runs, and at the end. Goal: flat within 1 MB over
10,000 runs.

  /usr/bin/python3 bench/daemon_rss.py [--omni-ctl build/release/apps/omni_ctl/omni_ctl]
                                       [--runs 10000] [--warmup 200] [--duration-s 0.002]
"""
import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


class Client:
    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.connect(path)
        self.buf = b""

    def send(self, obj):
        self.sock.sendall((json.dumps(obj) + "\n").encode())

    def next(self):
        while b"\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise RuntimeError("the daemon closed the connection")
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return json.loads(line)

    def run(self, duration_s):
        self.send({"cmd": "run", "waveform": "hold", "duration_s": duration_s})
        run_id = None
        while True:
            msg = self.next()
            if "ok" in msg:
                if not msg["ok"]:
                    raise RuntimeError(f"run refused: {msg}")
                run_id = msg["run_id"]
            elif msg.get("event") == "run_done" and msg.get("run_id") == run_id:
                if msg.get("fault") is not None:
                    raise RuntimeError(f"run faulted: {msg}")
                return msg


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--omni-ctl", default="build/release/apps/omni_ctl/omni_ctl")
    ap.add_argument("--runs", type=int, default=10000)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--duration-s", type=float, default=0.002)
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="alphainv_daemon_rss_")
    sock = os.path.join(tmp, "run", "omni_ctl.sock")
    daemon = subprocess.Popen(
        [args.omni_ctl, "--daemon", "--device", "sim", "--socket", sock, "--no-mlock",
         "--rt-priority", "0"],
        stderr=subprocess.DEVNULL)
    try:
        for _ in range(500):
            if os.path.exists(sock):
                break
            time.sleep(0.01)
        time.sleep(0.1)
        c = Client(sock)
        for _ in range(args.warmup):
            c.run(args.duration_s)
        start = rss_kb(daemon.pid)
        t0 = time.monotonic()
        print(f"after {args.warmup} warm-up runs: RSS {start} kB")
        for i in range(1, args.runs + 1):
            c.run(args.duration_s)
            if i % 1000 == 0:
                print(f"run {i:6d}: RSS {rss_kb(daemon.pid)} kB  ({time.monotonic() - t0:.0f} s)",
                      flush=True)
        end = rss_kb(daemon.pid)
        print(f"start {start} kB, end {end} kB: {end - start:+d} kB over {args.runs} runs "
              f"({1024.0 * (end - start) / args.runs:+.1f} B/run); goal: within 1024 kB")
        return 0 if abs(end - start) <= 1024 else 1
    finally:
        daemon.terminate()
        daemon.wait(10)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
