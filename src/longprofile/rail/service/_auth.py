"""People: scrypt password hashes (hashlib), signed login cookies (itsdangerous), CSRF tokens, roles."""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets

from itsdangerous import BadSignature, URLSafeTimedSerializer
from sqlalchemy import select

from ._db import ROLES, Database, Secret, User

__all__ = ["hash_password", "verify_password", "SessionSigner", "role_at_least", "SESSION_COOKIE", "PRE_COOKIE"]

SESSION_COOKIE = "lp_session"
PRE_COOKIE = "lp_pre"  # random value before login: the login form's CSRF token is bound to it
SCRYPT = dict(n=2**14, r=8, p=1)


def hash_password(password: str) -> str:
    salt = os.urandom(16)
    h = hashlib.scrypt(password.encode(), salt=salt, dklen=32, **SCRYPT)
    return f"scrypt${SCRYPT['n']}${SCRYPT['r']}${SCRYPT['p']}${salt.hex()}${h.hex()}"


def verify_password(password: str, stored: str) -> bool:
    try:
        kind, n, r, p, salt, h = stored.split("$")
        if kind != "scrypt":
            return False
        got = hashlib.scrypt(password.encode(), salt=bytes.fromhex(salt), dklen=len(h) // 2, n=int(n), r=int(r),
                             p=int(p))
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got.hex(), h)


def role_at_least(role: str | None, needed: str) -> bool:
    return role in ROLES and ROLES.index(role) >= ROLES.index(needed)


def _secret(db: Database) -> str:
    env = os.environ.get("LONGPROFILE_SECRET_KEY")
    if env:
        return env
    with db.write() as s:
        row = s.get(Secret, "cookie")
        if row is None:
            row = Secret(name="cookie", value=secrets.token_hex(32))
            s.add(row)
        return row.value


class SessionSigner:
    """Signs login cookies (user id, a per-login nonce) and derives CSRF tokens from them."""

    def __init__(self, db: Database, max_age_s: int = 12 * 3600):
        self.db = db
        self.key = _secret(db)
        self.max_age_s = max_age_s
        self._ser = URLSafeTimedSerializer(self.key, salt="longprofile-login")

    def login(self, username: str, password: str) -> str | None:
        from ._core import NAME_RE

        if not NAME_RE.match(username or "") or "\x00" in (password or ""):
            return None
        with self.db.read() as s:
            u = s.scalar(select(User).where(User.username == username, User.active.is_(True)))
            stored = u.password_hash if u is not None else hash_password("timing-equaliser")
            ok = verify_password(password, stored) and u is not None
            return self._ser.dumps({"u": u.id, "n": secrets.token_hex(8)}) if ok else None

    def user(self, cookie: str | None) -> tuple[str, str] | None:
        """(username, role) of a valid login cookie, else None."""
        if not cookie:
            return None
        try:
            data = self._ser.loads(cookie, max_age=self.max_age_s)
        except BadSignature:
            return None
        with self.db.read() as s:
            u = s.get(User, int(data.get("u", -1)))
            return None if u is None or not u.active else (u.username, u.role)

    def csrf(self, bound_to: str) -> str:
        return hmac.new(self.key.encode(), b"csrf:" + bound_to.encode(), hashlib.sha256).hexdigest()

    def check_csrf(self, bound_to: str | None, token: str | None) -> bool:
        return bool(bound_to) and bool(token) and hmac.compare_digest(self.csrf(bound_to), str(token))
