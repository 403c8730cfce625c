"""The committed pages of docs/: every computed page as ``esba docs --check`` finds it, no page
prints digits that are round-off, and the benchmark pages keep their structure (their numbers
are times: ``esba docs --check`` reruns the benchmarks, minutes each, which CI does not).

CI runs this file (the computed pages' checks are slow tests marked ``ci``): a change that makes
a page stale fails CI, and so does a page that only a quiet machine, one BLAS kernel or one
thread count would write again byte for byte.
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

import pytest

from esba.cli import build_parser, main
from esba.pages.registry import ENTRIES

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"

#: The computed pages (seconds to a minute or two each); the rest are the benchmarks.
COMPUTED = [name for name, e in ENTRIES.items() if not e.slow]
#: The benchmark pages: the registry's slow ones, and docs/embedded.md (``esba bench embedded``).
BENCHMARKS = {name: e.file for name, e in ENTRIES.items() if e.slow} | {"embedded": "embedded.md"}
#: Pages whose check takes a minute or more: run in CI and by ``pytest --slow``. (The experiments
#: page is also checked in tests/calibration/test_experiments.py, on the data its tests share.)
SLOW_CHECKS = {"sensing", "equilibria", "maps", "experiments"}


def _params(names, slow):
    return [pytest.param(n, marks=[pytest.mark.slow, pytest.mark.ci]) if n in slow else n for n in names]


@pytest.mark.timeout(1800)
@pytest.mark.parametrize("name", _params(COMPUTED, SLOW_CHECKS))
def test_esba_docs_check_finds_the_computed_page_up_to_date(name, capsys):
    code = main(["docs", "--check", name])
    out = capsys.readouterr().out
    assert code == 0, f"{out.strip()}\nrun `esba docs --write {name}` and commit it"


#: A number printed in e-notation whose exponent says it is round-off (1e-14 and below: a few units
#: in the last place of a double), or a zero printed in e-notation ("0.0e+00": the noise of a
#: difference that happened to vanish). A floor the page states ("< 1e-15", "within ±1e-08",
#: "below 1e-06") is not noise.
NOISE = re.compile(r"(?<![\w.<±])(?<!< )(?<!± )(?<!below )(?<!below\n)[-+]?(?:\d+(?:\.\d*)?|\.\d+)e(?:-(?:1[4-9]|[2-9]\d|\d{3})|[-+]?0+)(?![\w.])")


@pytest.mark.parametrize("name", COMPUTED)
def test_no_computed_page_prints_round_off_digits(name):
    text = (DOCS / ENTRIES[name].file).read_text(encoding="utf-8")
    found = [(text.count("\n", 0, m.start()) + 1, m.group()) for m in NOISE.finditer(text)]
    assert not found, f"docs/{ENTRIES[name].file} prints round-off (line, number): {found[:5]}; print it below a stated floor (esba.infra.roundoff.floored)"


def test_the_noise_pattern_tells_round_off_from_a_stated_floor():
    noise = ["1.1e-16", "0.0e+00", "+0.00e+00", "2e-34", "-7.5e-14"]
    fine = ["< 1e-15", "within ±1e-08", "below 1e-06", "3.478e-05", "1e-9", "2.5e-03", "1e-12"]
    assert all(NOISE.search(f"| {s} |") for s in noise)
    assert not any(NOISE.search(f"| {s} |") for s in fine)


# ---------------------------------------------------------------------------------------------
# the benchmark pages: structure, not numbers


def _tables(text: str) -> list[list[list[str]]]:
    """Each Markdown table of ``text`` as rows of cells (header first, the separator left out)."""
    lines, out, k = text.splitlines(), [], 0
    while k < len(lines) - 1:
        if lines[k].startswith("|") and re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", lines[k + 1].strip()):
            rows = [lines[k]]
            k += 2
            while k < len(lines) and lines[k].startswith("|"):
                rows.append(lines[k])
                k += 1
            out.append([[c.strip() for c in re.split(r"(?<!\\)\|", r.strip())[1:-1]] for r in rows])
        else:
            k += 1
    return out


def _commands(text: str) -> list[str]:
    """Every esba command the page names in backticks."""
    return sorted(set(re.findall(r"`(esba [^`]+)`", text)))


def _source_patterns() -> list[re.Pattern]:
    """The string literals of the pages' and benchmarks' source, each as a pattern whose replacement
    fields ({...} of an f-string) match anything: what a renderer can write on one line."""
    import ast

    pats = []
    for path in sorted((ROOT / "esba" / "pages").glob("*.py")) + sorted((ROOT / "esba" / "bench").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.JoinedStr):
                parts = [re.escape(v.value) if isinstance(v, ast.Constant) else ".*" for v in node.values]
                pats.append("".join(parts))
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                pats.append(re.escape(node.value))
    return [re.compile(p, re.S) for p in pats if len(p) > 2]


def _unknown_words(command: str) -> list[str]:
    """The subcommands and flags of ``command`` (``esba bench solve --repeat 3 ...``) that esba's
    parser does not have (values and placeholders are not judged)."""
    parser: argparse.ArgumentParser = build_parser()
    unknown = []
    for word in shlex.split(command.replace("|", " "))[1:]:
        subs = next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        if word.startswith("-"):
            if word.split("=")[0] not in parser._option_string_actions:
                unknown.append(word)
        elif subs is not None and word in subs:
            parser = subs[word]
        elif subs is not None and not parser._option_string_actions.keys() - {"-h", "--help"}:
            unknown.append(word)  # a command group (esba bench) followed by no command of it
    return unknown


@pytest.fixture(scope="module")
def source_patterns():
    return _source_patterns()


@pytest.mark.parametrize("name", sorted(BENCHMARKS))
def test_a_benchmark_page_keeps_its_structure(name, source_patterns):
    text = (DOCS / BENCHMARKS[name]).read_text(encoding="utf-8")
    # its sections: headings the renderers write, none twice
    headings = re.findall(r"^#{1,4} .+$", text, re.M)
    assert headings and len(headings) == len(set(headings)), headings
    # its tables: every row has the header's columns, and the header is one a renderer writes
    tables = _tables(text)
    assert tables or "```" in text, f"docs/{BENCHMARKS[name]} has no table"
    for table in tables:
        assert all(len(row) == len(table[0]) for row in table), f"a row of the table '{' | '.join(table[0])}' has other columns"
    for line in headings + [next(ln for ln in text.splitlines() if ln.startswith("|") and [c.strip() for c in ln.strip().split("|")[1:-1]] == t[0]) for t in tables]:
        assert any(p.search(line) for p in source_patterns), f"docs/{BENCHMARKS[name]}: {line!r} is written by no renderer of esba.pages or esba.bench"
    # the commands it names are commands of this esba, with flags it has
    commands = _commands(text)
    assert commands, f"docs/{BENCHMARKS[name]} names no command"
    for command in commands:
        unknown = _unknown_words(command)
        assert not unknown, f"docs/{BENCHMARKS[name]} names `{command}`: esba has no {unknown}"
    if name in ENTRIES:
        assert ENTRIES[name].command.split(" --")[0].split("|")[0] in text
