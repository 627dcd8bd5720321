"""PNG files of a dataset: a full structural check, and byte-reproducible files.

:func:`png_problem` reads a PNG as a decoder does, without a decoder's side effects: the
signature, every chunk's length and CRC, the header, the image data inflated to exactly the
size the header implies with a valid filter byte on every row, and ``IEND`` last. It is what
a resumed ``generate`` checks every kept image with (a truncated or corrupt one is rendered
again) and what ``dataset verify`` reports.

Blender writes the date and the render time into every PNG (``tEXt`` chunks), so two renders
of identical pixels differ in their bytes. :func:`strip_png_metadata` drops the chunks that
carry text or time (``tEXt``, ``zTXt``, ``iTXt``, ``tIME``) and keeps every other chunk as
it is, so a file's bytes depend only on its pixels and the encoder: one content hash per
seed and settings (``dataset.json``'s ``content_hash``).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

from viewadapt.io.files import atomic_write_bytes

__all__ = ["PNG_SIGNATURE", "METADATA_CHUNKS", "png_problem", "strip_png_metadata",
           "normalize_png"]

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: chunks that hold text or a time stamp: dropped, so the bytes depend on the pixels only
METADATA_CHUNKS = (b"tEXt", b"zTXt", b"iTXt", b"tIME")
_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
#: Adam7 passes: (x start, y start, x step, y step)
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4),
          (1, 0, 2, 2), (0, 1, 1, 2))


def _chunks(data: bytes):
    """``(type, body, start, end)`` of each chunk; ValueError on a broken structure."""
    if data[:8] != PNG_SIGNATURE:
        raise ValueError("not a PNG (bad signature)")
    pos = 8
    while pos < len(data):
        if pos + 12 > len(data):
            raise ValueError("truncated (a chunk is cut off)")
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        end = pos + 12 + n
        if end > len(data):
            raise ValueError(f"truncated ({kind.decode('latin-1')} chunk is cut off)")
        body = data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[end - 4:end])
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise ValueError(f"corrupt ({kind.decode('latin-1')} chunk fails its CRC)")
        yield kind, body, pos, end
        pos = end


def _row_bytes(width: int, bits: int) -> int:
    return (width * bits + 7) // 8


def png_problem(path, size=None) -> str | None:
    """What is wrong with the PNG at ``path``, or None if it is complete and intact.

    ``size``: the expected ``(width, height)``. Checks everything short of unfiltering the
    pixels: structure, CRCs, header, image data of the header's size, filter bytes, IEND.
    """
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    if not data:
        return "empty file"
    try:
        header, idat, ended = None, [], False
        for kind, body, _, _ in _chunks(data):
            if ended:
                return "data after IEND"
            if header is None and kind != b"IHDR":
                return "not a PNG (no IHDR first)"
            if kind == b"IHDR":
                if len(body) != 13:
                    return "corrupt header"
                header = struct.unpack(">IIBBBBB", body)
            elif kind == b"IDAT":
                idat.append(body)
            elif kind == b"IEND":
                ended = True
        if not ended:
            return "truncated (no IEND chunk)"
    except ValueError as exc:
        return str(exc)
    w, h, depth, color, _, _, interlace = header
    if color not in _CHANNELS or depth not in (1, 2, 4, 8, 16):
        return f"unsupported header (colour type {color}, bit depth {depth})"
    if size is not None and (w, h) != tuple(size):
        return f"size {w}x{h}, expected {size[0]}x{size[1]}"
    bits = depth * _CHANNELS[color]
    if interlace:
        rows = [(_row_bytes(len(range(x0, w, dx)), bits), len(range(y0, h, dy)))
                for x0, y0, dx, dy in _ADAM7]
        rows = [(n, k) for n, k in rows if n and k]
    else:
        rows = [(_row_bytes(w, bits), h)]
    expected = sum((n + 1) * k for n, k in rows)
    d = zlib.decompressobj()
    try:
        raw = d.decompress(b"".join(idat), expected + 1)
    except zlib.error as exc:
        return f"corrupt image data ({exc})"
    if len(raw) != expected or not d.eof or d.unconsumed_tail:
        return (f"corrupt image data ({len(raw)} bytes inflated, {expected} expected"
                + ("" if d.eof else ", stream unfinished") + ")")
    pos = 0
    for n, k in rows:
        for _ in range(k):
            if raw[pos] > 4:
                return f"corrupt image data (filter byte {raw[pos]})"
            pos += n + 1
    return None


def strip_png_metadata(data: bytes) -> bytes | None:
    """``data`` without its :data:`METADATA_CHUNKS`; None if it has none (or is no PNG)."""
    try:
        chunks = list(_chunks(data))
    except ValueError:
        return None
    drop = [(a, b) for kind, _, a, b in chunks if kind in METADATA_CHUNKS]
    if not drop:
        return None
    out, pos = [], 0
    for a, b in drop:
        out.append(data[pos:a])
        pos = b
    out.append(data[pos:])
    return b"".join(out)


def normalize_png(path) -> bool:
    """Rewrite ``path`` (atomically) without its metadata chunks; True if it changed."""
    stripped = strip_png_metadata(Path(path).read_bytes())
    if stripped is None:
        return False
    atomic_write_bytes(path, stripped)
    return True
