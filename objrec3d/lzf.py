"""LZF decompression in pure Python, for PCD files saved as ``binary_compressed``.

PCL compresses with liblzf; no LZF package ships with NumPy or Open3D's Python API, and the format is a
few lines: control bytes below 32 introduce a run of literals, the others a back reference.
"""

from __future__ import annotations


class LZFError(ValueError):
    """The compressed data is corrupt or truncated."""


def lzf_decompress(data: bytes | memoryview, expected_size: int) -> bytes:
    """Decompress ``data`` to exactly ``expected_size`` bytes, or raise LZFError saying where it failed."""
    out = bytearray(expected_size)
    src = bytes(data)
    ip = op = 0
    n = len(src)
    try:
        while ip < n:
            ctrl = src[ip]
            ip += 1
            if ctrl < 32:  # literal run of ctrl + 1 bytes
                length = ctrl + 1
                if ip + length > n or op + length > expected_size:
                    raise LZFError(f"literal run at byte {ip - 1} runs past the end")
                out[op : op + length] = src[ip : ip + length]
                ip += length
                op += length
                continue
            length = ctrl >> 5
            ref = op - ((ctrl & 0x1F) << 8) - 1
            if length == 7:
                length += src[ip]
                ip += 1
            ref -= src[ip]
            ip += 1
            length += 2
            if ref < 0 or op + length > expected_size:
                raise LZFError(f"back reference at byte {ip} points outside the data")
            distance = op - ref
            if distance >= length:
                out[op : op + length] = out[ref : ref + length]
            else:  # overlapping copy repeats the last `distance` bytes
                pattern = bytes(out[ref:op])
                out[op : op + length] = (pattern * (length // distance + 1))[:length]
            op += length
    except IndexError:
        raise LZFError("compressed data ends in the middle of a back reference") from None
    if op != expected_size:
        raise LZFError(f"decompressed to {op} bytes, the header promised {expected_size}")
    return bytes(out)


def lzf_store(data: bytes) -> bytes:
    """A valid LZF stream that stores ``data`` uncompressed (literal runs only); for writing test files."""
    chunks = []
    for start in range(0, len(data), 32):
        chunk = data[start : start + 32]
        chunks.append(bytes([len(chunk) - 1]) + chunk)
    return b"".join(chunks)
