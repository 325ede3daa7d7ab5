"""alphainv.batch: fit_many on a local process pool and on a Dask LocalCluster of 2 workers gives
the numbers of alphainv.fit, one row per dataset; a failed dataset is a row with its error."""

import numpy as np
import pytest

import alphainv
import alphainv.batch


def _specs(small, seeds):
    return [dict(small, seed=s) for s in seeds]


def test_fit_many_on_a_process_pool_keeps_failures_as_rows(small, tmp_path):
    good = alphainv.Dataset.generate(5, **small)
    good.write(tmp_path / "good")
    items = [str(tmp_path / "good"), good, "/nonexistent/ds", dict(small, seed=6, pose=17)]
    res = alphainv.batch.fit_many(items, workers=2)
    assert [r["name"] for r in res.rows] == ["%s" % (tmp_path / "good"), "dataset[1]", "/nonexistent/ds",
                                             res.rows[3]["name"]]
    direct = alphainv.fit(good, threads=1)
    for row in res.rows[:2]:
        assert row["ok"] and row["error"] == "" and row["runs"] == 10
        assert row["alpha_step_median_abs_err"] == direct.figures["alpha"]["step_median_abs_err"]
        assert row["c_n1_1"] == direct.model.alpha_model.c_n1[1]
    missing, bad_pose = res.rows[2], res.rows[3]
    assert not missing["ok"] and missing["error_file"] == "/nonexistent/ds/dataset.json"
    assert "Error" in missing["error"]
    assert not bad_pose["ok"] and bad_pose["error_field"] == "pose"
    assert len(res.failed) == 2 and "2 failed" in res.summary
    table = res.table
    assert len(table) == 4 and "model_json" not in table.columns
    assert alphainv.Model.from_json(res.rows[0]["model_json"]).has_alpha_model


def test_fit_many_on_a_dask_local_cluster_of_two_workers(small):
    distributed = pytest.importorskip("distributed")
    specs = _specs(small, [11, 12, 13, 14])
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        seen = []
        res = alphainv.batch.fit_many(specs + [dict(small, seed=1, bogus=1)], client=client,
                                      progress=lambda done, total, row: seen.append((done, total)))
        assert "Dask cluster of 2 workers" in res.backend
    assert sorted(seen) == [(k, 5) for k in range(1, 6)]
    for spec, row in zip(specs, res.rows):
        direct = alphainv.fit(alphainv.Dataset.generate(**spec), threads=1)
        assert row["ok"] and row["linear_step_median_abs_err"] == direct.figures["linear"]["step_median_abs_err"]
        np.testing.assert_array_equal([row[f"c_n1_{n}"] for n in range(4)], direct.model.alpha_model.c_n1)
    assert res.rows[4]["error_field"] == "bogus" and not res.rows[4]["ok"]
    assert "c_n1_0" in res.summary


def test_diagnose_many_rows(small):
    res = alphainv.batch.diagnose_many([dict(small, seed=21, effects=alphainv.Effects()), "/nonexistent"],
                                       workers=2, candidates=["offset_torque"])
    ok, bad = res.rows
    assert ok["ok"] and ok["effect"] == "none" and ok["error_before"] > 0.0
    assert bad["error_file"] == "/nonexistent/dataset.json"


def test_sweep_confusion_matrix():
    # omni_fit sweep --quick's cases for none and offset_torque at seed 4 (its ctest names the
    # offset there), the search limited to the offset to keep it short.
    res = alphainv.batch.sweep([4], ["none", "offset_torque"], workers=2, candidates=["offset_torque"],
                               discover=False)
    assert res.matrix == {"none": {"none": 1}, "offset_torque": {"offset_torque": 1}}
    assert [r["hidden"] for r in res.rows] == ["none", "offset_torque"]
    offset = res.rows[1]
    assert offset["offset_v"] == pytest.approx(0.02, rel=0.15)
    assert "| offset_torque | 0 | 0 | **1** |" in res.matrix_text and "Right: 2/2" in res.matrix_text
