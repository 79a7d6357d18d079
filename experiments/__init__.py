"""The lab, outside the installed package: the studies behind the docs' claims (one script each,
run from the checkout's root as ``python experiments/NAME.py``), the campaign driver and its
plans, the helper every script of benchmarks/ and experiments/ shares (`scripts`) and the lab's
own tests (experiments/tests). A script imports its neighbours by their bare names (``common``,
``scripts``: its folder is first on ``sys.path``); the benchmarks and the tests import the
helper as ``experiments.scripts``."""
