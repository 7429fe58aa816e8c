"""The study design: every (participant, condition, task, repetition) cell as one `Trial`.

Why seeds this way: a trial's seed depends on the study seed, the participant, the task and
the repetition, not on the condition (so each participant meets the same traffic and stimulus
schedule in every condition: the conditions are compared within subject on common random
numbers) and not on which worker runs it (so any worker count gives the same table).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .clones import with_clone_options
from .config import ConditionSpec, DrtSpec, Study, TaskSpec, format_agent


@dataclass(frozen=True)
class Trial:
    participant: int  # 0-based index in the virtual population
    condition: str
    task: str
    trial: int  # repetition, 0-based
    seed: int
    env_id: str
    env_args: tuple[tuple[str, Any], ...]
    agent: str
    load: str | None
    drt: DrtSpec | None
    metrics: tuple[str, ...] | None

    @property
    def key(self) -> str:
        """Trials with the same key can share one env (reset with their own seed)."""
        return repr((self.env_id, self.env_args, self.drt))


def participant_label(index: int) -> str:
    """`V001`, `V002`, ... for virtual participants (people keep the id the experimenter gives)."""
    return f"V{index + 1:03d}"


def trial_seed(study_seed: int, participant: int, task: int, repetition: int) -> int:
    return int(np.random.SeedSequence([study_seed, participant, task, repetition]).generate_state(1)[0] & 0x7FFFFFFF)


def env_args_for(study: Study, task: TaskSpec, condition: ConditionSpec, accepted: set[str]) -> dict[str, Any]:
    """The env options of one cell: the task's, then the condition's, then the study's
    `on_road_exit` and `on_collision` where the env has the option (envs without it keep their
    own behaviour)."""
    args: dict[str, Any] = {**task.env_args, **condition.env_args}
    for key, value in (("on_road_exit", study.on_road_exit), ("on_collision", study.on_collision)):
        if value is not None and key in accepted and key not in args:
            args[key] = value
    drt = condition.drt or task.drt
    if drt is not None and "action" not in args:
        args["action"] = "continuous_buttons"  # the DRT response is the reaction button
    return args


def agent_spec(study: Study, condition: ConditionSpec, task: TaskSpec, participant: int) -> str:
    return format_agent(condition.agent or study.agent, participant, condition.load, condition.name, task.name)


def expand(study: Study) -> list[Trial]:
    """Every trial of the virtual study in table order (participant, condition, task, repetition)."""
    from .config import env_fields

    accepted = {t.env_id: env_fields(t.env_id) for t in study.tasks}
    trials = []
    for p in range(study.participants):
        for cond in study.conditions:
            for ti, task in enumerate(study.tasks):
                agent = agent_spec(study, cond, task, p)
                args = with_clone_options(agent, env_args_for(study, task, cond, accepted[task.env_id]))  # (a clone's observation options)
                for rep in range(study.repetitions):
                    trials.append(
                        Trial(
                            participant=p,
                            condition=cond.name,
                            task=task.name,
                            trial=rep,
                            seed=trial_seed(study.seed, p, ti, rep),
                            env_id=task.env_id,
                            env_args=tuple(sorted(args.items(), key=lambda kv: kv[0])),
                            agent=agent,
                            load=cond.load,
                            drt=cond.drt or task.drt,
                            metrics=task.metrics or study.metrics,
                        )
                    )
    return trials
