"""Batches of fits and diagnoses: a local process pool, or a Dask cluster.

    result = alphainv.batch.fit_many(["joint_a", "joint_b", ds_c])             # process pool
    result = alphainv.batch.fit_many(specs, client=dask.distributed.Client())  # a cluster
    result.table      # one row per dataset (a pandas DataFrame when pandas is installed)
    print(result.summary)

A dataset is a folder (str or os.PathLike, readable where the task runs), an alphainv.Dataset
(pickled to the worker), or a dict of Dataset.generate() options (generated on the worker, e.g.
{"seed": 3, "pose": 2, "alpha_model": ...}). Each task runs the same C++ call as alphainv.fit /
alphainv.diagnose on one thread (threads=1 unless given: the batch is parallel over datasets).
A dataset that fails (bad file, bad option, a worker lost) is a row with ok=False and its error,
never a lost batch.
"""

from __future__ import annotations

import math
import os
import statistics
import time
from typing import Any, Callable, Iterable, Optional, Sequence

__all__ = ["BatchResult", "fit_many", "diagnose_many", "sweep"]


class BatchResult:
    """The rows of a batch (one per dataset, in input order), their table and a summary report."""

    def __init__(self, kind: str, rows: list[dict], seconds: float, backend: str):
        self.kind = kind
        self.rows = rows
        self.seconds = seconds
        self.backend = backend

    @property
    def failed(self) -> list[dict]:
        """The rows whose task raised (bad input, a lost worker): `error` says why."""
        return [r for r in self.rows if r.get("error")]

    @property
    def table(self) -> Any:
        """The rows as a pandas DataFrame (a list of dicts without pandas), model JSON left out."""
        rows = [{k: v for k, v in r.items() if k not in ("model_json", "report")} for r in self.rows]
        try:
            import pandas
        except ImportError:
            return rows
        return pandas.DataFrame(rows)

    @property
    def summary(self) -> str:
        """Several lines: counts, time, failures, and the spread of every numeric column."""
        ok = [r for r in self.rows if r.get("ok")]
        lines = [
            f"{self.kind}: {len(self.rows)} datasets, {len(ok)} ok, {len(self.failed)} failed, "
            f"{len(self.rows) - len(ok) - len(self.failed)} not usable; {self.seconds:.1f} s on "
            f"{self.backend}"
        ]
        for r in self.failed:
            lines.append(f"  failed {r['name']}: {r['error']}")
        for r in self.rows:
            if not r.get("ok") and not r.get("error"):
                lines.append(f"  not usable {r['name']}: {r.get('message', '')}")
        numeric = [k for k in (ok[0] if ok else {}) if k not in ("ok", "seconds")
                   and all(isinstance(r.get(k), (int, float)) and not isinstance(r.get(k), bool)
                           for r in ok)]
        if numeric:
            lines.append(f"  {'column':<34} {'median':>11} {'min':>11} {'max':>11} {'CV %':>7}")
        for k in numeric:
            xs = [float(r[k]) for r in ok if r[k] is not None and math.isfinite(r[k])]
            if not xs:
                continue
            mean = statistics.fmean(xs)
            cv = 100.0 * statistics.pstdev(xs) / abs(mean) if len(xs) > 1 and mean else float("nan")
            lines.append(f"  {k:<34} {statistics.median(xs):>11.5g} {min(xs):>11.5g} "
                         f"{max(xs):>11.5g} {cv:>7.2f}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "rows": self.rows, "seconds": self.seconds,
                "backend": self.backend, "summary": self.summary}

    def __repr__(self) -> str:
        return self.summary.splitlines()[0]


# --- the tasks (run in the workers) ---------------------------------------------------------------

def _name_of(item: Any, index: int) -> str:
    if isinstance(item, (str, os.PathLike)):
        return os.fspath(item)
    if isinstance(item, dict):
        return "generated(" + ", ".join(f"{k}={v!r}" for k, v in sorted(item.items())
                                        if isinstance(v, (int, float, str))) + ")"
    return f"dataset[{index}]"


def _load(item: Any):
    import alphainv
    if isinstance(item, dict):
        return alphainv.Dataset.generate(**item)
    return alphainv.Dataset.read(item) if isinstance(item, (str, os.PathLike)) else item


