"""``esba example``: the README's example files, copied out of the package into the current folder."""

from __future__ import annotations

import json

from esba.cli import main
from esba.infra.examples import examples_dir


def test_example_lists_copies_and_keeps_files(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["example", "--json"]) == 0
    names = json.loads(capsys.readouterr().out)["examples"]
    assert {"table2.toml", "annotated.toml", "measurements/paper_exp.csv"} <= set(names)
    assert main(["example", "table2"]) == 0
    assert capsys.readouterr().out == "wrote examples/table2.toml\n"
    assert (tmp_path / "examples" / "table2.toml").read_bytes() == (examples_dir() / "table2.toml").read_bytes()
    assert main(["example", "--all"]) == 0
    out = capsys.readouterr().out
    assert "unchanged examples/table2.toml" in out and "wrote examples/measurements/paper_exp.csv" in out
    for name in names:
        assert (tmp_path / "examples" / name).read_bytes() == (examples_dir() / name).read_bytes()
    # the copy is what the README's commands read
    assert main(["solve", "examples/table2.toml", "--json", "--no-plot"]) == 0
    capsys.readouterr()


def test_example_refuses_to_replace_another_file_and_an_unknown_name(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mine = tmp_path / "examples" / "table2.toml"
    mine.parent.mkdir()
    mine.write_text("# my own scene\n")
    assert main(["example", "--all"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"esba: error: {mine.relative_to(tmp_path)} exists and is not esba's table2.toml: move it away, or give --out DIR\n"
    assert mine.read_text() == "# my own scene\n" and not (tmp_path / "examples" / "annotated.toml").exists()  # nothing copied
    assert main(["example", "table9"]) == 2
    assert "example 'table9': expected one of annotated.toml, " in capsys.readouterr().err
    assert main(["example", "table2", "--out", "elsewhere"]) == 0
    assert (tmp_path / "elsewhere" / "table2.toml").is_file()
