"""OpenDS's powertrain formulas (OpenDS `PowerTrain`, `Transmission`) against hand-computed values."""

from __future__ import annotations

import math

import pytest

from opends_gym.sim.ego.powertrain import (
    Powertrain,
    bmep_kpa,
    engine_power_kw,
    fuel_grams,
    fuel_rpm_factor,
    gear_rpm,
    inner_friction_kw,
    load_terms,
)
from opends_gym.task.model_car import Car, Engine, Transmission

OPENDS_BMEP = (-19950.8, 3479.90, -231.809, 8.25775, -0.169919, 0.00202259, -1.2921e-5, 3.42208e-8)


def test_bmep_and_engine_power_at_3000_rpm() -> None:
    # n = 3000/60 = 50 1/s; bmep = sum(a_i 50^i) = 1650.45 kPa (worked out term by term:
    # -19950.8 + 173995 - 579522.5 + 1032218.75 - 1061993.75 + 632059.375 - 201890.625 + 26735 = 1650.45)
    assert bmep_kpa(50.0) == pytest.approx(1650.45, abs=1e-6)
    # P = bmep * n * V_d / 2 * |gas| = 1650.45 kPa * 50 /s * 0.0018 m^3 / 2 = 74.27025 kW
    assert engine_power_kw(3000.0, 1.0, 1800e-6) == pytest.approx(74.27025, rel=1e-9)
    assert engine_power_kw(3000.0, -0.5, 1800e-6) == pytest.approx(37.135125, rel=1e-9)  # |gas|


def test_engine_power_clamps_rpm_to_1500_5100() -> None:
    assert engine_power_kw(800.0, 1.0, 1800e-6) == engine_power_kw(1500.0, 1.0, 1800e-6)
    assert engine_power_kw(7000.0, 1.0, 1800e-6) == engine_power_kw(5100.0, 1.0, 1800e-6)


def test_inner_friction_and_load_terms() -> None:
    # 7e-7 * 3000^2 - 5e-4 * 3000 + 10.9 = 6.3 - 1.5 + 10.9
    assert inner_friction_kw(3000.0) == pytest.approx(15.7)
    terms = load_terms(mass_kg=1300.0, v_mps=20.0, dv_mps=0.1, dt_s=1 / 60, slope_rad=0.05, rpm=3000.0)
    assert terms.tire_kw == pytest.approx(0.008 * 1300 * 9.81 * 20 / 1000)  # 2.04048 kW
    assert terms.air_kw == pytest.approx(0.5 * 1.3 * 0.3 * 2.0 * 8000 / 1000)  # 3.12 kW
    assert terms.inertia_kw == pytest.approx(0.5 * 1.03 * 1300 * 0.01 * 60 / 1000)  # 0.4017 kW
    assert terms.grade_kw == pytest.approx(1300 * 9.81 * 20 * math.sin(0.05) / 1000)
    assert terms.accessories_kw == 0.75 and terms.inner_kw == pytest.approx(15.7)
    reverse = load_terms(1300.0, 20.0, 0.0, 1 / 60, 0.05, 3000.0, reverse=True)
    assert reverse.grade_kw == pytest.approx(-terms.grade_kw)  # slope negated in reverse


def test_rpm_from_speed_and_gear_ratio() -> None:
    # rpm = v_kmh * ratio / (380 * 0.00006): 100 km/h in 3rd (1.281) = 128.1 / 0.0228
    assert gear_rpm(100 / 3.6, 1.281) == pytest.approx(5618.421, rel=1e-6)


def test_fuel_grams_with_the_high_rpm_factor() -> None:
    # 30 kW for 1 s = 30 kJ / 43.7 kJ/g = 0.68650 g; x1.25 at 4200 rpm (halfway 3600..4800)
    assert fuel_grams(30.0, 1.0, 3000.0) == pytest.approx(30 / 43.7)
    assert fuel_rpm_factor(4200.0) == pytest.approx(1.25)
    assert fuel_rpm_factor(5000.0) == 1.5
    assert fuel_grams(30.0, 1.0, 4200.0) == pytest.approx(1.25 * 30 / 43.7)


