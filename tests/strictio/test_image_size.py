"""Image sizes read from headers alone: every format OpenCV writes, crafted headers of every layout, bombs
refused before decoding, cut-off JPEGs and PNGs told from whole ones, and bounded work on hostile bytes."""

from __future__ import annotations

import os
import struct
import time
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from strictio import IMAGE_PIXELS, InputError, LimitError
from strictio.image_size import UNKNOWN_FORMAT, check_image_pixels, image_size, read_image_file, truncation

WIDTH, HEIGHT = 53, 37
PICTURE = np.random.default_rng(7).integers(0, 255, (HEIGHT, WIDTH, 3), dtype=np.uint8)


def png_header(width: int, height: int) -> bytes:
    """A whole PNG (signature, IHDR, a small IDAT, IEND) whose header claims ``width`` x ``height``."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    idat = chunk(b"IDAT", zlib.compress(b"\0" * 256))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + idat + chunk(b"IEND", b"")


def jpeg_header(width: int, height: int, exif: bytes = b"") -> bytes:
    """SOI, an optional APP1 (EXIF) segment, a baseline frame header claiming the size, a scan, EOI."""
    app1 = b"\xff\xe1" + struct.pack(">H", len(exif) + 2) + exif if exif else b""
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, height, width, 1) + b"\x01\x11\x00"
    sos = b"\xff\xda" + struct.pack(">HB", 8, 1) + b"\x01\x00\x00\x3f\x00"
    return b"\xff\xd8" + app1 + sof + sos + b"\x12\x34" * 20 + b"\xff\xd9"


@pytest.mark.parametrize(
    "ext, grey",
    [(".png", False), (".jpg", False), (".bmp", False), (".tif", False), (".webp", False), (".ppm", False),
     (".pgm", True), (".pbm", True), (".gif", False), (".pam", False), (".pfm", False), (".hdr", False),
     (".sr", False)],
)
def test_every_format_opencv_writes_is_measured_from_its_header(ext, grey):
    ok, encoded = cv2.imencode(ext, PICTURE[..., 0] if grey else PICTURE)
    assert ok
    data = encoded.tobytes()
    assert image_size(data) == (WIDTH, HEIGHT)
    assert check_image_pixels("picture" + ext, data) == (WIDTH, HEIGHT)
    assert truncation(data) is None


def test_lossless_webp_ascii_pgm_and_a_file_path(tmp_path):
    lossless = cv2.imencode(".webp", PICTURE, [cv2.IMWRITE_WEBP_QUALITY, 101])[1].tobytes()
    assert lossless[12:16] == b"VP8L" and image_size(lossless) == (WIDTH, HEIGHT)
    ascii_pgm = cv2.imencode(".pgm", PICTURE[..., 0], [cv2.IMWRITE_PXM_BINARY, 0])[1].tobytes()
    assert ascii_pgm.startswith(b"P2") and image_size(ascii_pgm) == (WIDTH, HEIGHT)
    path = tmp_path / "picture.png"
    cv2.imwrite(str(path), PICTURE)
    assert image_size(path) == image_size(str(path)) == (WIDTH, HEIGHT)
    data, size = read_image_file(path)
    assert size == (WIDTH, HEIGHT) and data == path.read_bytes()


def test_crafted_headers_of_every_layout():
    # JPEG with a 3 kB EXIF segment (and its own thumbnail's markers inside) before the frame header.
    exif = b"Exif\x00\x00" + b"\xff\xd8\xff\xc0\x00\x11\x08\x00\x10\x00\x10" + b"\x00" * 3000 + b"\xff\xd9"
    assert image_size(jpeg_header(640, 480, exif)) == (640, 480)
    # Fill bytes before a marker and a progressive frame header (SOF2).
    progressive = jpeg_header(33, 44).replace(b"\xff\xc0", b"\xff\xff\xff\xc2")
    assert image_size(progressive) == (33, 44)
    # TIFF in both byte orders, with SHORT and LONG sizes; BigTIFF.
    little = b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 2) + struct.pack("<HHII", 256, 3, 1, 700) \
        + struct.pack("<HHII", 257, 4, 1, 500) + b"\x00" * 4
    big = b"MM\x00*" + struct.pack(">I", 8) + struct.pack(">H", 2) + struct.pack(">HHIHH", 256, 3, 1, 700, 0) \
        + struct.pack(">HHII", 257, 4, 1, 500) + b"\x00" * 4
    bigtiff = b"II+\x00" + struct.pack("<HHQ", 8, 0, 16) + struct.pack("<Q", 2) \
        + struct.pack("<HHQQ", 256, 16, 1, 700) + struct.pack("<HHQQ", 257, 4, 1, 500)
    assert image_size(little) == image_size(big) == image_size(bigtiff) == (700, 500)
    # WebP's extended header (VP8X) holds the canvas size minus one in 24 bits.
    vp8x = b"RIFF" + struct.pack("<I", 30) + b"WEBPVP8X" + struct.pack("<I", 10) + b"\x00" * 4 \
        + (1999).to_bytes(3, "little") + (999).to_bytes(3, "little")
    assert image_size(vp8x) == (2000, 1000)
    # BMP: the old 12-byte core header, and a top-down bitmap (negative height).
    core = b"BM" + b"\x00" * 12 + struct.pack("<IHHHH", 12, 320, 240, 1, 24)
    top_down = b"BM" + b"\x00" * 12 + struct.pack("<Iii", 40, 320, -240) + b"\x00" * 28
    assert image_size(core) == image_size(top_down) == (320, 240)
    # PNM with comments between the tokens; PAM; GIF; Radiance HDR in the -Y H +X W orientation.
    assert image_size(b"P6 # made by hand\n# another\n 12 # width\n 34\n255\n" + b"\x00" * 10) == (12, 34)
    assert image_size(b"P7\nWIDTH 9\nHEIGHT 8\nDEPTH 3\nMAXVAL 255\nENDHDR\n") == (9, 8)
    assert image_size(b"GIF89a" + struct.pack("<HH", 300, 200) + b"\x00" * 10) == (300, 200)
    assert image_size(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 480 +X 640\n") == (640, 480)


def test_unknown_formats_are_none_and_refused_by_the_check():
    for data in (b"", b"hello, world", b"\x00\x00\x00\x0cjP  \r\n\x87\n" + b"\x00" * 40):  # JPEG 2000
        assert image_size(data) is None
        with pytest.raises(InputError) as caught:
            check_image_pixels("x.png", data)
        assert caught.value.message == UNKNOWN_FORMAT


@pytest.mark.parametrize(
    "data, message",
    [
        (b"\xff\xd8garbage", "not a readable JPEG image: no marker at byte 2"),
        (b"\xff\xd8\xff\xd9", "not a readable JPEG image: the image ends before its frame header"),
        (b"\xff\xd8\xff\xda\x00\x08", "not a readable JPEG image: image data before the frame header"),
        (b"\xff\xd8\xff\xe0\x00\x01", "not a readable JPEG image: a segment of length 1 at byte 2"),
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDX" + b"\x00" * 8,
         "not a readable PNG image: the first chunk is not IHDR"),
        (b"\x89PNG\r\n\x1a\n\x00\x00", "not a readable PNG image: the header ends early (truncated)"),
        (png_header(0, 10), "not a readable PNG image: it claims 0x10 pixels"),
        (b"P5\n" + b"9" * 5000 + b" 10\n255\n",
         "not a readable PNM image: width b'99999999999999999999' is not a whole"),
        (b"P5\n# only a comment\n", "not a readable PNM image: the header ends before its size"),
        (b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 60000),
         "not a readable TIFF image: a directory of 60,000"),
        (b"II*\x00" + struct.pack("<I", 2**31), "not a readable TIFF image: the header ends early"),
        (b"BM" + b"\x00" * 12 + struct.pack("<Iii", 40, -5, 5), "not a readable BMP image: a negative width (-5)"),
        (b"RIFF\x00\x00\x00\x00WEBPVP8 " + b"\x00" * 14, "not a readable WebP image: a VP8 frame without its start"),
        (b"P7\nWIDTH 3\n", "not a readable PAM image: no ENDHDR"),
    ],
)
def test_headers_a_format_cannot_have_are_input_errors_naming_the_file(data, message):
    with pytest.raises(InputError) as caught:
        image_size(data, "shown.name")
    assert caught.value.path == "shown.name"
    assert caught.value.message.startswith(message)


@pytest.mark.parametrize(
    "data, side",
    [(png_header(30000, 30000), "30000x30000"), (jpeg_header(20000, 20000), "20000x20000")],
)
def test_bombs_of_a_few_hundred_bytes_are_refused_by_the_pixel_limit(data, side, monkeypatch):
    assert len(data) < 400
    monkeypatch.delenv(IMAGE_PIXELS.variable, raising=False)
    with pytest.raises(LimitError) as caught:
        check_image_pixels("bomb.png", data, "target.image")
    text = str(caught.value)
    assert text.startswith(f"bomb.png: target.image: image of {side}: ")
    assert "over the limit of 100,000,000 pixels (set OBJREC_MAX_IMAGE_PIXELS to raise it)" in text
    assert caught.value.limit is IMAGE_PIXELS
    # Someone with a real huge image raises the limit for one run.
    monkeypatch.setenv(IMAGE_PIXELS.variable, "1_000_000_000")
    assert check_image_pixels("bomb.png", data) == (int(side.split("x")[0]), int(side.split("x")[1]))


def test_special_files_are_refused_without_blocking(tmp_path):
    fifo = tmp_path / "camera.png"
    os.mkfifo(fifo)
    for path, what in ((fifo, "FIFO"), (tmp_path, "folder"), ("/dev/zero", "character device")):
        if not os.path.exists(path):
            continue
        with pytest.raises(InputError, match=what):
            image_size(path)
        with pytest.raises(InputError, match=what):
            read_image_file(path)


def test_a_file_longer_than_its_claimed_size_needs_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "long.png"
    path.write_bytes(png_header(2, 2))
    os.truncate(path, 70 * 1024 * 1024)  # sparse: no disk used
    with pytest.raises(InputError, match=r"long\.png: is 73,400,320 bytes, more than a 2x2 image needs"):
        read_image_file(path)


def test_truncated_jpegs_and_pngs_are_told_from_whole_ones():
    jpeg = cv2.imencode(".jpg", PICTURE)[1].tobytes()
    png = cv2.imencode(".png", PICTURE)[1].tobytes()
    assert truncation(jpeg) is None and truncation(png) is None
    assert truncation(jpeg + b"camera's own trailer") is None
    assert truncation(jpeg[:-2]) == "truncated: the JPEG ends before its end-of-image marker"
    assert truncation(jpeg[: len(jpeg) // 2]) == "truncated: the JPEG ends before its end-of-image marker"
    assert truncation(png[:-12]) == "truncated: the PNG ends before its IEND chunk"
    # The EXIF thumbnail's own end marker, before the main image's scan, does not make a cut file whole.
    exif = b"Exif\x00\x00\xff\xd8" + b"\x00" * 50 + b"\xff\xd9"
    whole = jpeg_header(64, 48, exif)
    assert truncation(whole) is None and truncation(whole[:-2]) is not None
    assert truncation(cv2.imencode(".bmp", PICTURE)[1].tobytes()[:100]) is None  # other formats: the decoder says


def test_many_tiny_segments_end_in_bounded_time():
    data = b"\xff\xd8" + b"\xff\xfe\x00\x02" * 200_000 + b"\xff\xc0\x00\x0b\x08\x00\x10\x00\x10\x01\x01\x11\x00"
    started = time.thread_time()  # CPU time of this thread: a loaded machine cannot fail it
    with pytest.raises(InputError, match="no image data within the first 65,536 markers"):
        image_size(data)
    assert time.thread_time() - started < 2.0


MAGICS = [b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR", b"\xff\xd8", b"\xff\xd8\xff\xe1", b"BM", b"II*\x00", b"MM\x00*",
          b"II+\x00", b"RIFF\x00\x00\x00\x00WEBPVP8 ", b"RIFF\x00\x00\x00\x00WEBPVP8X", b"GIF89a", b"P5\n", b"P7\n",
          b"PF\n", b"#?RADIANCE\n", b"\x59\xa6\x6a\x95"]


@settings(max_examples=400, deadline=500, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(MAGICS), st.binary(max_size=600))
def test_hostile_bytes_give_a_size_none_or_an_input_error_fast(magic, tail):
    data = magic + tail
    try:
        size = image_size(data)
    except InputError:
        return
    assert size is None or (size[0] > 0 and size[1] > 0)
    truncation(data)  # never raises


def test_offsets_past_the_end_of_a_file_are_a_short_header_not_a_crash(tmp_path):
    path = tmp_path / "far.tif"
    path.write_bytes(b"II+\x00" + struct.pack("<HHQ", 8, 0, 2**64 - 1))  # BigTIFF pointing 16 EB away
    with pytest.raises(InputError, match=r"far\.tif: not a readable TIFF image: the header ends early"):
        image_size(path)
