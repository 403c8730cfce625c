"""Write an export's folder: ``NAME.h``, ``NAME.c``, ``Makefile``, ``README.md`` and ``demo.c``.

A file of the same name that esba did not write (a ``Makefile`` of the user's), or one changed since
esba wrote it, is not replaced without ``force``: the manifest ``esba-export.json`` that every export
writes beside its files holds each file's SHA-256, which says which files are esba's own.

The README's example line (what ``./demo`` prints for the Table 1 actuator at 0.12 MPa under a
2 N horizontal tip payload) is computed here, in Python (:mod:`esba.export.reference`), and
formatted as the demo formats it: a test builds the demo from the Makefile alone and compares.

Examples
--------
>>> import tempfile
>>> e = export_c(ExportSpec(3), tempfile.mkdtemp())
>>> sorted(p.name for p in e.files)
['Makefile', 'README.md', 'demo.c', 'esba-export.json', 'esba_n3_air_axial_radial_fibres_payload1_paper.c', 'esba_n3_air_axial_radial_fibres_payload1_paper.h']
>>> e.example_input
'0.12 2 90'
>>> e.example_output
'theta_deg -3.9514 6.2537 20.2410 total_deg 22.5434 tip_mm 133.656 7.432 status ok'
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

from esba import __version__
from esba.infra import outputs

from .ccode import FLAGS, TEMPLATES, TOLERANCES, ExportSpec, fill, flag_meanings, render_source
from .reference import reference_equilibrium

__all__ = ["Export", "export_c", "MANIFEST", "file_names", "foreign_files", "check_out_folder", "EXAMPLE", "STATUS_TABLE", "flag_table", "example_line", "format_line", "default_command"]

#: The README's example: pressure (MPa) and the first payload (N, degrees from the vertical).
EXAMPLE = {"pressure": 0.12, "force": 2.0, "angle_deg": 90.0}
#: Table 1 with E = 0.54 MPa, as ``{name}_default_params`` (rho in radians), and g.
TABLE1 = {"L": 135.0, "r1": 8.0, "r2": 3.0, "d": 4.0, "rho": math.radians(10.0), "E": 0.54, "M": 0.035, "g": 9.81}


@dataclass(frozen=True)
class Export:
    """An export on disk."""

    spec: ExportSpec
    folder: Path
    files: tuple[Path, ...]
    example_input: str
    example_output: str
    example_status: str

    @property
    def header(self) -> Path:
        return self.folder / f"{self.spec.name}.h"

    @property
    def source(self) -> Path:
        return self.folder / f"{self.spec.name}.c"


def default_command(spec: ExportSpec, out: str = "DIR") -> str:
    """The command line that makes ``spec``'s export."""
    command = f"esba export c --segments {spec.n}"
    if spec.effects.spec() != ExportSpec(spec.n).effects.spec():
        command += f" --effects {spec.effects.spec()}"
    if spec.variant != "paper":
        command += f" --variant {spec.variant}"
    if spec.precision == "float":
        command += " --float"
    return command + f" --out {out}"


def format_line(theta, total: float, tip, status: str, pressure: float | None = None) -> str:
    """One line of the demo's output (``demo.c`` prints it with the same formats)."""
    head = "" if pressure is None else f"pressure_mpa {pressure:.7f} "
    angles = " ".join(f"{math.degrees(float(t)):.4f}" for t in theta)
    return f"{head}theta_deg {angles} total_deg {math.degrees(total):.4f} tip_mm {float(tip[0]):.3f} {float(tip[1]):.3f} status {status}"


def example_line(spec: ExportSpec) -> tuple[str, str, str]:
    """(the demo's input line, the line it prints, the status) for :data:`EXAMPLE`, from Python."""
    model = spec.model()
    values = dict(TABLE1, P=EXAMPLE["pressure"])
    words = [f"{EXAMPLE['pressure']:g}"]
    for k in range(1, spec.payloads + 1):
        force = EXAMPLE["force"] if k == 1 else 0.0
        values.update({f"F{k}": force, f"Omega{k}": math.radians(EXAMPLE["angle_deg"]), f"s{k}": 1.0})
        words += [f"{force:g}", f"{EXAMPLE['angle_deg']:g}"] + (["1"] if spec.payloads > 1 else [])
    r = reference_equilibrium(model, {k: values[k] for k in model.parameters})
    status = ("snapped" if r["snapped"] else "ok") if r["ok"] else "not_converged"
    return " ".join(words), format_line(r["theta"], r["total_angle"], r["tip"], status), status


