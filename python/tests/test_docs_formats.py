"""Every command of docs/formats-energyplus-solvers.md runs as written (from a scratch folder,
the repository's test data found where the page says)."""

import re
import shlex

from conftest import SOURCE_DIR, run_cli


def test_every_command_of_the_formats_page_runs(tmp_path, monkeypatch):
    text = (SOURCE_DIR / "docs" / "formats-energyplus-solvers.md").read_text()
    commands = [line for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S)
                for line in block.splitlines() if line.startswith("formfactor ")]
    assert len(commands) >= 8
    monkeypatch.chdir(tmp_path)
    for command in commands:
        args = [str(SOURCE_DIR / a) if a.startswith("tests/data/") else a
                for a in shlex.split(command)[1:]]
        run_cli(*args)
    assert (tmp_path / "view_factors.idf").read_text().count("!- View Factor") == 49
