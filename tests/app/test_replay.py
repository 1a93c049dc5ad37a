"""Run logs as evidence against a forger (issue 22, deliverables 1 and 2): each forgery the
issue reports as accepted by ``mcl replay``, made as its report says, with the chain
recomputed by its public rule.

- signed with the player's key (``run_mission(signer=...)``, ``mcl run --log-key``), every
  forgery is refused by ``mcl replay --key PUBLIC.pem``, whether the forger drops the
  signatures, keeps them, or signs with a key of their own;
- unsigned, the replay still refuses what the log's meaning betrays (a duplicate key, an
  unknown record kind, a line not written as the run writes it, an ignored alarm that a CATCH
  waited for, a log cut short with an appended ``ok`` end record, a clock that does not add
  up) and says of the rest that the log is "not signed: detects accidents, not forgery";
- hostile input is refused at its line, exit 2, on one line: 5,000-digit integers, ``t =
  1e400``, a line past the 1 MiB limit (not read whole), a 1 GiB file; a header naming
  ``/etc/shadow``-like files or a FIFO as task libraries reads nothing before the chain and
  the signatures hold, and quotes no file.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from cryptography.hazmat.primitives import serialization

from app import mcl
from mcl.api import compile_file
from mission import run_mission
from petri.execution.runlog import GENESIS, canonical
from petri.execution.signing import Signer
from tests.support import MISSIONS, REPO, subprocess_env
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"
LEAK = MISSIONS / "vehicles" / "dam_leak.toml"
Records = list[dict[str, Any]]


def write_key(signer: Signer, folder: Path, name: str) -> tuple[Path, Path]:
    """The key as PEM files: the private key and its public key."""
    private, public = folder / f"{name}.key", folder / f"{name}.pub"
    private.write_bytes(signer.key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption()))
    public.write_bytes(signer.key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo))
    return private, public


@pytest.fixture(scope="module")
def signed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A genuine signed run of the dam mission on the leaking scripted vehicle, as
    ``mcl run`` makes it (header fields, end record), and the key's files."""
    folder = tmp_path_factory.mktemp("signed")
    signer = Signer.generate()
    _, public = write_key(signer, folder, "run")
    log = folder / "run.jsonl"
    result = run_mission(compile_file(str(DAM), require_values=True),
                         InProcess(ScriptedVehicle(load_script(str(LEAK)))), log=log,
                         header={"file": str(DAM), "params": {}, "tasks": [],
                                 "vehicle": f"script:{LEAK}", "seed": 1, "inject": []},
                         signer=signer, verify=False)
    assert result.status == "ok" and result.handled, result
    return {"log": log, "public": public, "folder": folder}


def records_of(path: Path) -> Records:
    return [json.loads(line) for line in path.read_text("ascii").splitlines()]


def write_forged(path: Path, records: Records, how: str = "unsigned",
                 key: Signer | None = None) -> Path:
    """Write ``records`` with their chain recomputed by its public rule; ``how``:
    ``unsigned`` (no signatures, the header's key null), ``kept`` (the old signatures left
    in place) or ``resigned`` (signed with the forger's own ``key``, named in the header)."""
    previous, lines = GENESIS, []
    for r in records:
        r = {k: v for k, v in r.items() if k not in ("digest", "sig")}
        old = r.pop("_sig", None)
        if r["kind"] == "header":
            r["key"] = key.public() if how == "resigned" and key else (
                None if how == "unsigned" else r["key"])
        previous = hashlib.sha256((previous + canonical(r)).encode()).hexdigest()
        r["digest"] = previous
        if how == "kept" and old is not None:
            r["sig"] = old
        elif how == "resigned" and key is not None:
            r["sig"] = key.sign(previous)
        lines.append(json.dumps(r, separators=(",", ":")) + "\n")
    path.write_text("".join(lines), "ascii")
    return path


def keep_sigs(records: Records) -> Records:
    return [{**r, "_sig": r.get("sig")} for r in records]


def replay(capsys: pytest.CaptureFixture[str], log: Path, *more: str) -> tuple[int, str]:
    code = mcl.main(["replay", str(log), str(DAM), *more])
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def first(records: Records, **match: Any) -> int:
    return next(i for i, r in enumerate(records) if all(r.get(k) == v for k, v in match.items()))


# -- the forgeries of the issue -----------------------------------------------------------
def scaled(records: Records) -> Records:
    """Every time scaled by 0.1."""
    return [{**r, "t": round(r["t"] * 0.1, 6)} if "t" in r else r for r in records]


