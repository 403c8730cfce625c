"""Runners for the study tests: one that interrupts a study as Ctrl-C would."""

from __future__ import annotations


class StopAfter:
    """Wraps a runner: the study is interrupted after ``k`` chunks were handed back (as by Ctrl-C)."""

    def __init__(self, runner, k: int) -> None:
        self.runner, self.k = runner, k
        self.workers, self.description = runner.workers, runner.description

    def map_ordered(self, fn, args, done=None):
        for i, result in enumerate(self.runner.map_ordered(fn, args, done)):
            if i == self.k:
                raise KeyboardInterrupt
            yield result
