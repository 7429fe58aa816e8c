"""Input sources for human driving; see `base.InputSource`."""

from __future__ import annotations

from .base import InputCombiner, InputFrame, InputSource, InputStatus, TrafficControl, merge_frames

__all__ = ["InputCombiner", "InputFrame", "InputSource", "InputStatus", "TrafficControl", "merge_frames"]
