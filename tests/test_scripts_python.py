"""The scripts pick a supported CPython (scripts/_python.sh, used by _env.sh and core_check.sh).

Candidates are run to learn their real version: a pyenv shim for a version that is not
selected (it prints an error) or a `python3.12` that is something else is passed over.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HELPER = ROOT / "scripts" / "_python.sh"


def _fake(path: Path, prints: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"#!/bin/sh\n{prints}\n")
    path.chmod(0o755)
    return path


def _find(version: str, path_dirs: list[Path], pyenv_root: Path) -> subprocess.CompletedProcess[str]:
    env = {"PATH": os.pathsep.join([*map(str, path_dirs), "/usr/bin", "/bin"]), "PYENV_ROOT": str(pyenv_root), "HOME": str(pyenv_root)}
    return subprocess.run(["bash", "-c", f'source "{HELPER}" && find_python {version}'], env=env, capture_output=True, text=True)


def test_a_candidate_is_taken_only_if_it_really_is_that_version(tmp_path: Path) -> None:
    bin_dir = tmp_path / "bin"
    _fake(bin_dir / "python3.12", "echo 'pyenv: python3.12: command not found' >&2; exit 127")  # an unselected shim
    impostor = _fake(tmp_path / "pyenv" / "versions" / "3.12.0" / "bin" / "python3.12", "echo 3.11")
    r = _find("3.12", [bin_dir], tmp_path / "pyenv")
    assert r.returncode == 1 and r.stdout == ""
    real = _fake(tmp_path / "pyenv" / "versions" / "3.12.7" / "bin" / "python3.12", "echo 3.12")
    r = _find("3.12", [bin_dir], tmp_path / "pyenv")
    assert r.returncode == 0 and r.stdout.strip() == str(real) and str(impostor) not in r.stdout


def test_the_running_interpreter_is_found_by_its_version(tmp_path: Path) -> None:
    version = f"{sys.version_info[0]}.{sys.version_info[1]}"
    link = tmp_path / "bin" / f"python{version}"
    link.parent.mkdir()
    link.symlink_to(sys.executable)
    r = _find(version, [link.parent], tmp_path / "nothing")
    assert r.returncode == 0 and r.stdout.strip() == str(link)


def _low_disk(need_mb: int, where: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", "-c", f'source "{HELPER}" && warn_if_low_disk "{where}" {need_mb} "this install"'],
                          capture_output=True, text=True)  # fmt: skip


def test_an_install_warns_in_one_line_when_the_disk_lacks_the_space_it_needs(tmp_path: Path) -> None:
    short = _low_disk(10**12, tmp_path)  # (no disk has a petabyte free)
    assert short.returncode == 0 and short.stdout == ""
    lines = short.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: this install needs about 1000000000000 MB on /") and "MB free" in lines[0]
    roomy = _low_disk(1, tmp_path)
    assert roomy.returncode == 0 and roomy.stderr == "" and roomy.stdout == ""
