"""An image's width and height read from its header alone, so that a decoder is never handed a bomb.

A PNG of a few kilobytes can claim 30000x30000 pixels; OpenCV would allocate gigabytes before anything
refuses it. :func:`check_image_pixels` reads the claimed size here, in pure Python and in bounded work, and
refuses it against :data:`strictio.limits.IMAGE_PIXELS` *before* the caller decodes. A header that a known
format cannot have is an :class:`InputError`; an unknown format is ``None`` from :func:`image_size` and
refused by :func:`check_image_pixels` (what cannot be measured is not decoded).

:func:`truncation` tells a JPEG or PNG cut short from a whole one: their decoders report that on stderr
and still return a partly grey picture, which would be processed as if it were the real one.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from typing import BinaryIO

from .errors import InputError
from .limits import IMAGE_PIXELS, check
from .opener import DEFAULT_LIMIT, open_input

#: The formats whose header is read here; anything else is refused before decoding.
KNOWN_FORMATS = "PNG, JPEG, BMP, TIFF, WebP, GIF, PNM/PAM/PFM, Sun raster or Radiance HDR"
#: The refusal of any other format (an InputError's message).
UNKNOWN_FORMAT = f"not a readable image (not {KNOWN_FORMATS}: the formats whose size is checked before decoding)"
#: Markers, segments and fill bytes a JPEG header may take before its frame header (bounds the work).
_JPEG_MAX_STEPS = 65_536
#: Bytes a text header (PNM, PAM, HDR) may take; real ones take a few dozen.
_TEXT_HEADER_BYTES = 64 * 1024
#: Entries a TIFF directory may hold before it is taken for garbage (real ones hold a few dozen).
_TIFF_MAX_ENTRIES = 4096
#: Bytes a decoder may need per claimed pixel (16-bit RGBA is 8), on top of the default cap.
_BYTES_PER_PIXEL = 8

Source = bytes | bytearray | memoryview | str | os.PathLike[str]
Size = tuple[int, int]


class _Header:
    """Random access to the first bytes of an image, in memory or in an open file: a file is read only
    where the header is, never whole."""

    def __init__(self, data: bytes | bytearray | memoryview | None = None, stream: BinaryIO | None = None) -> None:
        self._data = bytes(data) if data is not None else None
        self._stream = stream
        if self._data is not None:
            self._length = len(self._data)
        else:
            assert stream is not None
            self._length = os.fstat(stream.fileno()).st_size

    def read(self, offset: int, size: int) -> bytes:
        """At most ``size`` bytes from ``offset`` (fewer at the end; none past it, wherever a header points)."""
        if offset < 0 or size <= 0 or offset >= self._length:
            return b""
        if self._data is not None:
            return self._data[offset : offset + size]
        assert self._stream is not None
        self._stream.seek(offset)
        return self._stream.read(min(size, self._length - offset))


class _Bad(Exception):
    """A header a known format cannot have; reported as an InputError naming the format and the file."""

    def __init__(self, fmt: str, why: str) -> None:
        super().__init__(f"not a readable {fmt} image: {why}")


def _u16(b: bytes, big: bool) -> int:
    return int.from_bytes(b[:2], "big" if big else "little")


def _u32(b: bytes, big: bool) -> int:
    return int.from_bytes(b[:4], "big" if big else "little")


def _need(data: bytes, size: int, fmt: str) -> bytes:
    if len(data) < size:
        raise _Bad(fmt, "the header ends early (truncated)")
    return data


def _png(head: _Header) -> Size:
    data = _need(head.read(0, 24), 24, "PNG")
    if data[12:16] != b"IHDR":
        raise _Bad("PNG", "the first chunk is not IHDR")
    return _u32(data[16:20], True), _u32(data[20:24], True)


_JPEG_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}


def _jpeg_scan(head: _Header) -> tuple[Size, int]:
    """(width, height) from the frame header, and the offset of the first scan (SOS) after it."""
    offset, size, steps = 2, None, 0
    while True:
        steps += 1
        if steps > _JPEG_MAX_STEPS:
            raise _Bad("JPEG", f"no image data within the first {_JPEG_MAX_STEPS:,} markers")
        pair = head.read(offset, 2)
        if len(pair) < 2:
            if size is None:
                raise _Bad("JPEG", "the file ends before its frame header (truncated)")
            return size, -1
        if pair[0] != 0xFF:
            raise _Bad("JPEG", f"no marker at byte {offset:,}")
        marker = pair[1]
        if marker == 0xFF:  # fill byte
            offset += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:  # markers without a length
            offset += 2
            continue
        if marker == 0xD9:
            raise _Bad("JPEG", "the image ends before its frame header")
        length = _u16(_need(head.read(offset + 2, 2), 2, "JPEG"), True)
        if length < 2:
            raise _Bad("JPEG", f"a segment of length {length} at byte {offset:,}")
        if marker in _JPEG_SOF:
            frame = _need(head.read(offset + 4, 5), 5, "JPEG")
            size = (_u16(frame[3:5], True), _u16(frame[1:3], True))
        elif marker == 0xDA:
            if size is None:
                raise _Bad("JPEG", "image data before the frame header")
            return size, offset
        offset += 2 + length


def _jpeg(head: _Header) -> Size:
    return _jpeg_scan(head)[0]


def _text_tokens(head: _Header, fmt: str, count: int) -> list[bytes]:
    """The first ``count`` whitespace-separated tokens of a PNM-style header, ``#`` comments skipped."""
    text = head.read(0, _TEXT_HEADER_BYTES)
    tokens = re.findall(rb"#[^\n\r]*|[^\s#]+", text)
    words = [t for t in tokens if not t.startswith(b"#")][:count]
    if len(words) < count:
        raise _Bad(fmt, f"the header ends before its size (or is longer than {_TEXT_HEADER_BYTES:,} bytes)")
    return words


