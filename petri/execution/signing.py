"""Signing run logs: an Ed25519 key of the player's signs every record as it is written, and
anyone holding only the public key can check it (docs/VEHICLES.md, "Run log").

Why a signature and not a keyed MAC: a MAC's verifier holds the very key that makes one, so
whoever can check a log can also forge it; with Ed25519 the player keeps the private key and
the public key is handed to whoever checks (``mcl replay --key``), who cannot sign with it.
The log's header records the public key it was signed with (``"key": "ed25519:HEX"``), so a
signed log can be checked on its own; ``--key`` then says whether that key is the one you
trust.

What is signed is a record's digest in the log's chain (``petri/execution/runlog.py``),
prefixed by :data:`CONTEXT`: the digest covers the record's bytes as written and, through the
chain, every line before it, so one signature per line authenticates the whole log up to that
line (a crash loses at most the line being written; a log cut short is still signed up to its
cut, and is refused for its missing end record).

Keys are PEM files, as ``openssl genpkey -algorithm ed25519 -out run.key`` and ``openssl pkey
-in run.key -pubout -out run.pub`` make them; each is read with a size limit, and only from
a regular file (a FIFO or a device such as ``/dev/zero`` is refused, not read).
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey

from diagnostics import MclError

ALGORITHM = "ed25519"
CONTEXT = b"mcl-run-log/3 record digest "  # what a signature is over: this, then the digest
MAX_KEY_BYTES = 16 * 1024  # a PEM key is a few hundred bytes


class BadKey(MclError):
    """A key file that cannot be used: says which and why, on one line (exit 2)."""

    def __init__(self, path: str | Path, option: str, reason: str) -> None:
        message = f"{path}: {option}: {reason}"
        super().__init__(message, hint="make a key with: openssl genpkey -algorithm ed25519 "
                         "-out run.key; its public key: openssl pkey -in run.key -pubout",
                         code="key", text=message)


def read_key_file(path: str | Path, option: str) -> bytes:
    """The bytes of a key file: a regular file of at most :data:`MAX_KEY_BYTES`, opened
    without following it into a FIFO or a device."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise BadKey(path, option, "no such file") from None
    except IsADirectoryError:
        raise BadKey(path, option, "is a directory, not a key") from None
    except OSError as exc:
        raise BadKey(path, option, f"cannot be read ({exc.strerror or exc})") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise BadKey(path, option, "not a regular file (a key is a PEM file)")
    with os.fdopen(fd, "rb") as f:
        data = f.read(MAX_KEY_BYTES + 1)
    if len(data) > MAX_KEY_BYTES:
        raise BadKey(path, option, f"larger than {MAX_KEY_BYTES // 1024} KiB: not a key")
    return data


@dataclass(frozen=True)
class Signer:
    """The player's signing key."""

    key: Ed25519PrivateKey

    @staticmethod
    def load(path: str | Path) -> Signer:
        """The Ed25519 private key in the PEM file ``path`` (``mcl run --log-key``)."""
        data = read_key_file(path, "--log-key")
        try:
            key = serialization.load_pem_private_key(data, password=None)
        except (ValueError, TypeError):
            raise BadKey(path, "--log-key", "not an unencrypted PEM private key") from None
        except Exception:  # noqa: BLE001 - cryptography's own errors for odd input
            raise BadKey(path, "--log-key", "not a PEM private key") from None
        if not isinstance(key, Ed25519PrivateKey):
            raise BadKey(path, "--log-key", "not an Ed25519 key")
        return Signer(key)

    @staticmethod
    def generate() -> Signer:
        return Signer(Ed25519PrivateKey.generate())

    def public(self) -> str:
        """The public key as the header records it: ``ed25519:HEX``."""
        return named(self.key.public_key())

    def sign(self, digest: str) -> str:
        """The signature (hex) of a record whose chain digest is ``digest``."""
        return self.key.sign(CONTEXT + digest.encode("ascii")).hex()


def named(key: Ed25519PublicKey) -> str:
    """A public key as a log's header records it."""
    raw = key.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    return f"{ALGORITHM}:{raw.hex()}"


def load_public(path: str | Path) -> str:
    """The public key in the PEM file ``path`` (``mcl replay --key``), as a header names it.
    A private key file is accepted too (its public half is used)."""
    data = read_key_file(path, "--key")
    try:
        if b"PRIVATE KEY" in data:
            private = serialization.load_pem_private_key(data, password=None)
            if not isinstance(private, Ed25519PrivateKey):
                raise BadKey(path, "--key", "not an Ed25519 key")
            return named(private.public_key())
        key = serialization.load_pem_public_key(data)
    except BadKey:
        raise
    except Exception:  # noqa: BLE001 - ValueError and cryptography's own for odd input
        raise BadKey(path, "--key", "not a PEM public key") from None
    if not isinstance(key, Ed25519PublicKey):
        raise BadKey(path, "--key", "not an Ed25519 key")
    return named(key)


def public_key(text: str) -> Ed25519PublicKey | None:
    """The key a header names (``ed25519:`` and 64 hex digits), or None if it names none."""
    algorithm, _, raw = text.partition(":")
    if algorithm != ALGORITHM or len(raw) != 64:
        return None
    try:
        return Ed25519PublicKey.from_public_bytes(bytes.fromhex(raw))
    except ValueError:
        return None


def signed(key: Ed25519PublicKey, digest: str, signature: str) -> bool:
    """Is ``signature`` (hex) the key's signature of the record with chain digest ``digest``?"""
    try:
        key.verify(bytes.fromhex(signature), CONTEXT + digest.encode("ascii"))
    except (InvalidSignature, ValueError):
        return False
    return True
