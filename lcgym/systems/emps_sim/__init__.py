"""EMPS-v0: a benchmark machine modelled on a real one, the EMPS (Electro-Mechanical Positioning
System) of Janot, Gautier and Brunot (2019): a carriage on a ball screw, one prismatic axis ``x``
[m], input the motor force [N] (``lcgym/EMPS-v0``; bench name ``emps_sim-v0``).

Every number is the description's (``EMPS_Description.txt`` of the benchmark), not fitted to its
data files:

* rigid body: M = 95.154 kg (IDIM-LS with the asymmetric friction model, Sec. 4.2); horizontal,
  no gravity along the axis (``emps.urdf``);
* friction (hidden from the nominal model, which has the rigid body and a viscous friction):
  eq. (12), Fv+ = 166.7061, Fv- = 240.4236 N s/m, Fc+ = 20.1440, Fc- = 20.6277 N, as a viscous
  friction of their mean plus ``asymmetric_friction``; the sign smoothed over eps = 10.4 mm/s (the
  value ``lcgym diagnose`` refines on the real runs, docs/emps.md). That model has no separate
  offset: Fc+ != Fc- is its offset;
* controller, eq. (6)-(7) and Sec. 2.2: force = g_tau (kp kv (q_r - q_m) - kv qd_m), g_tau =
  35.15 N/V, kp = 160.18 1/s, kv = 243.45 V s/m, qd_m = (q_m[k] - q_m[k-2]) / (2 dt) (a two-sample
  average of the measured position, then differenced; ``FeedbackGains.derivative =
  "measurement_fir2"``), at 1 kHz, saturated at 10 V (351.5 N);
* encoder: 50,000 counts per motor turn; the screw's lead is not in the description: 2.5 mm is
  assumed (5e-8 m per count);
* references: bang-bang accelerations (Sec. 2.1), here random point-to-point moves within the
  0-0.25 m travel at 0.05-0.125 m/s reached in 0.15 s.

``studies/emps_sim_to_real.py --data DIR`` runs this machine on the real runs' references and
compares the force and the tracking error with the measured ones. Its env is ``lcgym/Machine-v0``'s
(``systems.machine_env``), registered as ``lcgym/EMPS-v0``.
"""

from __future__ import annotations

from importlib import resources

from .. import ENVS
from ..machine import load_machine

EMPS_SIM = load_machine(str(resources.files(__name__).joinpath("machine.toml")),
                        envs={k: v for k, v in ENVS.items() if k.startswith("lcgym/EMPS-")})

__all__ = ["EMPS_SIM"]
