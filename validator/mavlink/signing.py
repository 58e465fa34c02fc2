"""MAVLink 2 message signing: the key file, a link that signs everything it sends and refuses
everything it receives that is not signed with the same key, and why a signed link heard nothing.

**The key file** holds one line: a passphrase of printable ASCII without spaces (at most
``MAX_PASSPHRASE_CHARS``), and the 32-byte secret key is its SHA-256 digest. That is what
MAVProxy's ``signing setup PASSPHRASE`` sends to the autopilot (SETUP_SIGNING) and
``signing key PASSPHRASE`` uses on its own link, so the vehicle is given the key by MAVProxy
(over USB, where ArduPilot accepts SETUP_SIGNING) and this tool is given the same passphrase:
no raw key is copied between tools, and one secret works in both. A raw 64-hex-digit key was
the alternative; it would need a second tool to put it on the vehicle. Keep the file private
and the passphrase long and random (``openssl rand -base64 24``): one captured packet lets an
attacker test guesses offline.

**The wire format** is pymavlink's (the MAVLink 2 standard): the packet's incompat flag 0x01,
then link id (1 byte), a 48-bit timestamp (10 µs units since 2015-01-01, increasing per
stream) and the first 6 bytes of SHA-256(key + packet). :func:`sign_and_verify` sets a
pymavlink ``MAVLink`` object's signing state as ``mavutil``'s ``setup_signing`` does for a
connection, with an ``allow_unsigned_callback`` that allows nothing: the parser then turns
every unsigned packet, every packet signed with another key and every replayed one (timestamp
not newer than the last of its stream, or a new stream over a minute behind our clock) into
BAD_DATA ("Invalid signature"), which no handler processes. :class:`RefusedTraffic` counts
those by sender so that a link that hears no vehicle can say why.
"""

from __future__ import annotations

import hashlib
import os
import stat
import time
from collections import Counter
from pathlib import Path
from typing import Any

from validator.errors import InputError
from validator.input_files import read_text

MAX_PASSPHRASE_CHARS = 256
KEY_FILE_MAX_BYTES = 4096
SIGNING_EPOCH_UNIX_S = 1420070400  # 2015-01-01T00:00:00Z, the signing timestamp's zero
REFUSED = "Invalid signature"  # pymavlink's BAD_DATA reason for a refused packet
_SIGNED_FLAG = 0x01  # MAVLINK_IFLAG_SIGNED


def key_from_passphrase(passphrase: str) -> bytes:
    """The 32-byte secret key of ``passphrase``: SHA-256 of its ASCII bytes (as MAVProxy)."""
    return hashlib.sha256(passphrase.encode("ascii")).digest()


def read_signing_key(path: str | Path) -> bytes:
    """The secret key of the key file ``path`` (see the module doc); a missing, unreadable or
    malformed file raises :class:`InputError` naming it (never quoting the passphrase)."""
    text = read_text(path, "signing key", KEY_FILE_MAX_BYTES)
    lines = text.splitlines()
    while lines and lines[-1] == "":
        lines.pop()
    problem = None
    if not lines:
        problem = "is empty (expected one line: the passphrase)"
    elif len(lines) > 1:
        problem = f"has {len(lines)} lines (expected one: the passphrase)"
    elif not lines[0].isascii() or not lines[0].isprintable():
        problem = "holds a character that is not printable ASCII"
    elif any(c.isspace() for c in lines[0]):
        problem = "holds a space (MAVProxy's passphrases have none)"
    elif len(lines[0]) > MAX_PASSPHRASE_CHARS:
        problem = f"holds a passphrase over {MAX_PASSPHRASE_CHARS} characters"
    if problem is not None:
        raise InputError(f"{path}: signing key file {problem}")
    return key_from_passphrase(lines[0])


def key_file_exposure(path: str | Path) -> str | None:
    """A one-line warning when other users may read the key file ``path`` (as gpg warns; ssh
    refuses such a key, but a signing passphrase in a shared lab folder is common and the user
    must be told, not stopped mid-flight-test), else None. POSIX permission bits only."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None  # read_signing_key reports the file itself
    if os.name != "posix" or not mode & (stat.S_IRWXG | stat.S_IRWXO):
        return None
    return (f"warning: signing key file {path} is readable by other users (mode "
            f"{stat.S_IMODE(mode):04o}): chmod 600 {path}")


def carries_signature(msg: Any) -> bool:
    """Whether the parsed packet ``msg`` came signed (checked or not: without a key of its
    own, pymavlink accepts a signed packet unchecked)."""
    return bool(msg.get_header().incompat_flags & _SIGNED_FLAG)


def _refuse_unsigned(_mav: Any, _msg_id: int) -> bool:
    return False  # nothing is accepted unsigned, not even a radio's RADIO_STATUS


def sign_and_verify(mav: Any, key: bytes, *, link_id: int = 0) -> None:
    """Make the pymavlink ``MAVLink`` object ``mav`` sign every packet it sends, as stream
    ``link_id``, and refuse every packet it parses that is not validly signed with ``key``."""
    if len(key) != 32:
        raise ValueError("a MAVLink signing key is 32 bytes")
    signing = mav.signing
    signing.secret_key = key
    signing.sign_outgoing = True
    signing.allow_unsigned_callback = _refuse_unsigned
    signing.link_id = link_id
    signing.timestamp = max(0, int((time.time() - SIGNING_EPOCH_UNIX_S) * 100_000))


class RefusedTraffic:
    """The packets a signed link refused, by sender and why, to explain a silent vehicle."""

    def __init__(self, key: bytes) -> None:
        self.key = key
        self.unsigned: Counter[int] = Counter()  # by system id
        self.other_key: Counter[int] = Counter()
        self.replayed: Counter[int] = Counter()  # right key, timestamp too old

    def note(self, msg: Any) -> None:
        """Count ``msg`` if it is a packet the link refused for its signature."""
        if msg.get_type() != "BAD_DATA" or getattr(msg, "reason", "") != REFUSED:
            return
        buf = bytes(msg.data)
        if len(buf) >= 10 and buf[0] == 0xFD:
            sysid, signed = buf[5], bool(buf[2] & _SIGNED_FLAG)
        elif len(buf) >= 6 and buf[0] == 0xFE:  # MAVLink 1 cannot be signed
            sysid, signed = buf[3], False
        else:
            return
        if not signed:
            self.unsigned[sysid] += 1
        elif hashlib.sha256(self.key + buf[:-6]).digest()[:6] == buf[-6:]:
            self.replayed[sysid] += 1
        else:
            self.other_key[sysid] += 1

    def __bool__(self) -> bool:
        return bool(self.unsigned or self.other_key or self.replayed)

    def explanation(self) -> str:
        """One clause on what was refused ("" if nothing), worst case first."""
        parts = []
        if self.unsigned:
            parts.append(f"refused {_packets(self.unsigned, 'unsigned ')}: the vehicle does "
                         "not sign (give it the key, e.g. with MAVProxy's signing setup, or "
                         "connect without --signing-key)")
        if self.other_key:
            parts.append(f"refused {_packets(self.other_key)} signed with another key (check "
                         "--signing-key)")
        if self.replayed:
            parts.append(f"refused {_packets(self.replayed)} with old signing timestamps "
                         "(replayed, or the vehicle's signing clock is over a minute behind)")
        return "; ".join(parts)


def _packets(counts: Counter[int], kind: str = "") -> str:
    return ", ".join(f"{n} {kind}packet{'s' if n != 1 else ''} from system {s}"
                     for s, n in sorted(counts.items()))