def _dimension(word: bytes, fmt: str, name: str) -> int:
    if not word.isdigit() or len(word) > 10:
        raise _Bad(fmt, f"{name} {word[:20]!r} is not a whole number of pixels")
    return int(word)


def _pnm(head: _Header) -> Size:
    fmt = "PNM" if head.read(0, 2)[1:2] not in (b"F", b"f") else "PFM"
    words = _text_tokens(head, fmt, 3)
    return _dimension(words[1], fmt, "width"), _dimension(words[2], fmt, "height")


def _pam(head: _Header) -> Size:
    text = head.read(0, _TEXT_HEADER_BYTES)
    end = text.find(b"ENDHDR")
    if end < 0:
        raise _Bad("PAM", f"no ENDHDR within the first {_TEXT_HEADER_BYTES:,} bytes")
    fields = dict(re.findall(rb"^[ \t]*(WIDTH|HEIGHT)[ \t]+(\S+)", text[:end], re.MULTILINE))
    if b"WIDTH" not in fields or b"HEIGHT" not in fields:
        raise _Bad("PAM", "WIDTH or HEIGHT is missing")
    return _dimension(fields[b"WIDTH"], "PAM", "WIDTH"), _dimension(fields[b"HEIGHT"], "PAM", "HEIGHT")


def _bmp(head: _Header) -> Size:
    data = _need(head.read(0, 26), 18, "BMP")
    info = _u32(data[14:18], False)
    if info == 12:
        data = _need(data, 22, "BMP")
        return _u16(data[18:20], False), _u16(data[20:22], False)
    if info < 16:
        raise _Bad("BMP", f"an information header of {info} bytes")
    data = _need(data, 26, "BMP")
    width = int.from_bytes(data[18:22], "little", signed=True)
    height = int.from_bytes(data[22:26], "little", signed=True)
    if width < 0:
        raise _Bad("BMP", f"a negative width ({width})")
    return width, abs(height)


_TIFF_SIZE_TAGS = {256: "width", 257: "height"}


