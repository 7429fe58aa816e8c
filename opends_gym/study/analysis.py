"""The study's statistics: per metric, a mixed-effects model, within-subject effect sizes with
95 % CIs, and the participants needed for a target power, found by simulation.

Why these: conditions are measured within subject, so a participant's own level is a random
intercept (`statsmodels` MixedLM: value ~ condition + (1 | participant)) and the standardised
effect is Cohen's d_z = mean(difference) / SD(difference) of each participant's condition minus
reference means (Cohen 1988, ch. 2.3; Lakens 2013, Front. Psychol. 4:863, eq. 6). The raw
difference has the t-interval; d_z a seeded percentile bootstrap over participants. Power: draw
n participants with replacement from the simulated population's differences, test them with a
two-sided paired t-test at alpha, count the rejections; the smallest n reaching the target
power is reported (the paired t-test is the mixed model's condition test for two conditions
and balanced data, and a thousand of them cost milliseconds).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..extras import require


@dataclass
class Effect:
    source: str
    task: str
    metric: str
    condition: str
    reference: str
    n: int  # participants measured in both conditions
    mean_reference: float
    sd_reference: float  # between participants
    mean_condition: float
    sd_condition: float
    difference: float  # condition - reference (raw units)
    difference_low: float
    difference_high: float
    cohens_dz: float
    dz_low: float
    dz_high: float
    mixedlm_coef: float
    mixedlm_low: float
    mixedlm_high: float
    mixedlm_p: float
    power_n: float  # participants for the target power (nan: not reached within max_n)
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def paired_differences(cells: Any, condition: str, reference: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(reference means, condition means, differences) of the participants measured in both."""
    both = cells[[reference, condition]].dropna()
    ref = both[reference].to_numpy(float)
    cond = both[condition].to_numpy(float)
    return ref, cond, cond - ref