def _read_line(spec: ExportSpec) -> str:
    """The demo's code that reads one line's numbers into ``loads``."""
    k = spec.payloads
    if k == 0:
        want, check = '"pressure_MPa" (-i: "total_angle_deg")', "count != 1"
        body = ""
    elif k == 1:
        want, check = '"pressure_MPa force_N angle_deg [at]" (-i: the total angle in degrees first)', "count != 3 && count != 4"
        body = (
            "        loads.payload[0].force = real_of(v[1]);\n"
            "        loads.payload[0].angle = real_of(v[2] / DEG);\n"
            "        if (count == 4) loads.payload[0].at = real_of(v[3]);\n"
        )
    else:
        want, check = f'"pressure_MPa" and {k} x "force_N angle_deg at" (-i: the total angle in degrees first)', f"count != {1 + 3 * k}"
        body = (
            f"        for (k = 0; k < {k}; ++k) {{\n"
            "            loads.payload[k].force = real_of(v[1 + 3 * k]);\n"
            "            loads.payload[k].angle = real_of(v[2 + 3 * k] / DEG);\n"
            "            loads.payload[k].at = real_of(v[3 + 3 * k]);\n"
            "        }\n"
        )
    want_c = want.replace('"', '\\"')
    return (
        f"        if ({check}) {{\n"
        f'            fprintf(stderr, "line %lu: expected {want_c}\\n", lineno);\n'
        "            failed = 1;\n            continue;\n        }\n"
        "        if (!inverse) loads.pressure = real_of(v[0]);\n" + body
    )


def _line_payloads(spec: ExportSpec) -> str:
    k = spec.payloads
    if k == 0:
        return ""
    if k == 1:
        return " force_N angle_deg [at]"
    return " then, per payload, force_N angle_deg at"


STATUS_TABLE = """| code | name | meaning |
|---|---|---|
| 0 | `ESBA_OK` | converged on a stable equilibrium (evaluations: done) |
| 1 | `ESBA_UNSTABLE` | converged on an equilibrium that is not stable (a saddle, or critical) |
| 2 | `ESBA_SNAPPED` | the load path snapped at a fold: the stable state after the jump, taken on to the full load (`snap_*` say where) |
| 3 | `ESBA_UNREACHABLE` | no stable state of the branch meets the target: the nearest reachable one is returned |
| 4 | `ESBA_NOT_CONVERGED` | an iteration limit was met: the last good state is returned |
| 5 | `ESBA_OUT_OF_DOMAIN` | the state would leave the model's domain (Eq. 10: the chamber closes) |
| 6 | `ESBA_BAD_INPUT` | a load or target not allowed: NaN, infinite, negative pressure or force, `at` outside (0, 1], NULL |
| 7 | `ESBA_BAD_PARAMETERS` | actuator parameters outside their ranges (L, r1, r2, E > 0; d, M >= 0; r2 + d < r1; 0 <= rho < pi/2) |
| 8 | `ESBA_BAD_SIZE` | `n` is not the segment count of this export |
"""


