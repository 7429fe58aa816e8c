"""OpenDS's gearbox polynomials as a table, and the automatic gearbox's choice as speed breaks.

Why: `Transmission.findBestPowerGear` picks, every physics step, the forward gear whose
fitted power polynomial (`Transmission.getPowerPercentage`) is highest at the speed. The
compiled car evaluated all six polynomials for it (and LLVM computed every one of them
even where a branch skipped it): ~17 of the car's ~76 ns per physics step when last split
(docs/performance.md, "What limits it"). The
choice depends on the speed share alone, so it changes only at a few speed shares; those
breaks are found once here, on the same floats the polynomials give (the gear at each
break and at the float below it are the polynomials' own choice), and the step looks the
gear up among them. `tests/test_powertrain.py` checks the breaks against evaluating every
polynomial.

The polynomials take x = v / 140 km/h (`kernels.SPEED_AT_FULL_SHARE_KMH`) and give the
share of the engine's power the gear passes on, clamped to 0..1 by the caller.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

# Transmission.getPowerPercentage's coefficients, highest power first, padded with leading zeros to degree 6 (a leading
# 0 * x + c is exactly c, so Horner's scheme over a padded row gives the floats of the unpadded polynomial). Row
# gear + 1: reverse, neutral (no power), gears 1..6. A tuple: the kernels take it as a constant, and Python indexes it fast.
POWER_ROWS = (
    (0.0, 0.0, -1154.84, 134.09, 21.63, 0.5, 0.57),  # reverse
    (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),  # neutral
    (0.0, -2892.78, 678.61, 558.43, -216.84, 17.78, 0.58),
    (-4206.38, 4837.65, -1897.61, 310.7, -34.7, 3.82, 0.43),
    (0.0, 0.0, 0.0, -3.17, 1.44, 0.12, 0.27),
    (0.0, 0.0, 0.0, -1.27, 0.64, 0.24, 0.20),
    (0.0, 0.0, 0.0, -0.47, 0.12, 0.35, 0.11),
    (0.0, 0.0, 0.0, -0.27, 0.24, 0.18, 0.01),
)
MAX_GEARS = 6  # forward gears with a polynomial
# past this speed share every forward polynomial is negative for good (each one's leading term is negative; the tests scan
# up to it), so the choice there is gear 1, Transmission.findBestPowerGear's default
SCAN_TO = 3.0


def clamped_share(gear: int, x: float) -> float:
    """OpenDS's `Transmission.getPowerPercentage`: the share of the engine's power a gear
    passes on at speed share x (its polynomial, clamped to 0..1; other gears 0). Plain Python
    here, for finding the breaks at import; the kernels compile this same function
    (`kernels.power_percentage`)."""
    if gear < -1 or gear > MAX_GEARS:
        return 0.0
    pp = 0.0
    for c in POWER_ROWS[gear + 1]:
        pp = pp * x + c
    return 0.0 if pp < 0.0 else 1.0 if pp > 1.0 else pp


def argmax_gear(n_gears: int, x: float) -> int:
    """`Transmission.findBestPowerGear` by evaluating every polynomial: the forward gear
    1..n of highest share (the first on a tie; 1 when all are 0)."""
    best, best_gear = 0.0, 1
    for g in range(1, min(n_gears, MAX_GEARS) + 1):
        pp = clamped_share(g, x)
        if pp > best:
            best, best_gear = pp, g
    return best_gear


def _candidates() -> list[float]:
    """Speed shares in 0..SCAN_TO where the choice can change: where two polynomials cross or
    one crosses 0 or 1 (numpy's roots, approximate: the breaks are then found on the floats)."""
    polys = [np.trim_zeros(np.array(POWER_ROWS[g + 1]), "f") for g in range(1, MAX_GEARS + 1)]
    found = {0.0, SCAN_TO}
    for i, p in enumerate(polys):
        others = [*polys[i + 1 :], np.array([0.0]), np.array([1.0])]
        for q in others:
            for root in np.roots(np.polysub(p, q)):
                if abs(root.imag) < 1e-9 and 0.0 < root.real < SCAN_TO:
                    found.add(float(root.real))
    return sorted(found)


def _breaks(n_gears: int, samples: list[float]) -> tuple[list[float], list[int]]:
    """The speed shares from which each successive choice holds, and the choices: the first
    break is -inf; each later one is the float at which the choice first differs from the
    one before, found by bisection between samples."""
    breaks, gears = [-math.inf], [argmax_gear(n_gears, samples[0])]
    x = samples[0]
    for s in samples[1:]:
        while argmax_gear(n_gears, s) != gears[-1]:
            lo, hi = x, s
            while True:
                mid = lo + 0.5 * (hi - lo)
                if mid <= lo or mid >= hi:
                    break
                if argmax_gear(n_gears, mid) == gears[-1]:
                    lo = mid
                else:
                    hi = mid
            breaks.append(hi)
            gears.append(argmax_gear(n_gears, hi))
            x = hi
        x = s
    return breaks, gears


def gear_breaks() -> tuple[np.ndarray, np.ndarray]:
    """(breaks, gears), row n - 1 for a gearbox of n forward gears (1..6): the choice is
    gears[row, k] for breaks[row, k] <= x < breaks[row, k + 1] (padded with +inf)."""
    points = _candidates()
    samples = sorted({*points, *(0.5 * (a + b) for a, b in itertools.pairwise(points))})
    rows = [_breaks(n, samples) for n in range(1, MAX_GEARS + 1)]
    width = max(len(b) for b, _ in rows) + 1
    breaks = np.full((MAX_GEARS, width), math.inf)
    gears = np.ones((MAX_GEARS, width), dtype=np.int64)
    for i, (b, g) in enumerate(rows):
        breaks[i, : len(b)], gears[i, : len(g)] = b, g
    return breaks, gears


GEAR_BREAKS, GEAR_RUNS = gear_breaks()
