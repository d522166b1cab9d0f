#!/usr/bin/env python3
"""Hostile assets: image files, image URIs, samplers, buffers and bake outputs as a hostile user
would make them, each run against the penumbra CLI and checked against its contract.

    hostile_assets.py PENUMBRA_CLI OUT_DIR [--jobs N] [--timeout S] [--only PATTERN] [--list]
                      [--markdown FILE] [--json FILE] [--keep] [--mem-limit GIB] [--quiet]

The contract: exit 0 (success), 2 (bad input: one error line naming the file and the place, no
output written) or 1 (a run-time failure); never a signal, a hang or partial output. Each case
states what it expects (the "expected" column):

    refuse  exit 2, exactly one "error:" line on stderr that names the scene or a file beside it
            (the messages cases: the image file and the material), nothing written
    accept  exit 0, its outputs there (a PFM: every pixel finite), and the property the case
            states: a colour, a texture or MASK in the baked glTF, valid URIs, ...
    either  0 or 2 (each as above), within the case's time and memory bounds, without a leak

Exit 1, a signal or a timeout is a breach in every case. On top of that, per case: a canary's
random bytes in no file written (render, bake, --web; .bin included) and no exit 0 after the CLI
read the canary (inotify IN_ACCESS on it); no absolute path or working folder in a bake; two
renders byte-identical; --dry-run agreeing with the run; a bake not failing after it solved;
baked URIs valid RFC 3986 references to files in the bake, the bake rendering again; bake.json and
the page only naming files inside the web folder; peak RSS (GNU time's %M of the CLI itself, else
os.wait4) under 1 GiB (2.5 GiB for decode bombs and many textures); refusals of bombs within
10 s; the 150,000-scan JPEG within 30 s.

Colours: the textured quad emits its texture (nothing else lights it), so the mean of the middle
of the PFM must be the texel's sRGB-decoded value within 0.02 + 5 % per channel (lossy WebP:
twice that). Stated expectations where the format allows a choice: a CMYK JPEG is read (not
black) or refused naming the file; a PNG with a bad CRC is refused, or read with a warning naming
the file (silence is a breach); a string wrapS or a texCoord of 2^32 + 1 is refused; an unused
image outside the asset folder is left unread (or the file refused); a used one is refused. JSON
and MTL textures outside the scene's folder are the user's own choice (either), but their bake
must not point outside its folder.

Every run is killed with its process group after --timeout seconds (FIFO cases: 20 s); its
address space is limited to --mem-limit GiB (default 8) so that a decode bomb cannot take the
machine (a run that hits the limit still shows as a breach). Each case lives in
OUT_DIR/cases/ID with a repro.sh; a case that holds is deleted, a breach keeps its inputs (its
outputs are deleted unless --keep). FIFOs are removed (repro.sh makes them again).

Prints a table by category (cases, refused with exit 2, held: exit 0 with the property checked,
breaches, skipped) and every breach with its reproducer; writes every case's record (expected
class, exit code, signal, seconds, peak RSS, stderr's first line, failed checks) to
OUT_DIR/results.json, and the table and records as Markdown with --markdown; exits 1 when there
is a breach. Standard library only; WebP files come from libwebp through ctypes (or cwebp), and
the WebP cases are skipped, saying so, where neither is installed.
"""
import argparse
import base64
import collections
import concurrent.futures
import ctypes
import ctypes.util
import fnmatch
import json
import math
import os
import re
import resource
import secrets
import shlex
import shutil
import signal
import stat
import struct
import subprocess
import sys
import threading
import time
import zlib

MiB = 1 << 20
GiB = 1 << 30

# ================================================================================================
# Image encoders (standard library only)
# ================================================================================================


def png_chunk(tag, data, bad_crc=False):
    crc = zlib.crc32(tag + data) & 0xFFFFFFFF
    if bad_crc:
        crc ^= 0xDEADBEEF
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)


PNG_SIG = b"\x89PNG\r\n\x1a\n"
CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}


def pack_samples(samples, bit_depth):
    """A row of samples (ints) packed as PNG stores them."""
    if bit_depth == 8:
        return bytes(samples)
    if bit_depth == 16:
        return struct.pack(">%dH" % len(samples), *samples)
    per = 8 // bit_depth
    out = bytearray()
    for i in range(0, len(samples), per):
        b = 0
        group = samples[i:i + per]
        for j, s in enumerate(group):
            b |= (s & ((1 << bit_depth) - 1)) << (8 - bit_depth * (j + 1))
        out.append(b)
    return bytes(out)


ADAM7 = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
         (0, 1, 1, 2)]


def png(width, height, pixel, color_type=2, bit_depth=8, plte=None, trns=None, interlace=False,
        bad_crc=(), extra=()):
    """A PNG from pixel(x, y) -> tuple of samples (as many as the colour type has).
    bad_crc: names of chunks ("IHDR", "IDAT", "IEND", "PLTE") written with a wrong CRC."""
    raw = bytearray()
    if interlace:
        for x0, y0, dx, dy in ADAM7:
            xs = list(range(x0, width, dx))
            ys = list(range(y0, height, dy))
            if not xs or not ys:
                continue
            for y in ys:
                row = [s for x in xs for s in pixel(x, y)]
                raw += b"\0" + pack_samples(row, bit_depth)
    else:
        for y in range(height):
            row = [s for x in range(width) for s in pixel(x, y)]
            raw += b"\0" + pack_samples(row, bit_depth)
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 1 if interlace else 0)
    out = PNG_SIG + png_chunk(b"IHDR", ihdr, "IHDR" in bad_crc)
    for tag, data in extra:
        out += png_chunk(tag, data)
    if plte is not None:
        out += png_chunk(b"PLTE", b"".join(bytes(c) for c in plte), "PLTE" in bad_crc)
    if trns is not None:
        out += png_chunk(b"tRNS", trns)
    out += png_chunk(b"IDAT", zlib.compress(bytes(raw), 9), "IDAT" in bad_crc)
    out += png_chunk(b"IEND", b"", "IEND" in bad_crc)
    return out


def solid_png(rgb, size=8, alpha=None):
    if alpha is None:
        return png(size, size, lambda x, y: rgb, 2)
    return png(size, size, lambda x, y: tuple(rgb) + (alpha,), 6)


def adler32_combine(a1, a2, len2):
    base = 65521
    rem = len2 % base
    sum1 = a1 & 0xFFFF
    sum2 = (rem * sum1) % base
    sum1 += (a2 & 0xFFFF) + base - 1
    sum2 += ((a1 >> 16) & 0xFFFF) + ((a2 >> 16) & 0xFFFF) + base - rem
    if sum1 >= base:
        sum1 -= base
    if sum1 >= base:
        sum1 -= base
    if sum2 >= (base << 1):
        sum2 -= (base << 1)
    if sum2 >= base:
        sum2 -= base
    return sum1 | (sum2 << 16)


def _raw_deflate(data, final=False):
    co = zlib.compressobj(9, zlib.DEFLATED, -15, 9)
    return co.compress(data) + co.flush(zlib.Z_FINISH if final else zlib.Z_FULL_FLUSH)


def big_png(path, width, height, color_type, bit_depth, row_samples, plte=None, first_row=None,
            extra=()):
    """Writes a PNG of any size whose rows are all `row_samples` (the first may differ) without
    holding its pixels: one block of rows is deflated once and repeated (each block ends with a
    full flush, so the copies are independent), the Adler-32 combined arithmetically."""
    line = b"\0" + pack_samples(row_samples, bit_depth)
    rows_per_block = max(1, min(height, (4 * MiB) // len(line)))
    block = line * rows_per_block
    block_z = _raw_deflate(block)
    block_adler = zlib.adler32(block)
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(PNG_SIG + png_chunk(b"IHDR", ihdr))
        for tag, data in extra:
            f.write(png_chunk(tag, data))
        if plte is not None:
            f.write(png_chunk(b"PLTE", b"".join(bytes(c) for c in plte)))
        pieces = [b"\x78\xda"]
        adler = 1
        rows_left = height
        if first_row is not None:
            first = b"\0" + pack_samples(first_row, bit_depth)
            pieces.append(_raw_deflate(first))
            adler = zlib.adler32(first, adler)
            rows_left -= 1
        full, rest = divmod(rows_left, rows_per_block)
        pending = bytearray()
        for p in pieces:
            pending += p

        def flush_pending(force=False):
            while len(pending) >= MiB or (force and pending):
                f.write(png_chunk(b"IDAT", bytes(pending[:MiB])))
                del pending[:MiB]

        for _ in range(full):
            pending += block_z
            adler = adler32_combine(adler, block_adler, len(block))
            flush_pending()
        tail = line * rest
        pending += _raw_deflate(tail, final=True)
        adler = adler32_combine(adler, zlib.adler32(tail), len(tail))
        pending += struct.pack(">I", adler)
        flush_pending(force=True)
        f.write(png_chunk(b"IEND", b""))


def bmp24(width, height, pixel, top_down=False):
    """A 24-bit BMP from pixel(x, y) -> (r, g, b), y = 0 the top row."""
    stride = (width * 3 + 3) & ~3
    rows = []
    for y in range(height):
        row = bytearray()
        for x in range(width):
            r, g, b = pixel(x, y)
            row += bytes((b, g, r))
        row += b"\0" * (stride - len(row))
        rows.append(bytes(row))
    if not top_down:
        rows.reverse()
    data = b"".join(rows)
    h = -height if top_down else height
    header = struct.pack("<2sIHHI", b"BM", 54 + len(data), 0, 0, 54)
    dib = struct.pack("<IiiHHIIiiII", 40, width, h, 1, 24, 0, len(data), 2835, 2835, 0, 0)
    return header + dib + data


def bmp32(width, height, pixel):
    """A 32-bit BI_RGB BMP (BGRA), bottom-up, pixel -> (r, g, b, a)."""
    rows = []
    for y in range(height):
        row = bytearray()
        for x in range(width):
            r, g, b, a = pixel(x, y)
            row += bytes((b, g, r, a))
        rows.append(bytes(row))
    rows.reverse()
    data = b"".join(rows)
    header = struct.pack("<2sIHHI", b"BM", 54 + len(data), 0, 0, 54)
    dib = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 32, 0, len(data), 2835, 2835, 0, 0)
    return header + dib + data


def bmp_header_only(width, height):
    """54 bytes: a 24-bit BMP header claiming width x height, and no pixel data."""
    header = struct.pack("<2sIHHI", b"BM", 54, 0, 0, 54)
    dib = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 2835, 2835, 0, 0)
    return header + dib


def bmp_rle8(width, height, index=1, palette=((0, 0, 0), (200, 40, 40))):
    """An 8-bit RLE (BI_RLE8) BMP, every pixel `index`."""
    pal = b"".join(bytes((b, g, r, 0)) for r, g, b in palette)
    pal += b"\0\0\0\0" * (256 - len(palette))
    data = bytearray()
    for _ in range(height):
        left = width
        while left > 0:
            n = min(255, left)
            data += bytes((n, index))
            left -= n
        data += b"\0\0"
    data += b"\0\1"
    off = 54 + len(pal)
    header = struct.pack("<2sIHHI", b"BM", off + len(data), 0, 0, off)
    dib = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 8, 1, len(data), 2835, 2835, 256, 0)
    return header + dib + pal + bytes(data)


def tga(width, height, pixel, top_down=True, rle=False):
    """A 24-bit TGA, pixel(x, y) -> (r, g, b), y = 0 the top row."""
    head = struct.pack("<BBBHHBHHHHBB", 0, 0, 10 if rle else 2, 0, 0, 0, 0, 0, width, height, 24,
                       0x20 if top_down else 0)
    order = range(height) if top_down else range(height - 1, -1, -1)
    data = bytearray()
    for y in order:
        row = [pixel(x, y) for x in range(width)]
        if rle:
            x = 0
            while x < width:
                n = 1
                while x + n < width and n < 128 and row[x + n] == row[x]:
                    n += 1
                r, g, b = row[x]
                data += bytes((0x80 | (n - 1), b, g, r))
                x += n
        else:
            for r, g, b in row:
                data += bytes((b, g, r))
    return head + bytes(data)


def tga_header_only(width, height):
    return struct.pack("<BBBHHBHHHHBB", 0, 0, 2, 0, 0, 0, 0, 0, width, height, 24, 0x20)


# --- JPEG: baseline (and a progressive bomb) whose every block is flat -------------------------


def _seg(marker, payload):
    return b"\xff" + bytes((marker,)) + struct.pack(">H", len(payload) + 2) + payload


def _dht(table_class, table_id, symbols_by_length):
    counts = bytes(len(symbols_by_length.get(n, [])) for n in range(1, 17))
    symbols = b"".join(bytes(symbols_by_length.get(n, [])) for n in range(1, 17))
    return _seg(0xC4, bytes(((table_class << 4) | table_id,)) + counts + symbols)


def _category(v):
    return 0 if v == 0 else abs(v).bit_length()


def _bits_of(v, cat):
    if cat == 0:
        return ""
    if v < 0:
        v = v + (1 << cat) - 1
    return format(v, "0%db" % cat)


def jpeg_flat(width, height, values, precision=8, adobe=None, sof=0xC0, app=()):
    """A JPEG with one flat value per component (values: 1 grey, 3 YCbCr, 4 CMYK), no
    subsampling, quantisation 1 for DC: every block decodes to its component's value exactly.
    Huffman tables of one-bit codes make every block after the first two zero bits, so a
    16384 x 16384 grey image is 1 MiB. adobe: the APP14 transform flag (0 CMYK, 1 YCbCr)."""
    nc = len(values)
    shift = 1 << (precision - 1)
    dcs = [8 * (v - shift) for v in values]
    cats = sorted({_category(d) for d in dcs} - {0})
    by_len = {1: [0]}
    for i, c in enumerate(cats):
        by_len[i + 2] = [c]
    code = {}
    # canonical codes: length 1 -> '0', length k -> '1'*(k-1) + '0'
    for length, syms in by_len.items():
        code[syms[0]] = "1" * (length - 1) + "0"
    out = b"\xff\xd8"
    out += _seg(0xE0, b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0")
    for marker, payload in app:
        out += _seg(marker, payload)
    if adobe is not None:
        out += _seg(0xEE, b"Adobe" + struct.pack(">HHHB", 100, 0, 0, adobe))
    if precision == 8:
        out += _seg(0xDB, b"\x00" + b"\x01" * 64)
    else:
        out += _seg(0xDB, b"\x10" + b"\x00\x01" * 64)
    comps = b"".join(bytes((i + 1, 0x11, 0)) for i in range(nc))
    out += _seg(sof, bytes((precision,)) + struct.pack(">HH", height, width) + bytes((nc,)) + comps)
    out += _dht(0, 0, by_len)
    out += _dht(1, 0, {1: [0]})
    out += _seg(0xDA, bytes((nc,)) + b"".join(bytes((i + 1, 0)) for i in range(nc)) + b"\x00\x3f\x00")
    first = "".join(code[_category(d)] + _bits_of(d, _category(d)) + "0" for d in dcs)
    blocks = ((width + 7) // 8) * ((height + 7) // 8)
    total_bits = len(first) + (blocks - 1) * 2 * nc
    head_bits = first + "0" * ((-len(first)) % 8)
    head = int(head_bits, 2).to_bytes(len(head_bits) // 8, "big") if head_bits else b""
    head = head.replace(b"\xff", b"\xff\x00")
    zero_bytes = (total_bits - len(head_bits)) // 8 if total_bits > len(head_bits) else 0
    tail_bits = total_bits - len(head_bits) - 8 * zero_bytes
    entropy = head + b"\0" * zero_bytes
    if tail_bits > 0:
        entropy += bytes((((1 << (8 - tail_bits)) - 1),))  # the rest padded with ones
    return out + entropy + b"\xff\xd9"


def jpeg_sos_bomb(width, height, scans):
    """A progressive grey JPEG with `scans` empty DC scans (each SOS straight after the last)."""
    out = b"\xff\xd8" + _seg(0xDB, b"\x00" + b"\x01" * 64)
    out += _seg(0xC2, bytes((8,)) + struct.pack(">HH", height, width) + b"\x01\x01\x11\x00")
    out += _dht(0, 0, {1: [0]})
    sos = _seg(0xDA, b"\x01\x01\x00\x00\x00\x00")
    return out + sos * scans + b"\xff\xd9"


def ycbcr(rgb):
    r, g, b = rgb
    y = 0.299 * r + 0.587 * g + 0.114 * b
    cb = 128 - 0.168736 * r - 0.331264 * g + 0.5 * b
    cr = 128 + 0.5 * r - 0.418688 * g - 0.081312 * b
    return tuple(max(0, min(255, int(round(v)))) for v in (y, cb, cr))


def rgb_of_ycbcr(v):
    y, cb, cr = v
    r = y + 1.402 * (cr - 128)
    g = y - 0.344136 * (cb - 128) - 0.714136 * (cr - 128)
    b = y + 1.772 * (cb - 128)
    return tuple(max(0, min(255, round(c))) for c in (r, g, b))


# --- WebP through libwebp (ctypes), else cwebp -------------------------------------------------

_WEBP = None


def _webp_lib():
    global _WEBP
    if _WEBP is None:
        _WEBP = False
        for name in (ctypes.util.find_library("webp"), "libwebp.so.7", "libwebp.so"):
            if not name:
                continue
            try:
                lib = ctypes.CDLL(name)
                lib.WebPEncodeRGB.restype = ctypes.c_size_t
                lib.WebPEncodeLosslessRGB.restype = ctypes.c_size_t
                _WEBP = lib
                break
            except OSError:
                continue
    return _WEBP


def webp_available():
    return bool(_webp_lib()) or bool(shutil.which("cwebp"))


def webp(width, height, rgb, lossless, quality=90.0):
    """A one-colour WebP (or None when neither libwebp nor cwebp is there)."""
    lib = _webp_lib()
    data = bytes(rgb) * (width * height)
    if lib:
        buf = ctypes.create_string_buffer(data, len(data))
        out = ctypes.POINTER(ctypes.c_uint8)()
        if lossless:
            n = lib.WebPEncodeLosslessRGB(buf, width, height, width * 3, ctypes.byref(out))
        else:
            n = lib.WebPEncodeRGB(buf, width, height, width * 3, ctypes.c_float(quality),
                                  ctypes.byref(out))
        if not n:
            return None
        result = ctypes.string_at(out, n)
        try:
            lib.WebPFree(out)
        except AttributeError:
            pass
        return result
    if shutil.which("cwebp"):
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            src = os.path.join(d, "in.png")
            dst = os.path.join(d, "out.webp")
            with open(src, "wb") as f:
                f.write(png(width, height, lambda x, y: tuple(rgb)))
            args = ["cwebp", "-quiet"] + (["-lossless"] if lossless else ["-q", str(quality)])
            subprocess.run(args + [src, "-o", dst], check=True)
            with open(dst, "rb") as f:
                return f.read()
    return None


def webp_header_only(width, height):
    """A VP8L (lossless) header claiming width x height, and nothing after it."""
    bits = (width - 1) | ((height - 1) << 14) | (0 << 28) | (0 << 29)
    vp8l = b"\x2f" + struct.pack("<I", bits)
    chunk = b"VP8L" + struct.pack("<I", len(vp8l)) + vp8l + b"\0" * (len(vp8l) % 2)
    return b"RIFF" + struct.pack("<I", 4 + len(chunk)) + b"WEBP" + chunk


# --- sRGB ----------------------------------------------------------------------------------------


def srgb_to_linear(c8):
    c = c8 / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


# ================================================================================================
# Scene builders
# ================================================================================================

MATERIAL = "HostileMaterial"  # every case's textured material: errors must name it

# A quad over [-1, 1]^2 at z = 0 facing +z, UV (0, 0) at the top left (glTF), and a camera at
# z = 2.2 whose view it fills; the material emits its texture, so a pixel is the texel's linear
# value (nothing else lights the scene).
QUAD_POS = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
QUAD_UV = [(0, 1), (1, 1), (1, 0), (0, 0)]


def quad_geometry():
    """(bytes, bufferViews, accessors) of the quad: POSITION 0, NORMAL 1, TEXCOORD_0 2,
    indices 3, in buffer 0."""
    pos = b"".join(struct.pack("<3f", *p) for p in QUAD_POS)
    nrm = b"".join(struct.pack("<3f", 0, 0, 1) for _ in range(4))
    uv = b"".join(struct.pack("<2f", *t) for t in QUAD_UV)
    idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\0\0"
    data = pos + nrm + uv + idx
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962},
             {"buffer": 0, "byteOffset": 48, "byteLength": 48, "target": 34962},
             {"buffer": 0, "byteOffset": 96, "byteLength": 32, "target": 34962},
             {"buffer": 0, "byteOffset": 128, "byteLength": 12, "target": 34963}]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                  "min": [-1, -1, 0], "max": [1, 1, 0]},
                 {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                 {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                 {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    return data, views, accessors


def textured_material(texture=0, emissive=True, alpha_mode=None, cutoff=None, normal=None):
    m = {"name": MATERIAL, "doubleSided": True,
         "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0,
                                  "roughnessFactor": 1}}
    if texture is not None:
        m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": texture}
        if emissive:
            m["emissiveFactor"] = [1, 1, 1]
            m["emissiveTexture"] = {"index": texture}
    if alpha_mode:
        m["alphaMode"] = alpha_mode
    if cutoff is not None:
        m["alphaCutoff"] = cutoff
    if normal is not None:
        m["normalTexture"] = {"index": normal}
    return m


def gltf_doc(images=(), textures=None, samplers=None, materials=None, light=False):
    """A glTF document (dict) and its binary buffer. images: dicts with "uri" or "embed" (bytes,
    put in a bufferView of buffer 0) plus any other keys; textures default to one per image
    (texture i -> image i) when None; the material defaults to one that uses texture 0 (when
    there is an image) as base colour and emission."""
    data, views, accessors = quad_geometry()
    data = bytearray(data)
    imgs = []
    for im in images:
        im = dict(im)
        if "embed" in im:
            blob = im.pop("embed")
            while len(data) % 4:
                data.append(0)
            views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
            data += blob
            im["bufferView"] = len(views) - 1
            im.setdefault("mimeType", "image/png")
        imgs.append(im)
    while len(data) % 4:
        data.append(0)
    if textures is None:
        textures = [{"source": i} for i in range(len(imgs))][:1]
    if materials is None:
        materials = [textured_material(0 if textures else None)]
    doc = {
        "asset": {"version": "2.0", "generator": "hostile_assets.py"},
        "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 2.2]}],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.8, "aspectRatio": 1.0, "znear": 0.01,
                                     "zfar": 100}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 0}]}],
        "materials": materials,
        "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": len(data)}],
    }
    if imgs:
        doc["images"] = imgs
    if textures:
        doc["textures"] = textures
    if samplers is not None:
        doc["samplers"] = samplers
    if light:
        doc["extensionsUsed"] = ["KHR_lights_punctual"]
        doc["extensions"] = {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 1, 1], "intensity": 500}]}}
        doc["nodes"].append({"translation": [0, 0, 1.5],
                             "extensions": {"KHR_lights_punctual": {"light": 0}}})
        doc["scenes"][0]["nodes"].append(2)
    return doc, bytes(data)