def t_interval(x: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    stats = require("study", "scipy.stats", "the study summary")
    n = len(x)
    if n < 2:
        return math.nan, math.nan
    m, se = float(np.mean(x)), float(np.std(x, ddof=1)) / math.sqrt(n)
    q = float(stats.t.ppf(0.5 + level / 2, n - 1))
    return m - q * se, m + q * se


def cohens_dz(diff: np.ndarray) -> float:
    if len(diff) < 2:
        return math.nan
    sd = float(np.std(diff, ddof=1))
    if sd == 0.0:
        return math.nan if float(np.mean(diff)) == 0.0 else math.copysign(math.inf, float(np.mean(diff)))
    return float(np.mean(diff)) / sd


def dz_bootstrap(diff: np.ndarray, resamples: int, seed: int, level: float = 0.95) -> tuple[float, float]:
    """Percentile bootstrap CI of d_z, participants resampled with replacement (seeded)."""
    n = len(diff)
    if n < 3:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    x = diff[rng.integers(0, n, (resamples, n))]
    sd = x.std(axis=1, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        dz = x.mean(axis=1) / sd
    dz = dz[np.isfinite(dz)]
    if len(dz) == 0:
        return math.nan, math.nan
    lo, hi = np.quantile(dz, [(1 - level) / 2, (1 + level) / 2])
    return float(lo), float(hi)


def power_at(diff: np.ndarray, n: int, alpha: float, simulations: int, seed: int) -> float:
    """Share of `simulations` studies of n participants (drawn from `diff`) whose paired t-test rejects at alpha."""
    stats = require("study", "scipy.stats", "the power analysis")
    rng = np.random.default_rng([seed, n])
    x = diff[rng.integers(0, len(diff), (simulations, n))]
    m = x.mean(axis=1)
    sd = x.std(axis=1, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = m / (sd / math.sqrt(n))
    p = np.where(sd > 0, 2.0 * stats.t.sf(np.abs(t), n - 1), np.where(m != 0, 0.0, 1.0))
    return float(np.mean(p < alpha))


def participants_needed(diff: np.ndarray, target: float, alpha: float, simulations: int, max_n: int, seed: int) -> float:
    """The smallest n (2..max_n) whose simulated power reaches `target`; nan if max_n does not."""
    if len(diff) < 2:
        return math.nan
    if power_at(diff, max_n, alpha, simulations, seed) < target:
        return math.nan
    lo, hi = 2, max_n  # power(hi) >= target; find the smallest such n (power rises with n)
    if power_at(diff, lo, alpha, simulations, seed) >= target:
        return float(lo)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if power_at(diff, mid, alpha, simulations, seed) >= target:
            hi = mid
        else:
            lo = mid
    return float(hi)


def mixed_model(data: Any, conditions: list[str], reference: str) -> tuple[dict[str, tuple[float, float, float, float]], str]:
    """MixedLM value ~ condition (treatment coded against `reference`) + random intercept per participant.

    Returns {condition: (coef, ci_low, ci_high, p)} and a note ('' when the fit converged).
    """
    sm = require("study", "statsmodels.api", "the study summary")
    others = [c for c in conditions if c != reference]
    y = data["value"].to_numpy(float)
    exog = np.column_stack([np.ones(len(y))] + [(data["condition"] == c).to_numpy(float) for c in others])
    if np.std(y) == 0.0:
        return {}, "constant value: no model"
    if data["participant"].nunique() < 3:
        return {}, "fewer than 3 participants: no model"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fit = sm.MixedLM(y, exog, groups=data["participant"].to_numpy()).fit(reml=True)
        except Exception as e:  # singular designs and the like: reported, not fatal
            return {}, f"model failed: {type(e).__name__}: {e}".splitlines()[0]
    ci = np.asarray(fit.conf_int(alpha=0.05))
    params = np.asarray(fit.params)
    pvalues = np.asarray(fit.pvalues)
    out = {c: (float(params[k + 1]), float(ci[k + 1, 0]), float(ci[k + 1, 1]), float(pvalues[k + 1])) for k, c in enumerate(others)}
    converged = bool(getattr(fit, "converged", True))
    names = sorted({type(w.message).__name__ for w in caught if "Convergence" in type(w.message).__name__})
    note = "" if converged and not names else "model: " + (", ".join(names) or "did not converge")
    return out, note


def summarize(
    table: Any,
    conditions: list[str],
    reference: str,
    *,
    target: float = 0.8,
    alpha: float = 0.05,
    simulations: int = 1000,
    max_n: int = 500,
    bootstrap: int = 2000,
    seed: int = 0,
) -> list[Effect]:
    """One `Effect` per (source, task, metric, condition other than the reference)."""
    effects: list[Effect] = []
    data = table[np.isfinite(table["value"].to_numpy(float))]
    for (source, task, metric), group in data.groupby(["source", "task", "metric"], sort=False):
        cells = group.groupby(["participant", "condition"])["value"].mean().unstack("condition")
        present = [c for c in conditions if c in cells.columns]
        if reference not in present:
            continue
        model, note = mixed_model(group, present, reference)
        for k, cond in enumerate(c for c in present if c != reference):
            ref, con, diff = paired_differences(cells, cond, reference)
            lo, hi = t_interval(diff)
            dz_lo, dz_hi = dz_bootstrap(diff, bootstrap, seed + k)
            coef, c_lo, c_hi, p = model.get(cond, (math.nan,) * 4)
            effects.append(
                Effect(
                    source=str(source),
                    task=str(task),
                    metric=str(metric),
                    condition=cond,
                    reference=reference,
                    n=len(diff),
                    mean_reference=_mean(ref),
                    sd_reference=_sd(ref),
                    mean_condition=_mean(con),
                    sd_condition=_sd(con),
                    difference=_mean(diff),
                    difference_low=lo,
                    difference_high=hi,
                    cohens_dz=cohens_dz(diff),
                    dz_low=dz_lo,
                    dz_high=dz_hi,
                    mixedlm_coef=coef,
                    mixedlm_low=c_lo,
                    mixedlm_high=c_hi,
                    mixedlm_p=p,
                    power_n=participants_needed(diff, target, alpha, simulations, max_n, seed + k),
                    note=note,
                )
            )
    return effects


def _mean(x: np.ndarray) -> float:
    return float(np.mean(x)) if len(x) else math.nan


def _sd(x: np.ndarray) -> float:
    return float(np.std(x, ddof=1)) if len(x) > 1 else math.nan
