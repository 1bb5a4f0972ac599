"""``python -m grainflow`` and the ``grainflow`` program: :func:`grainflow.cli.entry`, with
a Ctrl-C or a SIGTERM that arrives while the command's modules are still being imported
(before a run installs its own handlers, which checkpoint and exit 143) reported as one
line, exit code 130, like a Ctrl-C during a run; Python's default for SIGTERM would end the
process without a word."""

import sys

from grainflow import interrupt


def main() -> None:
    interrupt.install()
    try:
        from grainflow.cli import entry

        if interrupt.received():  # it landed where Python could not raise it (interrupt.py)
            raise KeyboardInterrupt
        entry()
    except KeyboardInterrupt:  # before entry() handles it (importing, or just after)
        _interrupted()
    except Exception:  # an import the interrupt broke (numba turns it into an ImportError)
        if not interrupt.received():
            raise
        _interrupted()


def _interrupted() -> None:
    print("error: interrupted", file=sys.stderr)
    sys.exit(130)


if __name__ == "__main__":
    main()
