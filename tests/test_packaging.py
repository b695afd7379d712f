"""Packaging as a user meets it: one version everywhere, the licence declared the way setuptools
wants it (an SPDX expression and the LICENSE file), and a wheel that builds without warnings and
carries its package data. (``.ci/wheel_check`` installs that wheel in a fresh venv, away from the
source tree, and runs the quick benchmark and the diagnosis examples there.)"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import lcgym

ROOT = Path(__file__).resolve().parents[1]


def test_one_version_everywhere():
    citation = (ROOT / "CITATION.cff").read_text()
    assert re.search(r"^version: (\S+)$", citation, flags=re.M).group(1) == lcgym.__version__
    changelog = (ROOT / "CHANGELOG.md").read_text()
    newest = re.search(r"^## (\d+\.\d+\.\d+)", changelog, flags=re.M).group(1)
    assert newest == lcgym.__version__, "CHANGELOG.md's newest entry is the package's version"
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert "version" in project["dynamic"] and "version" not in project


def test_licence_is_an_spdx_expression_with_its_file():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT"
    assert project["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")


def test_wheel_builds_without_warnings_and_carries_its_data(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # set here, it makes setuptools warn
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-w", str(tmp_path), "-v"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    # pip's own notes about this machine's package index folders are not the build's
    log = [line for line in (done.stdout + done.stderr).splitlines() if "Location 'file:" not in line]
    warnings = [line for line in log if re.search(r"warn|deprecat", line, flags=re.I)]
    assert not warnings, "\n".join(warnings)
    (wheel,) = tmp_path.glob("lcgym-*.whl")
    assert wheel.name.startswith(f"lcgym-{lcgym.__version__}-")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        metadata = z.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    # every machine description and machine file of the source tree travels with the wheel
    data = sorted(str(f.relative_to(ROOT)) for pattern in ("*.urdf", "*.toml") for f in (ROOT / "lcgym").rglob(pattern))
    assert "lcgym/systems/two_link/machine.toml" in data
    assert [n for n in data if n not in names] == []
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert "License-Expression: MIT" in metadata
