"""The core in Python: alpha (eqs. 33, 34, 36), AlphaModel (38)-(42) against the paper's Table 10,
InertiaModel (6), LinearModel (24)-(26), Controller (10), the effects generated from the effect
table, the streaming estimator, and alphainv.Error's fields."""

import math
import pickle

import numpy as np
import pytest

import alphainv

from conftest import BUILD_DIR

I_65_90 = 0.004366  # Table 10's pose


def test_paper_model_reproduces_table_10():
    # paper-notes erratum 3: C = 16.955, 10.619, 6.486, 3.710 at alpha = 0, 2.2, 25, 250;
    # beta~ = 267.6 at alpha = 0 and 170.9 at alpha = 250 (what tests/model/test_damping_model.cpp
    # asserts in C++), here through numpy arrays.
    m = alphainv.AlphaModel.paper()
    assert m.valid() and m.n_breakpoints == 4
    c = m.damping(np.array([0.0, 2.2, 25.0, 250.0]), I_65_90)
    np.testing.assert_allclose(c, [16.955, 10.619, 6.486, 3.710], rtol=1e-3)
    np.testing.assert_allclose(m.beta_tilde([0.0, 250.0], I_65_90), [267.6, 170.9], rtol=1e-3)
    # eq. (38): linear between breakpoints, held outside
    assert m.damping(10.0, I_65_90) == pytest.approx(c[1] + (c[2] - c[1]) * (10.0 - 2.2) / (25.0 - 2.2), abs=1e-12)
    assert m.damping(-5.0, I_65_90) == m.damping(0.0, I_65_90)
    assert m.damping(1e4, I_65_90) == m.damping(250.0, I_65_90)


def test_inertia_and_linear_models():
    i = alphainv.InertiaModel.paper()
    g1, g2 = math.radians(60.08), math.radians(87.0)
    psi = math.pi - g1 - g2 - i.gamma_offs_rad
    expected = i.i_base + i.i1 * math.cos(g1) ** 2 + i.i2 * math.cos(psi) ** 2 + i.i3 * math.cos(g1) * math.cos(psi)
    assert i.inertia(g1, g2) == pytest.approx(expected, rel=1e-15)  # eq. (6)
    assert i.inertia(g1, g2) == pytest.approx(I_65_90, rel=2e-3)   # the 65/90 pose of Table 10
    lin = alphainv.LinearModel.paper()
    assert lin.c0_bar == 36.694
    assert lin.damping(I_65_90) == pytest.approx(1.0 / (36.694 * I_65_90))  # eq. (24)
    assert lin.beta_tilde(I_65_90) == pytest.approx(1.0 / I_65_90)        # eq. (25)
    grid = i.inertia(np.radians([25.0, 45.0, 65.0]), np.radians([70.0, 90.0, 115.0]))
    assert grid.shape == (3,)


def test_alpha_of_a_sine_is_its_amplitude_times_frequency_squared():
    # eq. (35): for v = A sin(wt), alpha = A^2 w^2; the streaming estimator reads |H(f)|^2 of it.
    dt, f, amp = 1e-3, 3.0, 0.2
    t = np.arange(0.0, 4.0, dt)
    v = amp * np.sin(2 * np.pi * f * t)
    a = alphainv.alpha(v, dt)
    est = alphainv.AlphaEstimator(dt, 25.0)
    exact = (amp * 2 * np.pi * f) ** 2 * est.alpha_gain(f)
    steady = a[t > 1.0]
    assert np.max(np.abs(steady / exact - 1.0)) < 2e-3
    d = alphainv.alpha(v, dt, derivatives=True)
    np.testing.assert_array_equal(d["alpha"], a)
    np.testing.assert_allclose(d["alpha"], alphainv.alpha_instantaneous(d["v"], d["v_dot"], d["v_ddot"]), rtol=1e-12, atol=1e-12)
    # the same numbers sample by sample through update()
    est.reset(v[0])
    assert est.update(v[0])[3] == a[0] and est.update(v[1])[3] == a[1]


def test_alpha_closed_forms():
    assert alphainv.alpha_instantaneous(2.0, 3.0, 5.0) == 3.0 ** 2 - 2.0 * 5.0  # eq. (33)
    kp, w, a1, a2, ar = 2.0, 2 * np.pi * 3, 0.03, 0.05, 0.07
    assert alphainv.alpha_sine_steady_state(kp, w, a1, a2, ar) == pytest.approx(kp**2 * w**2 * (a1**2 + (ar - a2) ** 2))
    # eq. (34) over one period of a sine: A^2 w^2
    n, amp = 1001, 0.3
    t = np.linspace(0.0, 1.0 / 3.0, n)
    v, vd, vdd = amp * np.sin(w * t), amp * w * np.cos(w * t), -amp * w * w * np.sin(w * t)
    assert alphainv.alpha_cycle_average(v, vd, vdd, t[1] - t[0]) == pytest.approx(amp**2 * w**2, rel=1e-9)