def glb_bytes(doc, binary, json_len=None, bin_len=None, total_len=None, bin_type=b"BIN\0",
              version=2, extra_chunks=b"", drop_bin=False):
    """A GLB container; the *_len arguments write lies into its header and chunk headers."""
    js = json.dumps(doc).encode()
    js += b" " * ((-len(js)) % 4)
    binary = binary + b"\0" * ((-len(binary)) % 4)
    body = struct.pack("<I4s", len(js) if json_len is None else json_len, b"JSON") + js
    if not drop_bin:
        body += struct.pack("<I4s", len(binary) if bin_len is None else bin_len, bin_type) + binary
    body += extra_chunks
    total = 12 + len(body)
    return struct.pack("<4sII", b"glTF", version, total if total_len is None else total_len) + body


def write_gltf(directory, name, doc, binary, form="gltf", bin_name=None):
    """Writes doc + binary as `name` in `directory`: form "gltf" (an external .bin),
    "embedded" (a data URI buffer) or "glb". Returns the scene's path."""
    doc = json.loads(json.dumps(doc))
    path = os.path.join(directory, name)
    if form == "glb":
        with open(path, "wb") as f:
            f.write(glb_bytes(doc, binary))
        return path
    if form == "embedded":
        doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                    base64.b64encode(binary).decode())
    else:
        bin_name = bin_name or (os.path.splitext(name)[0] + ".bin")
        doc["buffers"][0]["uri"] = uri_quote(bin_name)
        with open(os.path.join(directory, bin_name), "wb") as f:
            f.write(binary)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1, ensure_ascii=False)
    return path


def uri_quote(name):
    """A file name as an RFC 3986 relative reference (path segments percent-encoded)."""
    safe = set(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-._~/")
    out = "".join(chr(b) if b in safe else "%%%02X" % b for b in name.encode("utf-8"))
    return out


# OBJ: the same quad, facing +z (the side the default camera of an OBJ looks from), with UVs and
# the material from quad.mtl.
def quad_obj(mtl="quad.mtl", material=MATERIAL, two_materials=False):
    s = "mtllib %s\n" % mtl if mtl else ""
    s += "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
    s += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    s += "usemtl %s\nf 1/1 2/2 3/3 4/4\n" % material
    return s


def mtl(lines, material=MATERIAL):
    return "newmtl %s\nKd 1 1 1\nKe 1 1 1\n%s\n" % (material, "\n".join(lines))


def json_scene(material, mesh="quad.obj", extra_materials=None, light=False):
    """A JSON scene of the OBJ quad with `material` (a dict) as HostileMaterial and a camera
    in front of the quad's front face (+z)."""
    mats = {MATERIAL: material}
    mats.update(extra_materials or {})
    doc = {"materials": mats,
           "meshes": [{"file": mesh, "material": MATERIAL}],
           "camera": {"position": [0, 0, 2.2], "look_at": [0, 0, 0], "up": [0, 1, 0],
                      "fov_deg": 45}}
    if light:
        doc["lights"] = [{"type": "point", "position": [0, 0, 1.5], "intensity": [3, 3, 3]}]
    return doc


def emissive_json_material(tex, key="emission_texture"):
    m = {"reflectance": [1, 1, 1], "emission": [1, 1, 1], "emission_texture": tex,
         "reflectance_texture": tex}
    return m


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() not in (b"PF", b"Pf"):
            raise ValueError("not a PFM file")
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read()
    fmt = ("<" if scale < 0 else ">") + "%df" % (3 * w * h)
    return w, h, struct.unpack(fmt, data[:4 * 3 * w * h])


def pfm_region_mean(path, x0=0.3, x1=0.7, y0=0.3, y1=0.7):
    """Mean RGB of a window of a PFM (fractions of the image, y = 0 the top)."""
    w, h, px = read_pfm(path)
    acc = [0.0, 0.0, 0.0]
    n = 0
    for row in range(int(y0 * h), max(int(y0 * h) + 1, int(y1 * h))):
        file_row = h - 1 - row  # PFM rows run bottom to top
        for x in range(int(x0 * w), max(int(x0 * w) + 1, int(x1 * w))):
            i = 3 * (file_row * w + x)
            for c in range(3):
                acc[c] += px[i + c]
            n += 1
    return tuple(a / max(n, 1) for a in acc)


# ================================================================================================
# Running the CLI
# ================================================================================================

class Skip(Exception):
    """A case that cannot be built here (the reason is reported)."""


class Run:
    def __init__(self, label, args, cwd, expect):
        self.label, self.args, self.cwd, self.expect = label, args, cwd, expect
        self.code = None
        self.signal = None
        self.timed_out = False
        self.seconds = 0.0
        self.rss_mb = 0.0
        self.stdout = ""
        self.stderr = ""

    @property
    def error_lines(self):
        return [l for l in self.stderr.splitlines() if "error:" in l]

    @property
    def errline(self):
        lines = self.error_lines
        return lines[0] if lines else ""

    @property
    def first_line(self):
        for l in self.stderr.splitlines():
            if l.strip():
                return l.strip()
        return ""

    def outcome(self):
        if self.timed_out:
            return "timeout"
        if self.signal:
            return "signal %d" % self.signal
        return "exit %d" % self.code

    def summary(self):
        return {"label": self.label, "expect": self.expect, "exit": self.code,
                "signal": self.signal, "timeout": self.timed_out,
                "seconds": round(self.seconds, 2), "max_rss_mb": round(self.rss_mb, 1),
                "stderr_first_line": self.first_line[:400], "error_line": self.errline[:400],
                "args": self.args, "cwd": self.cwd}


# Peak memory: a child forked from this (large) Python process inherits its resident pages, and
# the kernel keeps that high-water mark across exec, so os.wait4's ru_maxrss would never read
# less than this script's own size. GNU time, a small process, forks the CLI and reports the
# CLI's own peak; without it the campaign falls back to wait4 (an overestimate by this script's
# size, some tens of MiB).
GNU_TIME = "/usr/bin/time" if os.access("/usr/bin/time", os.X_OK) else None


def child_pid(p):
    """The CLI's pid: GNU time's child when the run is wrapped."""
    if not GNU_TIME:
        return p.pid
    for _ in range(50):
        try:
            with open("/proc/%d/task/%d/children" % (p.pid, p.pid)) as f:
                kids = f.read().split()
            if kids:
                return int(kids[0])
        except OSError:
            return p.pid
        time.sleep(0.02)
    return p.pid


def spawn(args, cwd, timeout, mem_limit_gib, env=None, stdin_data=None, on_start=None):
    """Runs args in its own process group; kills the group after `timeout` s. Returns
    (exit code or None, signal or None, timed out, seconds, max RSS MiB, stdout, stderr)."""
    import tempfile
    rss_file = None
    if GNU_TIME:
        fd, rss_file = tempfile.mkstemp(prefix="penumbra-rss-")
        os.close(fd)
        args = [GNU_TIME, "-f", "%M", "-o", rss_file] + list(args)

    def limits():
        if mem_limit_gib:
            lim = int(mem_limit_gib * GiB)
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))

    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        started = time.monotonic()
        p = subprocess.Popen(args, cwd=cwd, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                             start_new_session=True, preexec_fn=limits, env=env)
        killed = threading.Event()

        def kill():
            killed.set()
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass

        timer = threading.Timer(timeout, kill)
        timer.daemon = True
        timer.start()
        if on_start:
            on_start(p)
        while True:
            try:
                _, status, usage = os.wait4(p.pid, 0)
                break
            except InterruptedError:
                continue
        timer.cancel()
        seconds = time.monotonic() - started
        try:
            os.killpg(p.pid, signal.SIGKILL)  # anything the run left behind
        except OSError:
            pass
        p.returncode = status  # keep Popen from waiting again
        code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else None
        sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
        rss = usage.ru_maxrss / 1024.0
        if rss_file:
            try:
                with open(rss_file) as f:
                    lines = f.read().splitlines()
                os.remove(rss_file)
                m = [re.match(r"Command terminated by signal (\d+)", l) for l in lines]
                m = [x for x in m if x]
                if m:
                    sig, code = int(m[0].group(1)), None
                if lines and lines[-1].strip().isdigit():
                    rss = int(lines[-1]) / 1024.0
            except OSError:
                pass
        out.seek(0)
        err.seek(0)
        return (code, sig, killed.is_set(), seconds, rss,
                out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "replace"))


class Inotify:
    """Whether a file was opened or read (inotify through libc), to tell 'read the canary'
    from 'left it alone' even when nothing of it reaches an output."""
    IN_ACCESS, IN_OPEN = 0x1, 0x20

    def __init__(self, path):
        self.fd = -1
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            self.fd = libc.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
            if self.fd >= 0:
                if libc.inotify_add_watch(self.fd, os.fsencode(path),
                                          self.IN_ACCESS | self.IN_OPEN) < 0:
                    os.close(self.fd)
                    self.fd = -1
        except (OSError, AttributeError):
            self.fd = -1
        self.opened = False
        self.read = False

    def poll(self):
        if self.fd < 0:
            return
        while True:
            try:
                data = os.read(self.fd, 65536)
            except BlockingIOError:
                break
            except OSError:
                break
            if not data:
                break
            i = 0
            while i + 16 <= len(data):
                _, mask, _, n = struct.unpack_from("iIII", data, i)
                self.opened |= bool(mask & self.IN_OPEN)
                self.read |= bool(mask & self.IN_ACCESS)
                i += 16 + n

    def reset(self):
        self.poll()
        self.opened = self.read = False

    def close(self):
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def files_under(paths):
    for p in paths:
        if os.path.isfile(p) and not os.path.islink(p):
            yield p
        elif os.path.isdir(p):
            for root, _, names in os.walk(p):
                for n in names:
                    full = os.path.join(root, n)
                    if os.path.isfile(full) and not os.path.islink(full):
                        yield full


def find_needles(paths, needles):
    """[(file, needle name)] for every needle (bytes) found in any file under `paths`."""
    found = []
    longest = max((len(v) for v in needles.values()), default=1)
    for f in files_under(paths):
        try:
            with open(f, "rb") as fh:
                tail = b""
                hit = set()
                while True:
                    chunk = fh.read(8 * MiB)
                    if not chunk:
                        break
                    window = tail + chunk
                    for name, needle in needles.items():
                        if name not in hit and needle in window:
                            hit.add(name)
                    tail = window[-(longest - 1):] if longest > 1 else b""
                for name in sorted(hit):
                    found.append((f, name))
        except OSError:
            continue
    return found


RFC3986_REF = re.compile(r"^(?:[A-Za-z0-9\-._~!$&'()*+,;=:@/]|%[0-9A-Fa-f]{2})*$")


def uri_problem(uri):
    """Why `uri` is not a valid RFC 3986 relative reference to a file in the same folder tree
    (None when it is)."""
    if uri.startswith("data:"):
        return None
    if not RFC3986_REF.match(uri):
        return "not a percent-encoded RFC 3986 reference"
    first = uri.split("/")[0]
    if ":" in first:
        return "its first segment has ':' (read as a scheme)"
    if uri.startswith("/"):
        return "absolute path"
    segments = uri.split("/")
    if ".." in segments or "%2e%2e" in uri.lower():
        return "leaves the folder ('..')"
    return None


def uri_decode(uri):
    out = bytearray()
    i = 0
    b = uri.encode("utf-8")
    while i < len(b):
        if b[i:i + 1] == b"%" and i + 2 < len(b) + 0 and re.match(rb"[0-9A-Fa-f]{2}", b[i + 1:i + 3]):
            out.append(int(b[i + 1:i + 3], 16))
            i += 3
        else:
            out.append(b[i])
            i += 1
    return out.decode("utf-8", "replace")


class Ctx:
    """One case's folder, runs and findings."""

    def __init__(self, case, opts):
        self.case = case
        self.opts = opts
        self.cli = opts.cli
        self.dir = os.path.join(opts.out, "cases", case.id)
        if os.path.exists(self.dir):
            shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        self.runs = []
        self.failures = []
        self.notes = []
        self.repro = []
        self.n = 0
        self.watches = []

    # --- files ---
    def path(self, *parts):
        return os.path.join(self.dir, *parts)

    def rel(self, p, start=None):
        return os.path.relpath(p, start or self.dir)

    def write(self, rel, data):
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "wb" if isinstance(data, (bytes, bytearray)) else "w",
                  **({} if isinstance(data, (bytes, bytearray)) else {"encoding": "utf-8"})) as f:
            f.write(data)
        return p

    def write_json(self, rel, doc):
        return self.write(rel, json.dumps(doc, indent=1))

    def asset(self, rel, key, builder):
        """A hard link to a cached generated file (built once per campaign)."""
        src = self.opts.cache(key, builder)
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        try:
            os.link(src, p)
        except OSError:
            shutil.copyfile(src, p)
        return p

    def sparse(self, rel, size):
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "wb") as f:
            f.truncate(size)
        self.setup("[ -e {0} ] || truncate -s {1} {0}".format(shlex.quote(rel), size))
        return p

    def mkfifo(self, rel):
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        os.mkfifo(p)
        self.setup("[ -p {0} ] || mkfifo {0}".format(shlex.quote(rel)))
        return p

    def symlink(self, target, rel):
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        os.symlink(target, p)
        self.setup("[ -L {1} ] || ln -s {0} {1}".format(shlex.quote(target), shlex.quote(rel)))
        return p

    def canary(self, rel, kind="text"):
        """A file holding a unique random string; returns (path, the string's bytes)."""
        token = ("PENUMBRA-CANARY-" + secrets.token_hex(12)).encode()
        if kind == "png":
            data = png(4, 4, lambda x, y: (9, 99, 199), 2, extra=[(b"tEXt", b"Comment\0" + token)])
        else:
            data = b"root:x:0:0:" + token + b":/root:/bin/sh\n"
        p = self.write(rel, data)
        w = Inotify(p)
        self.watches.append((p, w))
        return p, token

    def watch(self, p):
        w = Inotify(p)
        self.watches.append((p, w))
        return w

    def setup(self, line):
        """A shell command that recreates what the campaign removes (FIFOs) or made specially."""
        self.repro.append(line)

    # --- findings ---
    def fail(self, msg):
        self.failures.append(msg)

    def note(self, msg):
        self.notes.append(msg)

    def check(self, cond, msg):
        if not cond:
            self.fail(msg)
        return cond

    # --- runs ---
    def run(self, args, expect, label, outputs=(), names=None, cwd=None, rss_mb=None,
            max_s=None, dry=False, pfm=(), no_outputs=False, on_start=None, timeout=None):
        """Runs the CLI with `args` and checks the contract for `expect` ("refuse", "accept",
        "either", or None: no expectation beyond no crash/hang). outputs: files or folders an
        exit 0 must leave (and an exit 2 must not); names: strings one of which the error line
        must hold (default: nothing checked)."""
        cwd = cwd or self.dir
        full = [self.cli] + list(args)
        r = Run(label, full, cwd, expect)
        for _, w in self.watches:
            w.poll()
        (r.code, r.signal, r.timed_out, r.seconds, r.rss_mb, r.stdout,
         r.stderr) = spawn(full, cwd, timeout or self.opts.timeout, self.opts.mem_limit,
                           on_start=on_start)
        self.runs.append(r)
        rc = os.path.relpath(cwd, self.dir)
        self.repro.append("(cd %s && %s)  # %s; was: %s" % (
            shlex.quote(rc), " ".join(shlex.quote(a) for a in full), label, r.outcome()))
        where = "%s: " % label
        rss_limit = rss_mb or self.case.rss_mb
        time_limit = max_s or self.case.max_s
        if r.timed_out:
            self.fail(where + "no result within %.0f s (killed)" % (timeout or self.opts.timeout))
        elif r.signal:
            self.fail(where + "killed by signal %d (%s)" % (r.signal, signal.Signals(r.signal).name
                                                             if r.signal in signal.valid_signals()
                                                             else "?"))
        elif r.code not in (0, 2) and not (r.code in (130, 143) and on_start):
            self.fail(where + "exit %d: %s" % (r.code, (r.errline or r.first_line)[:300]))
        else:
            if expect == "refuse" and r.code == 0:
                self.fail(where + "exit 0, expected a refusal (exit 2)")
            if expect == "accept" and r.code == 2:
                self.fail(where + "exit 2, expected success: %s" % r.errline[:300])
            if r.code == 2:
                n = len(r.error_lines)
                if n != 1:
                    self.fail(where + "exit 2 with %d error lines" % n)
                if names and r.errline and not any(nm in r.errline for nm in names):
                    self.fail(where + "the error line names none of %s: %s" % (
                        ", ".join(repr(x) for x in names), r.errline[:300]))
                for o in outputs:
                    if os.path.exists(o) and not (os.path.isdir(o) and not os.listdir(o)):
                        self.fail(where + "exit 2 left output %s" % self.rel(o))
            if r.code == 0:
                if dry or no_outputs:
                    for o in outputs:
                        if os.path.exists(o):
                            self.fail(where + "dry run left %s behind" % self.rel(o))
                else:
                    for o in outputs:
                        if not os.path.exists(o):
                            self.fail(where + "exit 0 without its output %s" % self.rel(o))
                    for p in pfm:
                        if os.path.exists(p):
                            try:
                                _, _, px = read_pfm(p)
                                if not all(math.isfinite(v) for v in px):
                                    self.fail(where + "non-finite pixel in %s" % self.rel(p))
                            except (ValueError, struct.error) as e:
                                self.fail(where + "unreadable image %s: %s" % (self.rel(p), e))
        for o in outputs:
            base = o if os.path.isdir(o) else os.path.dirname(o)
            for f in files_under([base]) if os.path.isdir(base) else []:
                if os.path.basename(f).startswith(".penumbra-"):
                    self.fail(where + "left a temporary file %s" % self.rel(f))
        if rss_limit and r.rss_mb > rss_limit:
            self.fail(where + "peak RSS %.0f MiB > %d MiB" % (r.rss_mb, rss_limit))
        if time_limit and r.seconds > time_limit and not r.timed_out:
            self.fail(where + "took %.1f s > %.0f s" % (r.seconds, time_limit))
        for p, w in self.watches:
            w.poll()
            if w.read and r.code == 0:
                self.fail(where + "exit 0 after reading %s (outside the asset)" % self.rel(p))
            w.reset()
        return r

    def out(self, name):
        self.n += 1
        d = self.path("out")
        os.makedirs(d, exist_ok=True)
        base, ext = os.path.splitext(name)
        return os.path.join(d, "%s-%d%s" % (base, self.n, ext))

    def render(self, scene, expect, method="pathtrace", extra=(), names=None, cwd=None,
               label=None, fmt=".pfm", dry=False, rss_mb=None, max_s=None, out=None,
               timeout=None):
        out = out or self.out("render" + fmt)
        cwd = cwd or self.dir
        args = ["render", scene if os.path.isabs(scene) else os.path.relpath(
                    self.path(scene), cwd),
                "--method", method, "--width", "32", "--height", "32", "--device", "cpu",
                "-o", out]
        args += defaults_without(METHOD_ARGS.get(method, []), extra)
        if dry:
            args.append("--dry-run")
        args += list(extra)
        r = self.run(args, expect, label or ("render %s%s" % (method, " --dry-run" if dry else "")),
                     outputs=[out], names=self.default_names(scene, names), cwd=cwd,
                     rss_mb=rss_mb, max_s=max_s, dry=dry, pfm=[out] if fmt == ".pfm" else [],
                     timeout=timeout)
        r.image = out
        return r

    def bake(self, scene, expect, web=None, dry=False, method="matrix", extra=(), names=None,
             cwd=None, label=None, out=None, rss_mb=None, max_s=None, on_start=None,
             timeout=None):
        out = out or self.out("bake")
        cwd = cwd or self.dir
        args = ["bake", scene if os.path.isabs(scene) else os.path.relpath(self.path(scene), cwd),
                "-o", out, "--method", method]
        args += defaults_without(BAKE_ARGS.get(method, []), extra)
        if web:
            args += ["--web", web]
        if dry:
            args.append("--dry-run")
        args += list(extra)
        outputs = [out] + ([web] if web else [])
        r = self.run(args, expect,
                     label or ("bake%s%s" % (" --web" if web else "", " --dry-run" if dry else "")),
                     outputs=outputs, names=self.default_names(scene, names), cwd=cwd,
                     rss_mb=rss_mb, max_s=max_s, dry=dry, on_start=on_start, timeout=timeout)
        r.bake_dir = out
        r.web_dir = web
        return r

    def default_names(self, scene, names):
        """What an error line may name: the scene, or any file beside it (a mesh, an MTL, an
        image), unless the case says."""
        if names is not None:
            return names
        full = scene if os.path.isabs(scene) else self.path(scene)
        out = [os.path.basename(scene)]
        try:
            out += [n for n in os.listdir(os.path.dirname(full)) if len(n) > 2]
        except OSError:
            pass
        return out

    def baked_gltf(self, r):
        """The .gltf a bake run wrote (or None)."""
        if not os.path.isdir(r.bake_dir):
            return None
        for n in sorted(os.listdir(r.bake_dir)):
            if n.endswith(".gltf"):
                return os.path.join(r.bake_dir, n)
        return None

    def finish(self):
        for p, w in self.watches:
            w.close()
        with open(self.path("repro.sh"), "w", encoding="utf-8") as f:
            f.write("#!/bin/sh\n# %s [%s] %s\n# expected: %s\n" % (
                self.case.id, self.case.category, self.case.title, self.case.expect))
            f.write('cd "$(dirname "$0")" && mkdir -p out\n')
            for line in self.repro:
                f.write(line + "\n")