def test_idle_consumption_is_0_0003_litres_per_second() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    for _ in range(600):
        pt.step(1 / 60, 0.0, 0.0, 0.0)
    assert pt.state.fuel_used_l == pytest.approx(10 * 0.0003, rel=1e-6)  # 1.08 L/h
    assert pt.state.l_per_h == pytest.approx(1.08, rel=1e-6)


def test_fuel_while_driving_matches_engine_power() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    dt = 1 / 60
    litres = 0.0
    for _ in range(120):
        pt.step(dt, 20.0, 0.6, 0.0)
        st = pt.state
        litres += fuel_grams(st.p_engine_kw, dt, st.rpm) / 760.0
    assert pt.state.fuel_used_l == pytest.approx(litres, rel=1e-9)
    # the consumption display averages the last 2 s: L/h = litres/2 s * 3600, L/100 km per 40 m
    assert pt.state.l_per_h == pytest.approx(litres / 2.0 * 3600, rel=0.02)
    assert pt.state.l_per_100km == pytest.approx(litres / 40.0 * 100_000, rel=0.02)


def test_power_percentage_is_opends_fitted_polynomial() -> None:
    # Transmission.getPowerPercentage at x = v / 140 km/h = 0.5 (70 km/h), term by term:
    # gear 3: -3.17/8 + 1.44/4 + 0.12/2 + 0.27 = 0.29375; gear 4: -1.27/8 + 0.64/4 + 0.24/2 + 0.20 = 0.32125
    # gear 5: -0.47/8 + 0.12/4 + 0.35/2 + 0.11 = 0.25625; gear 6: -0.27/8 + 0.24/4 + 0.18/2 + 0.01 = 0.12625
    # gears 1 and 2 are negative there (-22.9, -0.65), clamped to 0
    pt = Powertrain(Car(ref="car"), 1300.0)
    v = 70 / 3.6
    assert [pt.power_share(g, v) for g in range(1, 7)] == pytest.approx([0.0, 0.0, 0.29375, 0.32125, 0.25625, 0.12625], abs=1e-9)
    assert pt.power_share(1, 0.0) == pytest.approx(0.58) and pt.power_share(2, 0.0) == pytest.approx(0.43)
    assert pt.power_share(-1, 0.0) == pytest.approx(0.57)


def test_automatic_gearbox_picks_the_gear_of_highest_power_percentage() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    assert pt.best_gear(0.0) == 1  # 0.58 against 0.43
    assert pt.best_gear(70 / 3.6) == 4  # 0.32125 (above)
    gears = [pt.best_gear(kmh / 3.6) for kmh in range(5, 190, 5)]
    assert gears == sorted(gears) and gears[-1] == 6  # upshifts only as speed rises
    # Transmission.findBestPowerGear keeps gear 1 when every polynomial is <= 0 (above ~195 km/h)
    assert pt.best_gear(200 / 3.6) == 1


def test_engine_force_is_30_x_p_accel_x_power_percentage_per_jme_call() -> None:
    # 40 km/h in 2nd at full gas, rpm settled, steady speed: P_accel = P_engine - P_load (kW),
    # CarControl.accelerate puts 2 x 30 x P_accel x pp on each front wheel: 120 x P_accel x pp in all
    pt = Powertrain(Car(ref="car", transmission=Transmission(automatic=False)), 1300.0)
    v = 40 / 3.6
    pt.shift(2)
    rpm = gear_rpm(v, 1.955)  # 3429.8
    pt.state.rpm, pt.state.prev_v_mps = rpm, v
    out = pt.step(1 / 60, v, 1.0, 0.0, pitch_rad=0.031765)  # the pitch OpenDS's Car.getSlope reads as level
    p_load = load_terms(1300.0, v, 0.0, 1 / 60, 0.0, rpm).total_kw
    x = 40 / 140
    pp = -4206.38 * x**6 + 4837.65 * x**5 - 1897.61 * x**4 + 310.7 * x**3 - 34.7 * x**2 + 3.82 * x + 0.43
    assert out.drive_force_n == pytest.approx(120.0 * (engine_power_kw(rpm, 1.0, 1800e-6) - p_load) * pp, rel=1e-3)
    back = Powertrain(Car(ref="car", transmission=Transmission(automatic=False)), 1300.0)
    back.shift(2)
    back.state.rpm, back.state.prev_v_mps = rpm, v
    assert back.step(1 / 60, v, -1.0, 0.0, pitch_rad=0.031765).drive_force_n == pytest.approx(
        -out.drive_force_n
    )  # the "accelerate back" key


