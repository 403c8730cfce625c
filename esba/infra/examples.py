"""The example files (scene files and measurements) that ship inside the package.

In a checkout they are the repository's ``examples/`` folder; an installed esba carries the same
files as ``esba/examples/`` (``pyproject.toml`` maps the one onto the other), so ``esba example``
can copy them out wherever esba was installed from.

Examples
--------
>>> "table2.toml" in example_names() and "measurements/paper_exp.csv" in example_names()
True
"""

from __future__ import annotations

from pathlib import Path

from .errors import InputError
from .outputs import PACKAGE_ROOT, is_checkout

__all__ = ["ExampleError", "examples_dir", "example_names", "copy_examples"]


class ExampleError(InputError):
    """An example that does not exist, or a copy that would replace a different file."""


def examples_dir() -> Path:
    """The folder holding the examples: the checkout's ``examples/``, else the installed ``esba/examples/``."""
    return PACKAGE_ROOT / "examples" if is_checkout() else Path(__file__).resolve().parents[1] / "examples"


def example_names() -> list[str]:
    """Every example, as its path inside the examples folder (``table2.toml``, ``measurements/paper_exp.csv``)."""
    root = examples_dir()
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and p.suffix in (".toml", ".csv"))


def _resolve(name: str) -> str:
    names = example_names()
    if name in names:
        return name
    matches = [n for n in names if Path(n).name == name or Path(n).stem == name or n.rsplit(".", 1)[0] == name]
    if len(matches) == 1:
        return matches[0]
    raise ExampleError(f"example {name!r}: expected one of {', '.join(names)}")


def copy_examples(names: list[str], dest: str | Path) -> list[tuple[Path, str]]:
    """Copy the examples ``names`` (a path, a file name or a stem: ``table2``) into ``dest``, keeping
    their folders (``measurements/``). A file that is already there with the same content is left
    as it is; one with other content is refused (nothing is copied). Returns (path, ``wrote`` or
    ``unchanged``) per example."""
    chosen = list(dict.fromkeys(_resolve(n) for n in names))
    dest = Path(dest)
    plan = []
    for name in chosen:
        data = (examples_dir() / name).read_bytes()
        target = dest / name
        if target.is_dir() or (target.exists() and target.read_bytes() != data):
            raise ExampleError(f"{target} exists and is not esba's {name}: move it away, or give --out DIR")
        plan.append((target, data))
    done = []
    for target, data in plan:
        if target.exists():
            done.append((target, "unchanged"))
            continue
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        except OSError as exc:
            raise ExampleError(f"{target}: cannot write ({exc.strerror or exc})") from None
        done.append((target, "wrote"))
    return done
