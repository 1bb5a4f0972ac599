"""``python -m grainflow``: the same command as ``grainflow``."""

from grainflow.cli import app

app(prog_name="grainflow")
