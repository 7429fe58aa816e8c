"""Episodes into a Farama Minari dataset (and back), with the env spec that rebuilds our env.

Why Minari: offline RL and imitation users load datasets with `minari.load_dataset(NAME)` and
rebuild the env with `recover_environment()`; our env spec (registered id, entry point, kwargs)
goes in so that gives back the env the drives were stepped through. Per step the dataset holds
the env's numeric info keys (`infos`); per episode its metadata holds the drive's file, how it
was turned into actions (`kind`), the state it started in where that was not the task's start
(`start_pose/<key>`: the env's `start_pose` reset option, as a carData log is exported) and the
env's `episode_metrics` (`metric/<name>`).
Minari writes under MINARI_DATASETS_PATH (default ~/.minari/datasets).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from typing import Any

from ..errors import UserError
from ..extras import require
from .episodes import Episode

DATA_FORMAT = "arrow"  # Minari's Arrow storage (pyarrow); its HDF5 storage would need h5py
_VERSIONED = re.compile(r".*-v\d+$")


def dataset_id(name: str) -> str:
    """Minari's `[namespace/]name-vN`: `-v0` is added to a name without a version."""
    require("data", "minari", "the Minari dataset")
    from minari.dataset.minari_dataset import parse_dataset_id

    ident = name if _VERSIONED.fullmatch(name) else f"{name}-v0"
    try:
        parse_dataset_id(ident)
    except ValueError:
        raise UserError(f"dataset name {name!r}: Minari wants [NAMESPACE/]NAME[-vN] (letters, digits, _ and -)") from None
    return ident


def _same_env(episodes: Sequence[Episode]) -> None:
    first = episodes[0]
    for ep in episodes[1:]:
        if ep.env_spec.id != first.env_spec.id or ep.observation_space != first.observation_space or ep.action_space != first.action_space:
            raise UserError(
                f"{ep.source}: drives {ep.env_spec.id} {ep.observation_space} / {ep.action_space}, "
                f"but {first.source} drives {first.env_spec.id} {first.observation_space} / {first.action_space}: one env per dataset"
            )


def _buffer(ep: Episode, index: int) -> Any:
    from minari.data_collector import EpisodeBuffer

    return EpisodeBuffer(
        id=index,
        seed=ep.seed,
        observations=list(ep.observations),
        actions=list(ep.actions),
        rewards=list(ep.rewards),
        terminations=list(ep.terminations),
        truncations=list(ep.truncations),
        infos={k: [float(x) for x in v] for k, v in ep.infos.items()},  # lists: Minari 0.5.4's Arrow storage cannot read back 1-D arrays
    )


def _start_pose(ep: Episode) -> dict[str, float]:
    """`start_pose/<key>` metadata: `env.reset(options={"start_pose": ...})` starts the episode again."""
    return {f"start_pose/{k}": v for k, v in (ep.start_pose or {}).items()}


def write_dataset(name: str, episodes: Sequence[Episode], description: str = "", author: str | None = None) -> Any:
    """A new Minari dataset `name` from `episodes` (all of one env); returns the MinariDataset."""
    minari = require("data", "minari", "the Minari dataset")
    ident = dataset_id(name)
    if not episodes:
        raise UserError("no drives to write")
    _same_env(episodes)
    if ident in minari.list_local_datasets():
        raise UserError(f"dataset {ident} exists already (minari.delete_dataset({ident!r}) or another name)")
    with warnings.catch_warnings():  # Minari's reminders about unset author, e-mail and permalink
        warnings.filterwarnings("ignore", message=r"`(code_permalink|author|author_email|eval_env)` is set to None", category=UserWarning)
        ds = _create(minari, ident, episodes, description, author)
    meta = [
        {"source": ep.source, "kind": ep.kind, **_start_pose(ep), **{f"metric/{k}": v for k, v in sorted(ep.metrics.items())}}
        for ep in episodes
    ]
    ds.storage.update_episode_metadata(meta, episode_indices=range(len(episodes)))
    return ds


def _create(minari: Any, ident: str, episodes: Sequence[Episode], description: str, author: str | None) -> Any:
    first = episodes[0]
    return minari.create_dataset_from_buffers(
        dataset_id=ident,
        buffer=[_buffer(ep, i) for i, ep in enumerate(episodes)],
        env=first.env_spec,
        algorithm_name="opends-gym export",
        author=author,
        action_space=first.action_space,
        observation_space=first.observation_space,
        description=description or f"{len(episodes)} drives of {first.env_spec.id} exported by opends-gym",
        data_format=DATA_FORMAT,
    )


def episode_metrics(ds: Any) -> list[dict[str, float]]:
    """The env's episode_metrics of each episode of a dataset written by `write_dataset`."""
    out = []
    for m in ds.storage.get_episode_metadata(ds.episode_indices):
        out.append({k.removeprefix("metric/"): float(v) for k, v in m.items() if k.startswith("metric/")})
    return out
