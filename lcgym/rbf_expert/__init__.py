"""RBF neural-network prediction feedforward with expert logic of paper 002. Built so far: the RBF
network with its least-squares and momentum training (``network.py``); the motion influence,
preprocessing, expert logic and the leaderboard method follow (see its issue)."""
