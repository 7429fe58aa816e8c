"""`opends-gym export DRIVES... --minari NAME [--env ENV_ID] [--task TASK]`: drives into a Minari dataset.

DRIVES are MCAP recordings (`run`, `drive`, a study) and OpenDS carData.txt logs; each is driven
through the env at its policy rate (`opends_gym.data.episodes`) and written with the env spec
(`opends_gym.data.minari_io`) under MINARI_DATASETS_PATH. `--augment recovery` adds perturbed copies
of each carData log labelled with their way back to it (`opends_gym.data.recovery`).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

RECOVERY_LATERAL_M = 1.5  # data.recovery.RecoveryConfig.lateral_m (not imported: the CLI loads without the data modules)
RECOVERY_TAU_S = 2.0  # data.recovery.RecoveryConfig.tau_s


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("drives", nargs="+", help="MCAP recordings and/or OpenDS carData.txt logs")
    p.add_argument("--minari", required=True, metavar="NAME", help="dataset id, [NAMESPACE/]NAME[-vN] (-v0 added)")
    p.add_argument("--env", default=None, metavar="ENV_ID", help="env of person drives and carData logs (env recordings use their own)")
    p.add_argument("--task", default=None, help="driving task of carData logs (default: the generic env on their 'Driving Task:')")
    p.add_argument("--env-arg", action="append", default=[], metavar="KEY=VALUE", help="extra env option (repeatable)")
    p.add_argument(
        "--trim-idle", action="store_true", help="person drives and carData logs start at their first gas (not waiting at the start)"
    )
    p.add_argument(
        "--augment",
        choices=("recovery",),
        default=None,
        help="recovery: add perturbed copies of each carData log labelled with the action that returns the car to its path and speed",
    )
    p.add_argument(
        "--augment-every",
        type=float,
        default=1.0,
        metavar="SECONDS",
        help="--augment recovery: a copy starts every SECONDS of each log (default 1; fewer logs, more copies)",
    )
    p.add_argument(
        "--augment-draws",
        type=int,
        default=1,
        metavar="N",
        help="--augment recovery: N copies from each start point, each with its own perturbation (default 1)",
    )
    p.add_argument(
        "--augment-lateral",
        type=float,
        default=RECOVERY_LATERAL_M,
        metavar="M",
        help=f"--augment recovery: copies start up to M metres either side of the log (default {RECOVERY_LATERAL_M:g})",
    )
    p.add_argument(
        "--augment-tau",
        type=float,
        default=RECOVERY_TAU_S,
        metavar="S",
        help=f"--augment recovery: labels rejoin the log within S seconds (default {RECOVERY_TAU_S:g}, Bojarski et al. 2016)",
    )
    p.add_argument(
        "--augment-dart",
        type=int,
        default=0,
        metavar="N",
        help="--augment recovery: also N rollouts of each whole log driven by its labels plus noise (DART; default 0)",
    )
    p.add_argument("--author", default=None, help="dataset author (Minari metadata)")


def run(args: argparse.Namespace) -> int:
    from ..data.episodes import NeverSetsOff, load_episode
    from ..data.minari_io import dataset_id, write_dataset
    from ..data.recovery import RecoveryConfig, cardata_with_recovery
    from ..envs.config import EnvConfig
    from ..errors import UserError
    from .run import _parse_value
    from .targets import _coerce

    ident = dataset_id(args.minari)
    if not args.augment_every > 0.0:
        raise UserError(f"--augment-every must be a positive number of seconds, not {args.augment_every:g}")
    if not 0.1 <= args.augment_tau <= 10.0:
        raise UserError(f"--augment-tau must be 0.1-10 s, not {args.augment_tau:g}")
    if not 0.0 <= args.augment_lateral <= 10.0:
        raise UserError(f"--augment-lateral must be 0-10 m, not {args.augment_lateral:g}")
    if args.augment_draws < 1 or args.augment_dart < 0:
        raise UserError(f"--augment-draws must be at least 1 and --augment-dart 0 or more, not {args.augment_draws}, {args.augment_dart}")
    # the options every env shares typed by EnvConfig (road_preview_m=10,25,50), the rest as they read
    # (the env, a recording's or a carData log's, is known only once a drive is loaded)
    shared = {f.name: str(f.type) for f in dataclasses.fields(EnvConfig)}
    kwargs = {}
    for item in args.env_arg:
        key, _, value = item.partition("=")
        kwargs[key] = _coerce(key, value, shared[key]) if key in shared else _parse_value(value)
    episodes = []
    for path in args.drives:
        try:
            if args.augment == "recovery":
                config = RecoveryConfig(
                    every_s=args.augment_every,
                    draws=args.augment_draws,
                    dart=args.augment_dart,
                    lateral_m=args.augment_lateral,
                    tau_s=args.augment_tau,
                )
                ep, *copies = cardata_with_recovery(path, args.env, args.task, kwargs, args.trim_idle, config)
            else:
                ep, copies = load_episode(path, args.env, args.task, kwargs, args.trim_idle), []
        except NeverSetsOff as e:  # a log of someone waiting: with --trim-idle nothing of it is driving
            print(f"{e}: skipped", file=sys.stderr)
            continue
        more = f", {len(copies)} recovery copies and rollouts ({sum(c.steps for c in copies)} steps)" if args.augment else ""
        print(f"{path}: {ep.steps} steps ({ep.kind}) on {ep.env_spec.id}{more}", file=sys.stderr)
        episodes += [ep, *copies]
    if not episodes:
        raise UserError("no drive gives gas: nothing to export with --trim-idle")
    ds = write_dataset(ident, episodes, author=args.author)
    print(f"wrote Minari dataset {ident}: {ds.total_episodes} episodes, {ds.total_steps} steps")
    return 0
