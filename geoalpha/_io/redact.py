"""Keep credentials out of messages: redact passwords and tokens in text.

A data source name can hold a password (``PG:... password=secret``,
``postgresql://me:secret@db/gis``, ``...?token=...``); every message geoalpha
shows goes through :func:`redact` first.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

__all__ = ["MASK", "redact", "secrets_in"]

#: What a redacted secret is replaced with.
MASK = "***"

# Keys whose values are secrets, in key=value strings (libpq, GDAL, ODBC) and
# in URL query strings; compared ignoring case.
_KEYS = (
    r"password|passwd|pwd|pass|secret|client_secret|token|access_token|"
    r"refresh_token|id_token|auth|authorization|api_?key|access_?key|"
    r"secret_?access_?key|aws_secret_access_key|aws_session_token|"
    r"security_?token|sig|signature|x-amz-signature|x-amz-credential|"
    r"x-amz-security-token|x-goog-signature|x-goog-credential|key"
)
# key = value: a quoted value (with backslash escapes) or a bare one up to a
# separator. The key starts a word (``\b``: every key starts with a letter)
# not preceded by "-"; ``\b`` first lets the regex engine skip the inside of
# words fast (a lookbehind first costs twice as much on a long token).
_KEY_VALUE = re.compile(
    rf"\b(?<!-)(?P<key>(?:{_KEYS}))(?P<eq>\s*=\s*)"
    r"(?P<value>'(?:[^'\\]|\\.)*'?|\"(?:[^\"\\]|\\.)*\"?|[^\s&;,'\"]+)",
    re.IGNORECASE,
)
# scheme://user:password@host. The match starts at "://", not at the scheme:
# starting at the scheme is quadratic on a long run of letters (a 100 KB token
# took 10 s); from "://" the search is linear in the length of the text.
_URL_PASSWORD = re.compile(
    r"(?P<head>://(?<=[A-Za-z0-9+.-]://)[^\s:/@]*:)(?P<value>[^\s@/]*)(?=@)"
)
_SHORT = 4


def _unquote(value: str) -> str:
    if len(value) >= 2 and value[0] in "'\"" and value[-1] == value[0]:
        value = value[1:-1]
    return re.sub(r"\\(.)", r"\1", value)


def secrets_in(text: str) -> list[str]:
    """Return the secret values that ``text`` holds.

    Parameters
    ----------
    text : str

    Returns
    -------
    list of str
        Values of password-like keys and URL passwords, longest first.

    Examples
    --------
    >>> from geoalpha._io.redact import secrets_in
    >>> secrets_in("PG:host=db password='s3 cret' dbname=gis")
    ['s3 cret']
    >>> secrets_in("postgresql://me:pw%40x@db/gis")
    ['pw%40x']
    """
    keyed = set()
    if "=" in text:  # skip the scan of a long text that cannot hold key=value
        keyed = {_unquote(m.group("value")) for m in _KEY_VALUE.finditer(text)}
    urls = {m.group("value") for m in _URL_PASSWORD.finditer(text)}
    return sorted((keyed | urls) - {"", MASK}, key=len, reverse=True)


def redact(text: object, secrets: Iterable[str] = ()) -> str:
    """Replace passwords, tokens and the given secrets in ``text`` by ``***``.

    Parameters
    ----------
    text : object
        The message (converted with ``str``).
    secrets : iterable of str, optional
        Known secret values to remove wherever they appear.

    Returns
    -------
    str

    Examples
    --------
    >>> from geoalpha._io.redact import redact
    >>> redact("cannot open PG:host=db user=me password=secret dbname=gis")
    'cannot open PG:host=db user=me password=*** dbname=gis'
    >>> redact("cannot read https://me:secret@example.com/a.gpkg?token=abc&n=1")
    'cannot read https://me:***@example.com/a.gpkg?token=***&n=1'
    >>> redact("nonnumeric port: 'secret@example.com'", ["secret"])
    "nonnumeric port: '***@example.com'"
    """
    out = str(text)
    known = {*secrets, *secrets_in(out)}
    out = _URL_PASSWORD.sub(lambda m: m.group("head") + MASK, out)
    if "=" in out:
        out = _KEY_VALUE.sub(lambda m: m.group("key") + m.group("eq") + MASK, out)
    for secret in sorted(known - {"", MASK}, key=len, reverse=True):
        if len(secret) >= _SHORT:
            out = out.replace(secret, MASK)
        else:  # a short secret: only where it stands alone, not inside words
            out = re.sub(
                rf"(?<![A-Za-z0-9]){re.escape(secret)}(?![A-Za-z0-9])", MASK, out
            )
    return out
