"""Emit a :class:`derive.program.Program` as a CasADi model file, and keep ``generated/``.

A model file is plain Python: a header saying where it came from, then ``build()``, which makes
the CasADi ``Function``s (SX graphs, named inputs and outputs) from the straight-line program,
one assignment a line. Parameters stay symbolic, so one file serves every design.

Emission is deterministic: the same derivation source gives the same bytes (symbols are named by
their place in the program, never by hash order). ``generated/manifest.json`` records for each
file the segment count, effects, variant, the SymPy and CasADi versions and a hash of the
derivation source (every ``derive/*.py``).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

import sympy as sp

from .effects import EffectSet, check_segments, check_variant, model_filename
from .provenance import GENERATED_DIR, source_hash
from .program import Program, build

MANIFEST = "manifest.json"
#: Format of the model files; esba refuses files of another format.
FORMAT_VERSION = 1


# ---------------------------------------------------------------------------------------------
# SymPy -> CasADi (Python source)


class CasadiPrinter:
    """Prints a SymPy expression as Python code on CasADi SX values (module alias ``ca``)."""

    def __init__(self, names: dict[sp.Symbol, str]):
        self.names = names

    def __call__(self, e: sp.Expr) -> str:
        return self.p(e)

    def p(self, e) -> str:  # noqa: C901 - a dispatch table
        if isinstance(e, sp.Symbol):
            return self.names[e]
        if e is sp.pi:
            return "PI"
        if isinstance(e, (sp.Integer, int)):
            return f"{int(e)}.0" if int(e) >= 0 else f"({int(e)}.0)"
        if isinstance(e, (sp.Rational, sp.Float)) or e.is_Number:
            v = float(e)
            return repr(v) if v >= 0 else f"({v!r})"
        if isinstance(e, sp.Add):
            args = sp.Add.make_args(e)
            parts = [self.p(a) for a in args]
            return "(" + " + ".join(parts) + ")"
        if isinstance(e, sp.Mul):
            num, den = [], []
            for a in sp.Mul.make_args(e):
                if isinstance(a, sp.Pow) and a.exp.is_Number and a.exp < 0:
                    den.append(sp.Pow(a.base, -a.exp) if a.exp != -1 else a.base)
                elif isinstance(a, sp.Rational) and not isinstance(a, sp.Integer) and a.p in (1, -1):
                    den.append(sp.Integer(a.q))
                    if a.p == -1:
                        num.append(sp.Integer(-1))
                else:
                    num.append(a)
            if num and num[0] == -1:
                num = num[1:]
                sign = "-"
            else:
                sign = ""
            n_str = "*".join(self.p(a) for a in num) if num else "1.0"
            out = n_str if not den else f"{n_str}/({'*'.join(self.p(a) for a in den)})"
            return f"({sign}{out})" if sign else f"({out})"
        if isinstance(e, sp.Pow):
            base, ex = e.base, e.exp
            if ex == sp.Rational(1, 2):
                return f"ca.sqrt({self.p(base)})"
            if ex == -sp.Rational(1, 2):
                return f"(1.0/ca.sqrt({self.p(base)}))"
            if ex == 2:
                return f"({self.p(base)})**2"
            if ex == -1:
                return f"(1.0/{self.p(base)})"
            if ex == -2:
                return f"(1.0/({self.p(base)})**2)"
            if ex.is_Integer and ex > 0:
                return f"({self.p(base)})**{int(ex)}"
            return f"ca.power({self.p(base)}, {self.p(ex)})"
        fn = {sp.sin: "ca.sin", sp.cos: "ca.cos", sp.tan: "ca.tan", sp.Abs: "ca.fabs"}
        for cls, name in fn.items():
            if isinstance(e, cls):
                return f"{name}({self.p(e.args[0])})"
        if isinstance(e, (sp.Min, sp.Max)):
            op = "ca.fmin" if isinstance(e, sp.Min) else "ca.fmax"
            args = list(e.args)
            out = self.p(args[0])
            for a in args[1:]:
                out = f"{op}({out}, {self.p(a)})"
            return out
        if isinstance(e, sp.Piecewise):
            *heads, last = e.args
            assert last.cond == sp.true, e
            out = self.p(last.expr)
            for expr, cond in reversed(heads):
                out = f"ca.if_else({self.p(cond)}, {self.p(expr)}, {out})"
            return out
        if isinstance(e, sp.core.relational.Relational):
            return f"({self.p(e.lhs)} {e.rel_op} {self.p(e.rhs)})"
        raise TypeError(f"cannot print {type(e).__name__} to CasADi: {e}")


def render(prog: Program) -> str:
    """The body of a model file (everything after the header)."""
    names: dict[sp.Symbol, str] = {}
    lines: list[str] = []
    w = lines.append
    w("import casadi as ca")
    w("")
    w(f"N = {prog.n}")
    w(f"EFFECTS = {prog.effects.spec()!r}")
    w(f"VARIANT = {prog.variant!r}")
    w(f"PARAMETERS = {tuple(prog.effects.parameters())!r}")
    w(f"TERMS = {tuple(prog.effects.terms())!r}")
    w(f"FORMAT = {FORMAT_VERSION}")
    w("PI = 3.141592653589793")
    w("")
    w("")
    w("def build():")
    w('    """Make the CasADi Functions of this model: {name: casadi.Function}."""')
    for name, syms in prog.inputs.items():
        if name == "theta":
            w(f"    theta = ca.SX.sym('theta', {prog.n})")
            for i, s in enumerate(syms):
                names[s] = f"theta[{i}]"
        else:
            w(f"    {name} = ca.SX.sym('{name}')")
            names[syms[0]] = name
    pr = CasadiPrinter(names)
    for sym, expr in prog.assignments:
        names[sym] = sym.name
        w(f"    {sym.name} = {pr(expr)}")
    w("    out = {}")
    for fname, spec in prog.functions.items():
        outs = []
        for oname, mat in spec.outputs.items():
            rows = ", ".join("ca.horzcat(" + ", ".join(pr(sp.sympify(x)) for x in row) + ")" for row in mat)
            outs.append((oname, f"ca.vertcat({rows})" if len(mat) > 1 else rows))
        ins = ", ".join(spec.inputs)
        w(f"    # {fname}: {spec.doc}")
        w(f"    out[{fname!r}] = ca.Function(")
        w(f"        {fname!r},")
        w(f"        [{ins}],")
        w(f"        [{', '.join(o for _, o in outs)}],")
        w(f"        {spec.inputs!r},")
        w(f"        {[o for o, _ in outs]!r},")
        w("    )")
    w("    return out")
    w("")
    return "\n".join(lines)


def _exec_source(text: str) -> dict:
    """Run a model's source and return its CasADi Functions (our own generated code)."""
    ns: dict = {}
    exec(compile(text, "<model>", "exec"), ns)  # noqa: S102
    return ns["build"]()


