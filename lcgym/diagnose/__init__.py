"""Model-discrepancy workflow: compare a physical model with measurements, see where it fails,
learn which physical effect is missing, add it, and watch the error fall (`lcgym diagnose`).

    from lcgym.diagnose import diagnose
    report = diagnose(trials, system="ix", add=["coulomb_friction@roll"])   # or a System: a URDF, your own
    report = diagnose(trials, "ix", DiagnoseOptions(min_explained=0.2))      # the options as one object
    print(report.text())

Steps in ``workflow.py``; the candidate search in ``search.py``; candidates, and a user's effect
added to a machine (``register_effect``), in ``candidates.py``; regions in ``regions.py``; the
report in ``report.py``, its rows in ``rows.py``.
"""

from .candidates import Candidate, register_effect
from .report import NOTHING_FOUND
from .result import Diagnosis
from .workflow import DiagnoseOptions, diagnose, replay_tracking

__all__ = ["NOTHING_FOUND", "Candidate", "DiagnoseOptions", "Diagnosis", "diagnose", "register_effect",
           "replay_tracking"]
