"""The benchmark: the runner of (machine, method, seed) cells (``runner.py``), the results CSV
(``store.py``), the rankings as text, Markdown and HTML (``report.py``) and the plots
(``plots.py``). What a machine scores is its own (``System.bench``); the norms are ``lcgym.metrics``."""
