"""Securing the Zenoh link: who may connect, and who may publish actions (docs/AAL.md, ZENOH_SECURITY.md).

Three roles share one link. The **vehicle** listens and holds the keys to the door: the list of
accepted users (a Zenoh ``dictionary_file`` of ``user:password`` lines) and/or the certificate
authority that signs every accepted certificate (mutual TLS). It also enforces Zenoh's access
control: only the **player**'s identity (``--player-user``, ``--player-cn``) may put actions;
**observers** (an operator's monitor) may only subscribe; anyone else is refused when the
session is opened, before any message flows.

- :class:`Security` holds this side's credentials and, on the vehicle, who may do what.
- :func:`for_role` makes and checks the Security of one role (``vehicle``, ``player``,
  ``observer``) from its settings (every mistake is a ValueError whose message says what to do;
  the commands' options for them: ``app/zenoh_options.py``).
- :func:`apply` writes them into a ``zenoh.Config`` (called by ``zenoh_config``);
  :func:`access_control` is the vehicle's ACL block (Zenoh 1.x ``access_control``).

Zenoh itself checks the password (an HMAC of it keyed with a nonce: the password never crosses
the link) and the certificates; this module only builds the configuration, and checks the
files first so that a mistake is one clear line rather than a failure deep in Zenoh.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from diagnostics import open_input

ROLES = ("vehicle", "player", "observer")
PASSWORD_ENV = "MCL_ZENOH_PASSWORD"
DEFAULT_PLAYER = "player"  # the user name / certificate common name allowed to put actions

# Key expressions of the access-control rules; ``*`` stands for any vehicle name (keys() in
# zenoh_link). A rule applies to a message whose key it includes (not to a wider key).
ACTION_KEYS = ["mcl/*/aal/action"]
STATUS_KEYS = ["mcl/*/mission/status"]
PLAYER_TOKEN_KEYS = ["mcl/*/alive/player/**"]  # mcl/<v>/alive/player/<run>
# A fleet vehicle's modem (vehicle_adapters/zenoh_modem.py): its player asks what a message
# it sends carries and tells it what was delivered.
MODEM_KEYS = ["mcl/*/modem/payload", "mcl/*/modem/heard"]
ALL_KEYS = ["mcl/**"]
# A fleet's channels (vehicle_adapters/zenoh_channels.py): mcl/fleet/<fleet>/channel/<channel>;
# on a vehicle, its player may put on the channels its vehicle sends on, and on no other.
CHANNEL_KEY = re.compile(r"mcl/fleet/[A-Za-z0-9_.-]{1,64}/channel/[A-Za-z0-9_.-]{1,64}")

@dataclass(frozen=True)
class Security:
    """One side's credentials; with nothing set, an open link (the default, as on a bench).

    ``user``/``password``: what a player or observer presents. ``users_file``/``users``: the
    vehicle's dictionary and the names in it. ``tls_*``: PEM files (the CA that signs every
    certificate, this side's certificate and private key). ``player_user``/``player_cn``: on
    the vehicle, the one identity allowed to put actions. ``channels``: on the vehicle of a
    fleet, the keys of the channels it sends on, where its player (and nobody else) may put.
    """

    user: str | None = None
    password: str | None = None
    users_file: Path | None = None
    users: tuple[str, ...] = ()
    player_user: str = DEFAULT_PLAYER
    tls_ca: Path | None = None
    tls_cert: Path | None = None
    tls_key: Path | None = None
    player_cn: str = DEFAULT_PLAYER
    channels: tuple[str, ...] = ()

    @property
    def usrpwd(self) -> bool:
        return bool(self.users_file or self.user)

    @property
    def tls(self) -> bool:
        return self.tls_ca is not None

    def __bool__(self) -> bool:
        return self.usrpwd or self.tls


# -- one role's settings ------------------------------------------------------------------------
def for_role(role: str, endpoint: str, *, user: str | None = None,
             password_file: str | None = None, users_file: str | None = None,
             player_user: str | None = None, player_cn: str | None = None,
             tls_ca: str | None = None, tls_cert: str | None = None,
             tls_key: str | None = None, channels: tuple[str, ...] = ()) -> Security:
    """The Security of ``role`` on ``endpoint`` these settings describe, every file read and
    checked; raises ValueError with a clear message (naming the command-line option).
    ``channels``: the vehicle's, the keys of the fleet channels its player may put on."""
    _check_role(role)
    for channel in channels:
        if role != "vehicle" or not CHANNEL_KEY.fullmatch(channel):
            raise ValueError(f"{channel!r}: not a fleet channel a vehicle's player may put on "
                             "(mcl/fleet/FLEET/channel/CHANNEL, on the vehicle)")
    tls = _tls_files(tls_ca, tls_cert, tls_key)
    if endpoint.startswith("tls/") and not tls:
        raise ValueError(f"{endpoint}: a TLS endpoint: give --tls-ca, --tls-cert and "
                         "--tls-key (see docs/ZENOH_SECURITY.md)")
    if tls and not endpoint.startswith("tls/"):
        raise ValueError(f"{endpoint}: not a TLS endpoint: --tls-* options need a "
                         "tls/HOST:PORT endpoint (the certificates would not be used)")
    ca, cert, key = tls or (None, None, None)
    if cert is not None:
        common_names("--tls-cert", cert)
    if role == "vehicle":
        player_user = _name(player_user or DEFAULT_PLAYER, "--player-user")
        player_cn = _name(player_cn or DEFAULT_PLAYER, "--player-cn")
        users: tuple[str, ...] = ()
        if users_file:
            users = read_users(users_file)
            if player_user not in users:
                raise ValueError(f"{users_file}: no user {player_user!r}: add a line "
                                 f"'{player_user}:PASSWORD' or name the player with "
                                 "--player-user")
        users_path = Path(users_file).resolve() if users_file else None
        return Security(users_file=users_path, users=users,
                        player_user=player_user, tls_ca=ca, tls_cert=cert, tls_key=key,
                        player_cn=player_cn, channels=tuple(channels))
    password = None
    if user is not None:
        user = _name(user, "--user")
        if password_file:
            password = read_password(password_file)
        elif os.environ.get(PASSWORD_ENV):
            password = env_password(os.environ[PASSWORD_ENV])
        else:
            raise ValueError(f"--user {user} needs a password: --password-file FILE or "
                             f"the environment variable {PASSWORD_ENV}")
    elif password_file:
        raise ValueError("--password-file needs --user NAME")
    return Security(user=user, password=password, tls_ca=ca, tls_cert=cert, tls_key=key)


