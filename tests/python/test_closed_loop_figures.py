"""scripts/closed_loop_figures.py's `scale` (the robustness models of scripts/closed-loop.sh): every
effect's size parameters scaled, nothing else, and an effect with nothing to scale refused."""

import importlib.util
import json

import pytest

from conftest import SOURCE_DIR


def load_figures():
    spec = importlib.util.spec_from_file_location(
        "closed_loop_figures", SOURCE_DIR / "scripts" / "closed_loop_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_model(path, effects):
    path.write_text(json.dumps({"alpha_model": {}, "effects": effects}))


def test_scale_scales_every_size_and_nothing_else(tmp_path):
    figures = load_figures()
    effects = [
        {"effect": "asymmetric_friction",
         "parameters": {"asymmetric_coulomb_pos_v": 0.017, "asymmetric_coulomb_neg_v": 0.05,
                        "asymmetric_viscous_diff_v_s": 0.008,
                        "asymmetric_smoothing_rad_s": 0.014}},
        {"effect": "position_dependent_friction",
         "parameters": {"position_coulomb_v": 0.02, "position_slope_v_per_rad": -0.1,
                        "position_smoothing_rad_s": 0.001}},
        {"effect": "cogging",
         "parameters": {"cogging_v": 0.01, "cogging_period_rad": 0.016, "cogging_phase_rad": 1.1}},
        {"effect": "saturation", "parameters": {"saturation_v": 0.4}},
        {"effect": "time_delay", "parameters": {"delay_s": 0.002}},
        {"effect": "external_disturbance",
         "parameters": {"disturbance_rms_v": 0.001, "disturbance_window_s": 0.05}},
    ]
    write_model(tmp_path / "in.json", effects)
    figures.scale(str(tmp_path / "in.json"), 1.3, str(tmp_path / "out.json"))
    out = {e["effect"]: e["parameters"] for e in json.loads((tmp_path / "out.json").read_text())["effects"]}
    a = out["asymmetric_friction"]
    assert a["asymmetric_coulomb_pos_v"] == pytest.approx(0.017 * 1.3, rel=1e-12)
    assert a["asymmetric_coulomb_neg_v"] == pytest.approx(0.05 * 1.3, rel=1e-12)
    assert a["asymmetric_viscous_diff_v_s"] == pytest.approx(0.008 * 1.3, rel=1e-12)
    assert a["asymmetric_smoothing_rad_s"] == 0.014
    p = out["position_dependent_friction"]
    assert p["position_coulomb_v"] == pytest.approx(0.026, rel=1e-12)
    assert p["position_slope_v_per_rad"] == pytest.approx(-0.13, rel=1e-12)
    assert p["position_smoothing_rad_s"] == 0.001
    assert out["cogging"] == {"cogging_v": pytest.approx(0.013, rel=1e-12),
                              "cogging_period_rad": 0.016, "cogging_phase_rad": 1.1}
    assert out["saturation"] == {"saturation_v": 0.4}  # a limit, not a size
    assert out["time_delay"] == {"delay_s": 0.002}
    # A torque of time, located per run: not compensated by the tick, so not scaled.
    assert out["external_disturbance"] == {"disturbance_rms_v": 0.001, "disturbance_window_s": 0.05}


def test_scale_refuses_an_effect_with_nothing_to_scale(tmp_path):
    figures = load_figures()
    write_model(tmp_path / "in.json",
                [{"effect": "new_friction", "parameters": {"new_level": 0.02}}])
    with pytest.raises(SystemExit) as e:
        figures.scale(str(tmp_path / "in.json"), 0.7, str(tmp_path / "out.json"))
    assert "new_friction" in str(e.value)
    assert not (tmp_path / "out.json").exists()
