"""`opends-gym train CONFIG`: train a baseline policy from a YAML config or a bundled one by name.

A bundled config (`opends-gym train lct_ppo`; `opends-gym list --configs`) writes its run to
`runs/<name>` under the current folder unless `--output` says otherwise: the package's own
folder is no place for a run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..jsonsafe import dump_json
from .run import _parse_value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", help="a training config: a YAML file or a bundled config by name (lct_ppo, ...), or bc")
    p.add_argument("dataset", nargs="?", default=None, help="with bc: the Minari dataset to clone (opends-gym export --minari)")
    p.add_argument("--total-steps", type=int, default=None, help="override total_steps")
    p.add_argument("--output", "--out", default=None, help="run folder (default: the config's `output`; bc: bc-<dataset>)")
    p.add_argument("--epochs", type=int, default=None, help="with bc: training epochs (default 30)")
    p.add_argument("--history", type=int, default=1, help="with bc: recent observations the clone sees (default 1)")
    p.add_argument("--actions", action="store_true", help="with bc: the clone also sees the actions it took before them")
    p.add_argument("--validation", type=float, default=0.1, help="with bc: share of episodes held out for early stopping (default 0.1)")
    p.add_argument("--patience", type=int, default=10, help="with bc: epochs without a lower held-out error before it stops (default 10)")
    p.add_argument("--ensemble", type=int, default=1, help="with bc: networks trained, their outputs averaged (default 1)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a top-level config key (repeatable)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--resume", default=None, metavar="RUN_DIR", help="continue a finished run (its model.zip) for --total-steps more")


def _train_bc(args: argparse.Namespace) -> int:
    """`train bc DATASET [--out FOLDER]`: behaviour cloning (opends_gym.data.bc); drive it with --agent bc:FOLDER."""
    from ..data.bc import BCConfig, train_bc

    if not args.dataset:
        print("opends-gym train: bc needs a dataset: opends-gym train bc DATASET [--out FOLDER]", file=sys.stderr)
        return 2
    options = {"history": args.history, "actions": args.actions, "validation": args.validation, "patience": args.patience}
    options["ensemble"] = args.ensemble
    config = BCConfig(**options) if args.epochs is None else BCConfig(epochs=args.epochs, **options)
    out = Path(args.output) if args.output else Path("bc-" + args.dataset.replace("/", "-"))
    summary = train_bc(args.dataset, out, config)
    summary.pop("loss_per_epoch")
    summary.pop("validation_loss_per_epoch")
    dump_json(summary, sys.stdout, indent=2)
    print(f"drive it with --agent bc:{out}", file=sys.stderr)
    return 0


def run(args: argparse.Namespace) -> int:
    if args.config == "bc":
        return _train_bc(args)
    if args.dataset is not None:
        print(f"opends-gym train: unexpected argument {args.dataset!r} (only train bc takes a dataset)", file=sys.stderr)
        return 2
    from ..resources import ResourceNotFound, resolve_config
    from ..training import load_train_config

    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = _parse_value(value)
    if args.total_steps is not None:
        overrides["total_steps"] = args.total_steps
    if args.no_progress:
        overrides["progress_bar"] = False
    try:
        path = resolve_config(args.config)
        cfg, base = load_train_config(path, overrides)
    except (ResourceNotFound, OSError, ValueError) as e:
        print(f"opends-gym train: {e}", file=sys.stderr)
        return 2
    by_name = not Path(args.config).is_file()
    out = Path(args.output).resolve() if args.output else (Path.cwd() / "runs" / cfg.name if by_name else None)
    if cfg.framework == "rllib":
        from ..training.rllib import RllibConfigError
        from ..training.rllib import train as train_rllib

        try:
            metrics = train_rllib(cfg, base, out)
        except RllibConfigError as e:  # a bad `rllib:` block: one line, no traceback
            print(f"opends-gym train: {args.config}: {e}", file=sys.stderr)
            return 2
    else:
        resume = Path(args.resume).resolve() if args.resume else None
        try:
            if cfg.vec_env == "native":
                from ..training.native_ppo import train as train_ppo
                from ..training.native_sac import train as train_sac
                from .progress import ProgressBar

                bar = ProgressBar(cfg.total_steps, label="env steps") if cfg.progress_bar else None
                try:
                    train_native = train_sac if cfg.algorithm == "sac" else train_ppo
                    metrics = train_native(cfg, base, out, resume=resume, progress=bar.update if bar else None)
                finally:
                    if bar is not None:
                        bar.close()
            else:
                from ..training.sb3 import train

                metrics = train(cfg, base, out, resume=resume)
        except ValueError as e:
            print(f"opends-gym train: {e}", file=sys.stderr)
            return 2
    dump_json({k: v for k, v in metrics.items() if k != "episodes"}, sys.stdout, indent=2)
    return 0