def _check_role(role: str) -> None:
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}: use one of {', '.join(ROLES)}")


def _name(name: str, option: str) -> str:
    if not name or name != name.strip() or ":" in name:
        raise ValueError(f"{option} {name!r}: a name must be non-empty, without ':' and "
                         "without spaces at its ends")
    return name


def _tls_files(ca: str | None, cert: str | None, key: str | None
               ) -> tuple[Path, Path, Path] | None:
    """The three PEM files, all checked, or None if no --tls-* option was given."""
    given = {"tls-ca": ca, "tls-cert": cert, "tls-key": key}
    if not any(given.values()):
        return None
    missing = [f"--{o}" for o, v in given.items() if not v]
    if missing:
        first = next(f"--{o} {v}" for o, v in given.items() if v)
        raise ValueError(f"{first}: mutual TLS needs --tls-ca, --tls-cert and --tls-key: "
                         f"{' and '.join(missing)} missing")
    ca_pem, cert_pem, key_pem = (_pem(f"--{o}", str(v)) for o, v in given.items())
    return ca_pem, cert_pem, key_pem


def common_names(option: str, path: Path) -> tuple[str, ...]:
    """The common names of the certificate in ``path`` (none or one); ValueError if it has
    more than one, or is not a certificate.

    Zenoh's access control matches a peer's certificate on the *first* CN of its subject:
    one issued as ``/CN=player/CN=operator`` acts as the player though a reader of its
    subject may take it for an operator's (and ``/CN=operator/CN=player`` the other way
    round). Matching all CNs is not ours to do (Zenoh does the matching, on the vehicle), so
    a certificate with more than one CN is refused wherever a command reads one: one CN, one
    identity (docs/ZENOH_SECURITY.md)."""
    from cryptography import x509  # lazy: start-up speed (only with --tls-*)
    from cryptography.x509.oid import NameOID

    try:
        cert = x509.load_pem_x509_certificate(path.read_bytes()[:MAX_FILE_BYTES])
    except (ValueError, OSError) as exc:
        raise ValueError(f"{option} {path}: not a PEM certificate ({exc})") from None
    names = tuple(str(a.value) for a in cert.subject.get_attributes_for_oid(
        NameOID.COMMON_NAME))
    if len(names) > 1:
        raise ValueError(f"{option} {path}: a certificate with {len(names)} common names "
                         f"({', '.join(repr(n) for n in names)}): Zenoh's access control "
                         "matches only the first, so its identity is ambiguous; issue it "
                         "with one CN")
    return names


