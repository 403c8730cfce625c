"""``.ci/run`` (CI's entry point) leaves nothing behind in the temporary folder, however it ends."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: A stand-in for ``python3``: ``python3 -m venv DIR`` makes a "virtual environment" whose python,
#: pip and pytest only leave files in the temporary folder (as the real ones do: about 840 MB).
FAKE_PYTHON3 = r"""#!/usr/bin/env bash
set -e
[ "$1 $2" = "-m venv" ] || exit 3
mkdir -p "$3/bin"
printf 'export PATH="%s/bin:$PATH"\n' "$3" > "$3/bin/activate"
for tool in python pip pytest; do
  printf '#!/usr/bin/env bash\nd="$(mktemp -d)"; head -c 4096 /dev/zero > "$d/junk"; echo "$ESBA_CACHE_DIR" > "$d/cache"; exit ${FAKE_EXIT:-0}\n' > "$3/bin/$tool"
  chmod +x "$3/bin/$tool"
done
"""


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
@pytest.mark.parametrize("exit_code", [0, 1, 5])  # 5: pytest collected no test, a failure too
def test_ci_run_removes_its_temporary_files(tmp_path, exit_code):
    checkout = tmp_path / "checkout"
    (checkout / ".ci").mkdir(parents=True)
    shutil.copy(ROOT / ".ci" / "run", checkout / ".ci" / "run")
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "python3").write_text(FAKE_PYTHON3)
    (fake / "python3").chmod(stat.S_IRWXU)
    temp = tmp_path / "tmp"
    temp.mkdir()
    env = dict(os.environ, PATH=f"{fake}:{os.environ['PATH']}", TMPDIR=str(temp), FAKE_EXIT=str(exit_code))
    proc = subprocess.run(["bash", str(checkout / ".ci" / "run")], env=env, capture_output=True, text=True, timeout=60)
    assert proc.returncode == exit_code, proc.stderr
    assert list(temp.iterdir()) == []  # the venv, the model cache and every tool's temporary files: gone


def test_ci_runs_the_readmes_test_command():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    command = next(line.strip() for line in readme.splitlines() if line.strip().startswith('pip install -e ".[test]" && pytest'))
    assert command in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