@pytest.mark.parametrize("pitch_rad", [0.0, 0.05, -0.05])
def test_grade_load_takes_opends_slope_pitch_less_0_031765(pitch_rad) -> None:
    # Car.getSlope = chassis pitch (jME toAngles()[0]) - 0.031765 rad, and PowerTrain.getPGrade
    # is m g v sin(slope): a level chassis (pitch 0, every flat road here) reads 1.82 degrees
    # downhill, so 80 km/h in 4th at full gas gets m g v sin(0.031765) = 3.6 kW less load
    v = 80 / 3.6
    rpm = gear_rpm(v, 0.973)
    pt = Powertrain(Car(ref="car", transmission=Transmission(automatic=False)), 800.0)
    pt.shift(4)
    pt.state.rpm, pt.state.prev_v_mps = rpm, v
    out = pt.step(1 / 60, v, 1.0, 0.0, pitch_rad=pitch_rad)
    p_load = load_terms(800.0, v, 0.0, 1 / 60, pitch_rad - 0.031765, rpm).total_kw
    x = 80 / 140
    pp = -1.27 * x**3 + 0.64 * x**2 + 0.24 * x + 0.20
    assert out.drive_force_n == pytest.approx(120.0 * (engine_power_kw(rpm, 1.0, 1800e-6) - p_load) * pp, rel=1e-3)
    if pitch_rad == 0.0:  # on flat road: 120 x 3.6 kW x pp more force than with no grade term (~0.2 m/s2 on 800 kg)
        no_grade = 120.0 * (engine_power_kw(rpm, 1.0, 1800e-6) - load_terms(800.0, v, 0.0, 1 / 60, 0.0, rpm).total_kw) * pp
        assert out.drive_force_n - no_grade == pytest.approx(120.0 * 800 * 9.81 * v * math.sin(0.031765) / 1000 * pp, rel=1e-3)


def test_rpm_is_rate_limited_and_floored_at_min_rpm() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    pt.step(1 / 60, 0.0, 0.0, 0.0)
    assert pt.state.rpm == pytest.approx(5000 / 60)  # from 0 towards minRPM 750 at 5000 rpm/s
    for _ in range(60):
        pt.step(1 / 60, 0.0, 0.0, 0.0)
    assert pt.state.rpm == pytest.approx(750.0)


def test_neutral_revs_with_the_gas_and_gives_no_drive() -> None:
    pt = Powertrain(Car(ref="car", transmission=Transmission(automatic=False)), 1300.0)
    pt.shift(0)
    for _ in range(240):
        out = pt.step(1 / 60, 0.0, 0.5, 0.0)
    assert out.drive_force_n == 0.0 and out.gear == 0
    assert pt.state.rpm == pytest.approx(0.5 * 7500.0)  # rpm = gas x maxRPM


def test_brake_force_is_opends_brake_impulse_per_wheel() -> None:
    # SteeringCar: maxBrakeForce = 0.004375 x decelerationBrake x mass, a Bullet impulse per wheel
    # per 1/60 s; off the gas the free-wheel drag adds 0.2 (the least coefficient) x 0.004375 x
    # decelerationFreeWheel x mass. As a force on the four wheels: 4 x 100 x (their sum).
    pt = Powertrain(Car(ref="car"), 1300.0)
    pt.state.prev_v_mps = 20.0  # no inertia term: P_load = 2.04 + 3.12 + 0.75 + P_inner(83 rpm) < 10 kW + 10
    out = pt.step(1 / 60, 20.0, 0.0, 1.0)
    assert out.brake_force_n == pytest.approx(400.0 * (0.004375 * 8.7 * 1300.0 + 0.2 * 0.004375 * 0.4 * 1300.0))
    assert pt.max_brake_impulse == pytest.approx(0.004375 * 8.7 * 1300.0)