MAX_FILE_BYTES = 1 << 20  # a PEM file, a password, a user list: far less than 1 MiB


def read_small(option: str, name: str, encoding: str = "utf-8", errors: str = "strict") -> str:
    """The text of the file ``name`` given to ``option``, read with a size limit
    (``--users /dev/zero`` is refused, not read for ever); OSError, UnicodeDecodeError or a
    ValueError naming the option."""
    with open_input(name) as f:  # a named pipe nobody writes to: refused within 5 s
        data = f.read(MAX_FILE_BYTES + 1)
    if len(data) > MAX_FILE_BYTES:
        raise ValueError(f"{option} {name}: larger than {MAX_FILE_BYTES:,} bytes: not what "
                         f"{option} takes")
    return data.decode(encoding, errors)


def _pem(option: str, name: str) -> Path:
    path = Path(name)
    try:
        text = read_small(option, name, "ascii", errors="replace")
    except OSError as exc:
        raise ValueError(f"{option} {name}: cannot read it ({exc.strerror})") from None
    if "-----BEGIN " not in text:
        raise ValueError(f"{option} {name}: not a PEM file (no '-----BEGIN' line)")
    return path.resolve()


# -- files ----------------------------------------------------------------------------------------
def read_password(name: str) -> str:
    """The password on the first line of ``name`` (spaces at its ends removed, as Zenoh does)."""
    try:
        lines = read_small("--password-file", name).splitlines()
    except OSError as exc:
        raise ValueError(f"--password-file {name}: cannot read it ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ValueError(f"--password-file {name}: not UTF-8 text") from None
    password = lines[0].strip() if lines else ""
    if not password:
        raise ValueError(f"--password-file {name}: empty; put the password on its first line")
    return password


def env_password(text: str) -> str:
    """The password in ``$MCL_ZENOH_PASSWORD``, checked as a password file's first line is:
    UTF-8 text (Python holds bytes that are not as surrogates, which Zenoh refuses with a
    traceback), one line, at most :data:`MAX_FILE_BYTES`; ValueError naming the variable."""
    where = f"${PASSWORD_ENV}"
    try:
        size = len(text.encode("utf-8"))
    except UnicodeEncodeError:
        raise ValueError(f"{where}: not UTF-8 text") from None
    if size > MAX_FILE_BYTES:
        raise ValueError(f"{where}: longer than {MAX_FILE_BYTES:,} bytes: not a password")
    if any(c in text for c in "\r\n\x00"):
        raise ValueError(f"{where}: more than one line: give the password alone")
    if not text.strip():
        raise ValueError(f"{where}: only spaces: give the password")
    return text.strip()


def read_users(name: str) -> tuple[str, ...]:
    """The user names in a Zenoh user-password dictionary, checked line by line.

    Zenoh reads ``user:password`` a line (split at the first ':', spaces at the ends removed,
    blank lines skipped) and has no comments; a mistake is reported as ``file:line: ...``.
    """
    try:
        text = read_small("--users", name)
    except OSError as exc:
        raise ValueError(f"--users {name}: cannot read it ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ValueError(f"--users {name}: not UTF-8 text") from None
    users: list[str] = []
    for number, line in enumerate(text.splitlines(), 1):
        where = f"{name}:{number}"
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            raise ValueError(f"{where}: comments are not allowed (Zenoh reads every line "
                             "as user:password)")
        user, colon, password = line.partition(":")
        user = user.strip()
        if not colon:
            raise ValueError(f"{where}: expected 'user:password', found no ':'")
        if not user:
            raise ValueError(f"{where}: empty user name before ':'")
        if not password.strip():
            raise ValueError(f"{where}: empty password for user {user!r}")
        if user in users:
            raise ValueError(f"{where}: user {user!r} appears twice")
        users.append(user)
    if not users:
        raise ValueError(f"--users {name}: no users; write one 'user:password' a line")
    return tuple(users)


# -- the Zenoh configuration ----------------------------------------------------------------------
def apply(config: Any, security: Security, role: str) -> None:
    """Write ``security`` into the zenoh.Config ``config`` for ``role``."""
    _check_role(role)

    def put(key: str, value: object) -> None:
        config.insert_json5(key, json.dumps(value))

    if role == "vehicle":
        if security.users_file is not None:
            put("transport/auth/usrpwd/dictionary_file", str(security.users_file))
    elif security.user is not None:
        put("transport/auth/usrpwd/user", security.user)
        put("transport/auth/usrpwd/password", security.password or "")
    if security.tls:
        side = "listen" if role == "vehicle" else "connect"
        put("transport/link/tls/root_ca_certificate", str(security.tls_ca))
        put(f"transport/link/tls/{side}_certificate", str(security.tls_cert))
        put(f"transport/link/tls/{side}_private_key", str(security.tls_key))
        put("transport/link/tls/enable_mtls", True)
        if role == "vehicle":  # TLS only: no plain tcp/ beside it
            put("transport/link/protocols", ["tls"])
    if role == "vehicle" and security:
        put("access_control", access_control(security))


def access_control(security: Security) -> dict[str, Any]:
    """The vehicle's ACL: deny by default; the player puts actions; everyone admitted reads.

    Subjects: ``player`` is the one identity allowed to put (its user name and/or certificate
    common name: both must match when both are configured); ``readers`` is every admitted
    peer (every user in the dictionary, or with TLS alone every certificate the CA signed:
    the others never get a session). Flows: ``ingress`` rules say what a peer may send the
    vehicle (the player: actions, status, its token, answers to status queries; readers:
    subscriptions, liveliness subscriptions, status queries); the ``egress`` rule lets the
    vehicle's own publications, token and declarations out, and what it routes between the
    player and a monitor connected as a client (status, queries and replies). In a fleet, the
    player also puts on the channels its vehicle sends on (``channels``), which the vehicle
    routes to the receivers' carriers, its clients (vehicle_adapters/zenoh_channels.py), and
    asks and tells its vehicle's modem (``MODEM_KEYS``).
    """
    player: dict[str, Any] = {"id": "player"}
    readers: dict[str, Any] = {"id": "readers"}
    if security.users_file is not None:
        player["usernames"] = [security.player_user]
        readers["usernames"] = list(security.users)
    if security.tls:
        player["cert_common_names"] = [security.player_cn]
    rules = [
        _rule("player puts actions and status", "ingress", ["put"],
              ACTION_KEYS + STATUS_KEYS),
        _rule("player answers status queries", "ingress", ["declare_queryable", "reply"],
              STATUS_KEYS),
        _rule("player's token", "ingress", ["liveliness_token"], PLAYER_TOKEN_KEYS),
        _rule("player asks and tells its modem", "ingress", ["query"], MODEM_KEYS),
        *([_rule("player puts on its channels", "ingress", ["put"], list(security.channels))]
          if security.channels else []),
        _rule("readers subscribe", "ingress",
              ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"],
              ALL_KEYS),
        _rule("readers ask the status", "ingress", ["query"], STATUS_KEYS),
        _rule("vehicle publishes and forwards", "egress",
              ["put", "declare_subscriber", "declare_queryable", "query", "reply",
               "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
              ALL_KEYS),
    ]
    mine = 5 if security.channels else 4  # the player's rules come first
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [player, readers],
        "policies": [
            {"id": "player", "rules": [r["id"] for r in rules[:mine]], "subjects": ["player"]},
            {"id": "readers", "rules": [r["id"] for r in rules[mine:]], "subjects": ["readers"]},
        ],
    }


def _rule(rule_id: str, flow: str, messages: list[str], keys: list[str]) -> dict[str, Any]:
    return {"id": rule_id, "permission": "allow", "flows": [flow], "messages": messages,
            "key_exprs": keys}
