#!/usr/bin/env python3
"""Fit the bundled dataset and plot the paper's Figs 13-14 (time responses) with matplotlib.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/01_fit_and_plot.py --out out/py01

Reads data/omni_yaw_sim (made by scripts/setup.sh); without it, generates the same data in
memory (the bundled set is the virtual Omni's paper plan, seed 1, bit for bit). Writes
model.json, report.md, fig13_time_sine.png and fig14_time_step.png into --out.
"""

import argparse
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import alphainv  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]


def overlay(ax, sim, k0, k1, title):
    t = sim["t"][k0:k1]
    ax.plot(t, sim["r"][k0:k1], color="0.6", ls="--", label="reference r")
    ax.plot(t, sim["theta"][k0:k1], color="black", lw=2, label="measured")
    ax.plot(t, sim["theta_linear"][k0:k1], label="linear model (26)")
    ax.plot(t, sim["theta_alpha"][k0:k1], label="α-model (38)-(42)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("θ [rad]")
    ax.set_title(title)
    ax.legend(loc="best")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dataset", default=str(ROOT / "data" / "omni_yaw_sim"))
    ap.add_argument("--out", default="out/python_fit")
    ap.add_argument("--quick", action="store_true", help="(CI) the same: the fit takes seconds")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    if (pathlib.Path(args.dataset) / "dataset.json").exists():
        ds = alphainv.Dataset.read(args.dataset)
    else:
        print(f"{args.dataset} not found: generating the bundled set (seed 1) in memory")
        ds = alphainv.Dataset.generate(1)
    fit = alphainv.fit(ds, progress=None)
    print(fit.brief_report)
    if not fit.usable:
        print(fit.report, file=sys.stderr)
        return 3
    fit.model.write(out / "model.json")
    (out / "report.md").write_text(fit.report_markdown)
    fig = fit.figures
    print(f"step median |θ_sim − θ|: linear {fig['linear']['step_median_abs_err']:.4g}, "
          f"α {fig['alpha']['step_median_abs_err']:.4g} rad (ratio {fig['step_error_ratio']:.3g})")

    # The pose with the most sine points that has a square run (as omni_fit's report chooses).
    pts = fit.sine_points
    poses = fit.poses
    def has_step(p):
        return any(ds[i].kind in ("square", "step") for i in poses[p]["runs"])
    best = max(range(len(poses)), key=lambda p: (has_step(p), int(np.sum(pts["pose"] == p))))
    here = pts["pose"] == best
    f_res = pts["freq_hz"][here][np.argmax(pts["gain"][here])]
    sine_run = int(pts["run"][here][np.argmin(np.abs(pts["freq_hz"][here] - 0.75 * f_res))])
    step_run = next(i for i in poses[best]["runs"] if ds[i].kind in ("square", "step"))
    pose = f"{poses[best]['gamma1_deg']:.2f}°/{poses[best]['gamma2_deg']:.2f}°"

    # Fig 13: the last three periods of the sine run nearest 0.75 f_res.
    sim = fit.simulate_run(sine_run)
    t = sim["t"]
    k0 = int(np.searchsorted(t, t[-1] - 3.0 / ds[sine_run].freq_hz))
    f13, ax = plt.subplots(figsize=(9, 5.6))
    overlay(ax, sim, k0, len(t), f"Fig 13: {ds[sine_run].file} ({ds[sine_run].freq_hz:g} Hz, {pose})")
    f13.tight_layout()
    f13.savefig(out / "fig13_time_sine.png", dpi=100)

    # Fig 14: the square run around its first upward jump.
    sim = fit.simulate_run(step_run)
    t, r = sim["t"], sim["r"]
    jump = 0.5 * (r.max() - r.min())
    edge = int(np.argmax(np.diff(r) > jump)) + 1
    k0, k1 = np.searchsorted(t, [t[edge] - 0.1, t[edge] + 1.0])
    f14, ax = plt.subplots(figsize=(9, 5.6))
    overlay(ax, sim, k0, k1, f"Fig 14: {ds[step_run].file} ({pose}) around its first jump")
    f14.tight_layout()
    f14.savefig(out / "fig14_time_step.png", dpi=100)
    for name in ("model.json", "report.md", "fig13_time_sine.png", "fig14_time_step.png"):
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
