"""RBF neural-network prediction feedforward with expert logic of paper 002 (not built yet: see its issue)."""
