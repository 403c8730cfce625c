"""esba's errors: one base class, bad input beneath it on one side and run-time failures on the other.

Callers catch by meaning (as NumPy's ``AxisError`` is both a ``ValueError`` and an
``IndexError``):

* :class:`EsbaError`: anything esba itself reports.
* :class:`InputError` (also a ``ValueError``): the input is not allowed (a scene field, a flag,
  an option, a file, an output path). The message names the field or file, the value and what is
  allowed. The command line prints it as ``esba: error: ...`` and exits with 2, before any long
  computation.
* :class:`RunError` (also a ``RuntimeError``): a failure found while the work ran, not in its
  input (a lost Dask scheduler, a full disk, a solve that did not reach a stable equilibrium).
  The command line prints it in one line and exits with 1.

Each package defines the errors of its own concept beneath these two (``SceneError``,
``PathError``, ``SweepError``, ... are input errors; ``EquilibriumError``, ``StudyStopped``,
``WriteFailed`` are run-time failures), and the command line maps them by class
(:attr:`EsbaError.exit_code`, :attr:`EsbaError.label`), never by the module that defines them.

Examples
--------
>>> class SceneLikeError(InputError):
...     pass
>>> e = SceneLikeError("E=-1: expected a finite number > 0")
>>> isinstance(e, ValueError), isinstance(e, EsbaError), e.exit_code
(True, True, 2)
>>> EquilibriumError("did not converge").exit_code, EquilibriumError.label
(1, 'failed')
"""

from __future__ import annotations

__all__ = ["EsbaError", "InputError", "RunError", "EquilibriumError"]


class EsbaError(Exception):
    """Every error esba reports on purpose (one line, naming what went wrong)."""

    #: The command line's exit code for this error.
    exit_code: int = 1
    #: The word after ``esba:`` on the command line's one line.
    label: str = "error"


class InputError(EsbaError, ValueError):
    """Input that is not allowed: the message names the field or file, the value and what is allowed."""

    exit_code = 2


class RunError(EsbaError, RuntimeError):
    """A failure found while the work ran, not in its input."""

    exit_code = 1


class EquilibriumError(RunError):
    """A solve that failed or did not reach a stable equilibrium (or a target no pressure reaches)."""

    label = "failed"
