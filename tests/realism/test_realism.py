"""The realism layer's parts alone (lab/realism): the generator, knobs and presets, delays,
sensors, actuators and model error, against the models' own numbers."""

import math

import numpy as np
import pytest

from lab.description import ROBOT_NAMES, load_description
from lab.protocol import CommandError, parse_command
from lab.realism.actuators import FirstOrderTorque, SeriesElastic
from lab.realism.delays import DelayLine
from lab.realism.knobs import KNOBS, PRESET_NAMES, RealismKnobs, knobs_from, preset, sources
from lab.realism.layer import RealismLayer
from lab.realism.model_error import perturbed_model
from lab.realism.rng import normals
from lab.realism.sensors import IMU_DRAWS
from lab.robot import build_robot

DT = 1e-3


def test_the_generator_draws_standard_normals_and_is_a_function_of_seed_and_counter() -> None:
    z = normals(7, 0, 200_000)
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1.0) < 0.01  # 200 000 draws: σ/√n = 0.002
    np.testing.assert_array_equal(normals(7, 1000, 50), z[1000:1050])  # a draw is its counter's
    assert not np.allclose(normals(8, 0, 50), z[:50])


def test_bad_knobs_are_refused_by_name_and_presets_load_for_every_robot() -> None:
    base = RealismKnobs()
    for values, words in (
        ({"gyro_nois": 0.1}, "unknown knob 'gyro_nois'"),
        ({"command_delay": 2.5}, "command_delay must be a whole number"),
        ({"command_delay": 51}, "command_delay = 51 is out of range"),
        ({"attitude_noise": math.nan}, "attitude_noise must be finite"),
        ({"actuator": "hydraulic"}, "actuator must be one of"),
        ({"sea_kp": "stiff"}, "sea_kp must be a number"),
    ):
        with pytest.raises(ValueError, match=words):
            knobs_from(base, values)
    with pytest.raises(CommandError, match="'torque_saturation' = 0 is out of range"):
        parse_command("realism", {"torque_saturation": 0})
    with pytest.raises(CommandError, match="'command_delay'"):
        parse_command("realism", {"command_delay": 2.5})
    with pytest.raises(CommandError, match="preset"):
        parse_command("realism", {"preset": "brutal"})
    with pytest.raises(CommandError, match="mass"):
        parse_command("payload", {"body": "base", "mass": -1.0})
    for robot in ROBOT_NAMES:
        for name in PRESET_NAMES:
            knobs = preset(name, robot)  # every value range-checked on the way in
            assert knobs.preset == name
    assert preset("typical", "anymal").actuator == "sea"
    typical = sources("typical", "anymal")
    assert set(typical) >= {"gyro_noise", "sea_stiffness"}  # every typical value says its source


def test_a_delay_line_returns_what_was_pushed_that_many_ticks_before() -> None:
    line = DelayLine(5, 2)
    out = [line.push(np.array([t, -t], dtype=float))[0] for t in range(20)]
    assert out[:6] == [0.0] * 6  # the first value until five more have passed
    assert out[6:] == list(range(1, 15))


def test_encoders_quantize_and_differencing_measures_a_ramp() -> None:
    bits, rate = 12, 0.7  # rad/s
    knobs = replace_knobs(encoder_bits=bits, velocity_differencing=1, velocity_filter_hz=50.0)
    layer = RealismLayer(knobs, 2, DT)
    step = 2 * math.pi / 2**bits
    q, v = np.zeros(9), np.zeros(8)
    q[6] = 1.0
    for tick in range(400):
        q[7:] = [rate * tick * DT, 0.3 + 1e-5]
        qm, vm = layer.measure(q, v)
    np.testing.assert_allclose(qm[7:] / step, np.rint(qm[7:] / step), atol=1e-9)  # on the grid
    assert abs(qm[8] - 0.3) <= step / 2
    # 400 ticks ≫ the filter's 3.2 ms: the differenced velocity is the ramp's, to one
    # quantum per filter time constant
    assert abs(vm[6] - rate) < step / (1 / (2 * math.pi * 50.0))
    assert abs(vm[7]) < 1e-9