def header_edited(records: Records) -> Records:
    """The header's vehicle, seed and faults changed."""
    return [{**records[0], "vehicle": "sim", "seed": 7, "inject": ["leak@600"]}, *records[1:]]


def data_edited(records: Records) -> Records:
    i = first(records, kind="event", event="Alarms.leak")
    return [*records[:i], {**records[i], "data": {"depth": 3.5}}, *records[i + 1:]]


def invented_kind(records: Records) -> Records:
    i = first(records, kind="event")
    return [*records[:i], {"t": records[i]["t"], "kind": "override", "by": "operator"},
            *records[i:]]


def fake_ignored_leak(records: Records) -> Records:
    """An 'ignored Alarms.leak' inserted while the CATCH waits for it (after the survey
    started)."""
    i = first(records, kind="event", event="WallInspection.done") \
        if any(r.get("event") == "WallInspection.done" for r in records) \
        else first(records, kind="event", event="Alarms.leak")
    return [*records[:i], {"t": records[i - 1]["t"], "kind": "ignored",
                           "event": "Alarms.leak", "reason": "nobody waits for it"},
            *records[i:]]


def cut_with_ok_end(records: Records) -> Records:
    """Cut at record 30, with an end record claiming all went well."""
    return [*records[:30], {"t": records[29]["t"], "kind": "end", "how": "ok",
                            "why": "the mission ended OK", "exit": 0, "status": "ok",
                            "switched_off": [],
                            "confirmed": "confirmed: the vehicle has no behaviour on"}]


FORGERIES: dict[str, Callable[[Records], Records]] = {
    "times scaled by 0.1": scaled, "header vehicle, seed, faults": header_edited,
    "event data edited": data_edited, "an invented record kind": invented_kind,
    "a fake ignored Alarms.leak": fake_ignored_leak,
    "cut at record 30 with an ok end record": cut_with_ok_end,
}
# what the replay refuses by the log's meaning alone, without a signature
BETRAYED = {"an invented record kind", "a fake ignored Alarms.leak",
            "cut at record 30 with an ok end record", "times scaled by 0.1"}