def defaults_without(defaults, extra):
    """The default options (pairs) that `extra` does not give itself."""
    out = []
    for i in range(0, len(defaults), 2):
        if defaults[i] not in extra:
            out += defaults[i:i + 2]
    return out


# Quick settings for every method (a case is about its input, not about the solver).
METHOD_ARGS = {
    "pathtrace": ["--spp", "2"],
    "progressive": ["--elements", "400", "--iterations", "50"],
    "stochastic": ["--elements", "400", "--iterations", "20"],
    "matrix": ["--elements", "100"],
}
BAKE_ARGS = {
    "matrix": ["--elements", "100"],
    "progressive": ["--elements", "400", "--iterations", "50"],
}


# ================================================================================================
# Cases
# ================================================================================================

class Case:
    def __init__(self, cid, category, title, expect, fn, heavy=False, rss_mb=1024, max_s=None):
        self.id, self.category, self.title, self.expect = cid, category, title, expect
        self.fn, self.heavy, self.rss_mb, self.max_s = fn, heavy, rss_mb, max_s


CASES = []


def add(cid, category, title, expect, fn, heavy=False, rss_mb=1024, max_s=None):
    assert not any(c.id == cid for c in CASES), cid
    CASES.append(Case(cid, category, title, expect, fn, heavy, rss_mb, max_s))


RED = (200, 40, 40)
BLUE = (30, 60, 200)
GREEN = (40, 180, 60)
TEAL = (30, 160, 220)
GREY = (128, 128, 128)
FLAT_NORMAL = (128, 128, 255)

# Colour checks: the render is a PFM of linear radiance; the textured quad emits its texture, so
# the mean over the middle of the image must be the texel's sRGB-decoded value within
# COLOUR_ABS + COLOUR_REL * value per channel (lossy formats: twice that).
COLOUR_ABS = 0.02
COLOUR_REL = 0.05


def std_scene(ctx, images, form="gltf", name="scene.gltf", sub="asset", mutate=None, **kw):
    """The textured quad as glTF with `images`; mutate(doc, binary) may change the document in
    place and return a new binary (or None). Returns the scene's path relative to the case."""
    doc, binary = gltf_doc(images, **kw)
    if mutate:
        b = mutate(doc, binary)
        if b is not None:
            binary = b
    d = ctx.path(sub)
    os.makedirs(d, exist_ok=True)
    return ctx.rel(write_gltf(d, name, doc, binary, form))


def expect_colour(ctx, r, rgb8, label="render", region=(0.3, 0.7, 0.3, 0.7), lossy=False,
                  linear=None):
    if r.code != 0 or not os.path.exists(r.image):
        return None
    try:
        m = pfm_region_mean(r.image, *region)
    except (ValueError, OSError, struct.error) as e:
        ctx.fail("%s: cannot read the render: %s" % (label, e))
        return None
    exp = linear or [srgb_to_linear(c) for c in rgb8]
    k = 2.0 if lossy else 1.0
    if any(abs(a - b) > k * (COLOUR_ABS + COLOUR_REL * b) for a, b in zip(m, exp)):
        ctx.fail("%s: mean colour (%.3f, %.3f, %.3f), expected the texture's (%.3f, %.3f, %.3f)"
                 % ((label,) + tuple(m) + tuple(exp)))
    return m


def not_black(ctx, r, label="render"):
    if r.code != 0 or not os.path.exists(r.image):
        return
    m = pfm_region_mean(r.image)
    if max(m) < 1e-4:
        ctx.fail("%s: the textured quad renders black" % label)


def leak_check(ctx, needles, label="outputs"):
    found = find_needles([ctx.path("out")], needles)
    for f, name in found:
        ctx.fail("%s: %s holds the bytes of %s" % (label, ctx.rel(f), name))


def baked_doc(ctx, r):
    g = ctx.baked_gltf(r) if r.code == 0 else None
    if not g:
        if r.code == 0:
            ctx.fail("%s: no .gltf in the bake folder" % r.label)
        return None, None
    try:
        with open(g, encoding="utf-8") as f:
            return g, json.load(f)
    except (ValueError, OSError) as e:
        ctx.fail("%s: the baked glTF is not JSON: %s" % (r.label, e))
        return None, None


def check_baked_uris(ctx, r):
    """Every URI of the baked glTF a valid relative reference to a file in the bake folder."""
    g, doc = baked_doc(ctx, r)
    if not doc:
        return g, doc
    for key in ("images", "buffers"):
        for i, item in enumerate(doc.get(key, [])):
            uri = item.get("uri")
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            why = uri_problem(uri)
            if why:
                ctx.fail("%s: baked %s[%d].uri %r: %s" % (r.label, key, i, uri, why))
                continue
            target = os.path.join(os.path.dirname(g), uri_decode(uri))
            if not os.path.isfile(target):
                ctx.fail("%s: baked %s[%d].uri %r names no file in the bake" % (r.label, key, i,
                                                                                 uri))
    return g, doc


def render_baked(ctx, r, rgb=None, label="render of the baked glTF"):
    g, doc = check_baked_uris(ctx, r)
    if not g:
        return None
    # --environment: a baked OBJ or JSON scene need not carry the scene file's lights, and
    # the question here is whether the bake reads back, not how it is lit.
    rr = ctx.render(ctx.rel(g), "accept", label=label, names=[os.path.basename(g)],
                    extra=["--environment", "0.5,0.5,0.5"])
    if rgb is not None:
        not_black(ctx, rr, label)
    return rr


# ---------------------------------------------------------------------------- 1: buffer overruns

def _overrun_case(form, mutate, expect="refuse", runs=("render",), image_used=True):
    def fn(ctx):
        images = [{"embed": solid_png(RED), "mimeType": "image/png"}]
        if not image_used:
            ctx.write("asset/tex.png", solid_png(RED))
            images = [{"uri": "tex.png"}] + images
        scene = std_scene(ctx, images, form=form, name="scene." + ("glb" if form == "glb" else
                                                                    "gltf"), mutate=mutate)
        for kind in runs:
            if kind == "render":
                r = ctx.render(scene, expect)
                not_black(ctx, r)
            elif kind == "bake":
                ctx.bake(scene, expect)
            elif kind == "dry":
                ctx.render(scene, expect, dry=True)
    return fn


def _set(path, value):
    """mutate(doc, bin): sets doc[path...] = value (value may be a function of the old one)."""
    def m(doc, binary):
        node = doc
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value(node.get(path[-1]) if isinstance(node, dict) else node[path[-1]]) \
            if callable(value) else value
    return m


def _past_end(view, over):
    """mutate: bufferViews[view] reaches `over` bytes past the end of its buffer."""
    def m(doc, binary):
        v = doc["bufferViews"][view]
        v["byteLength"] = doc["buffers"][0]["byteLength"] - v.get("byteOffset", 0) + over
    return m


def define_overruns():
    cat = "buffer-overrun"
    for form in ("gltf", "glb"):
        for over in (1, 4096, 1 << 31, 1 << 32, 1 << 53):
            add("overrun-image-view-%s-plus%d" % (form, over), cat,
                "a used image's bufferView %d bytes longer than its buffer (%s)" % (over, form),
                "refuse", _overrun_case(form, _past_end(4, over)))
        for over in (1, 1 << 32):
            add("overrun-unused-image-view-%s-plus%d" % (form, over), cat,
                "an unused image's bufferView %d bytes longer than its buffer (%s)" % (over, form),
                "refuse", _overrun_case(form, _past_end(4, over), image_used=False))
        for name, off in (("at-end", None), ("end-plus-1", 1), ("2e32", 1 << 32), ("minus1", -1),
                          ("2e53", 1 << 53)):
            def m(doc, binary, off=off):
                v = doc["bufferViews"][4]
                if off is None:
                    v["byteOffset"] = doc["buffers"][0]["byteLength"]
                elif off == 1:
                    v["byteOffset"] = doc["buffers"][0]["byteLength"] - v["byteLength"] + 1
                else:
                    v["byteOffset"] = off
            if name == "2e53" and form == "glb":
                continue
            add("overrun-image-offset-%s-%s" % (name, form), cat,
                "a used image's bufferView byteOffset %s (%s)" % (name, form), "refuse",
                _overrun_case(form, m))
        add("overrun-image-view-buffer99-%s" % form, cat,
            "an image's bufferView names buffer 99 (%s)" % form, "refuse",
            _overrun_case(form, _set(["bufferViews", 4, "buffer"], 99)))
        add("overrun-image-bufferview99-%s" % form, cat,
            "an image names bufferView 99 (%s)" % form, "refuse",
            _overrun_case(form, _set(["images", 0, "bufferView"], 99)))
        for count in (5, 1 << 31, 357913942):
            add("overrun-position-count%d-%s" % (count, form), cat,
                "POSITION accessor count %d over a 4-vertex view (%s)" % (count, form), "refuse",
                _overrun_case(form, _set(["accessors", 0, "count"], count)))
        for off in (40, (1 << 32) - 4, -4):
            add("overrun-position-offset%d-%s" % (off, form), cat,
                "POSITION accessor byteOffset %d (%s)" % (off, form), "refuse",
                _overrun_case(form, _set(["accessors", 0, "byteOffset"], off)))
        strides = (4, 256, 13, 1 << 31) if form == "gltf" else (4, 256)
        for s in strides:
            add("overrun-position-stride%d-%s" % (s, form), cat,
                "POSITION bufferView byteStride %d (%s)" % (s, form), "refuse",
                _overrun_case(form, _set(["bufferViews", 0, "byteStride"], s)))
        add("overrun-indices-view-short-%s" % form, cat,
            "indices bufferView 10 bytes for 6 u16 indices (%s)" % form, "refuse",
            _overrun_case(form, _set(["bufferViews", 3, "byteLength"], 10)))
        for what, idx in (("count5", 5), ("offset2e31", None)):
            m = (_set(["accessors", 2, "count"], 5) if idx else
                 _set(["accessors", 2, "byteOffset"], 1 << 31))
            add("overrun-uv-%s-%s" % (what, form), cat,
                "TEXCOORD_0 accessor %s (%s)" % (what, form), "refuse", _overrun_case(form, m))
        add("overrun-position-view-longer-than-buffer-%s" % form, cat,
            "POSITION bufferView longer than the buffer (%s)" % form, "refuse",
            _overrun_case(form, _set(["bufferViews", 0, "byteLength"], 1 << 20)))
        for name, off in (("minus48", -48), ("2e53", 1 << 53)):
            if form == "glb" and name == "2e53":
                off = (1 << 32) + 4
            add("overrun-position-view-offset-%s-%s" % (name, form), cat,
                "POSITION bufferView byteOffset %d (%s)" % (off, form), "refuse",
                _overrun_case(form, _set(["bufferViews", 0, "byteOffset"], off)))
    add("overrun-position-stride0-gltf", cat, "byteStride 0 (tightly packed, must load)", "accept",
        _overrun_case("gltf", _set(["bufferViews", 0, "byteStride"], 0), expect="either"))
    add("overrun-indices-count-2e32m1", cat, "indices accessor count 2^32-1", "refuse",
        _overrun_case("gltf", _set(["accessors", 3, "count"], (1 << 32) - 1)))
    add("overrun-indices-value9", cat, "an index 9 into 4 vertices", "refuse",
        _overrun_case("gltf", lambda d, b: b[:128] + struct.pack("<6H", 0, 1, 9, 0, 2, 3) + b[140:]))
    add("overrun-indices-float", cat, "indices of componentType FLOAT", "refuse",
        _overrun_case("gltf", _set(["accessors", 3, "componentType"], 5126)))
    add("overrun-accessor-misaligned", cat, "POSITION accessor byteOffset 2 (misaligned floats)",
        "refuse", _overrun_case("gltf", _set(["accessors", 0, "byteOffset"], 2)))
    add("overrun-buffer-datauri-short", cat,
        "a data-URI buffer shorter than its byteLength", "refuse",
        _overrun_case("embedded", _set(["buffers", 0, "byteLength"], lambda v: v + 64)))
    add("overrun-buffer-file-short", cat, "an external .bin shorter than its byteLength", "refuse",
        _overrun_case("gltf", _set(["buffers", 0, "byteLength"], lambda v: v + 64)))
    add("overrun-buffer-glb-short", cat, "a GLB BIN chunk shorter than buffer 0's byteLength",
        "refuse", _overrun_case("glb", _set(["buffers", 0, "byteLength"], lambda v: v + 64)))
    add("overrun-image-view-render-bake-dry", cat,
        "a used image's bufferView 1 MiB past its buffer: render, bake and --dry-run", "refuse",
        _overrun_case("glb", _past_end(4, MiB), runs=("render", "bake", "dry")))


# ---------------------------------------------------------------------------- GLB container lies

def define_glb_lies():
    cat = "glb-container"

    def glb_case(expect, **lie):
        def fn(ctx):
            doc, binary = gltf_doc([{"embed": solid_png(RED), "mimeType": "image/png"}])
            if "truncate" in lie:
                data = glb_bytes(doc, binary)
                data = data[:lie["truncate"](len(data))]
            else:
                kw = {k: (v(doc, binary) if callable(v) else v) for k, v in lie.items()}
                data = glb_bytes(doc, binary, **kw)
            ctx.write("asset/scene.glb", data)
            r = ctx.render("asset/scene.glb", expect)
            not_black(ctx, r)
        return fn

    def js_len(doc):
        js = json.dumps(doc).encode()
        return len(js) + (-len(js)) % 4

    items = [
        ("total-plus8", "the header's total length 8 more than the file", "refuse",
         dict(total_len=lambda d, b: 12 + 8 + js_len(d) + 8 + len(b) + (-len(b)) % 4 + 8)),
        ("total-minus8", "the header's total length 8 less than the file", "refuse",
         dict(total_len=lambda d, b: 12 + 8 + js_len(d) + 8 + len(b) + (-len(b)) % 4 - 8)),
        ("total-zero", "the header's total length 0", "refuse", dict(total_len=0)),
        ("total-max", "the header's total length 2^32-1", "refuse", dict(total_len=0xFFFFFFFF)),
        ("json-len-past-end", "the JSON chunk's length past the end of the file", "refuse",
         dict(json_len=1 << 20)),
        ("json-len-zero", "the JSON chunk's length 0", "refuse", dict(json_len=0)),
        ("json-len-unaligned", "the JSON chunk's length 1 short (not a multiple of 4)", "either",
         dict(json_len=lambda d, b: js_len(d) - 1)),
        ("json-len-max", "the JSON chunk's length 2^32-1", "refuse", dict(json_len=0xFFFFFFFF)),
        ("bin-len-past-end", "the BIN chunk's length past the end of the file", "refuse",
         dict(bin_len=1 << 20)),
        ("bin-len-max", "the BIN chunk's length 2^32-1", "refuse", dict(bin_len=0xFFFFFFFF)),
        ("bin-len-16", "the BIN chunk's length 16, shorter than its buffer", "refuse",
         dict(bin_len=16)),
        ("bin-type-wrong", "the second chunk typed 'BIX\\0'", "refuse", dict(bin_type=b"BIX\0")),
        ("bin-missing", "no BIN chunk for a buffer without a uri", "refuse", dict(drop_bin=True)),
        ("unknown-chunk", "an unknown chunk after BIN (to be ignored, as the spec says)", "accept",
         dict(extra_chunks=struct.pack("<I4s", 8, b"XTRA") + b"\0" * 8)),
        ("two-bin-chunks", "a second BIN chunk", "either",
         dict(extra_chunks=struct.pack("<I4s", 8, b"BIN\0") + b"\0" * 8)),
        ("version1", "header version 1", "refuse", dict(version=1)),
        ("version3", "header version 3", "refuse", dict(version=3)),
        ("header-only", "a 12-byte file: the header alone", "refuse",
         dict(truncate=lambda n: 12)),
        ("truncated-mid-bin", "cut in the middle of the BIN chunk", "refuse",
         dict(truncate=lambda n: n - 100)),
        ("truncated-mid-json", "cut in the middle of the JSON chunk", "refuse",
         dict(truncate=lambda n: 60)),
    ]
    for name, title, expect, lie in items:
        add("glb-" + name, cat, title, expect, glb_case(expect, **lie))


# ---------------------------------------------------------------------------- 2-4: URIs that escape

ASSET = "root/a/b/c/d"  # the scene's folder; canaries sit above it


def _canaries(ctx):
    """Canary files around the asset folder; returns {name: (path, token)}."""
    c = {}
    c["passwd"] = ctx.canary("root/etc/passwd")
    c["secret"] = ctx.canary("root/secret.txt")
    c["txt"] = ctx.canary("root/a/b/canary.txt")
    c["png"] = ctx.canary("root/a/b/canary.png", kind="png")
    return c


