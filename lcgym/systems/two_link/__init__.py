"""TwoLink-v0: the planar two-link arm of ``two_link.urdf`` as a benchmark machine (``lcgym/TwoLink-v0``).

The whole machine is its machine file, ``machine.toml`` (``systems.machine``): the URDF's rigid
body, a 10 Hz PD loop per joint, 16-bit encoders, the URDF's effort limits, and two effects the
nominal model lacks, Coulomb friction in the elbow (3 N m) and a one-sided cable spring on the
shoulder (10 N m/rad beyond 0.3 rad: up to 20 N m at the joint limit, about the gravity torque the
shoulder holds). Its env is ``lcgym/Machine-v0``'s (``systems.machine_env``).
"""

from __future__ import annotations

from importlib import resources

from .. import ENVS
from ..machine import load_machine

TWO_LINK = load_machine(str(resources.files(__name__).joinpath("machine.toml")),
                        envs={k: v for k, v in ENVS.items() if k.startswith("lcgym/TwoLink-")})

__all__ = ["TWO_LINK"]