def _readme(spec: ExportSpec, command: str, example: tuple[str, str, str]) -> str:
    name = spec.name
    inp, out, _ = example
    precision_note = (
        "The example's numbers come from esba's Python solver in double precision; this export is single precision "
        "(`--float`), whose last digits may differ (its accuracy against double is measured on esba's `docs/embedded.md`)."
        if spec.precision == "float" else
        "The example's numbers come from esba's Python solver (`solve()`'s load history); the demo computes them in C."
    )
    return f"""# {name}: an eccentric soft bending actuator in C

Generated by `{command}` (esba): the model with n = {spec.n} segments, effects
`{spec.effects.spec()}`, variant `{spec.variant}`, in **{spec.precision}** precision, as C99 that depends on
nothing but libm. No `malloc`, no global mutable state (every call works in the caller's
`{name}_work`, so calls on different works may run in parallel), and every loop is bounded.
The actuator's parameters are a struct passed at run time: a calibrated actuator (`esba fit`)
needs no new export. Do not edit these files: export again. `esba-export.json` lists them with
their SHA-256: an export into this folder replaces them as long as they are unchanged, and refuses
(without `--force`) to replace a file it did not write or one that was changed since.

## Build

    make            # the demo: cc -std=c99 -O2 demo.c {name}.c -lm
    make check      # every warning an error: -std=c99 -Wall -Wextra -Werror -pedantic
    make cortex-m4  # arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os
                    # (Debian/Ubuntu: apt-get install gcc-arm-none-eabi)

In a controller, compile `{name}.c` with your sources and include `{name}.h`.

## The demo

`./demo` reads lines `pressure_MPa{_line_payloads(spec)}` (the payload's direction in degrees
from the vertical: 0 pulls down, 90 pushes horizontally against the bend; `at` the fraction of the
length where it acts, default 1 = the tip) and prints for each the segment angles (degrees), the
total angle, the tip (x down the unbent axis, y toward the bending side, mm) and the status, for
the paper's Table 1 actuator, then `flags` and their names when the result has any (see below).
`./demo -i` reads the total angle in degrees first instead of the pressure and prints the pressure
that reaches it under the payloads, then the same. Blank lines and lines starting with `#` are
skipped. A line is read whole: one longer than 4096 bytes, or holding a NUL byte, is refused with
its number on stderr, as is a line that is not numbers. The exit code is 0 when every line was
answered, 1 when a line was refused or standard input could not be read or standard output not
written (a full disk: the message says so), 2 for a wrong argument.

Example (Table 1 at {inp.split()[0]} MPa{', a 2 N horizontal tip payload' if spec.payloads else ''}):

    $ echo '{inp}' | ./demo
    {out}

{precision_note}

## Units

mm, N, MPa; angles in radians in the API (theta, rho, a payload's `angle`), degrees only in the
demo's lines; mass M in kg, g in m/s^2; energies in N mm; the stiffness in N/m and the compliance
in m/N. Tip x points down the unbent axis, y toward the bending side (the paper's base frame).

## API ({name}.h)

Every function takes `n` (must be {spec.n}: `ESBA_BAD_SIZE` otherwise), the actuator
(`{name}_params`: L, r1, r2, d, rho, E, M) and the loads (`{name}_loads`: `pressure`{', `payload[k]` = {force, angle, at}' if spec.payloads else ''}, `g`),
and returns a status code. Results are always finite: on bad input they are zeros. A result (`{name}_result`) also
carries `flags`: where its state lies outside the model's range (see Flags below).

- `{name}_equilibrium(n, params, loads, from, out, work)`: the equilibrium the actuator reaches
  along its load history. With `from == NULL`, from the straight state: the pressure is raised with
  the payloads off, then the payloads (and the weight) are raised together, as esba's `solve()` does.
  With a `{name}_state` (theta and the loads it is an equilibrium for, e.g. the last control
  cycle's answer), every load moves from those to `loads` together: a warm start. The stable branch
  is followed by continuation (tangent predictor, Newton corrector, the Hessian's chain structure
  making every solve O(n)); where it ends at a fold the actuator snaps: the state it lands in is
  found past the fold along the critical mode and the ramp goes on from there (`ESBA_SNAPPED`,
  with `out->snaps`, `snap_ramp`, `snap_at`, `snap_from`, `snap_to`).
- `{name}_pressure_for_angle(n, params, loads, total_angle, max_pressure, from, out, work)`: the
  pressure in [0, max_pressure] MPa whose stable equilibrium under the payloads of `loads` has the
  total angle `total_angle` (rad). The branch of equilibria is followed in the total angle from the
  equilibrium at P = 0 (or from `from`); a target that no stable state of that branch meets (it lies
  between two folds, below P = 0 or above `max_pressure`) gives `ESBA_UNREACHABLE` with the nearest
  reachable state in `out`. An answer (or nearest reachable state) that the load history at its
  pressure does not reach (the actuator is multistable there: it snapped past it, see below) is
  flagged `ESBA_FLAG_MULTISTABLE`; finding that out costs one `{name}_equilibrium` more.
- `{name}_newton(n, params, loads, theta0, out, work)`: Newton from `theta0` at fixed loads, the
  nearest equilibrium, stable (`ESBA_OK`) or not (`ESBA_UNSTABLE`); no load history, so it does not
  see folds: for tracking small changes.
- `{name}_stiffness(n, params, loads, theta, out, work)`: the tip's tangent stiffness at an
  equilibrium: compliance C = J H^-1 J^T (m/N), K = C^-1 (N/m), and the directional stiffness
  horizontally and vertically.
- `{name}_energy`, `{name}_gradient`, `{name}_hessian` (n x n, row-major), `{name}_tip`: the
  model itself at a state.
- `{name}_status_name(status)`, `{name}_work_bytes()`, `{name}_default_params` (Table 1, E = 0.54 MPa),
  `{name}_default_loads`.

```c
static {name}_work work;          /* {name}_work_bytes() bytes, yours to place */
{name}_params a;
{name}_loads loads;
{name}_result r;
{name}_default_params(&a);
{name}_default_loads(&loads);
loads.pressure = 0.12;{'''
loads.payload[0].force = 2.0;            /* N */
loads.payload[0].angle = 1.5707963;      /* rad from the vertical: horizontal */''' if spec.payloads else ''}
if ({name}_equilibrium({spec.n}, &a, &loads, NULL, &r, &work) <= ESBA_SNAPPED) {{
    /* r.theta, r.tip, r.total_angle */
}}
```

## Status codes

{STATUS_TABLE}
## Flags: results outside the model's range

A result's `flags` (bits beside its status; `{name}_flag_name` names one) say where its state lies
outside what the paper's model describes, by the same rule as esba's Python results
(`esba.model.validity`, whose thresholds this export was written with). The state may well be a
converged, stable equilibrium of the model: `ESBA_OK` with any of `ESBA_FLAGS_OUTSIDE_MODEL` is an
answer of the model, not of the actuator.

{flag_table()}
## What happens at a fold

A quasi-static load change keeps the actuator on a stable branch of equilibria until that branch
ends at a fold, where the stable state meets an unstable one and both vanish: the actuator snaps
to another stable state. `{name}_equilibrium` notices the end of the branch (its load steps
shrink to nothing while the Hessian turns singular), kicks the state along the critical mode
towards the side where the energy falls, minimises the energy just past the fold and goes on from
the state it lands in; the result is that state taken on to the full load, with `ESBA_SNAPPED`.
Near a cusp, where two folds are born (the pressure/payload cusp of the paper's actuator lies at
0.1686 MPa, 1.645 N: esba's `docs/maps.md`), the jump is small: a load path that crosses the tip
of a fold curve snaps by less than a degree, which esba's Python path trace may not resolve (it
then says `ok` where this says `ESBA_SNAPPED`); both end at the same state. The Hessian there is
nearly singular, and Newton's steps stay at its amplified round-off: a state whose gradient is
below {TOLERANCES[spec.precision]['GRAD_TOL']:g} N mm/rad counts as converged (esba's Python solvers accept
1e-9 N mm/rad in double precision; single precision's round-off is larger).
`{name}_pressure_for_angle` follows the branch of equilibria in the total angle, through its folds:
a target that no stable state of the branch meets (between two folds) is `ESBA_UNREACHABLE`, with
the fold's state as the nearest reachable one. A target held by a stable state past a fold is
answered, and when the load history at that pressure (inflated, then loaded: what
`{name}_equilibrium` does) reaches a different state, the answer is flagged
`ESBA_FLAG_MULTISTABLE`: the actuator holds it only if it gets there some other way (esba's
`pressure --total-angle` notes the same).
"""