def _tiff(head: _Header) -> Size:
    start = _need(head.read(0, 16), 8, "TIFF")
    big = start[:2] == b"MM"
    version = _u16(start[2:4], big)
    if version == 43:  # BigTIFF: 8-byte offsets and counts, 20-byte entries
        start = _need(start, 16, "TIFF")
        offset = int.from_bytes(start[8:16], "big" if big else "little")
        entry_size, count_size = 20, 8
    else:
        offset = _u32(start[4:8], big)
        entry_size, count_size = 12, 2
    count = int.from_bytes(_need(head.read(offset, count_size), count_size, "TIFF"), "big" if big else "little")
    if count > _TIFF_MAX_ENTRIES:
        raise _Bad("TIFF", f"a directory of {count:,} entries")
    entries = _need(head.read(offset + count_size, count * entry_size), count * entry_size, "TIFF")
    found: dict[str, int] = {}
    for i in range(count):
        entry = entries[i * entry_size : (i + 1) * entry_size]
        tag, kind = _u16(entry[0:2], big), _u16(entry[2:4], big)
        if tag not in _TIFF_SIZE_TAGS:
            continue
        value = entry[12:20] if entry_size == 20 else entry[8:12]
        width = {3: 2, 4: 4, 16: 8}.get(kind)
        if width is None or (width == 8 and entry_size == 12):
            raise _Bad("TIFF", f"the {_TIFF_SIZE_TAGS[tag]} has field type {kind}")
        found[_TIFF_SIZE_TAGS[tag]] = int.from_bytes(value[:width], "big" if big else "little")
    if len(found) < 2:
        raise _Bad("TIFF", "the first directory gives no width or height")
    return found["width"], found["height"]


def _webp(head: _Header) -> Size:
    data = _need(head.read(0, 30), 16, "WebP")
    chunk = data[12:16]
    if chunk == b"VP8 ":
        data = _need(data, 30, "WebP")
        if data[23:26] != b"\x9d\x01\x2a":
            raise _Bad("WebP", "a VP8 frame without its start code")
        return _u16(data[26:28], False) & 0x3FFF, _u16(data[28:30], False) & 0x3FFF
    if chunk == b"VP8L":
        data = _need(data, 25, "WebP")
        if data[20] != 0x2F:
            raise _Bad("WebP", "a lossless frame without its signature")
        bits = _u32(data[21:25], False)
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if chunk == b"VP8X":
        data = _need(data, 30, "WebP")
        return int.from_bytes(data[24:27], "little") + 1, int.from_bytes(data[27:30], "little") + 1
    raise _Bad("WebP", f"an unknown first chunk {chunk!r}")


def _gif(head: _Header) -> Size:
    data = _need(head.read(0, 10), 10, "GIF")
    return _u16(data[6:8], False), _u16(data[8:10], False)


def _sun(head: _Header) -> Size:
    data = _need(head.read(0, 12), 12, "Sun raster")
    return _u32(data[4:8], True), _u32(data[8:12], True)


def _hdr(head: _Header) -> Size:
    text = head.read(0, _TEXT_HEADER_BYTES)
    match = re.search(rb"\n\n([-+])([XY]) +(\d{1,10}) +([-+])([XY]) +(\d{1,10})", text)
    if match is None or match.group(2) == match.group(5):
        raise _Bad("Radiance HDR", f"no resolution line within the first {_TEXT_HEADER_BYTES:,} bytes")
    first, second = int(match.group(3)), int(match.group(6))
    return (second, first) if match.group(2) == b"Y" else (first, second)


