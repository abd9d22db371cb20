"""TOML at the file boundary: strict keys, units in key names, clear errors."""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from gearpit.errors import InputError


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; unreadable or malformed files raise :class:`InputError`."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")      # a byte-order mark (Windows Notepad) is no TOML error
    except OSError as exc:
        raise InputError("file", str(p), f"a readable TOML file ({exc.strerror})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("file", str(p), f"valid TOML ({exc})") from None


def check_keys(table: dict[str, Any], allowed: set[str] | list[str], where: str, *, required: set[str] | None = None) -> None:
    """Reject unknown keys (typos) and missing required keys in a TOML table."""
    allowed = set(allowed)
    for key in table:
        if key not in allowed:
            raise InputError(f"{where}.{key}" if where else key, table[key], f"a known key: {', '.join(sorted(allowed))}")
    for key in sorted(required or ()):
        if key not in table:
            raise InputError(f"{where}.{key}" if where else key, None, "a value (this key is required)")