def test_the_genuine_signed_log_conforms_with_its_key(
        signed: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    code, out = replay(capsys, signed["log"], "--key", str(signed["public"]))
    assert code == 0, out
    assert "conforms" in out and "signed by the key given" in out, out
    records = records_of(signed["log"])
    assert records[0]["key"].startswith("ed25519:")
    assert all(len(r["sig"]) == 128 for r in records)
    assert records[-1]["handled"] and "vehicle_t0" in records[-1]
    assert all("vt" in r for r in records if r["kind"] == "event")


@pytest.mark.parametrize("forgery", sorted(FORGERIES))
@pytest.mark.parametrize("how", ["unsigned", "kept", "resigned"])
def test_a_forged_log_is_refused_with_the_key(
        forgery: str, how: str, signed: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records = FORGERIES[forgery](keep_sigs(records_of(signed["log"])))
    log = write_forged(tmp_path / "forged.jsonl", records, how, Signer.generate())
    code, out = replay(capsys, log, "--key", str(signed["public"]))
    assert code in (1, 2), out
    assert out.startswith(f"{log}:") and out.count("\n") == 1, out
    assert "conforms" not in out and "Traceback" not in out


@pytest.mark.parametrize("forgery", sorted(FORGERIES))
def test_an_unsigned_forgery_is_refused_by_its_meaning_or_said_to_be_unsigned(
        forgery: str, signed: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records = FORGERIES[forgery](records_of(signed["log"]))
    log = write_forged(tmp_path / "forged.jsonl", records, "unsigned")
    code, out = replay(capsys, log)
    if forgery in BETRAYED:
        assert code in (1, 2) and "conforms" not in out, out
    else:  # only a signature can tell: the replay says the log proves nothing more
        assert code == 0, out
        assert "chain intact, not signed: detects accidents, not forgery" in out, out


def test_the_cut_log_with_an_ok_end_record_is_refused_at_the_end_record(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = cut_with_ok_end(records_of(signed["log"]))
    log = write_forged(tmp_path / "cut.jsonl", records)
    code, out = replay(capsys, log)
    assert code == 1 and f"{log}:31: not conformant" in out, out
    assert "running" in out or "still on" in out, out


def test_a_fake_ignored_leak_is_refused_naming_who_waits(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = fake_ignored_leak(records_of(signed["log"]))
    line = first(records, kind="ignored", event="Alarms.leak") + 1
    log = write_forged(tmp_path / "ignored.jsonl", records)
    code, out = replay(capsys, log)
    assert code == 1 and f"{log}:{line}: not conformant" in out and "waits for it" in out, out


def test_an_event_raised_after_its_delivery_is_refused(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    records = records_of(signed["log"])
    i = first(records, kind="event", event="Alarms.leak")
    records[i] = {**records[i], "vt": records[i]["vt"] + 50.0}
    log = write_forged(tmp_path / "late.jsonl", records)
    code, out = replay(capsys, log)
    assert code == 1 and f"{log}:{i + 1}: not conformant" in out and "raised" in out, out


@pytest.mark.parametrize("field, value", [("exit", 4), ("status", "fail"),
                                          ("switched_off", ["StartLogs"]),
                                          ("handled", []), ("limit", 10.0)])
def test_an_end_record_claim_that_the_log_does_not_show_is_refused(
        field: str, value: Any, signed: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records = records_of(signed["log"])
    records[-1] = {**records[-1], field: value}
    log = write_forged(tmp_path / "end.jsonl", records)
    code, out = replay(capsys, log)
    assert code == 1 and f"{log}:{len(records)}: not conformant" in out, out


@pytest.mark.parametrize("field, value", [("seed", -1), ("inject", ["leak@1e400"]),
                                          ("max_time", 0), ("operator", "me"),
                                          ("tasks", "x.tasks")])
def test_a_header_field_out_of_its_range_is_refused(
        field: str, value: Any, signed: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records = records_of(signed["log"])
    records[0] = {**records[0], field: value}
    log = write_forged(tmp_path / "header.jsonl", records)
    code, out = replay(capsys, log)
    assert code in (1, 2) and f"{log}:1:" in out and "conforms" not in out, out


# -- lines the replay will not interpret: exit 2, at their line ----------------------------
def raw_lines(signed: dict[str, Path]) -> list[str]:
    return signed["log"].read_text("ascii").splitlines(keepends=True)


LINE_EDITS: dict[str, Callable[[str], str]] = {
    "a duplicate key": lambda line: line.replace('"event":"Alarms.leak"',
                                                 '"event":"Alarms.leak","event":"GoTo.reached"'),
    "spaces": lambda line: line.replace(',"', ', "'),
    "a 5,000-digit integer": lambda line: line.replace('"t":', '"t":' + "9" * 5000 + ',"x":'),
    "t = 1e400": lambda line: line.replace('"t":', '"t":1e400,"x":'),
    "NaN": lambda line: line.replace('"t":', '"t":NaN,"x":'),
    "a byte not ASCII": lambda line: line.replace("Alarms", "Alärms"),
}


@pytest.mark.parametrize("edit", sorted(LINE_EDITS))
def test_a_line_not_written_as_the_run_writes_is_refused_at_its_line(
        edit: str, signed: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    lines = raw_lines(signed)
    i = next(i for i, line in enumerate(lines) if '"event":"Alarms.leak"' in line)
    lines[i] = LINE_EDITS[edit](lines[i])
    log = tmp_path / "odd.jsonl"
    log.write_bytes("".join(lines).encode("utf-8"))
    code, out = replay(capsys, log)
    assert code == 2, out
    assert out.startswith(f"{log}:{i + 1}: error: ") and out.count("\n") == 1, out


def test_a_line_past_the_limit_is_refused_without_reading_it_whole(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = raw_lines(signed)
    log = tmp_path / "long.jsonl"
    log.write_text(lines[0] + '{"t":0,"kind":"note","note":"' + "x" * (2 * 2**20) + '"}\n',
                   "ascii")
    code, out = replay(capsys, log)
    assert code == 2 and out.startswith(f"{log}:2: error: a line longer than 1024 KiB"), out


def test_a_1_gib_log_is_refused_by_its_size_within_little_memory(
        signed: dict[str, Path], tmp_path: Path) -> None:
    log = tmp_path / "huge.jsonl"
    with open(log, "wb") as f:  # sparse: one header line, then 1 GiB of one line
        f.write(raw_lines(signed)[0].encode())
        f.truncate(2**30)
    # the peak of this process alone: a child forked from a large pytest may inherit its
    # high-water mark, so the probe resets it first (Linux: "5" to clear_refs), then reads it
    probe = ("import re, sys; open('/proc/self/clear_refs', 'w').write('5'); "
             "from app import mcl; code = mcl.main(['replay', "
             f"{str(log)!r}, {str(DAM)!r}]); print(re.search(r'VmHWM:\\s+(\\d+)', "
             "open('/proc/self/status').read())[1], file=sys.stderr); sys.exit(code)")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, cwd=REPO, env=subprocess_env())
    assert done.returncode == 2, done.stderr
    assert "larger than 256 MiB" in done.stderr and "Traceback" not in done.stderr
    assert int(done.stderr.splitlines()[-1]) < 400_000, done.stderr  # KiB: far from 1 GiB


# -- what the header names is not read before the chain holds, and never quoted -----------
SECRET = "TOP SECRET: the first line of a file the replay was not asked to read"


def test_a_header_naming_a_private_file_reads_and_quotes_nothing(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shadow = tmp_path / "shadow"
    shadow.write_text(SECRET + "\n", "ascii")
    secret_tasks = tmp_path / "secret.tasks"
    secret_tasks.write_text(SECRET + "\n", "ascii")
    for named in (str(shadow), str(secret_tasks), "/etc/shadow"):
        records = records_of(signed["log"])
        records[0] = {**records[0], "tasks": [named]}
        for how in ("kept", "unsigned"):  # the chain broken by the edit, or recomputed
            lines = keep_sigs(records) if how == "kept" else records
            log = write_forged(tmp_path / "named.jsonl", lines, how)
            code, out = replay(capsys, log, "--key", str(signed["public"]))
            assert code in (1, 2) and f"{log}:1:" in out, out
            assert SECRET not in out and "root:" not in out, out
            code, out = replay(capsys, log)  # without --key: an unsigned log's chain holds
            assert code in (1, 2) and SECRET not in out and "root:" not in out, out


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs")
def test_a_fifo_named_by_the_header_or_given_as_the_log_does_not_hang(
        signed: dict[str, Path], tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.tasks"
    os.mkfifo(fifo)
    records = records_of(signed["log"])
    records[0] = {**records[0], "tasks": [str(fifo)]}
    unsigned = write_forged(tmp_path / "fifo.jsonl", records, "unsigned")
    broken = write_forged(tmp_path / "broken.jsonl", keep_sigs(records), "kept")
    for log, more in ((unsigned, []), (broken, ["--key", str(signed["public"])]),
                      (fifo, [])):
        done = subprocess.run([sys.executable, "-m", "app.mcl", "replay", str(log), str(DAM),
                               *more], capture_output=True, text=True, timeout=60, cwd=REPO,
                              env=subprocess_env())
        said = done.stdout + done.stderr
        assert done.returncode in (1, 2) and said.count("\n") <= 2, said
        assert "Traceback" not in said


def test_bad_key_files_are_one_line_and_exit_2(
        signed: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "junk.pem").write_text("-----BEGIN PUBLIC KEY-----\nxx\n", "ascii")
    for key in ("/dev/zero", str(tmp_path), str(tmp_path / "none.pem"),
                str(tmp_path / "junk.pem")):
        code, out = replay(capsys, signed["log"], "--key", key)
        assert code == 2 and "--key" in out and "Traceback" not in out, (key, out)
    done = subprocess.run([sys.executable, "-m", "app.mcl", "run", str(DAM), "--vehicle",
                           f"script:{LEAK}", "--log", str(tmp_path / "r.jsonl"),
                           "--log-key", "/dev/zero"], capture_output=True, text=True,
                          timeout=120, cwd=REPO, env=subprocess_env())
    assert done.returncode == 2 and "--log-key: not a regular file" in done.stderr, done.stderr
    assert not (tmp_path / "r.jsonl").exists()


def test_replay_help_names_the_option_that_signs_a_log(capsys: pytest.CaptureFixture[str]) -> None:
    # --key pairs with mcl run's --log-key (the run log's key); --signing-key is MAVLink's
    with pytest.raises(SystemExit):
        mcl.main(["replay", "--help"])
    replay_help = " ".join(capsys.readouterr().out.split())
    with pytest.raises(SystemExit):
        mcl.main(["run", "--help"])
    run_help = " ".join(capsys.readouterr().out.split())
    named = replay_help.split("the Ed25519 public key the run's ", 1)[1].split()[0]
    assert named == "--log-key", replay_help
    assert f"{named} FILE sign every line of the run log" in run_help, run_help
