"""Write docs/calibration.md and docs/images/calibration.png: the virtual population against
the published human values of opends_gym/drivers/literature.csv.

    PYTHONPATH=$PWD python docs/gen_calibration.py [--participants 24] [--full]

(`--full` drives the full-length tasks; the default uses the short tasks of
tests/test_calibration.py with more participants.)
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import opends_gym  # noqa: F401
from opends_gym.drivers.calibration import RUN_CHECKS, Comparison, effect, level, literature, runs
from opends_gym.drivers.population import DISTRIBUTIONS, LOADS, sample_population

ROOT = Path(__file__).resolve().parent
CHECKS = {**RUN_CHECKS, "glance_duration": ("lct", "glance_s", "visual_manual")}
PLAN = {
    "lct": LOADS,
    "lct_visual_drt": ("baseline", "visual_manual"),
    "brake_expected": ("baseline", "cognitive"),
    "brake_unexpected": ("baseline",),
    "platoon": LOADS,
    "lane_change": ("baseline",),
}


def _f(v: float) -> str:
    return "-" if not math.isfinite(v) else f"{v:.3g}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--participants", type=int, default=24)
    ap.add_argument("--full", action="store_true")
    args = ap.parse_args(argv)
    pop = sample_population(args.participants)
    r = runs(short=not args.full)
    sim = {}
    for name, loads in PLAN.items():
        for load in loads:
            sim[(name, load)] = r[name](pop, load, 0)
            print(f"  {name} {load} done", file=sys.stderr)
    rows = literature()
    comps: list[Comparison] = []
    for key, (run, measure, loaded) in CHECKS.items():
        base = [x[measure] for x in sim[(run, "baseline")]]
        if key == "glance_duration":
            comps.append(level(rows[key], [x[measure] for x in sim[(run, "visual_manual")]]))
        elif loaded is None:
            comps.append(level(rows[key], base))
        else:
            comps.append(effect(rows[key], base, [x[measure] for x in sim[(run, loaded)]]))
    _plot(comps, ROOT / "images" / "calibration.png")
    (ROOT / "calibration.md").write_text(_page(comps, args), encoding="utf-8")
    print(f"wrote {ROOT / 'calibration.md'}")
    return 0


def _plot(comps: list[Comparison], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 0.38 * len(comps) + 1))
    for i, c in enumerate(comps):
        r = c.row
        span = r.high - r.low
        lo, hi = r.low - span, r.high + span
        norm = lambda v, lo=lo, hi=hi: (v - lo) / (hi - lo)  # noqa: E731
        ax.plot([norm(r.low), norm(r.high)], [i, i], color="tab:green", lw=6, alpha=0.5)
        ax.plot([min(max(norm(c.value), -0.05), 1.05)], [i], "o", color="tab:blue" if c.ok else "tab:red")
    ax.set_yticks(range(len(comps)), [f"{c.row.key} ({_f(c.value)})" for c in comps], fontsize=7)
    ax.set_xticks([])
    ax.set_xlabel("green: published range; dot: model (blue inside, red outside); each row on its own scale")
    ax.invert_yaxis()
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def _page(comps: list[Comparison], args: argparse.Namespace) -> str:
    lines = [
        "# Calibration of the virtual participants",
        "",
        "The virtual participants (`opends_gym.drivers.participant`, `participant:ID[:LOAD]`) draw their",
        "parameters per driver (`opends_gym.drivers.population.DISTRIBUTIONS`); the load conditions switch",
        "on mechanisms (glances with a stale percept; a task holding the response-selection channel), never",
        "a metric's target. This page sets the simulated population against the published human values",
        "in `opends_gym/drivers/literature.csv`. Regenerate it with",
        "",
        "    PYTHONPATH=$PWD python docs/gen_calibration.py",
        "",
        f"({args.participants} participants, {'full-length' if args.full else 'the short test'} tasks; "
        "`tests/test_calibration.py` asserts the same rows on 10 participants).",
        "",
        "![model against literature](images/calibration.png)",
        "",
        "| row | condition | model: mean or difference | model: SD | model: d | published range "
        "(mean or difference) | SD range | d range | inside | asserted |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in comps:
        r = c.row
        lines.append(
            f"| {r.key} | {r.condition} | {_f(c.value)} | {_f(c.sd)} | {_f(c.d)} | {_f(r.low)} to {_f(r.high)} | "
            f"{_f(r.sd_low)} to {_f(r.sd_high)} | {_f(r.d_low)} to {_f(r.d_high)} | {'yes' if c.ok else 'no'} | {r.asserted} |"
        )
    lines += ["", "## Sources", "", "| row | metric, task | published | source | verified |", "|---|---|---|---|---|"]
    for c in comps:
        r = c.row
        lines.append(f"| {r.key} | {r.metric}, {r.task} | {r.published} | {r.source} | {r.verified} |")
    lines += [
        "",
        "A range is the published value or range itself where a study gives one; where a study gives only",
        "a point value the range adds a tolerance for a simulated sample (stated in the row); where a study",
        "gives only a direction (Engström, Johansson & Östlund 2005; Lansdown 2012) the range encodes the",
        "direction and a plausible size, marked 'size unverified'. Rows marked 'unverified' could not be",
        "checked against the paper's text here.",
        "",
        "## Parameter distributions",
        "",
        "| parameter | distribution | mean | between-driver SD | clipped to | centre from |",
        "|---|---|---|---|---|---|",
    ]
    for name, d in DISTRIBUTIONS.items():
        lines.append(f"| {name} | {d.kind} | {d.mean:g} | {d.sd:g} | {d.lo:g} to {d.hi:g} | {d.source} |")
    lines += [
        "",
        "## Known gaps",
        "",
        "- LCT MDEV at baseline: the model gives 0.3-0.4 m against the ~1 m reported for ISO 26022",
        "  drives (unverified). Our LCT track and basic normative model are not ISO 26022's, so the",
        "  row is shown but not asserted.",
        "- The visual DRT is one whose stimulus is seen only with the eyes on the road (a remote,",
        "  non-salient LED; Cooper, Castro & Strayer 2016, Exp. 2); a salient head-mounted LED seen",
        "  peripherally behaves like the tactile DRT. The DRT wrapper's `modality` attribute, or",
        "  `ParticipantDriver(..., drt_modality=...)`, picks it; the default is tactile.",
        "- Responses are acted on at the policy rate (10 Hz by default), so reaction times carry up to",
        "  one policy step of delay; the population's parameters are fitted at that rate.",
        "- Effect sizes from studies that report only a direction are tested for direction and a",
        "  plausible size; between-participant SDs from Green (2000) and ISO 17488 are unverified.",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