ESCAPES = [
    # name, uri (a function of the canaries), which canary it reaches
    ("passwd", lambda ctx, c: "../../../../etc/passwd", "passwd"),
    ("absolute", lambda ctx, c: c["secret"][0], "secret"),
    ("parent", lambda ctx, c: "../../canary.txt", "txt"),
    ("encoded-dotdot", lambda ctx, c: "%2e%2e/%2e%2e/canary.txt", "txt"),
    ("encoded-slash", lambda ctx, c: "..%2F..%2Fcanary.txt", "txt"),
    ("file-scheme", lambda ctx, c: "file://" + c["secret"][0], "secret"),
    ("symlink", lambda ctx, c: (ctx.symlink(c["png"][0], ASSET + "/link.png"), "link.png")[1],
     "png"),
    ("backslash", lambda ctx, c: "..\\..\\canary.txt", "txt"),
    ("used-png-parent", lambda ctx, c: "../../canary.png", "png"),
]


def _escape_case(uri_name, used, runs, uri_fn, target):
    def fn(ctx):
        c = _canaries(ctx)
        uri = uri_fn(ctx, c)
        ctx.write(ASSET + "/tex.png", solid_png(RED))
        if used:
            images = [{"uri": uri}]
        else:
            images = [{"uri": "tex.png"}, {"uri": uri}]
        scene = std_scene(ctx, images, sub=ASSET)
        expect = "refuse" if used else "either"
        for kind in runs:
            if kind == "render":
                ctx.render(scene, expect)
            elif kind == "bake":
                ctx.bake(scene, expect)
            elif kind == "web":
                ctx.bake(scene, expect, web=ctx.out("web"))
            elif kind == "dry":
                ctx.bake(scene, expect, dry=True)
        leak_check(ctx, {name: tok for name, (_, tok) in c.items()})
    return fn


def _cmd_subst_case(uri, runs):
    def fn(ctx):
        ctx.write(ASSET + "/tex.png", solid_png(RED))
        scene = std_scene(ctx, [{"uri": "tex.png"}, {"uri": uri}], sub=ASSET)
        for kind in runs:
            if kind == "render":
                ctx.render(scene, "either")
            else:
                ctx.bake(scene, "either")
        for root, dirs, names in os.walk(ctx.dir):
            for n in names + dirs:
                if n.startswith("PWNED"):
                    ctx.fail("the uri %r ran a command (%s exists)" % (uri, n))
    return fn


def _local_escape_case(fmt, how, runs):
    """JSON and MTL textures outside the scene's folder: the user's own scene may name them
    (either outcome), but a bake must not reference them by '../' or an absolute path."""
    def fn(ctx):
        c = _canaries(ctx)
        name = "../../canary.png" if how == "parent" else c["png"][0]
        ctx.write(ASSET + "/quad.obj", quad_obj())
        if fmt == "obj":
            ctx.write(ASSET + "/quad.mtl", mtl(["map_Kd " + name]))
            scene = ASSET + "/quad.obj"
        else:
            ctx.write(ASSET + "/quad.mtl", mtl([]))
            ctx.write_json(ASSET + "/scene.json",
                           json_scene({"reflectance": [1, 1, 1], "reflectance_texture": name},
                                      light=True))
            scene = ASSET + "/scene.json"
        ctx.watches = []  # reading is legitimate here
        for kind in runs:
            if kind == "render":
                ctx.render(scene, "either")
            else:
                r = ctx.bake(scene, "either", web=ctx.out("web") if kind == "web" else None)
                check_baked_uris(ctx, r)
    return fn


def define_escapes():
    cat = "uri-escape"
    for name, uri_fn, target in ESCAPES:
        if name == "used-png-parent":
            continue
        for runs in (("render",), ("bake",), ("web",)):
            if name == "backslash" and runs == ("web",):
                continue
            add("escape-unused-%s-%s" % (name, runs[0]), cat,
                "an unused image whose uri reaches a canary outside the asset (%s), %s" % (
                    name, runs[0]), "either",
                _escape_case(name, False, runs, uri_fn, target))
    for name, uri_fn, target in ESCAPES:
        if name not in ("absolute", "symlink", "encoded-dotdot", "used-png-parent", "file-scheme"):
            continue
        for runs in (("render",), ("bake",)):
            add("escape-used-%s-%s" % (name, runs[0]), cat,
                "a used image outside the asset folder (%s), %s" % (name, runs[0]), "refuse",
                _escape_case(name, True, runs, uri_fn, target))
    add("escape-unused-dry-run-absolute", cat, "an unused absolute-uri image, bake --dry-run",
        "either", _escape_case("absolute", False, ("dry",), ESCAPES[1][1], "secret"))
    for uri in ("$(touch PWNED).png", "`touch PWNED2`.png"):
        tag = "dollar" if uri.startswith("$") else "backtick"
        add("escape-command-substitution-%s" % tag, cat,
            "an unused image uri %r (no shell expansion)" % uri, "either",
            _cmd_subst_case(uri, ("render", "bake")))
    for fmt in ("obj", "json"):
        for how in ("parent", "absolute"):
            add("escape-%s-texture-%s" % (fmt, how), cat,
                "a %s texture outside the scene's folder (%s): a bake must not point outside" % (
                    fmt.upper(), how), "either", _local_escape_case(fmt, how, ("render", "web")))


# ---------------------------------------------------------------------------- 3: the working folder

def _cwd_case(fmt, used, runs, what="image"):
    def fn(ctx):
        cwd = ctx.path("elsewhere")
        os.makedirs(cwd)
        tok = ("PENUMBRA-CWD-" + secrets.token_hex(10)).encode()
        data = png(4, 4, lambda x, y: BLUE, 2, extra=[(b"tEXt", b"Comment\0" + tok)])
        p = ctx.write("elsewhere/cwd_only.png", data)
        ctx.watch(p)
        ctx.write("asset/tex.png", solid_png(RED))
        if fmt in ("gltf", "glb"):
            if what == "buffer":
                doc, binary = gltf_doc([{"uri": "tex.png"}])
                doc["buffers"][0]["uri"] = "cwd_only.bin"
                ctx.write("elsewhere/cwd_only.bin", binary)
                ctx.watch(ctx.path("elsewhere/cwd_only.bin"))
                with open(ctx.path("asset/scene.gltf"), "w") as f:
                    json.dump(doc, f)
                scene = "asset/scene.gltf"
            else:
                images = [{"uri": "cwd_only.png"}] if used else [{"uri": "tex.png"},
                                                                 {"uri": "cwd_only.png"}]
                scene = std_scene(ctx, images, form=fmt, name="scene." + fmt)
        else:
            ctx.write("asset/quad.obj", quad_obj())
            ctx.write("asset/quad.mtl", mtl(["map_Kd cwd_only.png"] if fmt == "obj" else []))
            scene = "asset/quad.obj"
            if fmt == "json":
                ctx.write_json("asset/scene.json", json_scene(
                    {"reflectance": [1, 1, 1], "reflectance_texture": "cwd_only.png"}, light=True))
                scene = "asset/scene.json"
        expect = "refuse" if used else "accept"
        for kind in runs:
            if kind == "render":
                ctx.render(scene, expect, cwd=cwd)
            elif kind == "dry":
                ctx.render(scene, expect, cwd=cwd, dry=True)
            else:
                r = ctx.bake(scene, expect, cwd=cwd, web=ctx.out("web") if kind == "web" else None)
        leak_check(ctx, {"the file in the working folder": tok})
    return fn


def define_cwd():
    cat = "cwd-lookup"
    for runs in (("render",), ("bake",), ("dry",)):
        add("cwd-used-gltf-%s" % runs[0], cat,
            "a used image missing beside the scene but in the working folder, %s" % runs[0],
            "refuse", _cwd_case("gltf", True, runs))
    add("cwd-used-glb-render", cat, "the same from a .glb", "refuse",
        _cwd_case("glb", True, ("render",)))
    for runs in (("render",), ("bake",), ("web",)):
        add("cwd-unused-gltf-%s" % runs[0], cat,
            "an unused image found only in the working folder, %s (exit 0, nothing embedded)"
            % runs[0], "accept", _cwd_case("gltf", False, runs))
    add("cwd-used-obj-render", cat, "map_Kd naming a file only in the working folder", "refuse",
        _cwd_case("obj", True, ("render",)))
    add("cwd-used-json-render", cat, "reflectance_texture naming a file only in the working folder",
        "refuse", _cwd_case("json", True, ("render",)))
    add("cwd-buffer-gltf-render", cat, "a buffer .bin only in the working folder", "refuse",
        _cwd_case("gltf", True, ("render",), what="buffer"))


# ---------------------------------------------------------------------------- 4: FIFOs, encodings

FIFO_TIMEOUT = 20


def _fifo_case(fmt, uri, used, runs, via="image"):
    def fn(ctx):
        ctx.mkfifo("asset/fifo.png")
        ctx.write("asset/tex.png", solid_png(RED))
        ctx.write("asset/quad.obj", quad_obj())
        if fmt == "gltf":
            if via == "buffer":
                doc, binary = gltf_doc([{"uri": "tex.png"}])
                doc["buffers"][0]["uri"] = uri
                ctx.write_json("asset/scene.gltf", doc)
            elif via == "symlink":
                ctx.symlink("fifo.png", "asset/link.png")
                std_scene(ctx, [{"uri": "link.png"}])
            else:
                std_scene(ctx, [{"uri": uri}] if used else [{"uri": "tex.png"}, {"uri": uri}])
            scene = "asset/scene.gltf"
        elif fmt == "obj":
            ctx.write("asset/quad.mtl", mtl(["map_Kd " + uri]))
            scene = "asset/quad.obj"
        else:
            ctx.write("asset/quad.mtl", mtl([]))
            m = {"reflectance": [1, 1, 1]}
            if via == "normal":
                m["normal_map"] = uri
            else:
                m["reflectance_texture"] = uri
            ctx.write_json("asset/scene.json", json_scene(m, light=True))
            scene = "asset/scene.json"
        expect = "refuse" if used else "either"
        for kind in runs:
            if kind == "render":
                ctx.render(scene, expect, timeout=FIFO_TIMEOUT)
            elif kind == "dry":
                ctx.bake(scene, expect, dry=True, timeout=FIFO_TIMEOUT)
            else:
                ctx.bake(scene, expect, timeout=FIFO_TIMEOUT)
    return fn


def _named_case(files, uri, expect, rgb=None, runs=("render",), dirs=(), mkscene=None):
    """files: {relative name in asset/: bytes}; the scene's used image has `uri`."""
    def fn(ctx):
        for d in dirs:
            os.makedirs(ctx.path("asset", d), exist_ok=True)
        for name, data in files.items():
            ctx.write(os.path.join("asset", name), data)
        scene = std_scene(ctx, [{"uri": uri}])
        for kind in runs:
            if kind == "render":
                r = ctx.render(scene, expect)
                if rgb:
                    expect_colour(ctx, r, rgb)
            elif kind == "bake-rerender":
                r = ctx.bake(scene, expect, web=ctx.out("web"))
                if r.code == 0:
                    render_baked(ctx, r, rgb)
    return fn


def define_fifo_and_encoding():
    cat = "fifo"
    for used in (True, False):
        for runs in (("render",), ("bake",), ("dry",)):
            add("fifo-encoded-%s-%s" % ("used" if used else "unused", runs[0]), cat,
                "uri 'fif%%6F.png' naming a FIFO, %s, %s" % ("used" if used else "unused",
                                                              runs[0]),
                "refuse" if used else "either", _fifo_case("gltf", "fif%6F.png", used, runs))
    add("fifo-plain-used-render", cat, "uri 'fifo.png' naming a FIFO, used", "refuse",
        _fifo_case("gltf", "fifo.png", True, ("render",)))
    add("fifo-plain-unused-render", cat, "uri 'fifo.png' naming a FIFO, unused", "either",
        _fifo_case("gltf", "fifo.png", False, ("render",)))
    add("fifo-symlink-used-render", cat, "a symlink to a FIFO, used", "refuse",
        _fifo_case("gltf", "link.png", True, ("render",), via="symlink"))
    add("fifo-buffer-render", cat, "a buffer uri naming a FIFO", "refuse",
        _fifo_case("gltf", "fif%6F.png", True, ("render",), via="buffer"))
    add("fifo-mtl-map-kd", cat, "map_Kd naming a FIFO", "refuse",
        _fifo_case("obj", "fifo.png", True, ("render",)))
    add("fifo-json-texture", cat, "reflectance_texture naming a FIFO", "refuse",
        _fifo_case("json", "fifo.png", True, ("render",)))
    add("fifo-json-normal-map", cat, "normal_map naming a FIFO", "refuse",
        _fifo_case("json", "fifo.png", True, ("render",), via="normal"))

    cat = "uri-encoding"
    red = solid_png(RED)
    add("enc-directory-used", cat, "uri 'tex%64ir' decoding to a directory, used", "refuse",
        _named_case({}, "tex%64ir", "refuse", dirs=("texdir",)))

    def unused_dir(ctx):
        os.makedirs(ctx.path("asset", "texdir"))
        ctx.write("asset/tex.png", red)
        scene = std_scene(ctx, [{"uri": "tex.png"}, {"uri": "tex%64ir"}])
        r = ctx.render(scene, "either")
        ctx.bake(scene, "either")
    add("enc-directory-unused", cat, "uri 'tex%64ir' decoding to a directory, unused", "either",
        unused_dir)
    add("enc-space-in-dir", cat, "uri 'my%20dir/tex.png' (a folder with a space)", "accept",
        _named_case({"my dir/tex.png": red}, "my%20dir/tex.png", "accept", rgb=RED))
    add("enc-encoded-letter-dir", cat, "uri '%74extures/tex.png' (an encoded letter)", "accept",
        _named_case({"textures/tex.png": red}, "%74extures/tex.png", "accept", rgb=RED))
    add("enc-encoded-slash", cat, "uri 'sub%2Ftex.png' (an encoded slash; sub/tex.png exists)",
        "either", _named_case({"sub/tex.png": red}, "sub%2Ftex.png", "either"))
    add("enc-encoded-dotdot-used-render", cat, "uri '%2e%2e/tex.png' (encoded traversal), used",
        "refuse", _named_case({}, "%2e%2e/tex.png", "refuse"))
    add("enc-plus-literal", cat, "a file 'a+b.png' named by uri 'a+b.png': '+' is a plus",
        "accept", _named_case({"a+b.png": red}, "a+b.png", "accept", rgb=RED))
    add("enc-plus-literal-decoy", cat,
        "'a+b.png' (red) and 'a b.png' (blue) both there: uri 'a+b.png' must read the red one",
        "accept", _named_case({"a+b.png": red, "a b.png": solid_png(BLUE)}, "a+b.png", "accept",
                              rgb=RED))
    add("enc-plus-bake-rerender", cat, "'a+b.png': bake --web, then render the baked glTF",
        "accept", _named_case({"a+b.png": red}, "a+b.png", "accept",
                              runs=("render", "bake-rerender")))
    add("enc-plus-encoded", cat, "uri 'a%2Bb.png' for 'a+b.png'", "accept",
        _named_case({"a+b.png": red}, "a%2Bb.png", "accept", rgb=RED))
    add("enc-raw-space", cat, "uri 'a b.png' (a raw space, not valid RFC 3986)", "either",
        _named_case({"a b.png": red}, "a b.png", "either"))
    add("enc-nul-byte", cat, "uri 'tex.png%00.txt' (an encoded NUL; tex.png exists)", "refuse",
        _named_case({"tex.png": red}, "tex.png%00.txt", "refuse"))
    add("enc-long-uri", cat, "a 5000-character uri", "refuse",
        _named_case({}, "x" * 5000 + ".png", "refuse"))
    add("enc-bad-percent", cat, "uri 'tex%zz.png' (a malformed escape)", "refuse",
        _named_case({"tex.png": red}, "tex%zz.png", "refuse"))
    add("enc-trailing-percent", cat, "uri 'tex.png%' (a lone percent)", "refuse",
        _named_case({"tex.png": red}, "tex.png%", "refuse"))
    add("enc-dot", cat, "uri '.' (the folder itself)", "refuse", _named_case({}, ".", "refuse"))
    add("enc-slash", cat, "uri '/' (the root folder)", "refuse", _named_case({}, "/", "refuse"))
    add("enc-empty", cat, "uri '' (empty)", "refuse", _named_case({}, "", "refuse"))
    add("enc-self", cat, "uri 'scene.gltf' (the scene as its own image)", "refuse",
        _named_case({}, "scene.gltf", "refuse"))


# ---------------------------------------------------------------------------- 5-6: unused images

def _bulk_case(n, runs, target="sparse", size=100 * MiB, form="gltf"):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        if target == "sparse":
            ctx.sparse("asset/huge.png", size)
        else:
            ctx.asset("asset/huge.png", "png-8192-rgb", lambda p: big_png(
                p, 8192, 8192, 2, 8, [0, 0, 0] * 8192))
        images = [{"uri": "tex.png"}] + [{"uri": "huge.png", "name": "unused %d" % i}
                                         for i in range(n)]
        scene = std_scene(ctx, images, form=form, name="scene." + form)
        for kind in runs:
            if kind == "render":
                r = ctx.render(scene, "accept", max_s=10)
                expect_colour(ctx, r, RED)
            elif kind == "render-dry":
                ctx.render(scene, "accept", dry=True, max_s=10)
            elif kind == "dry":
                ctx.bake(scene, "accept", dry=True, max_s=10)
            else:
                r = ctx.bake(scene, "accept", web=ctx.out("web") if kind == "web" else None)
                if r.code == 0:
                    total = sum(os.path.getsize(f) for f in files_under([r.bake_dir]))
                    ctx.check(total < 16 * MiB, "%s: the bake wrote %.0f MiB (the unused images "
                              "embedded?)" % (r.label, total / MiB))
    return fn


def _unused_obj_material(ctx):
    ctx.sparse("asset/huge.png", 100 * MiB)
    ctx.write("asset/tex.png", solid_png(RED))
    ctx.write("asset/quad.obj", quad_obj())
    ctx.write("asset/quad.mtl", mtl(["map_Kd tex.png"]) + "\nnewmtl Unused\nKd 1 1 1\n" +
              "".join("map_Kd huge.png\n" for _ in range(1)))
    r = ctx.render("asset/quad.obj", "accept", max_s=10)


def _missing_unused_case(form, how):
    """A missing (or empty, or corrupt) unused image: bake --dry-run and bake must agree, and
    a bake must not fail after it has solved."""
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        bad = {"missing": None, "empty": b"", "corrupt": b"\x89PNG\r\n\x1a\nnot a png at all",
               "directory": "dir"}[how]
        if bad == "dir":
            os.makedirs(ctx.path("asset", "gone.png"))
        elif bad is not None:
            ctx.write("asset/gone.png", bad)
        scene = std_scene(ctx, [{"uri": "tex.png"}, {"uri": "gone.png"}], form=form,
                          name="scene." + form, light=True)
        d = ctx.bake(scene, "either", dry=True, method="progressive", extra=MISSING_BAKE_ARGS)
        b = ctx.bake(scene, "either", method="progressive", extra=MISSING_BAKE_ARGS)
        if d.code in (0, 2) and b.code in (0, 2) and d.code != b.code:
            ctx.fail("bake --dry-run exit %d but bake exit %d: %s" % (d.code, b.code,
                                                                       (b.errline or "")[:200]))
        if b.code not in (0, None) and b.seconds > d.seconds + LATE_FAILURE_S:
            ctx.fail("bake failed after %.1f s (its dry run took %.1f s): a late failure, after "
                     "solving" % (b.seconds, d.seconds))
    return fn


MISSING_BAKE_ARGS = ["--elements", "200000", "--iterations", "300"]  # a solve of a few seconds
LATE_FAILURE_S = 3.0


def define_unused():
    cat = "unused-bulk"
    add("bulk-100-unused-100MB-render", cat,
        "100 unused images naming one 100 MB file, render (not read: RSS < 1 GiB, < 10 s)",
        "accept", _bulk_case(100, ("render",)), heavy=True)
    add("bulk-100-unused-100MB-render-dry", cat, "the same, render --dry-run", "accept",
        _bulk_case(100, ("render-dry",)), heavy=True)
    add("bulk-20-unused-100MB-bake", cat, "20 unused images naming one 100 MB file, bake (.bin "
        "small)", "accept", _bulk_case(20, ("bake",)), heavy=True)
    add("bulk-20-unused-100MB-bake-dry", cat, "the same, bake --dry-run", "accept",
        _bulk_case(20, ("dry",)), heavy=True)
    add("bulk-20-unused-100MB-bake-web", cat, "the same, bake --web", "accept",
        _bulk_case(20, ("web",)), heavy=True)
    add("bulk-100-unused-100MB-glb-render", cat, "100 unused images naming a 100 MB file, from "
        "a .glb", "accept", _bulk_case(100, ("render",), form="glb"), heavy=True)
    add("bulk-unused-4GiB-render", cat, "one unused image naming a 4 GiB file, render", "accept",
        _bulk_case(1, ("render",), size=4 * GiB), heavy=True)
    add("bulk-unused-4GiB-bake", cat, "one unused image naming a 4 GiB file, bake", "accept",
        _bulk_case(1, ("bake",), size=4 * GiB), heavy=True)
    add("bulk-100-unused-8192-png-render", cat, "100 unused images naming one 8192^2 PNG: not "
        "decoded", "accept", _bulk_case(100, ("render",), target="png"), heavy=True)
    add("bulk-unused-mtl-material", cat, "an MTL material no face uses, its map_Kd a 100 MB file",
        "accept", _unused_obj_material, heavy=True)
    cat = "missing-unused"
    for form in ("gltf", "glb"):
        for how in ("missing", "empty", "corrupt", "directory"):
            add("missing-unused-%s-%s" % (how, form), cat,
                "an unused image %s (%s): dry run and bake agree, no late failure" % (how, form),
                "either", _missing_unused_case(form, how))