def _counts(body: str) -> dict[str, dict[str, int]]:
    funs = _exec_source(body)
    return {name: {"instructions": f.n_instructions(), "nodes": f.n_nodes()} for name, f in funs.items()}


def header(prog: Program, counts: dict[str, dict[str, int]], lines: int) -> str:
    out = [
        '"""ESBA model, generated by derive/emit.py: DO NOT MODIFY BY HAND.',
        "",
        f"Segments n = {prog.n}; effects: {prog.effects.spec()}; variant: {prog.variant}.",
        "Regenerate with:",
        f"    esba generate --segments {prog.n} --effects {prog.effects.spec()} --variant {prog.variant}",
        f"(or `esba generate --refresh` for every committed model). Derivation source sha256: {source_hash()[:16]}.",
        "",
        f"Straight-line program: {len(prog.assignments)} assignments, {lines} lines.",
        "CasADi Functions (SX instructions / nodes):",
    ]
    for name, c in counts.items():
        spec = prog.functions[name]
        out.append(f"    {name}({', '.join(spec.inputs)}) -> {', '.join(spec.outputs)}: {c['instructions']} / {c['nodes']}")
    out += [
        "",
        "Units: mm, N, MPa, kg, m/s^2; angles in radians. Energies in N*mm.",
        '"""',
        "",
    ]
    return "\n".join(out)


