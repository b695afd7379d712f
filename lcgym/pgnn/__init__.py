"""Physics-guided neural network feedforward of paper 000 (not built yet: see the PGNN issue)."""