def test_max_speed_cap_cuts_power_in_the_last_kmh() -> None:
    car = Car(ref="car", engine=Engine(max_speed_mps=100 / 3.6))

    def drive_at(kmh: float) -> float:
        pt = Powertrain(car, 1300.0)
        pt.state.gear, pt.state.prev_v_mps = 4, kmh / 3.6  # steady speed in 4th
        pt.state.rpm = gear_rpm(kmh / 3.6, 0.973)
        return pt.step(1 / 60, kmh / 3.6, 1.0, 0.0).drive_force_n

    below, half, above = drive_at(98.0), drive_at(99.5), drive_at(100.5)
    # Transmission.performAcceleration: from maxSpeed - 1 the share is multiplied by (maxSpeed - v)
    # km/h, so it is halved at 99.5 and turns negative (a push back) above maxSpeed
    assert below > 0.0 and 0.0 < half < below and above < 0.0


def test_gear_lookup_picks_the_gear_every_polynomial_would_pick() -> None:
    # The compiled gearbox looks the automatic's gear up among the speed shares where the choice changes
    # (`gearbox.GEAR_BREAKS`) instead of evaluating every polynomial each physics step. For every gearbox size (1..6
    # forward gears) the lookup must pick what evaluating every polynomial (OpenDS Transmission.findBestPowerGear over
    # getPowerPercentage, its coefficients below) picks: on a dense scan past the speeds where all of them are negative,
    # at random speed shares, and at each break and the float just below it.
    import numpy as np

    from opends_gym.sim.ego.gearbox import GEAR_BREAKS, GEAR_RUNS, SCAN_TO
    from opends_gym.sim.ego.kernels import best_power_gear_py, power_percentage_py

    opends = {
        -1: [-1154.84, 134.09, 21.63, 0.5, 0.57],
        1: [-2892.78, 678.61, 558.43, -216.84, 17.78, 0.58],
        2: [-4206.38, 4837.65, -1897.61, 310.7, -34.7, 3.82, 0.43],
        3: [-3.17, 1.44, 0.12, 0.27],
        4: [-1.27, 0.64, 0.24, 0.20],
        5: [-0.47, 0.12, 0.35, 0.11],
        6: [-0.27, 0.24, 0.18, 0.01],
    }
    for g, coeffs in opends.items():
        for x in (0.0, 0.2, 0.45, 0.9):
            assert power_percentage_py(g, x) == pytest.approx(min(1.0, max(0.0, np.polyval(coeffs, x))), abs=1e-12)
        if g > 0:  # beyond the scan every polynomial stays negative (their leading terms are), so the choice there is gear 1
            assert np.polyval(coeffs, np.linspace(1.4, SCAN_TO, 100_001)).max() < -1e-4
    assert power_percentage_py(0, 0.3) == 0.0 and power_percentage_py(7, 0.3) == 0.0
    breaks = [b for row in GEAR_BREAKS for b in row if 0.0 < b < np.inf]
    assert len(breaks) >= 6  # (the six-gear box alone shifts up five times and back to 1 past ~195 km/h)
    edges = breaks + [float(np.nextafter(b, 0.0)) for b in breaks]
    grid = np.linspace(0.0, SCAN_TO + 1.0, 4001).tolist() + np.random.default_rng(0).uniform(0.0, 1.6, 20_000).tolist()
    for n in range(1, 7):
        for x in grid + edges:
            shares = [power_percentage_py(g, x) for g in range(1, n + 1)]
            plain = 1 + shares.index(max(shares)) if max(shares) > 0.0 else 1
            assert best_power_gear_py(n, x) == plain, (n, x)
    assert best_power_gear_py(9, 0.5) == best_power_gear_py(6, 0.5) and best_power_gear_py(0, 0.5) == 1
    assert GEAR_RUNS[5, :7].tolist() == [1, 2, 3, 4, 5, 6, 1]
