"""Where results come from: lcgym's version, a hash of its own source and the git commit of the
checkout.

They go into the results (``leaderboard.store``) and into the keys of caches (``methods.rl``), so
that numbers computed by other code are never mixed with these.
"""

from __future__ import annotations

import hashlib
import subprocess
from functools import cache
from pathlib import Path

__version__ = "0.2.0"


@cache
def source_hash() -> str:
    """Hash of every Python file of the installed lcgym package."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:12]


@cache
def git_commit() -> str:
    """Commit of the lcgym checkout in use, "+dirty" when tracked files differ from it, or
    "unknown" (an installed wheel has no git)."""
    here = Path(__file__).parent
    try:
        out = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=here, capture_output=True, text=True,
                             timeout=5)
        if out.returncode != 0 or not out.stdout.strip():
            return "unknown"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "."],
                               cwd=here, capture_output=True, text=True, timeout=5).stdout.strip()
        return out.stdout.strip() + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"
