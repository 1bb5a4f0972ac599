"""``python -m grainflow`` and the ``grainflow`` program: :func:`grainflow.cli.entry`, with
a Ctrl-C or a SIGTERM that arrives while the command's modules are still being imported
(before a run installs its own handlers, which checkpoint and exit 143) reported as one
line, exit code 130, like a Ctrl-C during a run; Python's default for SIGTERM would end the
process without a word."""

import signal
import sys


def main() -> None:
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # a KeyboardInterrupt
    try:
        from grainflow.cli import entry

        entry()
    except KeyboardInterrupt:  # before entry() handles it (importing, or just after)
        print("error: interrupted", file=sys.stderr)
        sys.exit(130)


if __name__ == "__main__":
    main()