# ---------------------------------------------------------------------------- 7-9: decode bombs

BOMB_RSS_MB = 2560
BOMB_SECONDS = 10


def _bomb_images():
    """name -> (file name, cache key, builder(path))"""
    def w(data):
        def b(p):
            with open(p, "wb") as f:
                f.write(data() if callable(data) else data)
        return b
    return {
        "bmp-header-16k": ("bomb.bmp", "bmp-header-16k", w(bmp_header_only(16384, 16384))),
        "tga-header-16k": ("bomb.tga", "tga-header-16k", w(tga_header_only(16384, 16384))),
        "bmp-truncated": ("bomb.bmp", "bmp-truncated",
                          w(lambda: bmp24(256, 256, lambda x, y: RED)[:54 + 3 * 256 * 40])),
        "tga-truncated": ("bomb.tga", "tga-truncated",
                          w(lambda: tga(256, 256, lambda x, y: RED)[:18 + 100])),
        "png-16k-rgb8": ("bomb.png", "png-16k-rgb8",
                         lambda p: big_png(p, 16384, 16384, 2, 8, [60, 60, 60] * 16384)),
        "jpeg-16k-grey": ("bomb.jpg", "jpeg-16k-grey", w(lambda: jpeg_flat(16384, 16384, [90]))),
        "png-16k-rgb16": ("bomb.png", "png-16k-rgb16",
                          lambda p: big_png(p, 16384, 16384, 2, 16, [9000, 9000, 9000] * 16384)),
        "png-16k-palette1": ("bomb.png", "png-16k-palette1",
                             lambda p: big_png(p, 16384, 16384, 3, 1, [1] * 16384,
                                               plte=[(0, 0, 0), TEAL])),
        "webp-header-16k": ("bomb.webp", "webp-header-16k", w(webp_header_only(16384, 16384))),
        "png-65535-header": ("bomb.png", "png-65535-header",
                             w(lambda: PNG_SIG + png_chunk(b"IHDR", struct.pack(
                                 ">IIBBBBB", 65535, 65535, 8, 2, 0, 0, 0)) +
                               png_chunk(b"IDAT", zlib.compress(b"\0" * 1000)) +
                               png_chunk(b"IEND", b""))),
    }


def _bomb_case(key, mode):
    def fn(ctx):
        fname, cache, builder = _bomb_images()[key]
        ctx.asset("asset/" + fname, cache, builder)
        uses_webp = fname.endswith(".webp")
        textures = [{"source": 0}]
        if uses_webp:
            textures = [{"extensions": {"EXT_texture_webp": {"source": 0}}}]

        def m(doc, binary):
            if uses_webp:
                doc["extensionsUsed"] = ["EXT_texture_webp"]
                doc["extensionsRequired"] = ["EXT_texture_webp"]
        scene = std_scene(ctx, [{"uri": fname}], textures=textures, mutate=m)
        if mode == "render":
            r = ctx.render(scene, "either")
        elif mode == "dry":
            r = ctx.render(scene, "either", dry=True)
            if key == "webp-header-16k":
                # A valid header with no pixel data behind it: a dry run plans from headers and
                # decodes nothing, so only the run finds the data missing (docs/cli.md, --dry-run).
                ctx.render(scene, "either")
            else:
                dry_agrees(ctx, r, ctx.render(scene, "either"))
        else:
            r = ctx.bake(scene, "either")
        if r.code == 2:
            ctx.check(fname in r.errline, "%s: the refusal does not name %s: %s" % (
                r.label, fname, r.errline[:200]))
            if r.seconds > BOMB_SECONDS:
                ctx.fail("%s: refused only after %.1f s" % (r.label, r.seconds))
        for line in r.stderr.splitlines():
            low = line.lower()
            if ("downsampl" in low or "reduced" in low or "scaled down" in low) and \
                    fname not in line:
                ctx.fail("%s: a downsampling warning that does not name the image: %s" % (
                    r.label, line[:200]))
    return fn


def _many_textures_case(mode):
    """200 distinct 8192^2 textures (compressible PNGs), each on its own material."""
    def fn(ctx):
        n = 200
        images = []
        for i in range(n):
            name = "t%03d.png" % i
            ctx.asset("asset/" + name, "png-8192-distinct-%d" % i, lambda p, i=i: big_png(
                p, 8192, 8192, 2, 8, [0, 0, 0] * 8192, first_row=[i % 256, i // 256, 7] * 8192))
            images.append({"uri": name})
        textures = [{"source": i} for i in range(n)]
        materials = [dict(textured_material(i), name="%s %d" % (MATERIAL, i)) for i in range(n)]

        def m(doc, binary):
            prim = doc["meshes"][0]["primitives"][0]
            doc["meshes"][0]["primitives"] = [dict(prim, material=i) for i in range(n)]
        scene = std_scene(ctx, images, textures=textures, materials=materials, mutate=m)
        run_mode(ctx, scene, mode)
    return fn


def _shared_normal_case(mode):
    def fn(ctx):
        n = 50
        ctx.write("asset/tex.png", solid_png(RED))
        ctx.asset("asset/normal.png", "png-8192-normal", lambda p: big_png(
            p, 8192, 8192, 2, 8, list(FLAT_NORMAL) * 8192))
        textures = [{"source": 0}, {"source": 1}]
        materials = [dict(textured_material(0, normal=1), name="%s %d" % (MATERIAL, i))
                     for i in range(n)]

        def m(doc, binary):
            prim = doc["meshes"][0]["primitives"][0]
            doc["meshes"][0]["primitives"] = [dict(prim, material=i) for i in range(n)]
        scene = std_scene(ctx, [{"uri": "tex.png"}, {"uri": "normal.png"}], textures=textures,
                          materials=materials, mutate=m, light=True)
        run_mode(ctx, scene, mode, method="progressive")
    return fn


def run_mode(ctx, scene, mode, method="pathtrace"):
    if mode == "render":
        r = ctx.render(scene, "either", method=method)
    elif mode == "dry":
        r = ctx.render(scene, "either", method=method, dry=True)
        dry_agrees(ctx, r, ctx.render(scene, "either", method=method))
    else:
        r = ctx.bake(scene, "either")
    if r.code == 2 and r.seconds > BOMB_SECONDS:
        ctx.fail("%s: refused only after %.1f s (not before decoding)" % (r.label, r.seconds))
    return r


SOS_SCANS = 150000


def _sos_case(mode, fmt="gltf", scans=SOS_SCANS):
    def fn(ctx):
        ctx.asset("asset/scans.jpg", "jpeg-sos-%d" % scans, lambda p: open(p, "wb").write(
            jpeg_sos_bomb(2048, 2048, scans)))
        if fmt == "obj":
            ctx.write("asset/quad.obj", quad_obj())
            ctx.write("asset/quad.mtl", mtl(["map_Kd scans.jpg"]))
            scene = "asset/quad.obj"
        else:
            scene = std_scene(ctx, [{"uri": "scans.jpg"}])
        if mode == "render":
            ctx.render(scene, "either")
        elif mode == "dry":
            dry_agrees(ctx, ctx.render(scene, "either", dry=True), ctx.render(scene, "either"))
        else:
            ctx.bake(scene, "either")
    return fn


def dry_agrees(ctx, dry, real):
    """--dry-run gives the error and exit code the real run would (docs/cli.md)."""
    if dry.code in (0, 2) and real.code in (0, 2) and dry.code != real.code:
        ctx.fail("--dry-run exit %d, the same command without it exit %d%s" % (
            dry.code, real.code, (": " + (real.errline or dry.errline)[:160])
            if (real.errline or dry.errline) else ""))


def define_bombs():
    cat = "decode-bomb"
    for key in _bomb_images():
        for mode in ("render", "bake", "dry"):
            add("bomb-%s-%s" % (key, mode), cat,
                "%s, %s: refused within %d s or read within %d MiB" % (
                    key, {"dry": "render --dry-run (agreeing with render)"}.get(mode, mode),
                    BOMB_SECONDS, BOMB_RSS_MB),
                "either", _bomb_case(key, mode), heavy=True, rss_mb=BOMB_RSS_MB)
    cat = "many-textures"
    for mode in ("render", "dry", "bake"):
        add("many-200-textures-8192-%s" % mode, cat,
            "200 distinct 8192^2 textures, %s: refused before decoding or bounded" % mode,
            "either", _many_textures_case(mode), heavy=True, rss_mb=BOMB_RSS_MB)
        add("many-normal-map-50-materials-%s" % mode, cat,
            "one 8192^2 normal map used by 50 materials, %s" % mode, "either",
            _shared_normal_case(mode), heavy=True, rss_mb=BOMB_RSS_MB)
    cat = "decode-bomb"
    for mode in ("render", "dry", "bake"):
        add("bomb-jpeg-150000-scans-%s" % mode, cat,
            "a progressive JPEG of %d empty scans, %s (flag > 30 s)" % (SOS_SCANS, mode),
            "either", _sos_case(mode), heavy=True, rss_mb=BOMB_RSS_MB, max_s=30)
    add("bomb-jpeg-150000-scans-obj", cat, "the same JPEG as an MTL map_Kd", "either",
        _sos_case("render", fmt="obj"), heavy=True, rss_mb=BOMB_RSS_MB, max_s=30)


# ---------------------------------------------------------------------------- 10: palettes

def _scene_for(ctx, fmt, fname, light=False):
    """The textured quad using asset/<fname> in `fmt` (gltf, json, obj); returns the scene."""
    if fmt == "gltf":
        return std_scene(ctx, [{"uri": fname}], light=light)
    ctx.write("asset/quad.obj", quad_obj())
    if fmt == "obj":
        ctx.write("asset/quad.mtl", mtl(["map_Kd " + fname, "map_Ke " + fname]))
        return "asset/quad.obj"
    ctx.write("asset/quad.mtl", mtl([]))
    ctx.write_json("asset/scene.json", json_scene(emissive_json_material(fname), light=light))
    return "asset/scene.json"


def _palette_twice_case(fmt, data):
    def fn(ctx):
        ctx.write("asset/pal.png", data)
        scene = _scene_for(ctx, fmt, "pal.png")
        a = ctx.render(scene, "either", label="render 1")
        b = ctx.render(scene, "either", label="render 2")
        if a.code != b.code:
            ctx.fail("two renders of one file: exit %s then %s" % (a.code, b.code))
        elif a.code == 0:
            with open(a.image, "rb") as f1, open(b.image, "rb") as f2:
                if f1.read() != f2.read():
                    ctx.fail("two renders of one file differ (out-of-range palette indices read "
                             "undefined memory)")
    return fn


def _palette_valid_case(fmt, bits):
    def fn(ctx):
        n = 1 << bits
        plte = [(i * 7 % 256, i * 13 % 256, i * 29 % 256) for i in range(n - 1)] + [TEAL]
        data = png(64, 64, lambda x, y: (n - 1,), 3, bits, plte=plte)
        ctx.write("asset/pal.png", data)
        scene = _scene_for(ctx, fmt, "pal.png")
        r = ctx.render(scene, "accept")
        expect_colour(ctx, r, TEAL)
    return fn


def define_palettes():
    cat = "palette"
    oob = png(64, 64, lambda x, y: ((x + 64 * y) % 256,), 3, 8, plte=[RED, BLUE])
    for fmt in ("gltf", "json", "obj"):
        add("palette-oob-indices-%s" % fmt, cat,
            "8-bit palette PNG, PLTE of 2, indices to 255 (%s): two renders byte-identical" % fmt,
            "either", _palette_twice_case(fmt, oob))
    add("palette-oob-one-entry", cat, "PLTE of 1 entry, every index 255: deterministic",
        "either", _palette_twice_case("gltf", png(64, 64, lambda x, y: (255,), 3, 8, plte=[RED])))
    add("palette-oob-4bit", cat, "4-bit palette, PLTE of 3, indices to 15: deterministic",
        "either", _palette_twice_case("gltf", png(64, 64, lambda x, y: (x % 16,), 3, 4,
                                                  plte=[RED, BLUE, GREEN])))
    add("palette-trns-longer", cat, "tRNS longer than PLTE: deterministic", "either",
        _palette_twice_case("gltf", png(64, 64, lambda x, y: (x % 2,), 3, 8, plte=[RED, BLUE],
                                        trns=b"\xff" * 200)))

    def refuse_png(data):
        def fn(ctx):
            ctx.write("asset/pal.png", data)
            ctx.render(_scene_for(ctx, "gltf", "pal.png"), "refuse")
        return fn
    empty_plte = PNG_SIG + png_chunk(b"IHDR", struct.pack(">IIBBBBB", 8, 8, 8, 3, 0, 0, 0)) + \
        png_chunk(b"PLTE", b"") + png_chunk(b"IDAT", zlib.compress(b"\0" * 9 * 8)) + \
        png_chunk(b"IEND", b"")
    add("palette-empty-plte", cat, "a palette PNG with an empty PLTE", "refuse",
        refuse_png(empty_plte))
    no_plte = PNG_SIG + png_chunk(b"IHDR", struct.pack(">IIBBBBB", 8, 8, 8, 3, 0, 0, 0)) + \
        png_chunk(b"IDAT", zlib.compress(b"\0" * 9 * 8)) + png_chunk(b"IEND", b"")
    add("palette-missing-plte", cat, "a palette PNG without PLTE", "refuse", refuse_png(no_plte))
    for fmt in ("gltf", "json"):
        for bits in (1, 2, 4, 8):
            add("palette-valid-%dbit-%s" % (bits, fmt), cat,
                "a valid %d-bit palette PNG (%s): exit 0, the palette colour" % (bits, fmt),
                "accept", _palette_valid_case(fmt, bits))


# ---------------------------------------------------------------------------- 11: valid images

def two_tone(top, bottom):
    return lambda x, y, h=64: top if y < h // 2 else bottom


def _valid_case(fname, maker, rgb=None, top=None, bottom=None, lossy=False, webp_ext=False,
                expect="accept", fmt="gltf"):
    def fn(ctx):
        data = maker()
        if data is None:
            raise Skip("no WebP encoder (libwebp or cwebp) on this machine")
        ctx.write("asset/" + fname, data)
        if fmt == "gltf":
            textures = [{"extensions": {"EXT_texture_webp": {"source": 0}}}] if webp_ext else None

            def m(doc, binary):
                if webp_ext:
                    doc["extensionsUsed"] = ["EXT_texture_webp"]
                    doc["extensionsRequired"] = ["EXT_texture_webp"]
            scene = std_scene(ctx, [{"uri": fname}], textures=textures, mutate=m)
        else:
            scene = _scene_for(ctx, fmt, fname)
        r = ctx.render(scene, expect)
        if rgb:
            expect_colour(ctx, r, rgb, lossy=lossy)
        if top:
            expect_colour(ctx, r, top, "top half", region=(0.3, 0.7, 0.05, 0.4), lossy=lossy)
            expect_colour(ctx, r, bottom, "bottom half", region=(0.3, 0.7, 0.6, 0.95),
                          lossy=lossy)
        if expect == "either" and r.code == 0:
            not_black(ctx, r)
    return fn


def _normal_map_case(fname, maker, fmt="gltf", method="progressive"):
    """A flat normal map in another format: exit 0 and the same image as with the PNG one."""
    def fn(ctx):
        data = maker()
        if data is None:
            raise Skip("no WebP encoder (libwebp or cwebp) on this machine")
        ctx.write("asset/" + fname, data)
        ctx.write("asset/flat.png", solid_png(FLAT_NORMAL))
        ctx.write("asset/tex.png", solid_png(GREY))
        scenes = []
        for n in (fname, "flat.png"):
            if fmt == "gltf":
                sub = "asset"
                doc, binary = gltf_doc([{"uri": "tex.png"}, {"uri": n}],
                                       textures=[{"source": 0}, {"source": 1}],
                                       materials=[textured_material(0, emissive=False,
                                                                    normal=1)], light=True)
                scenes.append(ctx.rel(write_gltf(ctx.path(sub), "scene-%s.gltf" % n.replace(
                    ".", "-"), doc, binary)))
            else:
                ctx.write("asset/quad.obj", quad_obj())
                ctx.write("asset/quad.mtl", mtl([]))
                p = "asset/scene-%s.json" % n.replace(".", "-")
                ctx.write_json(p, json_scene({"reflectance": [0.5, 0.5, 0.5], "normal_map": n},
                                             light=True))
                scenes.append(p)
        r = ctx.render(scenes[0], "accept", method=method, label="render with the %s map" % fname)
        ref = ctx.render(scenes[1], "accept", method=method, label="render with the PNG map")
        if r.code == 0 and ref.code == 0:
            a = pfm_region_mean(r.image)
            b = pfm_region_mean(ref.image)
            if any(abs(x - y) > 0.05 * max(y, 1e-3) + 0.01 for x, y in zip(a, b)):
                ctx.fail("the %s normal map renders (%.3f, %.3f, %.3f), the same map as PNG "
                         "(%.3f, %.3f, %.3f)" % ((fname,) + a + b))
    return fn


def define_valid():
    cat = "valid-image"
    for size, lossless in ((128, True), (512, True), (512, False), (1024, False)):
        kind = "lossless" if lossless else "lossy"
        add("valid-webp-%s-%d" % (kind, size), cat,
            "a one-colour %s WebP %dx%d (EXT_texture_webp)" % (kind, size, size), "accept",
            _valid_case("tex.webp", lambda s=size, l=lossless: webp(s, s, TEAL, l), rgb=TEAL,
                        lossy=not lossless, webp_ext=True))
    add("valid-webp-plain-source", cat, "a lossless WebP named by a texture's plain source",
        "accept", _valid_case("tex.webp", lambda: webp(128, 128, TEAL, True), rgb=TEAL))
    add("valid-bmp-top-down", cat, "a top-down BMP (negative height), red over blue", "accept",
        _valid_case("tex.bmp", lambda: bmp24(64, 64, two_tone(RED, BLUE), top_down=True),
                    top=RED, bottom=BLUE))
    add("valid-bmp-bottom-up", cat, "a bottom-up BMP, red over blue (control)", "accept",
        _valid_case("tex.bmp", lambda: bmp24(64, 64, two_tone(RED, BLUE)), top=RED, bottom=BLUE))
    add("valid-bmp-32bit", cat, "a 32-bit BMP", "accept",
        _valid_case("tex.bmp", lambda: bmp32(16, 16, lambda x, y: RED + (255,)), rgb=RED))
    add("valid-png-two-tone", cat, "an RGB PNG, red over blue (control for orientation)",
        "accept", _valid_case("tex.png", lambda: png(64, 64, two_tone(RED, BLUE)), top=RED,
                              bottom=BLUE))
    add("valid-png-palette1-512", cat, "a 1-bit palette PNG 512x512", "accept",
        _valid_case("tex.png", lambda: png(512, 512, lambda x, y: (1,), 3, 1,
                                           plte=[(0, 0, 0), TEAL]), rgb=TEAL))
    add("valid-png-grey-alpha", cat, "a grey+alpha PNG (opaque)", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: (150, 255), 4),
                    rgb=(150, 150, 150)))
    add("valid-png-grey8", cat, "an 8-bit grey PNG", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: (90,), 0), rgb=(90, 90, 90)))
    add("valid-png-grey16", cat, "a 16-bit grey PNG", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: (90 * 257,), 0, 16),
                    rgb=(90, 90, 90)))
    add("valid-png-rgb16", cat, "a 16-bit RGB PNG", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: tuple(c * 257 for c in TEAL), 2,
                                           16), rgb=TEAL))
    add("valid-png-rgba16", cat, "a 16-bit RGBA PNG (opaque)", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: tuple(c * 257 for c in RED) +
                                           (65535,), 6, 16), rgb=RED))
    add("valid-png-interlaced", cat, "an interlaced (Adam7) RGB PNG, red over blue", "accept",
        _valid_case("tex.png", lambda: png(64, 64, two_tone(RED, BLUE), interlace=True),
                    top=RED, bottom=BLUE))
    add("valid-png-interlaced-palette", cat, "an interlaced 2-bit palette PNG", "accept",
        _valid_case("tex.png", lambda: png(37, 29, lambda x, y: (2,), 3, 2,
                                           plte=[RED, BLUE, TEAL], interlace=True), rgb=TEAL))
    add("valid-png-trns-key", cat, "an RGB PNG with a tRNS colour key not present", "accept",
        _valid_case("tex.png", lambda: png(16, 16, lambda x, y: RED, 2,
                                           trns=struct.pack(">HHH", 1, 2, 3)), rgb=RED))
    yc = ycbcr(RED)
    add("valid-jpeg-ycbcr", cat, "a baseline YCbCr JPEG", "accept",
        _valid_case("tex.jpg", lambda: jpeg_flat(64, 64, list(yc)), rgb=rgb_of_ycbcr(yc)))
    add("valid-jpeg-grey", cat, "a baseline grey JPEG", "accept",
        _valid_case("tex.jpg", lambda: jpeg_flat(64, 64, [90]), rgb=(90, 90, 90)))
    add("valid-jpeg-cmyk", cat, "an Adobe CMYK JPEG: read (exit 0, not black) or refused naming "
        "the file", "either",
        _valid_case("tex.jpg", lambda: jpeg_flat(16, 16, [10, 200, 220, 30], adobe=0),
                    expect="either"))
    add("valid-tga-top-left", cat, "a TGA stored top-left, red over blue", "accept",
        _valid_case("tex.tga", lambda: tga(64, 64, two_tone(RED, BLUE)), top=RED, bottom=BLUE))
    add("valid-tga-bottom-left", cat, "a TGA stored bottom-left, red over blue", "accept",
        _valid_case("tex.tga", lambda: tga(64, 64, two_tone(RED, BLUE), top_down=False),
                    top=RED, bottom=BLUE))
    add("valid-tga-rle", cat, "an RLE TGA", "accept",
        _valid_case("tex.tga", lambda: tga(64, 64, lambda x, y: TEAL, rle=True), rgb=TEAL))
    add("valid-webp-json", cat, "a lossless WebP as a JSON scene's texture", "accept",
        _valid_case("tex.webp", lambda: webp(128, 128, TEAL, True), rgb=TEAL, fmt="json"))
    add("valid-jpeg-obj", cat, "a JPEG as an MTL map_Kd/map_Ke", "accept",
        _valid_case("tex.jpg", lambda: jpeg_flat(64, 64, list(yc)), rgb=rgb_of_ycbcr(yc),
                    fmt="obj"))
    nyc = ycbcr(FLAT_NORMAL)
    add("valid-normal-map-jpeg", cat, "a JPEG normal map (glTF normalTexture)", "accept",
        _normal_map_case("normal.jpg", lambda: jpeg_flat(64, 64, list(nyc))))
    add("valid-normal-map-webp", cat, "a WebP normal map (glTF normalTexture)", "accept",
        _normal_map_case("normal.webp", lambda: webp(64, 64, FLAT_NORMAL, True)))
    add("valid-normal-map-png16", cat, "a 16-bit PNG normal map", "accept",
        _normal_map_case("normal.png", lambda: png(16, 16, lambda x, y: tuple(
            c * 257 for c in FLAT_NORMAL), 2, 16)))
    add("valid-normal-map-json-jpeg", cat, "a JPEG normal map in a JSON scene", "accept",
        _normal_map_case("normal.jpg", lambda: jpeg_flat(64, 64, list(nyc)), fmt="json"))

    def webp_bake(ctx):
        data = webp(128, 128, TEAL, True)
        if data is None:
            raise Skip("no WebP encoder (libwebp or cwebp) on this machine")
        ctx.write("asset/tex.webp", data)

        def m(doc, binary):
            doc["extensionsUsed"] = ["EXT_texture_webp"]
            doc["extensionsRequired"] = ["EXT_texture_webp"]
        scene = std_scene(ctx, [{"uri": "tex.webp"}],
                          textures=[{"extensions": {"EXT_texture_webp": {"source": 0}}}],
                          mutate=m)
        r = ctx.bake(scene, "accept")
        if r.code == 0:
            g, doc = baked_doc(ctx, r)
            if doc:
                mimes = [im.get("mimeType") for im in doc.get("images", [])]
                ctx.check("image/webp" in mimes, "the baked glTF has no image/webp image (%s)" %
                          mimes)
            render_baked(ctx, r, TEAL)
    add("valid-webp-bake-rerender", cat, "bake a WebP-textured glTF, render the bake", "accept",
        webp_bake)


