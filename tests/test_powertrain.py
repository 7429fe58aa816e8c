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


def test_automatic_gearbox_picks_the_gear_of_highest_power_share() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    gears = []
    for kmh in range(5, 200, 5):
        v = kmh / 3.6
        best = pt.best_gear(v)
        shares = [pt.power_share(g, v) for g in range(1, 7)]
        assert shares[best - 1] == pytest.approx(max(shares), abs=0.02)  # table at 0.1 m/s resolution
        gears.append(best)
    assert gears[0] == 1 and gears[-1] >= 5  # above ~5100 rpm the power curve is flat (clamped), so 5th and 6th tie
    assert gears == sorted(gears)  # upshifts only as speed rises (no hysteresis needed)


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


def test_brake_force_is_the_pedal_times_deceleration_times_mass() -> None:
    pt = Powertrain(Car(ref="car"), 1300.0)
    out = pt.step(1 / 60, 20.0, 0.0, 1.0)
    free_wheel = 1300.0 * 0.4 * 0.2  # decelerationFreeWheel x mass x the minimum drag coefficient
    assert out.brake_force_n == pytest.approx(1300.0 * 8.7 + free_wheel, rel=0.05)


def test_max_speed_cap_cuts_power_in_the_last_kmh() -> None:
    car = Car(ref="car", engine=Engine(max_speed_mps=100 / 3.6))
    pt = Powertrain(car, 1300.0)
    below = pt.step(1 / 60, 98.0 / 3.6, 1.0, 0.0).drive_force_n
    half = pt.step(1 / 60, 99.5 / 3.6, 1.0, 0.0).drive_force_n
    above = pt.step(1 / 60, 100.5 / 3.6, 1.0, 0.0).drive_force_n
    assert below > 0.0 and 0.0 < half < below and above == 0.0