def flag_table() -> str:
    """The README's table of the flag bits (:data:`esba.export.ccode.FLAGS`)."""
    meanings = flag_meanings()
    rows = [f"| {1 << i} | `ESBA_FLAG_{flag.upper()}` | `{flag}` | {meanings[flag]} |" for i, flag in enumerate(FLAGS)]
    return "| bit | name | printed | set when |\n|---|---|---|---|\n" + "\n".join(rows) + "\n"


#: The manifest of an export, beside its files: what wrote them and each file's SHA-256.
MANIFEST = "esba-export.json"
_WRITER = "esba export c"


def file_names(spec: ExportSpec) -> tuple[str, ...]:
    """The files ``spec``'s export writes (the manifest last)."""
    return (f"{spec.name}.h", f"{spec.name}.c", "demo.c", "Makefile", "README.md", MANIFEST)


def _sha256(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _manifest(folder: Path) -> dict[str, str] | None:
    """The files an earlier export wrote into ``folder`` (name -> SHA-256); None when the folder holds
    no manifest of esba's (none at all, or a file of that name that esba did not write)."""
    path = folder / MANIFEST
    try:
        data = None if path.is_symlink() else json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(data, dict) or data.get("written_by") != _WRITER:
        return None
    files = data.get("files")
    return {str(k): str(v) for k, v in files.items() if isinstance(v, str)} if isinstance(files, dict) else {}


def foreign_files(folder: str | Path, names: Iterable[str]) -> list[str]:
    """The files among ``names`` that are in ``folder`` and that an export would replace although esba
    did not write them: not in the folder's manifest, changed since (their SHA-256 differs), links or
    folders. The manifest itself counts as esba's when it is one.

    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "Makefile").write_text("all:\\n")
    >>> foreign_files(d, ["Makefile", "demo.c", MANIFEST])
    ['Makefile']
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    known = _manifest(folder)
    found = []
    for name in names:
        path = folder / name
        if not path.exists() and not path.is_symlink():
            continue
        if name == MANIFEST:
            ours = known is not None
        else:
            ours = not path.is_symlink() and path.is_file() and (known or {}).get(name) == _sha256(path)
        if not ours:
            found.append(name)
    return found


def check_out_folder(out: str | Path, spec: ExportSpec, force: bool = False, flag: str = "--out") -> tuple[Path, bool]:
    """The export's folder, checked before anything is generated: writable (created when missing, one
    level), and no file in it that the export would replace without ``force`` (:func:`foreign_files`).
    Returns the folder and whether it was created here.

    Raises
    ------
    esba.infra.outputs.OutputError
        naming the folder and every file in the way.
    """
    path = Path(out)
    existed = path.exists() or path.is_symlink()
    foreign = foreign_files(path, file_names(spec)) if path.is_dir() else []
    folders = [name for name in foreign if (path / name).is_dir() and not (path / name).is_symlink()]
    if folders:
        raise outputs.OutputError(f"{flag} {str(out)!r}: {', '.join(folders)} in it {'is a folder' if len(folders) == 1 else 'are folders'}, "
                                  "where the export writes a file")
    if foreign and not force:
        raise outputs.OutputError(f"{flag} {str(out)!r}: the export would replace {', '.join(foreign)}, which esba did not write there "
                                  "(or which changed since): move them away, or give --force to replace them")
    folder = outputs.check_folder(out, flag)
    return folder, not existed


def export_c(spec: ExportSpec, out: str | Path, command: str | None = None, force: bool = False) -> Export:
    """Write ``spec``'s export into the folder ``out`` (created when missing, one level); return it.

    Files of the same names that esba did not write there are replaced only with ``force``
    (:func:`check_out_folder`). When the export fails, a folder it created is removed again.

    Raises
    ------
    esba.infra.outputs.OutputError
        when ``out`` cannot be written or holds files in the way (checked before anything is generated).
    """
    folder, created = check_out_folder(out, spec, force)
    try:
        return _write(spec, folder, command or default_command(spec, str(out)))
    except BaseException:
        if created:
            for name in file_names(spec):
                (folder / name).unlink(missing_ok=True)
            try:
                folder.rmdir()
            except OSError:  # something else is in it now: leave it
                pass
        raise


def _write(spec: ExportSpec, folder: Path, command: str) -> Export:
    model = spec.model()
    header, source = render_source(spec, command, model)
    example = example_line(spec)
    values = {"NAME": spec.name, "UPPER": spec.name.upper(), "COMMAND": command, "REAL_MAX": "DBL_MAX" if spec.precision == "double" else "(double)FLT_MAX"}
    demo = fill((TEMPLATES / "demo.c").read_text(encoding="utf-8"), {**values, "READ_LINE": _read_line(spec), "LINE_PAYLOADS": _line_payloads(spec)})
    makefile = fill((TEMPLATES / "Makefile").read_text(encoding="utf-8"), values)
    files = {
        f"{spec.name}.h": header,
        f"{spec.name}.c": source,
        "demo.c": demo,
        "Makefile": makefile,
        "README.md": _readme(spec, command, example),
    }
    known = _manifest(folder) or {}
    written = []
    for name, text in files.items():
        path = folder / name
        if path.is_symlink():  # replaced (with force), not written through
            path.unlink()
        written.append(outputs.write_text(path, text))
    # the manifest: these files, and those of earlier exports into the folder that are still as written
    hashes = {name: sha for name, sha in known.items() if name not in files and _sha256(folder / name) == sha}
    hashes.update({p.name: _sha256(p) for p in written})
    manifest = {"written_by": _WRITER, "command": command, "esba": __version__, "files": dict(sorted(hashes.items()))}
    if (folder / MANIFEST).is_symlink():
        (folder / MANIFEST).unlink()
    written.append(outputs.write_text(folder / MANIFEST, json.dumps(manifest, indent=1) + "\n"))
    return Export(spec, folder, tuple(written), example[0], example[1], example[2])