# ---------------------------------------------------------------------------- 12: data URIs

def _data_uri_case(uri_maker, expect, rgb=None, webp_ext=False, used=True, bake=False,
                   lossy=False):
    def fn(ctx):
        uri = uri_maker()
        if uri is None:
            raise Skip("no WebP encoder (libwebp or cwebp) on this machine")
        ctx.write("asset/tex.png", solid_png(RED))
        images = [{"uri": uri}] if used else [{"uri": "tex.png"}, {"uri": uri}]
        textures = [{"extensions": {"EXT_texture_webp": {"source": 0}}}] if webp_ext else None

        def m(doc, binary):
            if webp_ext:
                doc["extensionsUsed"] = ["EXT_texture_webp"]
        scene = std_scene(ctx, images, textures=textures, mutate=m)
        r = ctx.render(scene, expect)
        if rgb and r.code == 0:
            expect_colour(ctx, r, rgb, lossy=lossy)
        elif r.code == 0 and used:
            not_black(ctx, r)
        if bake:
            b = ctx.bake(scene, expect, web=ctx.out("web"))
            if b.code == 0:
                rr = render_baked(ctx, b)
    return fn


def b64(data):
    return base64.b64encode(data).decode()


def define_data_uris():
    cat = "data-uri"
    red = solid_png(RED)
    w = lambda: webp(64, 64, TEAL, True)
    add("data-png", cat, "data:image/png;base64 (valid)", "accept",
        _data_uri_case(lambda: "data:image/png;base64," + b64(red), "accept", rgb=RED))
    add("data-webp-plain", cat, "data:image/webp;base64 as a texture's source", "accept",
        _data_uri_case(lambda: (lambda d: d and "data:image/webp;base64," + b64(d))(w()),
                       "accept", rgb=TEAL))
    add("data-webp-ext", cat, "data:image/webp;base64 through EXT_texture_webp", "accept",
        _data_uri_case(lambda: (lambda d: d and "data:image/webp;base64," + b64(d))(w()),
                       "accept", rgb=TEAL, webp_ext=True))
    add("data-jpeg", cat, "data:image/jpeg;base64 (valid)", "accept",
        _data_uri_case(lambda: "data:image/jpeg;base64," + b64(jpeg_flat(16, 16, [90])),
                       "accept", rgb=(90, 90, 90)))
    add("data-bmp", cat, "data:image/bmp;base64 (valid)", "accept",
        _data_uri_case(lambda: "data:image/bmp;base64," + b64(bmp24(8, 8, lambda x, y: RED)),
                       "accept", rgb=RED))
    add("data-bad-base64", cat, "data:image/png;base64 with characters outside base64",
        "refuse", _data_uri_case(lambda: "data:image/png;base64,!!!!" + b64(red)[4:], "refuse"))
    add("data-truncated-base64", cat, "a PNG data URI cut in half", "refuse",
        _data_uri_case(lambda: "data:image/png;base64," + b64(red)[:len(b64(red)) // 2],
                       "refuse"))
    add("data-bad-padding", cat, "a PNG data URI with '=' in the middle", "refuse",
        _data_uri_case(lambda: "data:image/png;base64," + b64(red)[:20] + "==" + b64(red)[20:],
                       "refuse"))
    add("data-whitespace", cat, "a PNG data URI with line breaks in the base64", "either",
        _data_uri_case(lambda: "data:image/png;base64," + "\n".join(
            b64(red)[i:i + 16] for i in range(0, len(b64(red)), 16)), "either"))
    add("data-no-mime", cat, "'data:;base64,' + a PNG (no mime type): read it or refuse it "
        "cleanly", "either", _data_uri_case(lambda: "data:;base64," + b64(red), "either"))
    add("data-no-mime-no-semicolon", cat, "'data:base64,' + a PNG", "either",
        _data_uri_case(lambda: "data:base64," + b64(red), "either"))
    add("data-percent-encoded", cat, "'data:image/png,' + the PNG percent-encoded (not base64)",
        "either", _data_uri_case(lambda: "data:image/png," + "".join(
            "%%%02X" % b for b in red), "either"))
    add("data-mime-mismatch", cat, "PNG bytes labelled data:image/jpeg", "either",
        _data_uri_case(lambda: "data:image/jpeg;base64," + b64(red), "either"))
    add("data-empty", cat, "'data:image/png;base64,' (no data)", "refuse",
        _data_uri_case(lambda: "data:image/png;base64,", "refuse"))
    add("data-unused-bad-base64", cat, "an unused image with a bad base64 data URI", "either",
        _data_uri_case(lambda: "data:image/png;base64,@@@@", "either", used=False))
    add("data-text-html", cat, "a data:text/html;base64 image", "refuse",
        _data_uri_case(lambda: "data:text/html;base64," + b64(b"<html>hi</html>"), "refuse"))
    add("data-huge-garbage", cat, "a 24 MB data URI of 'A's (decodes to zeros)", "refuse",
        _data_uri_case(lambda: "data:image/png;base64," + "A" * (24 * MiB), "refuse"))
    add("data-png-bake-rerender", cat, "a PNG data URI: bake --web, render the bake", "accept",
        _data_uri_case(lambda: "data:image/png;base64," + b64(red), "accept", rgb=RED, bake=True))

    def bad_buffer(ctx):
        doc, binary = gltf_doc([{"uri": "tex.png"}])
        ctx.write("asset/tex.png", red)
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64,!!" + b64(binary)[2:]
        ctx.write_json("asset/scene.gltf", doc)
        ctx.render("asset/scene.gltf", "refuse")
    add("data-buffer-bad-base64", cat, "a buffer data URI with bad base64", "refuse", bad_buffer)


# ---------------------------------------------------------------------------- 13, 14, 21: bakes

ODD_NAMES = [
    ("percent", "per%cent.png"), ("plus", "a+b.png"), ("hash", "hash#tag.png"),
    ("question", "what?.png"), ("space", "sp ace.png"), ("unicode", "\u00fcn\u00ef\u00e7\u00f8d\u00e9.png"),
    ("backslash", "back\\slash.png"), ("colon", "c:colon.png"), ("semicolon-amp", "semi;co&amp.png"),
    ("quote", "quo'te.png"), ("brackets", "[brackets].png"),
]


def _roundtrip_texture_case(fname):
    def fn(ctx):
        ctx.write("asset/" + fname, solid_png(RED))
        scene = std_scene(ctx, [{"uri": uri_quote(fname)}])
        r0 = ctx.render(scene, "accept", label="render of the input")
        expect_colour(ctx, r0, RED, "render of the input")
        b = ctx.bake(scene, "accept", web=ctx.out("web"))
        if b.code == 0:
            rr = render_baked(ctx, b, RED)
    return fn


def _roundtrip_scene_name_case(sname):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        scene = std_scene(ctx, [{"uri": "tex.png"}], name=sname, sub="asset")
        b = ctx.bake(scene, "accept", web=ctx.out("web"), names=[sname])
        if b.code == 0:
            render_baked(ctx, b, RED)
            check_web(ctx, b)
    return fn


def _roundtrip_local_case(fmt, fname):
    def fn(ctx):
        ctx.write("asset/" + fname, solid_png(RED))
        scene = _scene_for(ctx, fmt, fname, light=True)
        if fmt == "obj":
            ctx.write("asset/quad.mtl", mtl(["map_Kd " + fname]))
        b = ctx.bake(scene, "accept", web=ctx.out("web"))
        if b.code == 0:
            g, doc = check_baked_uris(ctx, b)
            if doc is not None:
                ctx.check(len(doc.get("images", [])) > 1, "the baked glTF has no image for the "
                          "texture (images: %s)" % [im.get("uri", im.get("name"))
                                                    for im in doc.get("images", [])])
            render_baked(ctx, b)
    return fn


def check_web(ctx, r):
    """bake.json and the page: paths relative, inside the web folder, no '../'."""
    web = r.web_dir
    if r.code != 0 or not web:
        return
    manifest = os.path.join(web, "bake.json")
    if not ctx.check(os.path.isfile(manifest), "--web wrote no bake.json"):
        return
    with open(manifest, encoding="utf-8") as f:
        try:
            m = json.load(f)
        except ValueError:
            ctx.fail("bake.json is not JSON")
            return
    refs = []

    def walk(v):
        if isinstance(v, str):
            refs.append(v)
        elif isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            for x in v:
                walk(x)
    walk(m)
    for ref in refs:
        if not re.search(r"\.(gltf|glb|png|exr|bin|json)$", ref):
            continue
        why = uri_problem(ref)
        if why:
            ctx.fail("bake.json names %r: %s (a server rooted at the web folder cannot serve it)"
                     % (ref, why))
        elif not os.path.isfile(os.path.join(web, uri_decode(ref))):
            ctx.fail("bake.json names %r, which is not in the web folder" % ref)
    for page in ("index.html", "viewer.js"):
        p = os.path.join(web, page)
        if os.path.isfile(p):
            with open(p, encoding="utf-8", errors="replace") as f:
                text = f.read()
            for ref in re.findall(r"""(?:src|href)\s*=\s*["']([^"']+)["']""", text):
                if ref.startswith(("http:", "https:", "data:", "#", "//")):
                    continue
                if ref.startswith("/") or ".." in ref.split("/"):
                    ctx.fail("%s references %r (outside the web folder)" % (page, ref))


def _web_case(web_rel, out_rel):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        scene = std_scene(ctx, [{"uri": "tex.png"}])
        web = ctx.path("out", web_rel)
        out = ctx.path("out", out_rel)
        b = ctx.bake(scene, "accept", web=web, out=out)
        check_web(ctx, b)
    return fn


def _abs_path_case(fmt, preview=False, relative=False):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        scene = _scene_for(ctx, fmt if fmt != "glb" else "gltf", "tex.png", light=True)
        if fmt == "glb":
            doc, binary = gltf_doc([{"uri": "tex.png"}])
            scene = ctx.rel(write_gltf(ctx.path("asset"), "scene.glb", doc, binary, "glb"))
        cwd = ctx.path("working-folder-" + secrets.token_hex(6))
        os.makedirs(cwd)
        absolute = os.path.abspath(ctx.path(scene))
        given = ctx.rel(absolute) if relative else absolute  # ctx.bake makes it relative to cwd
        b = ctx.bake(given, "accept", web=ctx.out("web"), cwd=cwd,
                     extra=["--preview"] if preview else [])
        if b.code == 0:
            needles = {"the scene's absolute folder": os.path.dirname(absolute).encode(),
                       "the working folder": cwd.encode()}
            leak_check(ctx, needles)
            home = os.path.expanduser("~")
            if len(home) > 1:
                for f in files_under([ctx.path("out")]):
                    if f.endswith((".gltf", ".json", ".html", ".js")):
                        with open(f, "rb") as fh:
                            if ('"' + home + "/").encode() in fh.read():
                                ctx.fail("%s names the home folder" % ctx.rel(f))
    return fn


def define_bake_outputs():
    cat = "uri-roundtrip"
    for tag, fname in ODD_NAMES:
        add("roundtrip-texture-%s" % tag, cat,
            "a texture named %r: render, bake --web, baked URIs RFC 3986, render the bake" % fname,
            "accept", _roundtrip_texture_case(fname))
    for tag, sname in (("space", "my scene.gltf"), ("hash", "sc#ene.gltf"),
                       ("question", "sc?ene.gltf"), ("percent", "sc%ene.gltf"),
                       ("unicode", "sc\u00e8ne.gltf"), ("plus", "sc+ene.gltf")):
        add("roundtrip-scene-name-%s" % tag, cat,
            "a scene named %r: the bake's own URIs (lightmap, .bin) valid and readable" % sname,
            "accept", _roundtrip_scene_name_case(sname))
    add("roundtrip-obj-odd-texture", cat, "an OBJ whose map_Kd is 'sp ace#1.png': bake, URIs, "
        "render the bake", "accept", _roundtrip_local_case("obj", "sp ace#1.png"))
    add("roundtrip-json-odd-texture", cat, "a JSON scene texture 'a+b%.png': bake, URIs, render "
        "the bake", "accept", _roundtrip_local_case("json", "a+b%.png"))
    cat = "web-dir"
    add("web-sibling-new", cat, "--web a new folder beside -o: bake.json inside it, no '../'",
        "accept", _web_case("web-new", "bake"))
    add("web-deep-new", cat, "--web a new folder three levels deep, -o elsewhere", "accept",
        _web_case("x/y/z/web", "bake"))
    add("web-inside-out", cat, "--web inside -o", "accept", _web_case("bake/web", "bake"))
    add("web-outside-out", cat, "-o inside --web", "accept", _web_case("site", "site/bake"))
    add("web-same-as-out", cat, "--web the same folder as -o (control)", "accept",
        _web_case("bake", "bake"))
    cat = "abs-path"
    for fmt in ("gltf", "glb", "obj", "json"):
        add("abs-path-%s" % fmt, cat, "bake --web of a %s given by absolute path: no output "
            "holds that path or the working folder" % fmt, "accept", _abs_path_case(fmt))
    add("abs-path-preview", cat, "the same with --preview", "accept",
        _abs_path_case("gltf", preview=True))
    for fmt in ("gltf", "glb", "obj", "json"):
        add("abs-path-%s-given-relative" % fmt, cat, "bake --web of a %s given by a relative path "
            "from another folder: no output holds the absolute folder or the working folder" % fmt,
            "accept", _abs_path_case(fmt, relative=True))

    def render_absolute(fmt):
        def fn(ctx):
            ctx.write("asset/tex.png", solid_png(RED))
            if fmt == "glb":
                doc, binary = gltf_doc([{"uri": "tex.png"}])
                scene = ctx.rel(write_gltf(ctx.path("asset"), "scene.glb", doc, binary, "glb"))
            else:
                scene = _scene_for(ctx, fmt, "tex.png")
            r = ctx.render(os.path.abspath(ctx.path(scene)), "accept")
            expect_colour(ctx, r, RED)
        return fn
    for fmt in ("gltf", "glb", "obj", "json"):
        add("abs-path-render-%s" % fmt, cat, "render a %s (with its texture beside it) given by "
            "its absolute path" % fmt, "accept", render_absolute(fmt))


# ---------------------------------------------------------------------------- 15-16: OBJ and MTL

def _lit_obj_scene(ctx, map_line, extra_files=()):
    """quad.obj with map_Kd `map_line` under a point light, in a JSON scene that keeps the
    OBJ's own materials; returns the scene."""
    ctx.write("asset/tex.png", solid_png(RED))
    for name in extra_files:
        ctx.write("asset/" + name, solid_png(RED))
    ctx.write("asset/quad.obj", quad_obj())
    ctx.write("asset/quad.mtl", "newmtl %s\nKd 1 1 1\n%s\n" % (MATERIAL, map_line))
    doc = json_scene({}, light=True)
    del doc["materials"]
    del doc["meshes"][0]["material"]
    ctx.write_json("asset/scene.json", doc)
    return "asset/scene.json"


def _mtl_option_case(map_line, extra_files=()):
    def fn(ctx):
        scene = _lit_obj_scene(ctx, map_line, extra_files)
        r = ctx.render(scene, "accept", names=["quad.mtl", "scene.json", "quad.obj"])
        if r.code == 0:
            m = pfm_region_mean(r.image, 0.4, 0.6, 0.4, 0.6)
            if not (m[0] > 1e-4 and m[1] < 0.5 * m[0] and m[2] < 0.5 * m[0]):
                ctx.fail("the quad renders (%.3f, %.3f, %.3f): the red texture of %r is not used"
                         % (m + (map_line,)))
    return fn


def _mtl_emissive_option_case(map_line):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        ctx.write("asset/quad.obj", quad_obj())
        ctx.write("asset/quad.mtl", "newmtl %s\nKd 0 0 0\nKe 1 1 1\n%s\n" % (MATERIAL, map_line))
        r = ctx.render("asset/quad.obj", "accept", names=["quad.mtl", "quad.obj"])
        expect_colour(ctx, r, RED, region=(0.45, 0.55, 0.45, 0.55))
    return fn


def _bake_textures_case(fmt, kind):
    """A textured (and cut-out) OBJ or JSON scene baked: the baked glTF references the
    texture and the cut-out."""
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        ctx.write("asset/cut.png", png(16, 16, lambda x, y: RED + ((255 if x < 8 else 0),), 6))
        ctx.write("asset/mask.png", png(16, 16, lambda x, y: ((255 if x < 8 else 0),), 0))
        ctx.write("asset/quad.obj", quad_obj())
        want_mask = kind in ("cutout", "alpha-mode", "coverage")
        want_emissive = kind == "emission"
        if fmt == "obj":
            lines = ["map_Kd tex.png"] + (["map_d mask.png"] if kind == "cutout" else [])
            ctx.write("asset/quad.mtl", "newmtl %s\nKd 1 1 1\n%s\n" % (MATERIAL, "\n".join(lines)))
            doc = json_scene({}, light=True)
            del doc["materials"]
            del doc["meshes"][0]["material"]
            ctx.write_json("asset/scene.json", doc)
            scene = "asset/quad.obj" if kind == "plain-obj" else "asset/scene.json"
        elif fmt == "json":
            ctx.write("asset/quad.mtl", mtl([]))
            m = {"reflectance": [1, 1, 1], "reflectance_texture": "tex.png"}
            if kind == "coverage":
                m["coverage_texture"] = "mask.png"
            elif kind == "alpha-mode":
                m["reflectance_texture"] = "cut.png"
                m["alpha_mode"] = "mask"
            elif kind == "emission":
                m = {"reflectance": [1, 1, 1], "emission": [1, 1, 1], "emission_texture": "tex.png"}
            ctx.write_json("asset/scene.json", json_scene(m, light=True))
            scene = "asset/scene.json"
        else:
            scene = std_scene(ctx, [{"uri": "cut.png"}], materials=[
                textured_material(0, emissive=False, alpha_mode="MASK", cutoff=0.5)], light=True)
        # An OBJ given alone has no light: a uniform environment lights it.
        lit = ("--environment", "1,1,1") if kind == "plain-obj" else ()
        b = ctx.bake(scene, "accept", extra=lit)
        if b.code != 0:
            return
        g, doc = check_baked_uris(ctx, b)
        if doc is None:
            return
        own = [im for im in doc.get("images", [])
               if "lightmap" not in (im.get("name", "") + im.get("uri", ""))]
        ctx.check(own, "the baked glTF has no image but the lightmap: the texture is lost")
        mats = doc.get("materials", [])
        if want_mask:
            ctx.check(any(m.get("alphaMode") == "MASK" for m in mats),
                      "the baked glTF has no alphaMode MASK material: the cut-out is lost")
        if want_emissive:
            ctx.check(any("emissiveTexture" in m for m in mats),
                      "the baked glTF has no emissiveTexture: the emission texture is lost")
        else:
            ctx.check(any("baseColorTexture" in m.get("pbrMetallicRoughness", {}) for m in mats),
                      "the baked glTF has no baseColorTexture: the texture is lost")
        render_baked(ctx, b)
    return fn


def define_obj():
    cat = "obj-mtl"
    options = [
        ("s-three", "map_Kd -s 1 1 1 tex.png"), ("o-two", "map_Kd -o 0.5 0.5 tex.png"),
        ("s-two", "map_Kd -s 2 2 tex.png"), ("o-three", "map_Kd -o 0.5 0.5 0.5 tex.png"),
        ("s-one", "map_Kd -s 1 tex.png"), ("clamp", "map_Kd -clamp on tex.png"),
        ("bm", "map_Kd -bm 1 tex.png"), ("blend", "map_Kd -blendu on -blendv off tex.png"),
        ("mm", "map_Kd -mm 0 1 tex.png"), ("o-negative", "map_Kd -o -0.5 -0.5 tex.png"),
        ("s-and-o", "map_Kd -s 1 1 1 -o 0.5 0.5 0.5 tex.png"), ("t", "map_Kd -t 0 0 0 tex.png"),
        ("texres", "map_Kd -texres 512 tex.png"), ("plain", "map_Kd tex.png"),
    ]
    for tag, line in options:
        add("mtl-option-%s" % tag, cat, "%r: the texture is used" % line, "accept",
            _mtl_option_case(line))
    add("mtl-option-space-name", cat, "'map_Kd my tex.png' (a name with a space)", "accept",
        _mtl_option_case("map_Kd my tex.png", extra_files=("my tex.png",)))
    add("mtl-option-s-two-space-name", cat, "'map_Kd -s 1 1 my tex.png'", "accept",
        _mtl_option_case("map_Kd -s 1 1 my tex.png", extra_files=("my tex.png",)))
    add("mtl-option-backslash", cat, "'map_Kd sub\\tex.png' (a Windows path)", "accept",
        _mtl_option_case("map_Kd sub\\tex.png", extra_files=("sub/tex.png",)))
    add("mtl-emissive-s-two", cat, "'map_Ke -s 1 1 tex.png': the emission is the texture's",
        "accept", _mtl_emissive_option_case("map_Ke -s 1 1 tex.png"))
    add("mtl-emissive-o-two", cat, "'map_Ke -o 0.5 0.5 tex.png'", "accept",
        _mtl_emissive_option_case("map_Ke -o 0.5 0.5 tex.png"))
    cat = "bake-textures"
    add("bake-obj-cutout", cat, "bake an OBJ with map_Kd and a map_d cut-out: images and MASK",
        "accept", _bake_textures_case("obj", "cutout"))
    add("bake-obj-texture-direct", cat, "bake an OBJ (given directly) with map_Kd", "accept",
        _bake_textures_case("obj", "plain-obj"))
    add("bake-json-coverage", cat, "bake a JSON scene with reflectance_texture and "
        "coverage_texture", "accept", _bake_textures_case("json", "coverage"))
    add("bake-json-alpha-mode", cat, "bake a JSON scene with alpha_mode mask", "accept",
        _bake_textures_case("json", "alpha-mode"))
    add("bake-json-emission-texture", cat, "bake a JSON scene with emission_texture", "accept",
        _bake_textures_case("json", "emission"))
    add("bake-gltf-mask-control", cat, "bake a glTF with a MASK material (control)", "accept",
        _bake_textures_case("gltf", "mask"))


# ---------------------------------------------------------------------------- 17: checkpoints

CHECKPOINT_ELEMENTS = "400000"
CHECKPOINT_SIGINT_AFTER = 2.0  # seconds after the bake says it has built its lightmap


def _checkpoint_scene(ctx, fmt, variant):
    """Writes the scene for `variant` ("before" or "after"); returns its path."""
    if fmt == "gltf":
        change = ctx.case_change
        tex = "tex.png"
        mat = textured_material(0, emissive=False)
        samplers = None
        if change == "alpha-mode":
            tex = "cut.png"
            mat = textured_material(0, emissive=False, alpha_mode="MASK" if variant == "after"
                                    else "OPAQUE")
        elif change == "alpha-cutoff":
            tex = "cut.png"
            mat = textured_material(0, emissive=False, alpha_mode="MASK",
                                    cutoff=0.9 if variant == "after" else 0.1)
        elif change == "texture-removed" and variant == "after":
            del mat["pbrMetallicRoughness"]["baseColorTexture"]
        elif change == "sampler-wrap":
            samplers = [{"wrapS": 33071 if variant == "after" else 10497, "wrapT": 10497}]
            mat["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
                "KHR_texture_transform": {"scale": [3, 3], "offset": [0.25, 0.25]}}
        elif change == "factor" and variant == "after":
            mat["pbrMetallicRoughness"]["baseColorFactor"] = [0.2, 0.2, 0.2, 1]
        lamp = {"name": "lamp", "emissiveFactor": [1, 1, 1], "doubleSided": True,
                "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1]},
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20}}}
        textures = [{"source": 0}] if samplers is None else [{"source": 0, "sampler": 0}]
        doc, binary = gltf_doc([{"uri": tex}], textures=textures, samplers=samplers,
                               materials=[mat, lamp])
        doc["meshes"].append({"primitives": [dict(doc["meshes"][0]["primitives"][0],
                                                  material=1)]})
        # the lamp: the quad turned to face the textured one, above it
        doc["nodes"].append({"mesh": 1, "translation": [0, 0, 1.0], "scale": [0.5, 0.5, 0.5],
                             "rotation": [1, 0, 0, 0]})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
        doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
        if change == "sampler-wrap":
            doc["extensionsUsed"].append("KHR_texture_transform")
        return ctx.rel(write_gltf(ctx.path("asset"), "scene.gltf", doc, binary))
    ctx.write("asset/quad.obj", quad_obj())
    lamp = "v -0.5 -0.5 1\nv -0.5 0.5 1\nv 0.5 0.5 1\nv 0.5 -0.5 1\n"
    ctx.write("asset/lamp.obj", lamp + "f 1 2 3 4\n")
    if fmt == "obj":
        tex = "tex.png" if variant == "before" else "other.png"
        ctx.write("asset/quad.mtl", "newmtl %s\nKd 1 1 1\nmap_Kd %s\nnewmtl lamp\nKd 0.8 0.8 0.8\n"
                  "Ke 20 20 20\n"
                  % (MATERIAL, tex))
        ctx.write("asset/quad.obj", "mtllib quad.mtl\n" + quad_obj(mtl=None) +
                  "o lamp\n" + lamp + "usemtl lamp\nf 5 6 7 8\n")
        return "asset/quad.obj"
    ctx.write("asset/quad.mtl", mtl([]))
    tex = "tex.png" if variant == "before" else "other.png"
    doc = json_scene({"reflectance": [1, 1, 1], "reflectance_texture": tex},
                     extra_materials={"lamp": {"emission": [20, 20, 20]}})
    doc["meshes"].append({"file": "lamp.obj", "material": "lamp"})
    ctx.write_json("asset/scene.json", doc)
    return "asset/scene.json"


