"""The `lanes_known` info of a native batch's envs: `RoadGuide.lanes_known_at` per env.

Why: the single env reports the task's lanes as known only from the point where the start
connector joins them on (`OpenDSEnv._info`: `guide.lanes_known_at(_last_s)`, i.e. the task
defines lanes and s >= `RoadGuide.join_s_m`; 0 m on X-band lanes, so a car that spins
behind its start line reports False). A batch reports the same per env, from its arc
lengths `BatchCore.last_s` (the floats `RoadGuide.locate` gives), in Python
(`lanes_known_rows`) and in the compiled step passes (`lanes_known_at` with `known_from`).
"""

from __future__ import annotations

import numpy as np

from ..jit import inline
from ..sim.guide import RoadGuide


def known_from(guide: RoadGuide) -> tuple[bool, float]:
    """(the task defines lanes, arc length they start at): `lanes_known_at`'s geometry."""
    return bool(guide.lanes_known), float(guide.join_s_m)


def lanes_known_rows(guide: RoadGuide, s_m: np.ndarray) -> np.ndarray:
    """`guide.lanes_known_at(s)` of each arc length in `s_m` (a new bool array)."""
    return (s_m >= guide.join_s_m) & bool(guide.lanes_known)


@inline
def lanes_known_at(known: tuple[bool, float], s_m: float) -> bool:
    """`RoadGuide.lanes_known_at(s_m)` inside a kernel (`known`: `known_from(guide)`)."""
    return known[0] and s_m >= known[1]