def test_gyro_white_noise_has_the_datasheet_density() -> None:
    density = 1.745e-4  # rad/s/√Hz, Xsens MTi-100
    layer = RealismLayer(replace_knobs(gyro_noise=density, seed=3), 0, DT)
    q, v = np.array([0, 0, 0, 0, 0, 0, 1.0]), np.zeros(6)
    rates = np.array([layer.measure(q, v)[1][3:6] for _ in range(4000)])
    expected = density / math.sqrt(DT)  # Kalibr: σ_d = σ_c / √dt
    assert abs(rates.std() / expected - 1.0) < 0.05  # 12 000 draws: 1.3 % std error
    assert IMU_DRAWS == 15


def _rise_time(signal: np.ndarray, final: float, dt: float) -> float:
    """10–90 % rise time of `signal` sampled every `dt` from t = dt, crossings interpolated."""
    t = dt * np.arange(1, signal.size + 1)
    rising = signal[: np.argmax(signal >= 0.95 * final) + 1]  # before any overshoot
    return float(
        np.interp(0.9 * final, rising, t[: rising.size])
        - np.interp(0.1 * final, rising, t[: rising.size])
    )


def test_the_sea_follows_a_torque_step_with_its_second_order_rise_time() -> None:
    """Joint held: J δ̈ + K_d δ̇ + (K_p + k) δ = (K_p + k) δ_d (actuators.py), a second-order
    system of ω_n = √((K_p + k)/J), ζ = K_d / (2√((K_p + k) J)); the SEA's torque k δ rises
    10–90 % in that system's rise time (its closed-form step response) to 3 %."""
    k, inertia, kp, kd = 200.0, 0.05, 1800.0, 10.0  # the typical ANYmal preset
    knobs = replace_knobs(
        actuator="sea", sea_stiffness=k, sea_motor_inertia=inertia, sea_kp=kp, sea_kd=kd
    )
    sea = SeriesElastic(knobs, 1, DT)
    sea.reset(np.zeros(1), np.zeros(1))
    step = 10.0  # N m
    zero = np.zeros(1)
    torque = np.array([sea.apply(np.array([step]), zero, zero)[0] for _ in range(300)])
    wn = math.sqrt((kp + k) / inertia)
    zeta = kd / (2 * math.sqrt((kp + k) * inertia))
    assert (wn, zeta) == pytest.approx((200.0, 0.5))
    wd, fine = wn * math.sqrt(1 - zeta**2), 1e-6
    t = fine * np.arange(1, 30_001)
    exact = step * (
        1
        - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    )
    expected = _rise_time(exact, step, fine)
    assert abs(_rise_time(torque, step, DT) - expected) <= 0.03 * expected
    assert torque[-1] == pytest.approx(step, rel=1e-3)  # no steady-state error


def test_a_first_order_torque_reaches_63_percent_after_one_time_constant() -> None:
    f = 25.0  # Hz: τ = 1 / (2π f) = 6.37 ms
    actuator = FirstOrderTorque(replace_knobs(actuator="bandwidth", torque_bandwidth_hz=f), 1, DT)
    actuator.reset(np.zeros(1))
    out = [actuator.apply(np.ones(1), None, None)[0] for _ in range(200)]
    ticks = 1.0 / (2 * math.pi * f) / DT
    assert np.interp(ticks, np.arange(1, 201), out) == pytest.approx(1 - math.exp(-1), abs=0.01)


def test_model_error_perturbs_a_copy_within_its_bounds() -> None:
    model = build_robot(load_description("anymal")).model
    masses = [model.inertias[j].mass for j in range(1, model.njoints)]
    wrong = perturbed_model(model, 0.1, 0.01, seed=4)
    assert [model.inertias[j].mass for j in range(1, model.njoints)] == masses  # untouched
    ratios = np.array([wrong.inertias[j].mass / m for j, m in enumerate(masses, 1)])
    assert np.all(np.abs(ratios - 1) <= 0.1) and np.any(np.abs(ratios - 1) > 0.02)
    shifts = [
        np.abs(wrong.inertias[j].lever - model.inertias[j].lever).max()
        for j in range(1, model.njoints)
    ]
    assert max(shifts) <= 0.01 + 1e-15
    same = perturbed_model(model, 0.1, 0.01, seed=4)
    assert all(same.inertias[j] == wrong.inertias[j] for j in range(1, model.njoints))


def replace_knobs(**values: object) -> RealismKnobs:
    """Ideal knobs with `values` set (checked)."""
    assert set(values) <= {*KNOBS, "actuator"}
    return knobs_from(RealismKnobs(), values)