def _checkpoint_case(fmt, change):
    def fn(ctx):
        ctx.case_change = change
        ctx.write("asset/tex.png", solid_png(RED))
        ctx.write("asset/other.png", solid_png(BLUE))
        ctx.write("asset/cut.png", png(16, 16, lambda x, y: RED + ((255 if x < 8 else 0),), 6))
        scene = _checkpoint_scene(ctx, fmt, "before")
        ckpt = ctx.path("out", "run.checkpoint")
        stats = ctx.path("out", "stats.json")
        os.makedirs(ctx.path("out"), exist_ok=True)
        common = ["--elements", CHECKPOINT_ELEMENTS]

        def interrupt(p):
            pid = child_pid(p)

            def later():
                # SIGINT once the solve runs (the info line about the lightmap is out): a signal
                # while loading or during the first shot ends the run without a checkpoint.
                deadline = time.monotonic() + 30
                while time.monotonic() < deadline:
                    try:
                        with open("/proc/%d/fd/2" % pid, "rb") as f:
                            if b"lightmap texels" in f.read():
                                break
                    except OSError:
                        pass
                    time.sleep(0.1)
                time.sleep(CHECKPOINT_SIGINT_AFTER)
                try:
                    os.kill(pid, signal.SIGINT)
                except OSError:
                    pass
            threading.Thread(target=later, daemon=True).start()
        first = ctx.bake(scene, None, method="progressive", label="bake, interrupted by SIGINT",
                         extra=common + ["--iterations", "1000000", "--tolerance", "1e-12",
                                         "--checkpoint", ckpt, "--stats", stats],
                         on_start=interrupt, timeout=max(ctx.opts.timeout, 120))
        ctx.repro.append("# (the bake above was sent SIGINT %.0f s after its 'lightmap texels' "
                         "line)" % CHECKPOINT_SIGINT_AFTER)
        if first.code != 130 or not os.path.isfile(ckpt):
            raise Skip("could not make a checkpoint (the bake ended %s without one)" %
                       first.outcome())
        done = 0
        try:
            with open(stats) as f:
                done = int(json.load(f).get("iterations", 0))
        except (OSError, ValueError, TypeError):
            pass
        if change == "none":
            pass
        elif change == "texture-content":
            ctx.write("asset/tex.png", solid_png(BLUE))
        else:
            _checkpoint_scene(ctx, fmt, "after")
        ctx.repro.append("# (then the scene changed: %s)" % change)
        expect = "accept" if change == "none" else "either"
        r = ctx.bake(scene, expect, method="progressive", label="bake --resume after: " + change,
                     extra=common + ["--resume", ckpt, "--keep-checkpoint", "--tolerance", "0.9",
                                     "--iterations", str(done + 5)],
                     names=["checkpoint", os.path.basename(scene)])
        if change != "none" and r.code == 0:
            warned = [l for l in r.stderr.splitlines()
                      if "warning" in l.lower() and "checkpoint" in l.lower()]
            if not warned:
                ctx.fail("the checkpoint resumed silently after the scene's %s changed" % change)
    return fn


def define_checkpoints():
    cat = "checkpoint"
    for fmt, change in (("gltf", "none"), ("gltf", "texture-content"), ("gltf", "alpha-mode"),
                        ("gltf", "alpha-cutoff"), ("gltf", "texture-removed"),
                        ("gltf", "sampler-wrap"), ("gltf", "factor"), ("json", "texture-file"),
                        ("obj", "texture-file")):
        add("checkpoint-%s-%s" % (fmt, change), cat,
            "bake --method progressive interrupted, then resumed after %s (%s)" % (
                "no change" if change == "none" else "the " + change + " changed", fmt),
            "accept" if change == "none" else "refuse or warn", _checkpoint_case(fmt, change),
            heavy=True, rss_mb=4096)


# ---------------------------------------------------------------------------- 18: messages

FORBIDDEN = ("unknown image type", "outofmem", "bad_alloc", "std::bad_alloc")


def _message_images():
    return {
        "too-large-png": ("big.png", lambda: PNG_SIG + png_chunk(b"IHDR", struct.pack(
            ">IIBBBBB", 70000, 70000, 8, 2, 0, 0, 0)) + png_chunk(b"IDAT", zlib.compress(
                b"\0" * 4096)) + png_chunk(b"IEND", b""), "refuse"),
        "jpeg-12bit": ("deep.jpg", lambda: jpeg_flat(16, 16, [2048], precision=12, sof=0xC1),
                       "either"),
        "bmp-rle8": ("rle.bmp", lambda: bmp_rle8(16, 16), "either"),
        "empty-file": ("empty.png", lambda: b"", "refuse"),
        "truncated-png": ("cut.png", lambda: solid_png(RED, size=64)[:60], "refuse"),
        "png16-16k": ("deep16.png", None, "either"),
    }


def _message_case(kind, fmt, normal=False):
    def fn(ctx):
        fname, maker, expect = _message_images()[kind] if not normal else (
            "normal.png", lambda: PNG_SIG + b"garbage" * 10, "refuse")
        if maker is None:
            ctx.asset("asset/" + fname, "png-16k-rgb16", _bomb_images()["png-16k-rgb16"][2])
        else:
            ctx.write("asset/" + fname, maker())
        if normal:
            ctx.write("asset/tex.png", solid_png(RED))
            if fmt == "gltf":
                scene = std_scene(ctx, [{"uri": "tex.png"}, {"uri": fname}],
                                  textures=[{"source": 0}, {"source": 1}],
                                  materials=[textured_material(0, normal=1)])
            else:
                ctx.write("asset/quad.obj", quad_obj())
                ctx.write("asset/quad.mtl", mtl([]))
                ctx.write_json("asset/scene.json", json_scene(
                    {"reflectance": [1, 1, 1], "normal_map": fname}))
                scene = "asset/scene.json"
        else:
            scene = _scene_for(ctx, fmt, fname)
        r = ctx.render(scene, expect, names=[fname])
        if r.code == 2:
            line = r.errline
            ctx.check(fname in line and MATERIAL in line,
                      "the error line must name the image %r and the material %r: %s" % (
                          fname, MATERIAL, line[:300]))
            low = line.lower()
            for bad in FORBIDDEN + (("missing or unreadable",) if kind == "empty-file" else ()):
                ctx.check(bad not in low, "the error line says %r: %s" % (bad, line[:300]))
    return fn


def define_messages():
    cat = "messages"
    for kind in _message_images():
        for fmt in ("gltf", "obj", "json"):
            heavy = kind == "png16-16k"
            add("message-%s-%s" % (kind, fmt), cat,
                "%s as a %s texture: one error line naming the image and the material" % (
                    kind, fmt), _message_images()[kind][2], _message_case(kind, fmt),
                heavy=heavy, rss_mb=BOMB_RSS_MB if heavy else 1024)
    for fmt in ("gltf", "json"):
        add("message-normal-map-%s" % fmt, cat, "a corrupt normal map (%s): the error names the "
            "image and the material" % fmt, "refuse", _message_case(None, fmt, normal=True))


# ---------------------------------------------------------------------------- 19: silent accepts

def _crc_case(chunk, fmt="gltf"):
    def fn(ctx):
        ctx.write("asset/crc.png", png(16, 16, lambda x, y: (1,) if chunk == "PLTE" else RED,
                                       3 if chunk == "PLTE" else 2,
                                       plte=[(0, 0, 0), RED] if chunk == "PLTE" else None,
                                       bad_crc=(chunk,)))
        scene = _scene_for(ctx, fmt, "crc.png")
        r = ctx.render(scene, "either", names=["crc.png"])
        if r.code == 0:
            warned = [l for l in r.stderr.splitlines() if "crc.png" in l and
                      ("warning" in l.lower() or "crc" in l.lower())]
            ctx.check(warned, "a PNG with a bad %s CRC was read without a warning or an error"
                      % chunk)
    return fn


def _value_case(mutate, expect="refuse", key=None):
    def fn(ctx):
        ctx.write("asset/tex.png", solid_png(RED))
        scene = std_scene(ctx, [{"uri": "tex.png"}], samplers=[{"wrapS": 10497, "wrapT": 10497}],
                          textures=[{"source": 0, "sampler": 0}], mutate=mutate)
        r = ctx.render(scene, expect)
        if key and r.code == 2:
            ctx.check(key in r.errline, "the error line does not name %r: %s" % (key,
                                                                                 r.errline[:300]))
    return fn


def _mat_tex(field, key, value):
    """mutate: materials[0]...<field>.<key> = value (field: baseColor, emissive, normal)."""
    def m(doc, binary):
        mat = doc["materials"][0]
        if field == "baseColor":
            mat["pbrMetallicRoughness"]["baseColorTexture"][key] = value
        elif field == "emissive":
            mat["emissiveTexture"][key] = value
        elif field == "normal":
            mat["normalTexture"] = {"index": 0, key: value}
    return m


def define_silent():
    cat = "silent-accept"
    for chunk in ("IHDR", "IDAT", "IEND", "PLTE"):
        add("crc-bad-%s" % chunk.lower(), cat, "a PNG whose %s CRC is wrong: an error, or a "
            "warning naming the file" % chunk, "refuse or warn", _crc_case(chunk))
    add("crc-bad-idat-json", cat, "the bad IDAT CRC in a JSON scene", "refuse or warn",
        _crc_case("IDAT", "json"))
    add("crc-bad-idat-obj", cat, "the bad IDAT CRC in an MTL map", "refuse or warn",
        _crc_case("IDAT", "obj"))
    for key, value in (("wrapS", "10497"), ("wrapT", "33071"), ("magFilter", "9729"),
                       ("minFilter", "9987")):
        add("string-%s" % key, cat, "sampler %s given as the string %r" % (key, value), "refuse",
            _value_case(_set(["samplers", 0, key], value), key=key))
    for tag, value in (("4294967297", 4294967297), ("4294967296", 4294967296),
                       ("minus-4294967295", -4294967295), ("1.5", 1.5), ("string", "0"),
                       ("1e20", 1e20)):
        add("texcoord-%s" % tag, cat, "baseColorTexture.texCoord %r" % (value,), "refuse",
            _value_case(_mat_tex("baseColor", "texCoord", value), key="texCoord"))
    add("texture-source-string", cat, "textures[0].source \"0\"", "refuse",
        _value_case(_set(["textures", 0, "source"], "0"), key="source"))
    add("texture-sampler-string", cat, "textures[0].sampler \"0\"", "refuse",
        _value_case(_set(["textures", 0, "sampler"], "0"), key="sampler"))
    add("material-texture-index-string", cat, "baseColorTexture.index \"0\"", "refuse",
        _value_case(_mat_tex("baseColor", "index", "0"), key="index"))
    add("material-texture-index-2e32", cat, "baseColorTexture.index 4294967296", "refuse",
        _value_case(_mat_tex("baseColor", "index", 4294967296), key="index"))
    add("normal-scale-string", cat, "normalTexture.scale \"1\"", "refuse",
        _value_case(_mat_tex("normal", "scale", "1"), key="scale"))
    add("transform-texcoord-2e32p1", cat, "KHR_texture_transform texCoord 4294967297", "refuse",
        _value_case(_mat_tex("baseColor", "extensions", {"KHR_texture_transform": {
            "texCoord": 4294967297}}), key="texCoord"))