def _error_row(name: str, error: BaseException, seconds: float) -> dict:
    return {"name": name, "ok": False, "error": f"{type(error).__name__}: {error}",
            "error_field": getattr(error, "field", ""), "error_file": getattr(error, "file", ""),
            "error_line": getattr(error, "line", 0), "seconds": seconds}


def _fit_row(name: str, result) -> dict:
    fig = result.figures
    model = result.model
    row = {"name": name, "ok": result.usable, "error": "", "message": result.message,
           "runs": fig["runs"], "poses": fig["poses"]}
    for which in ("linear", "alpha"):
        for k, v in fig[which].items():
            row[f"{which}_{k}"] = v
    row["step_error_ratio"] = fig["step_error_ratio"]
    row["has_inertia_model"] = model.has_inertia_model
    if model.has_inertia_model:
        row["c0_bar"] = model.linear.c0_bar
    if model.has_alpha_model:
        a = model.alpha_model
        for n, (x, c) in enumerate(zip(a.alpha, a.c_n1)):
            row[f"alpha_{n}"] = float(x)
            row[f"c_n1_{n}"] = float(c)
        row["beta_n1_0"], row["beta_n1_1"] = a.beta_n1
        af = result.alpha_fit
        row["alpha_data_min"], row["alpha_data_max"] = af["alpha_data_min"], af["alpha_data_max"]
    row["model_json"] = model.to_json()
    row["report"] = result.brief_report
    return row


def _diagnose_row(name: str, result) -> dict:
    row = {"name": name, "ok": result.ok, "error": "", "message": result.message,
           "termination": result.termination,
           "effect": result.effects_named[0] if result.effects_named else "none",
           "effects": ", ".join(result.effects_named) or "none",
           "error_before": result.error_before, "error_after": result.error_after}
    for effect, params in result.effects.to_dict().items():
        for k, v in params.items():
            row[k] = v
    row["model_json"] = result.model.to_json() if result.model is not None else ""
    row["report"] = result.brief_report
    return row


def _run_task(kind: str, item: Any, name: str, options: dict) -> dict:
    """One dataset: load, fit or diagnose, a row. Never raises (the error is the row)."""
    import alphainv
    t0 = time.perf_counter()
    try:
        ds = _load(item)
        if kind == "fit_many":
            row = _fit_row(name, alphainv.fit(ds, **options))
        else:
            row = _diagnose_row(name, alphainv.diagnose(ds, **options))
    except Exception as e:  # noqa: BLE001 - a failed dataset is a row, never a lost batch
        return _error_row(name, e, time.perf_counter() - t0)
    row["seconds"] = time.perf_counter() - t0
    return row


# --- the schedulers -------------------------------------------------------------------------------

def _run(kind: str, datasets: Iterable[Any], client: Any, workers: Optional[int],
         names: Optional[Sequence[str]], progress: Optional[Callable[[int, int, dict], None]],
         options: dict) -> BatchResult:
    items = list(datasets)
    names = list(names) if names is not None else [_name_of(d, i) for i, d in enumerate(items)]
    if len(names) != len(items):
        raise ValueError(f"{kind}: {len(names)} names for {len(items)} datasets")
    options = dict(options)
    options.setdefault("threads", 1)
    rows: list[Optional[dict]] = [None] * len(items)
    t0 = time.perf_counter()

    def done(i: int, row: dict) -> None:
        rows[i] = row
        if progress is not None:
            progress(sum(r is not None for r in rows), len(items), row)

    if client is not None:
        from distributed import as_completed
        futures = [client.submit(_run_task, kind, item, name, options, pure=False)
                   for item, name in zip(items, names)]
        index = {f.key: i for i, f in enumerate(futures)}
        for f in as_completed(futures):
            i = index[f.key]
            try:
                done(i, f.result())
            except Exception as e:  # noqa: BLE001 - a lost worker or an unpicklable dataset
                done(i, _error_row(names[i], e, 0.0))
        n = len(client.scheduler_info().get("workers", {}))
        backend = f"a Dask cluster of {n} workers ({client.scheduler.address})"
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed as cf_completed
        n = workers or os.cpu_count() or 1
        with ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(_run_task, kind, item, name, options): i
                       for i, (item, name) in enumerate(zip(items, names))}
            for f in cf_completed(futures):
                i = futures[f]
                try:
                    done(i, f.result())
                except Exception as e:  # noqa: BLE001 - a worker that died
                    done(i, _error_row(names[i], e, 0.0))
        backend = f"a local process pool of {n} workers"
    return BatchResult(kind, [r for r in rows if r is not None], time.perf_counter() - t0, backend)


