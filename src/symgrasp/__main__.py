"""``python -m symgrasp …``: the ``symgrasp`` command (what ``torchrun … -m symgrasp train``
starts on every rank)."""

from symgrasp.cli import main

main()
