"""``python -m grainflow``: the same command as ``grainflow``."""

from grainflow.cli import entry

entry()
