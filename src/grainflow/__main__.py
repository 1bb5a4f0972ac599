"""``python -m grainflow`` and the ``grainflow`` program: :func:`grainflow.cli.entry`, with
a Ctrl-C that arrives while the command's modules are still being imported reported as one
line (exit code 130), like one during a run."""

import sys


def main() -> None:
    try:
        from grainflow.cli import entry
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        sys.exit(130)
    entry()


if __name__ == "__main__":
    main()
