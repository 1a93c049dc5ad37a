"""``mcl fmt`` as a user runs it (app/fmt.py): in place by default, ``--check`` and ``--diff``
for CI (exit 1 naming what would change, writing nothing), a directory for its missions, ``-``
for a filter, and invalid input exit 2 in one diagnostic with no file touched."""

from __future__ import annotations

import re
import subprocess
import tomllib
from pathlib import Path

import yaml

from mcl.formatter import format_text
from tests.support import BIN, MISSIONS, REPO, cli, subprocess_env, write

MESSY = "MISSION{GoTo((1,2,3,0 deg));Surface()}  // up\n"
TIDY = "MISSION {\n    GoTo((1, 2, 3, 0 deg));\n    Surface()\n}  // up\n"


def test_rewrites_in_place_and_then_has_nothing_to_do(tmp_path: Path) -> None:
    path = write(tmp_path, MESSY)
    path.chmod(0o640)
    proc = cli("mcl", "fmt", str(path))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == f"{path}: reformatted\n"
    assert path.read_text("utf-8") == TIDY == format_text(MESSY)
    assert path.stat().st_mode & 0o777 == 0o640
    again = cli("mcl", "fmt", str(path))
    assert (again.returncode, again.stdout) == (0, "")
    assert [p.name for p in tmp_path.iterdir()] == ["m.mcl"]  # no temporary file left


def test_check_names_the_file_and_writes_nothing(tmp_path: Path) -> None:
    messy, tidy = write(tmp_path, MESSY, "messy.mcl"), write(tmp_path, TIDY, "tidy.mcl")
    proc = cli("mcl", "fmt", "--check", str(messy), str(tidy))
    assert proc.returncode == 1
    assert proc.stdout == f"{messy}: would be reformatted (mcl fmt {messy})\n"
    assert messy.read_text("utf-8") == MESSY
    assert cli("mcl", "fmt", "--check", str(tidy)).returncode == 0


def test_diff_shows_the_change(tmp_path: Path) -> None:
    messy = write(tmp_path, MESSY)
    proc = cli("mcl", "fmt", "--diff", str(messy))
    assert proc.returncode == 1
    assert f"--- {messy}\n+++ {messy} (mcl fmt)\n" in proc.stdout
    assert "-MISSION{GoTo((1,2,3,0 deg));Surface()}  // up\n" in proc.stdout
    assert "+    GoTo((1, 2, 3, 0 deg));\n" in proc.stdout
    assert messy.read_text("utf-8") == MESSY


def test_a_directory_stands_for_its_missions(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    a = write(tmp_path, MESSY, "a.mcl")
    b = write(tmp_path / "sub", MESSY, "b.mcl")
    other = write(tmp_path, MESSY, "notes.txt")
    proc = cli("mcl", "fmt", "--check", str(tmp_path))
    assert proc.returncode == 1
    assert proc.stdout.splitlines() == [f"{a}: would be reformatted (mcl fmt {a})",
                                        f"{b}: would be reformatted (mcl fmt {b})"]
    assert other.read_text("utf-8") == MESSY


def test_a_filter_on_standard_input() -> None:
    proc = subprocess.run([str(BIN / "mcl"), "fmt", "-"], input=MESSY, capture_output=True,
                          text=True, env=subprocess_env(), cwd=REPO, timeout=60)
    assert (proc.returncode, proc.stdout) == (0, TIDY)


def test_invalid_input_is_exit_2_and_no_file_is_written(tmp_path: Path) -> None:
    messy = write(tmp_path, MESSY, "messy.mcl")
    broken = write(tmp_path, "MISSION { A(); }\n", "broken.mcl")
    proc = cli("mcl", "fmt", str(messy), str(broken))
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"{broken}:1:14: error: ';' before '}}'")
    assert "Traceback" not in proc.stderr
    assert messy.read_text("utf-8") == MESSY
    missing = cli("mcl", "fmt", str(tmp_path / "nothing.mcl"))
    assert missing.returncode == 2 and "no such file" in missing.stderr
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli("mcl", "fmt", str(empty)).returncode == 2


def test_the_shipped_missions_are_in_the_layout() -> None:
    proc = cli("mcl", "fmt", "--check", str(MISSIONS))
    assert (proc.returncode, proc.stdout) == (0, "")


LIBRARY = "behaviour Go drives x events done;\ntask Go() {ok:Go.done;\n}\n"
TIDY_LIBRARY = "behaviour Go  drives x  events done;\ntask Go() {\n    ok:      Go.done;\n}\n"


def test_task_libraries_in_place_check_diff_and_filter(tmp_path: Path) -> None:
    library = write(tmp_path, LIBRARY, "lib.tasks")
    proc = cli("mcl", "fmt", "--check", str(tmp_path))
    assert (proc.returncode, proc.stdout) == (1, f"{library}: would be reformatted "
                                                 f"(mcl fmt {library})\n")
    proc = cli("mcl", "fmt", "--diff", str(library))
    assert proc.returncode == 1 and "+    ok:      Go.done;\n" in proc.stdout
    assert library.read_text("utf-8") == LIBRARY
    proc = cli("mcl", "fmt", str(library))
    assert (proc.returncode, proc.stdout) == (0, f"{library}: reformatted\n")
    assert library.read_text("utf-8") == TIDY_LIBRARY
    filtered = subprocess.run([str(BIN / "mcl"), "fmt", "--stdin-filename", "lib.tasks", "-"],
                              input=LIBRARY, capture_output=True, text=True,
                              env=subprocess_env(), cwd=REPO, timeout=60)
    assert (filtered.returncode, filtered.stdout) == (0, TIDY_LIBRARY)


def test_a_library_that_does_not_parse_is_exit_2_and_nothing_written(tmp_path: Path) -> None:
    library = write(tmp_path, LIBRARY, "lib.tasks")
    broken = write(tmp_path, "task T( { }\n", "broken.tasks")
    proc = cli("mcl", "fmt", str(tmp_path))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith(f"{broken}:1:9: error: task library: unexpected '{{'")
    assert library.read_text("utf-8") == LIBRARY


def test_the_shipped_libraries_are_in_the_layout() -> None:
    proc = cli("mcl", "fmt", "--check", str(REPO / "mcl" / "tasks"), str(MISSIONS / "seabed.tasks"))
    assert (proc.returncode, proc.stdout) == (0, "")


def test_the_pre_commit_hooks_run_mcl_fmt() -> None:
    hooks = {h["id"]: h for h in yaml.safe_load((REPO / ".pre-commit-hooks.yaml").read_text())}
    assert hooks["mcl-fmt"]["entry"] == "mcl fmt"
    assert hooks["mcl-fmt-check"]["entry"] == "mcl fmt --check"
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    for hook in ("mcl-fmt", "mcl-fmt-check"):
        assert hooks[hook]["entry"].split()[0] in scripts
        assert re.search(hooks[hook]["files"], "missions/dam_inspection.mcl")
        assert re.search(hooks[hook]["files"], "missions/seabed.tasks")
