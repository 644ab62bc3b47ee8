"""The one PNG encoder (procgen.exchange.image.png_bytes): Pillow decodes exactly the pixels that
went in (8-bit L / LA / RGB / RGBA, 16-bit L), every PNG carries its provenance text chunks, the
chunks are well formed (independent parse: CRC-32, order, filtered scanlines), and the bytes are
the same for the same input, from the cache of large encodings or not."""
from __future__ import annotations

import io
import json
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from procgen.errors import InputError
from procgen.exchange import image as image_mod
from procgen.exchange.image import png_bytes

PROV = {"recipe": "test", "seed": 3}


def _chunks(png: bytes) -> list[tuple[bytes, bytes]]:
    """(type, data) of every chunk, checking the signature, lengths and CRC-32s on the way."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    out, pos = [], 8
    while pos < len(png):
        (n,) = struct.unpack(">I", png[pos:pos + 4])
        kind, data = png[pos + 4:pos + 8], png[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", png[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(kind + data), kind
        out.append((kind, data))
        pos += 12 + n
    assert pos == len(png)
    return out


def _images(rng: np.random.Generator) -> list[np.ndarray]:
    smooth = np.add.outer(np.arange(37), 3 * np.arange(53))          # gradients: the 'Up' filter's case
    return [rng.integers(0, 256, (37, 53), dtype=np.uint8),
            rng.integers(0, 256, (37, 53, 2), dtype=np.uint8),
            rng.integers(0, 256, (37, 53, 3), dtype=np.uint8),
            rng.integers(0, 256, (37, 53, 4), dtype=np.uint8),
            (smooth % 256).astype(np.uint8)[..., None].repeat(3, axis=2),
            rng.integers(0, 65536, (37, 53), dtype=np.uint16),
            (smooth * 311).astype(np.uint16),
            np.array([[0, 1, 255, 256, 65535]], dtype=np.uint16),        # byte order: 0x0100 is not 0x0001
            rng.integers(0, 256, (1, 1, 3), dtype=np.uint8),
            rng.integers(0, 256, (9, 1), dtype=np.uint8)]


def test_pillow_decodes_the_same_pixels_and_mode():
    for arr in _images(np.random.default_rng(5)):
        img = Image.open(io.BytesIO(png_bytes(arr, PROV)))
        channels = 1 if arr.ndim == 2 else arr.shape[2]
        want = {np.dtype(np.uint16): "I;16"}.get(arr.dtype, {1: "L", 2: "LA", 3: "RGB", 4: "RGBA"}[channels])
        assert img.mode == want, (arr.shape, arr.dtype)
        back = np.asarray(img)
        assert back.shape == arr.shape and np.array_equal(back.astype(np.int64), arr.astype(np.int64)), (arr.shape, arr.dtype)


def test_text_chunks_carry_provenance_and_extras():
    arr = np.zeros((4, 5), np.uint16)
    png = png_bytes(arr, PROV, {"height_min": -1.5, "height_max": 2.25, "procgen_channels": "rock,soil",
                                "note": "Gr\u00fcn \u2192 gelb"})
    img = Image.open(io.BytesIO(png))
    assert json.loads(img.text["procgen"]) == PROV
    assert json.loads(img.text["height_min"]) == -1.5 and json.loads(img.text["height_max"]) == 2.25
    assert img.text["procgen_channels"] == "rock,soil"
    assert img.text["note"] == "Gr\u00fcn \u2192 gelb"                  # not Latin-1: an iTXt chunk
    kinds = [k for k, _ in _chunks(png)]
    assert kinds[0] == b"IHDR" and kinds[-1] == b"IEND"
    assert kinds.count(b"tEXt") == 4 and kinds.count(b"iTXt") == 1
    assert max(i for i, k in enumerate(kinds) if k in (b"tEXt", b"iTXt")) < kinds.index(b"IDAT")
    assert json.loads(Image.open(io.BytesIO(png_bytes(np.zeros((2, 2, 3), np.uint8)))).text["procgen"]) == {}


def test_scanlines_are_up_filtered_and_decode_independently():
    """Undo the PNG 'Up' filter by hand (cumulative byte sums down the rows): the raw samples,
    big-endian for 16 bits, without Pillow."""
    rng = np.random.default_rng(8)
    for arr in (rng.integers(0, 65536, (6, 7), dtype=np.uint16), rng.integers(0, 256, (6, 7, 3), dtype=np.uint8)):
        chunks = _chunks(png_bytes(arr))
        w, h, depth = struct.unpack(">IIB", chunks[0][1][:9])
        assert (w, h, depth) == (7, 6, 8 * arr.itemsize)
        rows = np.frombuffer(zlib.decompress(b"".join(d for k, d in chunks if k == b"IDAT")), np.uint8).reshape(h, -1)
        assert (rows[:, 0] == 2).all()
        raw = np.cumsum(rows[:, 1:].astype(np.int64), axis=0) % 256
        want = arr.astype(">u2") if arr.dtype == np.uint16 else arr
        assert np.array_equal(raw.astype(np.uint8).tobytes(), np.ascontiguousarray(want).tobytes())


def test_bytes_are_deterministic_and_the_cache_is_keyed_by_content(monkeypatch):
    monkeypatch.setattr(image_mod, "LARGE", 1000)                     # small images take the cached path
    monkeypatch.setattr(image_mod, "_CACHE", type(image_mod._CACHE)())
    rng = np.random.default_rng(1)
    arr = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    first = png_bytes(arr, PROV)
    assert png_bytes(arr.copy(), PROV) == first                       # served from the cache
    image_mod._CACHE.clear()
    assert png_bytes(arr, PROV) == first                              # encoded again: same bytes
    assert png_bytes(arr, {"seed": 4}) != first                       # provenance is part of the key
    assert png_bytes(arr, PROV, {"k": "v"}) != first
    changed = arr.copy()
    changed[7, 9, 1] ^= 1
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png_bytes(changed, PROV)))), changed)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png_bytes(arr[:, :, 0].copy(), PROV)))), arr[:, :, 0])
    # equal bytes, other shape: not confused
    flat = arr.reshape(50, 40, 3).copy()
    assert Image.open(io.BytesIO(png_bytes(flat, PROV))).size == (40, 50)


def test_large_image_round_trip():
    """Above LARGE samples (deflate level 3, cached): still lossless."""
    arr = np.random.default_rng(2).integers(0, 256, (1100, 1300, 3), dtype=np.uint8)
    assert arr.size > image_mod.LARGE
    png = png_bytes(arr, PROV)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png))), arr)
    assert png_bytes(arr, PROV) == png


@pytest.mark.parametrize("bad", [np.zeros((3, 3), np.float32), np.zeros((3, 3, 3), np.uint16),
                                 np.zeros((3, 3, 5), np.uint8), np.zeros((0, 4), np.uint8)])
def test_refuses_what_png_cannot_hold(bad):
    with pytest.raises(InputError):
        png_bytes(bad)


@pytest.mark.parametrize("key", ["", "x" * 80, "\u2192", "a\0b"])
def test_refuses_text_keys_png_cannot_hold(key):
    with pytest.raises(InputError):
        png_bytes(np.zeros((2, 2), np.uint8), None, {key: "v"})