def _reader(magic: bytes) -> tuple[str, Callable[[_Header], Size]] | None:
    if magic.startswith(b"\x89PNG\r\n\x1a\n"):
        return "PNG", _png
    if magic.startswith(b"\xff\xd8"):
        return "JPEG", _jpeg
    if magic.startswith(b"BM"):
        return "BMP", _bmp
    if magic[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return "TIFF", _tiff
    if magic[:4] == b"RIFF" and magic[8:12] == b"WEBP":
        return "WebP", _webp
    if magic[:6] in (b"GIF87a", b"GIF89a"):
        return "GIF", _gif
    if magic[:4] == b"\x59\xa6\x6a\x95":
        return "Sun raster", _sun
    if magic.startswith((b"#?RADIANCE", b"#?RGBE")):
        return "Radiance HDR", _hdr
    if magic[:1] == b"P" and magic[1:2] in b"123456Ff" and magic[1:2] and magic[2:3].isspace():
        return "PNM", _pnm
    if magic[:3] == b"P7\n":
        return "PAM", _pam
    return None


def _measure(head: _Header, name: str) -> Size | None:
    try:
        found = _reader(head.read(0, 16))
    except OSError as exc:
        raise InputError(name, f"cannot be read: {exc.strerror or exc}") from None
    if found is None:
        return None
    fmt, reader = found
    try:
        width, height = reader(head)
    except _Bad as exc:
        raise InputError(name, str(exc)) from None
    except OSError as exc:
        raise InputError(name, f"cannot be read: {exc.strerror or exc}") from None
    if width <= 0 or height <= 0:
        raise InputError(name, f"not a readable {fmt} image: it claims {width}x{height} pixels")
    return width, height


def image_size(source: Source, name: str | None = None) -> Size | None:
    """(width, height) from the header of an image given as bytes or as a path, or None for a format not
    read here. A header its format cannot have is an InputError naming ``name`` (default: the path)."""
    if isinstance(source, bytes | bytearray | memoryview):
        return _measure(_Header(data=source), name or "<image>")
    with open_input(source, limit=None) as stream:
        return _measure(_Header(stream=stream), name or str(source))


def check_image_pixels(path: str | os.PathLike[str], data: Source, where: str = "") -> Size:
    """The size of an image, after checking it against the pixel limit; an image whose size cannot be read
    from its header (an unknown format) is refused too, since nothing else stops it before decoding."""
    size = image_size(data, str(path))
    if size is None:
        raise InputError(path, UNKNOWN_FORMAT, where)
    width, height = size
    check(path, IMAGE_PIXELS, width * height, f"image of {width}x{height}", where)
    return size


def read_image_file(path: str | os.PathLike[str]) -> tuple[bytes, Size]:
    """The bytes of an image file whose header passed :func:`check_image_pixels`, opened once: refused if not
    a regular file, and never more bytes than its claimed size can need."""
    with open_input(path, limit=None) as stream:
        size = _measure(_Header(stream=stream), str(path))
        if size is None:
            raise InputError(path, UNKNOWN_FORMAT)
        check(path, IMAGE_PIXELS, size[0] * size[1], f"image of {size[0]}x{size[1]}")
        cap = DEFAULT_LIMIT + _BYTES_PER_PIXEL * size[0] * size[1]
        length = os.fstat(stream.fileno()).st_size
        if length > cap:
            raise InputError(path, f"is {length:,} bytes, more than a {size[0]}x{size[1]} image needs "
                                   f"(at most {cap:,})")
        stream.seek(0)
        try:
            data = stream.read(cap + 1)
        except OSError as exc:
            raise InputError(path, f"cannot be read: {exc.strerror or exc}") from None
    if len(data) > cap:
        raise InputError(path, f"grew past {cap:,} bytes while it was read")
    return data, size


def truncation(data: bytes | bytearray | memoryview) -> str | None:
    """Why a JPEG or PNG ends before its image does, or None (other formats: their decoders fail cleanly).

    A JPEG must hold its end-of-image marker after its first scan (an EXIF thumbnail's own marker, earlier,
    does not count); a PNG its IEND chunk. Data after either (some cameras append some) is allowed.
    """
    data = bytes(data)
    if data.startswith(b"\xff\xd8"):
        try:
            _size, scan = _jpeg_scan(_Header(data=data))
        except _Bad:
            return None  # the header check reports it
        if scan < 0 or data.find(b"\xff\xd9", scan) < 0:
            return "truncated: the JPEG ends before its end-of-image marker"
    elif data.startswith(b"\x89PNG\r\n\x1a\n") and data.rfind(b"\x00\x00\x00\x00IEND") < 8:
        return "truncated: the PNG ends before its IEND chunk"
    return None
