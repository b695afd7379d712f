"""Fitted state is checked one way (``lcgym.fitted``, scikit-learn's ``check_is_fitted``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from lcgym.fitted import NotFittedError, check_fitted, is_fitted


class _Estimator:
    name = "my-method"


def test_check_fitted_names_the_estimator_the_call_and_what_is_missing():
    est = _Estimator()
    assert not is_fitted(est, "model_")
    with pytest.raises(NotFittedError, match=r"my-method: call fit\(trials\) first \(it has no model_, kept_ yet\)"):
        check_fitted(est, "model_", "kept_", hint="call fit(trials) first")
    est.model_, est.kept_ = object(), True
    check_fitted(est, "model_", "kept_", hint="call fit(trials) first")
    assert is_fitted(est, "model_", "kept_")
    assert issubclass(NotFittedError, RuntimeError)  # what the methods raised before


def test_fitted_state_is_probed_through_lcgym_fitted():
    """No method or model probes its learned attributes with hasattr itself."""
    package = Path(__file__).resolve().parents[1] / "lcgym"
    probes = [f"{p.relative_to(package)}:{n}" for p in sorted(package.rglob("*.py")) if p.name != "fitted.py"
              for n, line in enumerate(p.read_text().splitlines(), 1)
              if re.search(r"hasattr\(self, [\"']\w+_[\"']\)", line)]
    assert len(probes) <= 3, probes
