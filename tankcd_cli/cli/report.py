"""Messages and progress on stderr, scaled by -q/-v. Data never goes through here."""

from __future__ import annotations

import sys
import time

import click

from tankcd_cli.threads import get_num_threads, openmp_enabled


class Reporter:
    """verbosity: -1 quiet (errors only: they do not go through here; warnings are dropped where they are shown), 0 normal, 1+ detail."""

    def __init__(self, verbosity: int = 0):
        self.verbosity = verbosity
        self.started = time.perf_counter()
        self.interactive = sys.stderr.isatty()

    def info(self, message: str) -> None:
        if self.verbosity >= 0:
            click.echo(message, err=True)

    def detail(self, message: str) -> None:
        if self.verbosity >= 1:
            click.echo(message, err=True)

    def progress(self, prefix: str):
        """A stage callback: prints stages on a terminal (or with -v), silent in pipelines."""
        def stage(text: str) -> None:
            if self.verbosity >= 1 or (self.interactive and self.verbosity >= 0):
                click.echo(f"{prefix}: {text} ({self.elapsed():.1f} s)", err=True)
        return stage

    def bar(self, text: str | None) -> None:
        """A progress line rewritten in place, only on a terminal; None ends it."""
        if not self.interactive or self.verbosity < 0:
            return
        if text is None:
            click.echo("\r\033[K", err=True, nl=False)
        else:
            click.echo(f"\r{text}\033[K", err=True, nl=False)

    def kernels(self) -> None:
        """Under -v: how the compiled kernels run here (OpenMP threads, or serially without it)."""
        if self.verbosity < 1:
            return

        if openmp_enabled():
            self.detail(f"kernels: compiled with OpenMP, {get_num_threads()} threads")
        else:
            self.detail("kernels: compiled without OpenMP (the compiler had none): running on one thread")

    def elapsed(self) -> float:
        return time.perf_counter() - self.started