def generate_source(n: int, effects: EffectSet, variant: str, progress=None) -> tuple[str, dict]:
    """Derive and render one model; return its source and its manifest entry.

    ``progress(message)``, when given, is called as each stage ends (derivation, CasADi code).
    """
    t0 = time.perf_counter()
    prog = build(n, effects, variant)
    t1 = time.perf_counter()
    if progress:
        progress(f"derived {len(prog.assignments)} assignments in {t1 - t0:.1f} s; writing the CasADi code")
    body = render(prog)
    counts = _counts(body)
    text = header(prog, counts, body.count("\n") + 1) + body
    entry = {
        "file": model_filename(n, effects, variant),
        "segments": n,
        "effects": effects.spec(),
        "variant": variant,
        "format": FORMAT_VERSION,
        "source_sha256": source_hash(),
        "sha256": hashlib.sha256(text.encode()).hexdigest(),
        "instructions": {k: v["instructions"] for k, v in counts.items()},
    }
    entry["_timing"] = {"derive_s": t1 - t0, "emit_s": time.perf_counter() - t1}
    if progress:
        progress(f"CasADi code written in {entry['_timing']['emit_s']:.1f} s")
    entry["_assignments"] = len(prog.assignments)
    return text, entry


def atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that readers never see a partial file (rename is atomic), with
    the mode a new file of the user's gets (0666 less the umask; mkstemp's own is 0600)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def versions() -> dict[str, str]:
    import casadi

    return {"sympy": sp.__version__, "casadi": casadi.__version__}


def read_manifest(folder: Path) -> dict:
    path = Path(folder) / MANIFEST
    if not path.exists():
        return {"format": FORMAT_VERSION, "models": {}}
    return json.loads(path.read_text(encoding="utf-8"))


def write_model(n: int, effects: EffectSet | str, variant: str = "paper", folder: Path | None = None, manifest: bool = True) -> tuple[Path, dict]:
    """Generate one model into ``folder`` (default: ``generated/``) and record it in the manifest."""
    n = check_segments(n)
    check_variant(variant)
    effects = EffectSet.parse(effects) if isinstance(effects, str) else effects
    folder = Path(folder) if folder is not None else GENERATED_DIR
    text, entry = generate_source(n, effects, variant)
    path = folder / entry["file"]
    atomic_write(path, text)
    if manifest:
        update_manifest(folder, entry)
    return path, entry


def update_manifest(folder: Path, entry: dict) -> None:
    """Add or replace one entry of ``folder/manifest.json`` (entries sorted by file name)."""
    data = read_manifest(folder)
    data["format"] = FORMAT_VERSION
    data.update(versions())
    models = data.setdefault("models", {})
    models[entry["file"]] = {k: v for k, v in entry.items() if k != "file" and not k.startswith("_")}
    data["models"] = dict(sorted(models.items()))
    atomic_write(Path(folder) / MANIFEST, json.dumps(data, indent=2, sort_keys=True) + "\n")


#: The models committed in ``generated/``: n = 1..8, default effects, both variants.
COMMITTED = [(n, "air,axial,radial,fibres,payload", v) for v in ("paper", "printed") for n in range(1, 9)]


def refresh(folder: Path | None = None, progress=None) -> list[Path]:
    """Regenerate every committed model (``COMMITTED``) into ``folder``."""
    folder = Path(folder) if folder is not None else GENERATED_DIR
    paths = []
    for n, eff, var in COMMITTED:
        path, _ = write_model(n, eff, var, folder)
        paths.append(path)
        if progress:
            progress(path)
    return paths
