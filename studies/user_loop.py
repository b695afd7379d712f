"""The user's loop on a machine of their own, as a new user runs it (issue 60, item 5): a rail carrying
a two-link arm (a URDF and a machine file written here) whose plant carries two effects its nominal
model lacks, a 20 N Coulomb friction on the rail and a one-sided cable spring on the elbow (25 N m/rad
from 0.3 rad, 0.15 rad wide).

1. ``lcgym simulate --controller feedback`` writes a log of the plant (2 runs of 20 s);
2. ``lcgym diagnose LOG --system rail.toml --replay`` names the effects, prints their ``[[model]]``
   tables and replays the log's references on the plant with the model before and after them;
3. the tables, pasted into a copy of the machine file (``rail_model.toml``), give the benchmark's
   physical model those effects, fitted by the estimator the diagnosis used;
4. ``lcgym bench --systems rail.toml,rail_model.toml --methods physical,ilc`` (seed 0, the default
   budgets) ranks both files.

It prints the replay's tracking RMS per axis after the effects, the physical model's and ILC's on
both files, and the ratios the issue asks of them: the physical model with the tables within 2x of
the replay's figure on every axis, and ILC on it at or below ILC on the bare model.

Run:  .venv/bin/python studies/user_loop.py [--folder DIR] [--seed 0]   (about 4 minutes on a 2-core machine)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

URDF = """<?xml version="1.0"?>
<robot name="rail">
  <link name="base"/>
  <link name="carriage">
    <inertial><origin xyz="0 0 0"/><mass value="8.0"/>
      <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
  </link>
  <link name="upper">
    <inertial><origin xyz="0.2 0 0"/><mass value="2.0"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial>
  </link>
  <link name="fore">
    <inertial><origin xyz="0.15 0 0"/><mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="rail" type="prismatic">
    <parent link="base"/><child link="carriage"/><origin xyz="0 0 0.1"/><axis xyz="1 0 0"/>
    <limit lower="-0.4" upper="0.4" effort="300" velocity="0.5"/>
  </joint>
  <joint name="shoulder" type="revolute">
    <parent link="carriage"/><child link="upper"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-1.5" upper="1.5" effort="60" velocity="2.0"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0.4 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1.5" upper="1.5" effort="30" velocity="2.0"/>
  </joint>
</robot>
"""

MACHINE = """urdf = "rail.urdf"
name = "rail"

[feedback]
bandwidth = 8.0   # Hz

[sensors]
encoder_resolution = [1e-6, 1e-4, 1e-4]   # m, rad, rad

[[hidden]]
effect = "coulomb_friction"
axis = "rail"
Fc = 20.0     # N
eps = 0.005   # m/s

[[hidden]]
effect = "cable_spring"
axis = "elbow"
k = 25.0      # N m/rad
q0 = 0.3      # rad
width = 0.15  # rad
side = 1.0
"""


def lcgym(*args: str, folder: Path) -> str:
    """Run the ``lcgym`` command in ``folder`` and return what it printed (it fails loudly)."""
    run = subprocess.run([sys.executable, "-c", "import sys; from lcgym.cli import main; sys.exit(main())", *args],
                         cwd=folder, capture_output=True, text=True)
    if run.returncode != 0:
        raise SystemExit(f"lcgym {' '.join(args)} failed:\n{run.stdout}\n{run.stderr}")
    return run.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", type=Path, default=None, help="where the files go (default a new temporary one)")
    parser.add_argument("--seed", default="0")
    args = parser.parse_args()
    folder = args.folder or Path(tempfile.mkdtemp(prefix="lcgym-user-loop-"))
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "rail.urdf").write_text(URDF)
    (folder / "rail.toml").write_text(MACHINE)
    print(f"files in {folder}", flush=True)
    lcgym("simulate", "--system", "rail.toml", "--controller", "feedback", "--n-train", "1", "--n-validation", "2",
          "--duration", "20", "--out", "log.csv", folder=folder)
    print(lcgym("diagnose", "log.csv", "--system", "rail.toml", "--replay", "--json", "diagnosis.json", folder=folder))
    report = json.loads((folder / "diagnosis.json").read_text())
    (folder / "rail_model.toml").write_text(MACHINE + "\n" + report["model_tables"] + "\n")
    lcgym("bench", "--systems", "rail.toml,rail_model.toml", "--methods", "physical,ilc", "--seeds", args.seed,
          "--out", "results.csv", "--no-html", folder=folder)
    df = pd.read_csv(folder / "results.csv")
    rows = df[(df["reference_set"] == "validation") & (df["signal"] == "tracking_error")]
    rms = rows.pivot_table(index="axis", columns=["system", "method"], values="RMS", sort=False)
    replay = pd.Series(report["replay"]["after"])
    out = pd.DataFrame({"replay, after": replay,
                        "physical, [[model]]": rms[("rail_model.toml", "physical")],
                        "physical / replay": rms[("rail_model.toml", "physical")] / replay,
                        "ilc, bare": rms[("rail.toml", "ilc")], "ilc, [[model]]": rms[("rail_model.toml", "ilc")],
                        "ilc [[model]] / bare": rms[("rail_model.toml", "ilc")] / rms[("rail.toml", "ilc")],
                        "unit": rows.groupby("axis", sort=False)["unit"].first()})
    print("validation RMS tracking error (the replay: the log's references) per axis:")
    print(out.to_string(float_format=lambda x: f"{x:.4g}"))


if __name__ == "__main__":
    main()
