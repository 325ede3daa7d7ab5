"""The formats in Python: Dataset read/write (alphainv-dataset/1) with runs as numpy views, Run
from arrays, pickling, the reader's errors with their file, line and field, Model (model.json)."""

import pickle

import numpy as np
import pytest

import alphainv


def test_runs_are_numpy_views_without_copies(one_pose):
    run = one_pose[0]
    assert len(one_pose) == 10 and run.kind == "sine" and run.freq_hz == 1.5
    t1, t2 = run.t, run.t
    assert np.shares_memory(t1, t2) and t1.dtype == np.float64
    assert set(run.columns) == {"t", "r", "theta", "v"}
    assert np.shares_memory(run.columns["theta"], run.theta)
    np.testing.assert_allclose(np.diff(run.t), 1e-3, rtol=1e-9)
    frame = run.to_frame()
    assert list(frame.columns) == ["t", "r", "theta", "v"] and len(frame) == len(run)
    runs = one_pose.to_frame()
    assert list(runs["kind"]) == ["sine"] * 9 + ["square"]
    assert one_pose.sample_rate_hz == 1000.0 and one_pose.controller.kp == 2.0


def test_write_then_read_gives_the_same_numbers(one_pose, tmp_path):
    one_pose.write(tmp_path / "ds")
    back = alphainv.Dataset.read(tmp_path / "ds")
    assert len(back) == len(one_pose) and back.dir == str(tmp_path / "ds")
    for a, b in zip(one_pose, back):
        assert a.file == b.file and a.gamma1_deg == b.gamma1_deg
        for k in ("t", "r", "theta", "v"):
            np.testing.assert_array_equal(a.columns[k], b.columns[k])  # shortest round-trip form
    assert back.extra["truth"]["alpha_model"]["c_n1"] == [13.509, 21.57, 35.316, 61.733]
    p = pickle.loads(pickle.dumps(back))
    np.testing.assert_array_equal(p[9].theta, back[9].theta)
    assert p[9].file == back[9].file


def test_a_dataset_from_arrays(tmp_path):
    t = np.arange(0.0, 1.0, 1e-3)
    r = 0.07 * np.sin(2 * np.pi * 2 * t)
    run = alphainv.Run(t, r, 0.5 * r, 2.0 * 0.5 * r, kind="sine", file="runs/a.csv", freq_hz=2.0,
                       amplitude_rad=0.07, gamma1_deg=60.0, gamma2_deg=87.0, columns={"gamma1": np.full_like(t, 1.0)})
    ds = alphainv.Dataset([run], sample_rate_hz=1000.0, controller=alphainv.Controller(kp=2.0))
    assert ds[0].controller.kp == 2.0 and "gamma1" in ds[0].columns
    ds.write(tmp_path / "arr")
    back = alphainv.Dataset.read(str(tmp_path / "arr"))
    np.testing.assert_array_equal(back[0].r, r)
    with pytest.raises(alphainv.Error) as e:
        alphainv.Run(t, r[:-1], r, r)
    assert e.value.field == "r" and "999" in e.value.message


def test_a_malformed_cell_names_its_file_line_and_column(one_pose, tmp_path):
    one_pose.write(tmp_path / "bad")
    csv = tmp_path / "bad" / one_pose[2].file
    lines = csv.read_text().splitlines()
    cells = lines[41].split(",")
    cells[2] = "abc"  # theta of data row 41: file line 42
    lines[41] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(alphainv.Error) as e:
        alphainv.Dataset.read(tmp_path / "bad")
    err = e.value
    assert err.file.endswith(one_pose[2].file) and err.line == 42 and err.field == "theta"
    assert str(err).startswith(err.file + ":42: ")
    assert pickle.loads(pickle.dumps(err)).line == 42  # the fields survive a process boundary


def test_model_file_round_trip(tmp_path):
    m = alphainv.Model(alpha_model=alphainv.AlphaModel.paper(), linear=alphainv.LinearModel.paper(),
                       controller=alphainv.Controller(kp=2.0), effects="offset_torque=0.02")
    m.write(tmp_path / "model.json")
    back = alphainv.Model.read(tmp_path / "model.json")
    assert back.has_alpha_model and back.has_inertia_model
    np.testing.assert_array_equal(back.alpha_model.c_n1, [13.509, 21.57, 35.316, 61.733])
    assert back.effects.offset_v == 0.02 and back.to_dict()["schema"] == "alphainv-model/1"
    joint, note = back.at_pose(60.08, 87.0)
    assert joint.damping(25.0) == pytest.approx(6.486, rel=2e-3)  # Table 10 via the pose's I
    assert pickle.loads(pickle.dumps(back)).to_json() == back.to_json()
    (tmp_path / "broken.json").write_text(back.to_json().replace('"offset_v": 0.02', '"offset_v": "x"'))
    with pytest.raises(alphainv.Error) as e:
        alphainv.Model.read(tmp_path / "broken.json")
    assert e.value.file.endswith("broken.json") and "offset_v" in e.value.field
