"""Files shipped inside the package, found by name: trained policies, training configs,
the example CAN DBC and the wheel calibration example.

Why: a wheel installed outside the repository has no `agents/` or `configs/` beside it, so
`--agent ppo:lct`, `opends-gym train lct_ppo` and `drive --input can-bus` must find the
copies inside the package. In the repository `opends_gym/bundled_policies` and
`opends_gym/bundled_configs` are symlinks to the top-level `agents/policies/` and `configs/`
(as `bundled_tasks` is to `tasks/`); the wheel carries the files themselves. A name that is
an existing path is always taken as that path.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .errors import UserError

PACKAGE = "opends_gym"
POLICY_FILE = "model.zip"
EXAMPLE_DBC = "can_example.dbc"
EXAMPLE_CALIBRATION = "wheel_calibration.yaml"


class ResourceNotFound(UserError, FileNotFoundError):
    """A name that is neither an existing path nor a bundled file (the message lists them)."""


def _dir(name: str) -> Path:
    return Path(str(resources.files(PACKAGE).joinpath(name)))


def policies_dir() -> Path:
    """Folder of the bundled policies (one sub-folder per policy, each with model.zip)."""
    return _dir("bundled_policies")


def configs_dir() -> Path:
    """Folder of the bundled training configs, the example DBC and the calibration example."""
    return _dir("bundled_configs")


def policy_names() -> list[str]:
    """Bundled policy names (`lct_ppo`, ...), sorted."""
    d = policies_dir()
    if not d.is_dir():
        return []
    return sorted(p.name for p in d.iterdir() if (p / POLICY_FILE).is_file())


def policy_algorithm(name: str) -> str:
    """The algorithm a bundled policy was trained with: its name's suffix (`lct_sac` -> `sac`)."""
    return name.rpartition("_")[2]


def resolve_policy(algorithm: str, spec: str | Path) -> Path:
    """`ppo:SPEC` -> the saved model: SPEC is a path (`.zip` optional, or a folder holding
    model.zip) or a bundled policy, by full name (`lct_ppo`) or by task with the algorithm
    implied (`ppo:lct` -> `lct_ppo`)."""
    p = Path(spec)
    for candidate in (p, p.with_name(p.name + ".zip"), p / POLICY_FILE):
        if candidate.is_file():
            return candidate
    names = policy_names()
    text = str(spec)
    for name in (text, f"{text}_{algorithm}"):
        if name in names:
            if policy_algorithm(name) != algorithm:
                other = policy_algorithm(name)
                raise ResourceNotFound(f"bundled policy '{name}' was trained with {other}: use --agent {other}:{name}")
            return policies_dir() / name / POLICY_FILE
    mine = [n for n in names if policy_algorithm(n) == algorithm]
    raise ResourceNotFound(
        f"no saved policy at '{text}' and no bundled {algorithm} policy named '{text}' "
        f"(bundled: {', '.join(mine) or 'none'}; e.g. --agent {algorithm}:{mine[0] if mine else 'PATH'})"
    )


def _yaml_names(d: Path) -> list[str]:
    if not d.is_dir():
        return []
    return sorted(p.stem for p in d.glob("*.yaml"))


def config_names() -> list[str]:
    """Bundled training configs (`lct_ppo`, ...), sorted; the calibration example is not one."""
    return [n for n in _yaml_names(configs_dir()) if n != Path(EXAMPLE_CALIBRATION).stem]


def resolve_config(spec: str | Path) -> Path:
    """A training config: a YAML path, or a bundled config by name (`lct_ppo` or `lct_ppo.yaml`)."""
    p = Path(spec)
    if p.is_file():
        return p
    stem = p.name.removesuffix(".yaml").removesuffix(".yml")
    if p.parent == Path(".") and stem in config_names():
        return configs_dir() / f"{stem}.yaml"
    bundled = ", ".join(config_names()) or "none"
    raise ResourceNotFound(f"no training config at '{spec}' and no bundled config named '{stem}' (bundled: {bundled})")


def example_dbc() -> Path:
    """The example DBC that `drive --input can-bus` decodes frames with unless `--dbc` says otherwise."""
    return configs_dir() / EXAMPLE_DBC


def example_calibration() -> Path:
    """The shipped wheel/pedal calibration example (a Logitech G27/G29-class wheel)."""
    return configs_dir() / EXAMPLE_CALIBRATION


def resolve_calibration(spec: str | Path) -> Path:
    """A calibration file: a path, or `wheel_calibration` (the shipped example) by name."""
    p = Path(spec)
    if p.is_file():
        return p
    if str(spec).removesuffix(".yaml") == Path(EXAMPLE_CALIBRATION).stem:
        return example_calibration()
    raise ResourceNotFound(f"no calibration file at '{spec}' (the shipped example is '{Path(EXAMPLE_CALIBRATION).stem}')")
