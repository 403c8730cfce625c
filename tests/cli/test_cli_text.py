"""What the command line says: help texts, one wording for one error, no Python reprs."""

from __future__ import annotations

import argparse

import pytest

from esba.cli import build_parser, main


def _subparsers(parser: argparse.ArgumentParser, prefix: str = "esba"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield f"{prefix} {name}", sub
                yield from _subparsers(sub, f"{prefix} {name}")


COMMANDS = dict(_subparsers(build_parser()))


@pytest.mark.parametrize("command", sorted(c for c, p in COMMANDS.items() if any("--json" in a.option_strings for a in p._actions)))
def test_every_json_flag_says_what_it_does(command):
    (flag,) = [a for a in COMMANDS[command]._actions if "--json" in a.option_strings]
    assert flag.help and "JSON" in flag.help


def test_validate_and_experiments_check_take_the_same_arguments():
    """``--check`` alone checks the default page, ``--check FILE`` that file, for both commands."""
    for command in ("validate", "experiments"):
        check = next(a for a in COMMANDS[f"esba {command}"]._actions if "--check" in a.option_strings)
        assert check.nargs == "?" and check.const is True and check.metavar == "FILE", command


@pytest.mark.parametrize("command", ["experiments", "path", "design"])
@pytest.mark.parametrize("page, needle", [("nope/x.md", "--write-doc 'nope/x.md': the folder 'nope' does not exist (create it first)"),
                                          ("x.txt", "--write-doc 'x.txt': '.txt'; expected a file ending in .md")])
def test_one_wording_of_the_write_doc_error(capsys, tmp_path, monkeypatch, command, page, needle):
    monkeypatch.chdir(tmp_path)
    assert main([command, "--write-doc", page]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"esba: error: {needle}\n"
    assert not (tmp_path / "x.txt").exists()
