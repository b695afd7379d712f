"""Model-discrepancy workflow: where the model fails and which effect is missing (not built yet: see its issue)."""
