"""Fixtures for the report tests: small PNG files and a static check for external references."""

from __future__ import annotations

import re
import struct
import zlib
from collections.abc import Callable
from html.parser import HTMLParser
from pathlib import Path

import pytest


def _png_bytes(width: int, height: int) -> bytes:
    """A valid RGB PNG with a horizontal gradient (no matplotlib: fast)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    row = bytes(v for x in range(width) for v in (x * 255 // max(width - 1, 1), 90, 160))
    raw = b"".join(b"\x00" + row for _ in range(height))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


@pytest.fixture
def make_png() -> Callable[..., Path]:
    """``make_png(path, width=32, height=16)`` writes a small PNG and returns its path."""

    def make(path: Path, width: int = 32, height: int = 16) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(_png_bytes(width, height))
        return path

    return make


class _References(HTMLParser):
    """Collects every tag and every attribute that can make a browser fetch or navigate."""

    URL_ATTRIBUTES = frozenset(
        {"src", "href", "srcset", "action", "formaction", "data", "poster", "background",
         "manifest", "ping", "xlink:href", "codebase", "cite", "longdesc"}
    )  # fmt: skip

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.urls: list[tuple[str, str, str]] = []  # (tag, attribute, value)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        for name, value in attrs:
            if name in self.URL_ATTRIBUTES and value is not None:
                self.urls.append((tag, name, value.strip()))


def external_references(page: str) -> list[str]:
    """Everything in ``page`` that would fetch from outside the file; empty when self-contained.

    Allowed: ``data:image/png`` in img src and same-page ``#fragment`` links.
    """
    found = []
    parser = _References()
    parser.feed(page)
    for tag, name, value in parser.urls:
        if tag == "img" and name == "src" and value.startswith("data:image/png;base64,"):
            continue
        if tag == "a" and name == "href" and value.startswith("#"):
            continue
        found.append(f"<{tag} {name}={value[:60]!r}>")
    found += [f"<{t}> element" for t in parser.tags if t in {"link", "iframe", "object", "embed"}]
    pattern = r"""(?:src|href)\s*=\s*["']?\s*(?:https?:|wss?:)?//"""
    found += [f"attribute {m!r}" for m in re.findall(pattern, page, flags=re.IGNORECASE)]
    found += [f"CSS {m!r}" for m in re.findall(r"@import|url\(", page, flags=re.IGNORECASE)]
    return found


@pytest.fixture
def find_external() -> Callable[[str], list[str]]:
    return external_references