def fit_many(datasets: Iterable[Any], client: Any = None, *, workers: Optional[int] = None,
             names: Optional[Sequence[str]] = None,
             progress: Optional[Callable[[int, int, dict], None]] = None,
             **options: Any) -> BatchResult:
    """alphainv.fit on every dataset, in parallel; one row per dataset.

    client: None (a local process pool of `workers` processes, default: the CPU count) or a
    dask.distributed.Client (that cluster). options: those of alphainv.fit (threads defaults
    to 1 per dataset). progress(done, total, row) is called here as rows arrive. A row holds
    name, ok (usable), error (empty or why the task failed, with error_field/file/line), the
    figures of omni_fit fit --json flattened (linear_*, alpha_*, step_error_ratio), the
    alpha-model (alpha_n, c_n1_n, beta_n1_0/1, and alpha_data_min/max: the range of alpha the
    sine runs cover, where the model is backed by data), c0_bar with an inertia model, seconds, and
    model_json (model.json text).
    """
    return _run("fit_many", datasets, client, workers, names, progress, options)


def diagnose_many(datasets: Iterable[Any], client: Any = None, *, workers: Optional[int] = None,
                  names: Optional[Sequence[str]] = None,
                  progress: Optional[Callable[[int, int, dict], None]] = None,
                  **options: Any) -> BatchResult:
    """alphainv.diagnose on every dataset, in parallel; one row per dataset (effect named,
    RMS before and after, the effects' parameters, model_json). Same scheduling as fit_many."""
    return _run("diagnose_many", datasets, client, workers, names, progress, options)


def sweep(seeds: Sequence[int] = (1, 2), effects: Optional[Sequence[str]] = None, *,
          noise_std_rad: Sequence[float] = (5e-5,), client: Any = None,
          workers: Optional[int] = None, **options: Any) -> BatchResult:
    """The confusion matrix of diagnose on generated datasets, as `omni_fit sweep --quick` lays
    the cases out: per effect of the table (and none), per seed and noise level, one pose's 10
    runs (pose = seed mod 9) with only that effect hidden at its first sweep magnitude (the
    table's), then diagnose_many. The result's rows carry `hidden` and `named`; its `matrix`
    attribute is {hidden: {named: count}} and `matrix_text` the Markdown table.
    """
    import alphainv
    specs = {s.name: s for s in alphainv.EFFECTS}
    kinds = list(effects) if effects is not None else [s.name for s in alphainv.EFFECTS]
    items, hidden = [], []
    for name in kinds:
        if name not in specs:
            raise alphainv.Error(f"unknown effect; expected one of {', '.join(specs)}", "", 0, "effects")
        spec = specs[name]
        for seed in seeds:
            for noise in noise_std_rad:
                fx = "" if name == "none" else spec.sweep_spec()
                items.append({"seed": int(seed), "pose": int(seed) % 9, "noise_std_rad": noise,
                              "effects": [fx] if fx else alphainv.Effects()})
                hidden.append(name)
    names = [f"{h} seed {it['seed']} noise {it['noise_std_rad']:g}" for h, it in zip(hidden, items)]
    result = diagnose_many(items, client, workers=workers, names=names, **options)
    matrix: dict[str, dict[str, int]] = {h: {} for h in kinds}
    for h, row in zip(hidden, result.rows):
        row["hidden"] = h
        row["named"] = row.get("effect", "error") if not row.get("error") else "error"
        matrix[h][row["named"]] = matrix[h].get(row["named"], 0) + 1
    columns = [s.name for s in alphainv.EFFECTS] + (["error"] if result.failed else [])
    text = "| hidden \\ named | " + " | ".join(columns) + " |\n|---|" + "---|" * len(columns) + "\n"
    for h in kinds:
        cells = [str(matrix[h].get(c, 0)) for c in columns]
        cells = [f"**{x}**" if c == h and x != "0" else x for c, x in zip(columns, cells)]
        text += f"| {h} | " + " | ".join(cells) + " |\n"
    right = sum(matrix[h].get(h, 0) for h in kinds)
    text += f"\nRight: {right}/{len(items)} cases; {result.seconds:.0f} s on {result.backend}.\n"
    result.kind = "sweep"
    result.matrix = matrix
    result.matrix_text = text
    return result