# ---------------------------------------------------------------------------- 20: all holes

HOLE_METHODS = ("pathtrace", "progressive", "stochastic", "matrix")


def _holes_case(kind):
    def fn(ctx):
        hole = png(16, 16, lambda x, y: RED + (0,), 6)
        if kind in ("gltf-mask", "gltf-blend", "gltf-cutoff1"):
            if kind == "gltf-cutoff1":
                hole = png(16, 16, lambda x, y: RED + (254,), 6)
            ctx.write("asset/hole.png", hole)
            mode = "BLEND" if kind == "gltf-blend" else "MASK"
            scene = std_scene(ctx, [{"uri": "hole.png"}], materials=[textured_material(
                0, alpha_mode=mode, cutoff=1.0 if kind == "gltf-cutoff1" else
                (None if mode == "BLEND" else 0.5))], light=True)
        elif kind == "json-coverage":
            ctx.write("asset/hole.png", png(16, 16, lambda x, y: (0,), 0))
            ctx.write("asset/tex.png", solid_png(RED))
            ctx.write("asset/quad.obj", quad_obj())
            ctx.write("asset/quad.mtl", mtl([]))
            ctx.write_json("asset/scene.json", json_scene(
                {"reflectance": [1, 1, 1], "reflectance_texture": "tex.png",
                 "emission": [1, 1, 1], "emission_texture": "tex.png",
                 "coverage_texture": "hole.png"}, light=True))
            scene = "asset/scene.json"
        else:
            ctx.write("asset/hole.png", png(16, 16, lambda x, y: (0,), 0))
            ctx.write("asset/tex.png", solid_png(RED))
            ctx.write("asset/quad.obj", quad_obj())
            ctx.write("asset/quad.mtl", mtl(["map_Kd tex.png", "map_Ke tex.png",
                                             "map_d hole.png"]))
            doc = json_scene({}, light=True)
            del doc["materials"]
            del doc["meshes"][0]["material"]
            ctx.write_json("asset/scene.json", doc)
            scene = "asset/scene.json"
        results = []
        for method in HOLE_METHODS:
            r = ctx.render(scene, "either", method=method)
            peak = None
            if r.code == 0 and os.path.exists(r.image):
                _, _, px = read_pfm(r.image)
                peak = max(px) if px else 0.0
            results.append((method, r, peak))
        codes = {r.code for _, r, _ in results}
        if len(codes) > 1:
            ctx.fail("the methods disagree: " + ", ".join(
                "%s %s%s" % (m, r.outcome(), (" (" + r.errline[:120] + ")") if r.code == 2 else "")
                for m, r, _ in results))
        elif codes == {0}:
            for m, r, peak in results:
                if peak is not None and peak > 1e-4:
                    ctx.fail("%s: exit 0 but not black (peak %.4g) though every texel is a hole"
                             % (m, peak))
        elif codes == {2}:
            reasons = {re.sub(r"--method \w+|\b(pathtrace|progressive|stochastic|matrix)\b", "M",
                              r.errline) for _, r, _ in results}
            if len(reasons) > 1:
                ctx.fail("the methods refuse for different reasons: " + " | ".join(
                    sorted(x[:150] for x in reasons)))
    return fn


def define_holes():
    cat = "alpha-holes"
    for kind, title in (("gltf-mask", "glTF MASK, every texel alpha 0"),
                        ("gltf-cutoff1", "glTF MASK cutoff 1.0, every alpha 254/255"),
                        ("gltf-blend", "glTF BLEND, every texel alpha 0"),
                        ("json-coverage", "JSON coverage_texture all 0"),
                        ("obj-map-d", "MTL map_d all 0")):
        add("holes-%s" % kind, cat, "a scene of nothing but holes (%s): pathtrace, progressive, "
            "stochastic and matrix behave alike" % title, "all 0 black, or all 2 alike",
            _holes_case(kind))


# ---------------------------------------------------------------------------- samplers and indices

def define_samplers():
    cat = "sampler"
    for key, values in (("wrapS", (0, 1, -1, 33070, 2147483648, 10497.5, 1e10)),
                        ("wrapT", (33649, -10497)), ("magFilter", (9984, 0, -1)),
                        ("minFilter", (0, 9829))):
        for v in values:
            add("sampler-%s-%s" % (key, str(v).replace(".", "p")), cat,
                "sampler %s %r (not a glTF enum)" % (key, v), "refuse",
                _value_case(_set(["samplers", 0, key], v), key=key))
    add("sampler-index-missing", cat, "textures[0].sampler 1 (no such sampler)", "refuse",
        _value_case(_set(["textures", 0, "sampler"], 1), key="sampler"))
    add("sampler-index-negative", cat, "textures[0].sampler -2", "refuse",
        _value_case(_set(["textures", 0, "sampler"], -2), key="sampler"))
    for v in (8, 255, -1):
        add("texcoord-out-of-range-%s" % v, cat, "baseColorTexture.texCoord %d" % v, "refuse",
            _value_case(_mat_tex("baseColor", "texCoord", v), key="texCoord"))
    add("texcoord-missing-set", cat, "texCoord 1 on a mesh without TEXCOORD_1", "refuse",
        _value_case(_mat_tex("baseColor", "texCoord", 1), key="TEXCOORD_1"))
    add("emissive-texcoord-8", cat, "emissiveTexture.texCoord 8", "refuse",
        _value_case(_mat_tex("emissive", "texCoord", 8), key="texCoord"))
    add("normal-texcoord-3", cat, "normalTexture.texCoord 3 (warned or refused)", "either",
        _value_case(_mat_tex("normal", "texCoord", 3), expect="either"))
    add("texture-index-99", cat, "baseColorTexture.index 99", "refuse",
        _value_case(_mat_tex("baseColor", "index", 99), key="99"))
    add("texture-source-99", cat, "textures[0].source 99", "refuse",
        _value_case(_set(["textures", 0, "source"], 99), key="99"))
    add("texture-source-missing", cat, "textures[0] without a source", "refuse",
        _value_case(lambda d, b: d["textures"][0].clear()))
    for v in (99, -1):
        add("webp-source-%s" % v, cat, "EXT_texture_webp source %d" % v, "refuse",
            _value_case(_set(["textures", 0, "extensions"], {"EXT_texture_webp": {"source": v}})))
    add("transform-texcoord-9", cat, "KHR_texture_transform texCoord 9", "refuse",
        _value_case(_mat_tex("baseColor", "extensions", {"KHR_texture_transform": {
            "texCoord": 9}}), key="texCoord"))
    add("image-uri-and-bufferview", cat, "an image with both uri and bufferView", "refuse",
        _value_case(lambda d, b: d["images"][0].update({"bufferView": 0,
                                                        "mimeType": "image/png"})))
    add("image-mime-bogus", cat, "an embedded image whose mimeType is 'image/x-bogus'", "either",
        lambda ctx: ctx.render(std_scene(ctx, [{"embed": solid_png(RED),
                                                "mimeType": "image/x-bogus"}]), "either"))
    add("image-bufferview-with-stride", cat, "an image's bufferView with byteStride 4", "refuse",
        lambda ctx: ctx.render(std_scene(ctx, [{"embed": solid_png(RED)}],
                                         mutate=_set(["bufferViews", 4, "byteStride"], 4)),
                               "refuse"))


def define_gltf_values():
    cat = "gltf-values"

    def no_pbr(ctx, pbr):
        ctx.write("asset/tex.png", solid_png(RED))

        def m(doc, binary):
            mat = doc["materials"][0]
            if pbr is None:
                del mat["pbrMetallicRoughness"]
            else:
                mat["pbrMetallicRoughness"] = pbr
        r = ctx.render(std_scene(ctx, [{"uri": "tex.png"}], mutate=m), "accept")
        expect_colour(ctx, r, RED)
    add("material-without-pbr", cat, "an emissive-textured material without "
        "pbrMetallicRoughness (valid: the defaults apply)", "accept",
        lambda ctx: no_pbr(ctx, None))
    add("material-empty-pbr", cat, "pbrMetallicRoughness {} (valid: the defaults apply)",
        "accept", lambda ctx: no_pbr(ctx, {}))

    def no_materials(ctx):
        doc, binary = gltf_doc([])
        del doc["materials"]
        del doc["meshes"][0]["primitives"][0]["material"]
        os.makedirs(ctx.path("asset"))
        doc["extensionsUsed"] = ["KHR_lights_punctual"]
        doc["extensions"] = {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 1, 1], "intensity": 500}]}}
        doc["nodes"].append({"translation": [0, 0, 1.5],
                             "extensions": {"KHR_lights_punctual": {"light": 0}}})
        doc["scenes"][0]["nodes"].append(2)
        with open(ctx.path("asset/scene.bin"), "wb") as f:
            f.write(binary)
        doc["buffers"][0]["uri"] = "scene.bin"
        ctx.write_json("asset/scene.gltf", doc)
        ctx.render("asset/scene.gltf", "accept")
    add("no-materials", cat, "a glTF without materials (the default material)", "accept",
        no_materials)


def define_all():
    if CASES:
        return CASES
    for f in (define_overruns, define_glb_lies, define_escapes, define_cwd,
              define_fifo_and_encoding, define_unused, define_bombs, define_palettes,
              define_valid, define_data_uris, define_bake_outputs, define_obj, define_checkpoints,
              define_messages, define_silent, define_holes, define_samplers,
              define_gltf_values):
        f()
    return CASES


# ================================================================================================
# Main
# ================================================================================================

class Options:
    def __init__(self, a):
        self.cli = os.path.abspath(a.cli)
        self.out = os.path.abspath(a.out)
        self.timeout = a.timeout
        self.mem_limit = a.mem_limit
        self.keep = a.keep
        self.heavy_lock = threading.Lock()
        self._locks = collections.defaultdict(threading.Lock)
        self._locks_lock = threading.Lock()

    def cache(self, key, builder):
        d = os.path.join(self.out, "_cache")
        os.makedirs(d, exist_ok=True)
        p = os.path.join(d, key)
        with self._locks_lock:
            lock = self._locks[key]
        with lock:
            if not os.path.exists(p):
                tmp = p + ".tmp"
                builder(tmp)
                os.replace(tmp, p)
        return p


def remove_special_files(root):
    for r, dirs, names in os.walk(root):
        for n in names + dirs:
            p = os.path.join(r, n)
            try:
                if stat.S_ISFIFO(os.lstat(p).st_mode):
                    os.remove(p)
            except OSError:
                pass


def run_case(case, opts):
    started = time.monotonic()
    ctx = Ctx(case, opts)
    status = None
    try:
        if case.heavy:
            with opts.heavy_lock:
                case.fn(ctx)
        else:
            case.fn(ctx)
    except Skip as e:
        status = "skipped"
        ctx.note(str(e))
    except Exception as e:  # the campaign's own failure: shown, never hidden
        import traceback
        status = "harness-error"
        ctx.note("the campaign failed to build or check this case: %s: %s" % (
            type(e).__name__, e))
        ctx.note(traceback.format_exc(limit=3).replace("\n", " | "))
    ctx.finish()
    if status is None:
        if ctx.failures:
            status = "breach"
        elif ctx.runs and all(r.code == 2 for r in ctx.runs if r.expect is not None):
            status = "refused"
        else:
            status = "held"
    remove_special_files(ctx.dir)
    if not opts.keep:
        shutil.rmtree(ctx.path("out"), ignore_errors=True)
        if status in ("held", "refused", "skipped"):
            shutil.rmtree(ctx.dir, ignore_errors=True)
    main_run = ctx.runs[-1] if ctx.runs else None
    return {
        "id": case.id, "category": case.category, "title": case.title, "expect": case.expect,
        "status": status, "failures": ctx.failures, "notes": ctx.notes,
        "seconds": round(time.monotonic() - started, 2),
        "max_rss_mb": round(max((r.rss_mb for r in ctx.runs), default=0.0), 1),
        "exit": main_run.code if main_run else None,
        "signal": main_run.signal if main_run else None,
        "stderr_first_line": main_run.first_line[:300] if main_run else "",
        "runs": [r.summary() for r in ctx.runs],
        "reproducer": os.path.join(ctx.dir, "repro.sh"),
    }


def select(cases, pattern):
    if not pattern:
        return cases
    pats = [p.strip() for p in pattern.split(",") if p.strip()]

    def match(c):
        for p in pats:
            if any(ch in p for ch in "*?["):
                if fnmatch.fnmatch(c.id, p) or fnmatch.fnmatch(c.category, p):
                    return True
            elif p in c.id or p == c.category:
                return True
        return False
    return [c for c in cases if match(c)]


def table(results):
    cats = collections.OrderedDict()
    for r in results:
        row = cats.setdefault(r["category"], collections.Counter())
        row["cases"] += 1
        row[r["status"]] += 1
    total = collections.Counter()
    for row in cats.values():
        total.update(row)
    return cats, total


COLUMNS = [("cases", "cases"), ("refused", "refused (exit 2)"), ("held", "held (exit 0, checked)"),
           ("breach", "breaches"), ("skipped", "skipped"), ("harness-error", "harness errors")]


def text_table(cats, total):
    w = max([len(c) for c in cats] + [8])
    head = "%-*s" % (w, "category") + "".join("  %*s" % (len(t), t) for _, t in COLUMNS)
    lines = [head, "-" * len(head)]
    for name, row in list(cats.items()) + [("TOTAL", total)]:
        if name == "TOTAL":
            lines.append("-" * len(head))
        lines.append("%-*s" % (w, name) + "".join("  %*d" % (len(t), row.get(k, 0))
                                                  for k, t in COLUMNS))
    return "\n".join(lines)


def breach_lines(results):
    out = []
    for r in results:
        if r["status"] not in ("breach", "harness-error"):
            continue
        msg = "; ".join(r["failures"][:3]) or "; ".join(r["notes"][:2])
        if len(r["failures"]) > 3:
            msg += "; (+%d more)" % (len(r["failures"]) - 3)
        out.append((r, msg))
    return out


def markdown(results, cats, total, seconds, opts, cli):
    lines = ["# Hostile assets campaign", "",
             "CLI: `%s`; %d cases; %.0f s; timeout %.0f s per run; address space limited to "
             "%s GiB per run." % (cli, len(results), seconds, opts.timeout,
                                  opts.mem_limit or "no"), "",
             "| category | " + " | ".join(t for _, t in COLUMNS) + " |",
             "|---|" + "---:|" * len(COLUMNS)]
    for name, row in list(cats.items()) + [("**total**", total)]:
        lines.append("| %s | " % name + " | ".join(str(row.get(k, 0)) for k, _ in COLUMNS) + " |")
    bl = breach_lines(results)
    lines += ["", "## Breaches (%d)" % sum(1 for r, _ in bl if r["status"] == "breach"), ""]
    for r, msg in bl:
        lines.append("- `%s` [%s] %s: %s (exit %s, %.1f s, %.0f MiB; reproducer `%s`)" % (
            r["id"], r["category"], r["status"], msg.replace("|", "\\|"), r["exit"],
            r["seconds"], r["max_rss_mb"], r["reproducer"]))
    skipped = [r for r in results if r["status"] == "skipped"]
    if skipped:
        lines += ["", "## Skipped", ""]
        for r in skipped:
            lines.append("- `%s`: %s" % (r["id"], "; ".join(r["notes"])))
    lines += ["", "## Every case", "",
              "| case | category | expected | outcome | exit | signal | s | max RSS MiB | "
              "stderr (first line) |", "|---|---|---|---|---:|---:|---:|---:|---|"]
    for r in results:
        first = r["stderr_first_line"].replace("|", "\\|")[:160]
        lines.append("| `%s` | %s | %s | %s | %s | %s | %.1f | %.0f | %s |" % (
            r["id"], r["category"], r["expect"], r["status"], r["exit"], r["signal"] or "",
            r["seconds"], r["max_rss_mb"], first))
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cli", help="the penumbra executable")
    ap.add_argument("out", help="a folder for the cases (created)")
    ap.add_argument("--jobs", type=int, default=1, help="cases run at once (heavy cases one at "
                    "a time whatever this says); default 1")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds before a run is killed "
                    "(default 60)")
    ap.add_argument("--only", help="case ids or categories: substrings, or fnmatch patterns, "
                    "separated by commas")
    ap.add_argument("--categories", help="whole categories, by exact name, separated by commas "
                    "(with --only: the cases both select)")
    ap.add_argument("--no-skips", action="store_true", help="a skipped case fails the run (a "
                    "missing WebP encoder, a lost race): for unattended runs, where a skip "
                    "would pass unseen")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--markdown", help="also write the table (and every case) as Markdown here")
    ap.add_argument("--json", help="write every case's record (runs, exit codes, RSS) here "
                    "(default OUT/results.json)")
    ap.add_argument("--keep", action="store_true", help="keep every case's inputs and outputs")
    ap.add_argument("--mem-limit", type=float, default=8.0, help="address-space limit per run, "
                    "GiB (0: none; default 8): keeps a decode bomb from taking the machine")
    ap.add_argument("--quiet", action="store_true", help="no line per case while running")
    a = ap.parse_args(argv)
    cases = select(define_all(), a.only)
    if a.categories:
        wanted = {c.strip() for c in a.categories.split(",") if c.strip()}
        unknown = wanted - {c.category for c in define_all()}
        if unknown:
            print("no such category: %s" % ", ".join(sorted(unknown)), file=sys.stderr)
            return 2
        cases = [c for c in cases if c.category in wanted]
    if a.list:
        for c in cases:
            print("%-48s %-15s %-12s %s" % (c.id, c.category, c.expect, c.title))
        print("%d cases" % len(cases))
        return 0
    if not (os.path.isfile(a.cli) and os.access(a.cli, os.X_OK)):
        print("not an executable: %s" % a.cli, file=sys.stderr)
        return 2
    opts = Options(a)
    os.makedirs(opts.out, exist_ok=True)
    if not webp_available():
        print("note: no libwebp or cwebp here: the WebP cases are skipped", file=sys.stderr)
    started = time.monotonic()
    results = [None] * len(cases)
    # Heavy cases last, so that a parallel run does the many small ones together first.
    order = sorted(range(len(cases)), key=lambda i: cases[i].heavy)
    done = 0
    with concurrent.futures.ThreadPoolExecutor(max(1, a.jobs)) as pool:
        futures = {pool.submit(run_case, cases[i], opts): i for i in order}
        for f in concurrent.futures.as_completed(futures):
            i = futures[f]
            results[i] = f.result()
            done += 1
            if not a.quiet:
                r = results[i]
                print("[%d/%d] %-48s %-8s %6.1f s %6.0f MiB%s" % (
                    done, len(cases), r["id"], r["status"], r["seconds"], r["max_rss_mb"],
                    ("  " + r["failures"][0][:110]) if r["failures"] else ""),
                    file=sys.stderr, flush=True)
    seconds = time.monotonic() - started
    cats, total = table(results)
    print(text_table(cats, total))
    print("%d cases in %.0f s (%s)" % (len(results), seconds, time.strftime("%H:%M:%S",
                                                                            time.gmtime(seconds))))
    for r, msg in breach_lines(results):
        print("%s %s [%s]: %s\n    reproducer: %s" % (
            "BREACH" if r["status"] == "breach" else "HARNESS-ERROR", r["id"], r["category"],
            msg, r["reproducer"]))
    for r in results:
        if r["status"] == "skipped":
            print("SKIPPED %s: %s" % (r["id"], "; ".join(r["notes"])))
    with open(a.json or os.path.join(opts.out, "results.json"), "w", encoding="utf-8") as f:
        json.dump({"cli": opts.cli, "seconds": round(seconds, 1), "cases": results}, f, indent=1)
    if a.markdown:
        with open(a.markdown, "w", encoding="utf-8") as f:
            f.write(markdown(results, cats, total, seconds, opts, opts.cli))
    if not a.keep:
        shutil.rmtree(os.path.join(opts.out, "_cache"), ignore_errors=True)
    bad = total.get("breach", 0) + total.get("harness-error", 0)
    if a.no_skips:
        bad += total.get("skipped", 0)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
