"""What `heft` commands say, through Python's ``logging``: the ``heft`` logger writes info and debug
lines to stdout (the results a command reports) and warnings and errors to stderr, as plain text;
``heft -v`` shows debug lines, ``heft -q`` only warnings and errors (and no progress)."""

from __future__ import annotations

import logging
import sys

ROOT = "heft"


class _ConsoleHandler(logging.Handler):
    """Plain lines to the streams as they are when written (a test's captured ones too)."""

    def emit(self, record: logging.LogRecord) -> None:
        stream = sys.stdout if record.levelno < logging.WARNING else sys.stderr
        try:
            stream.write(self.format(record) + "\n")
            stream.flush()
        except Exception:  # noqa: BLE001 - logging's contract: a broken stream never breaks the command
            self.handleError(record)


def configure(verbosity: int = 0) -> None:
    """The ``heft`` logger at INFO, one step down per ``-v`` (DEBUG) and up per ``-q`` (WARNING, ERROR)."""
    logger = logging.getLogger(ROOT)
    if not any(isinstance(handler, _ConsoleHandler) for handler in logger.handlers):
        handler = _ConsoleHandler()
        handler.setFormatter(logging.Formatter("%(message)s"))
        logger.addHandler(handler)
    logger.propagate = False
    logger.setLevel(min(max(logging.INFO - 10 * verbosity, logging.DEBUG), logging.ERROR))


def logger(name: str) -> logging.Logger:
    """A command's logger, under ``heft``; configured at INFO if ``configure`` has not been called
    (a command's ``run`` called directly)."""
    if not logging.getLogger(ROOT).handlers:
        configure()
    return logging.getLogger(name)