def test_alpha_refuses_a_bad_sample_period_naming_the_field():
    with pytest.raises(alphainv.Error) as e:
        alphainv.alpha(np.zeros(10), 0.0)
    assert e.value.field == "sample_period_s" and isinstance(e.value, ValueError)
    with pytest.raises(alphainv.Error) as e:
        alphainv.alpha(np.zeros(10), 1e-3, cutoff_hz=400.0)
    assert e.value.field == "cutoff_hz" and "250" in e.value.message


def test_effects_are_generated_from_the_table():
    names = [s.name for s in alphainv.EFFECTS]
    assert names[0] == "none" and "coulomb_friction" in names and "deadzone" in names
    e = alphainv.Effects()
    assert e.active == []
    for spec in alphainv.EFFECTS:
        for p in spec.parameters:
            assert hasattr(e, p.name), p.name
            old = getattr(e, p.name)
            setattr(e, p.name, 0.125)
            assert getattr(e, p.name) == 0.125
            setattr(e, p.name, old)
    # the stubs list every parameter of the table too (generated at build time)
    stubs = (BUILD_DIR / "python" / "alphainv" / "__init__.pyi").read_text()
    for spec in alphainv.EFFECTS:
        for p in spec.parameters:
            assert f"    {p.name}: float" in stubs, p.name
        assert f'"{spec.name}"' in stubs


def test_effect_terms_and_specs():
    e = alphainv.Effects.parse("coulomb_friction:coulomb_v=0.004")
    assert e.active == ["coulomb_friction"]
    theta_dot = np.array([-1.0, 0.0, 1e-3, 1.0])
    np.testing.assert_allclose(e.torque(0.0, theta_dot), -0.004 * np.tanh(theta_dot / 1e-3), rtol=1e-15)
    dz = alphainv.Effects(deadzone_v=0.01, saturation_v=0.5)
    np.testing.assert_allclose(dz.amplifier([-1.0, -0.005, 0.02, 0.7]), [-0.5, 0.0, 0.01, 0.5], atol=1e-15)
    assert sorted(dz.active) == ["deadzone", "saturation"]
    assert alphainv.Effects.parse(e.spec_text("coulomb_friction")) == e
    assert alphainv.Effects.parse({"gravity": {"gravity_v": 0.02, "gravity_theta0_rad": 0.1}}).to_dict() == \
        {"gravity": {"gravity_v": 0.02, "gravity_theta0_rad": 0.1}}
    assert pickle.loads(pickle.dumps(dz)) == dz


def test_effects_refuse_unknown_or_bad_values_naming_the_field():
    with pytest.raises(alphainv.Error) as e:
        alphainv.Effects(coulomb=1.0)
    assert e.value.field == "Effects.coulomb" and "coulomb_v" in e.value.message
    with pytest.raises(alphainv.Error) as e:
        alphainv.Effects(coulomb_v=-1.0)
    assert e.value.field == "Effects.coulomb_v"
    with pytest.raises(alphainv.Error) as e:
        alphainv.Effects.parse("friction=0.1")
    assert "unknown effect" in e.value.message and e.value.field == "--effect friction=0.1"


def test_controller_and_pickling():
    c = alphainv.Controller(kp=3.0, kd=0.1, derivative_on="measurement", v_limit=0.5)
    np.testing.assert_array_equal(c.clamp([-1.0, 0.2, 1.0]), [-0.5, 0.2, 0.5])
    assert pickle.loads(pickle.dumps(c)) == c
    with pytest.raises(alphainv.Error) as e:
        alphainv.Controller(derivative_on="rate")
    assert e.value.field == "derivative_on"
    m = alphainv.AlphaModel.paper()
    m2 = pickle.loads(pickle.dumps(m))
    np.testing.assert_array_equal(m2.c_n1, m.c_n1)
    with pytest.raises(alphainv.Error) as e:
        m.c_n1 = [1.0, 2.0]
    assert e.value.field == "c_n1"
    with pytest.raises(alphainv.Error) as e:
        alphainv.AlphaModel([0.0, 1.0], [1.0, -1.0])
    assert e.value.field == "AlphaModel"
