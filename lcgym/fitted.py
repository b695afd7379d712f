"""Fitted state, as scikit-learn keeps it: what an estimator learns is stored in attributes with a
trailing underscore (``model_``, ``kept_``), set by the call that learns it (``fit``, ``learn``) and
absent before. ``check_fitted`` is the one check a method makes before it uses them; ``is_fitted``
the one test of whether a step already ran (a learner that trains once on its first ``learn``)."""

from __future__ import annotations


class NotFittedError(RuntimeError):
    """A learned attribute was asked for before the call that learns it."""


def is_fitted(obj: object, *attributes: str) -> bool:
    """Whether ``obj`` holds every learned attribute named (``"model_"``, ...)."""
    return all(hasattr(obj, a) for a in attributes)


def check_fitted(obj: object, *attributes: str, hint: str) -> None:
    """Raise ``NotFittedError`` where ``obj`` lacks one of the learned ``attributes``; the message
    names the estimator (its ``name``, else its class) and ``hint``, the call that learns them
    ("call fit(trials) before learn()")."""
    missing = [a for a in attributes if not hasattr(obj, a)]
    if missing:
        label = getattr(obj, "name", None) or type(obj).__name__
        raise NotFittedError(f"{label}: {hint} (it has no {', '.join(missing)} yet)")
