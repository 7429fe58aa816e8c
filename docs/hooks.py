"""MkDocs hook: serve figures that live elsewhere in the repository without copying them.

Why: the benchmark and training plots are written by their own scripts into
`benchmarks/results/` and `agents/policies/`; a copy under docs/ would go stale.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parent.parent
# site path -> file in the repository
EXTERNAL_FIGURES = {
    "images/distraction_sensitivity.png": "benchmarks/results/distraction_sensitivity.png",
    "images/training_curves.png": "agents/policies/training_curves.png",
}


def on_files(files: Files, config: Any) -> Files:
    for uri, source in EXTERNAL_FIGURES.items():
        files.append(File.generated(config, uri, abs_src_path=str(ROOT / source)))
    return files
