"""Benchmark: grid.load on a large 16-bit PNG and GeoTIFF (issue 18).

Per format and size: the time to decode the file alone (Pillow / rasterio: the baseline, measured
in the same run), the time of grid.load at full size and resampled to a quarter of the width, the
ratio to the baseline, and the peak Python/numpy memory (tracemalloc) against the raster's bytes.

    python benchmarks/load.py [--size 4096]
"""
from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from PIL import Image

from procgen.builtin.loaders import LoadGrid
from procgen.domains import Grid
from procgen.exchange import heightmap_png16, write_many
from procgen.exchange.raster_read import read_raster
from procgen.noise import fbm_spectral


def _timed(fn):
    tracemalloc.start()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, dt, peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    args = ap.parse_args()
    n = args.size
    g = Grid((n, n), 10.0)
    g.add_field("surface__height", 100 * fbm_spectral(np.random.default_rng(1), (n, n), 0.8), at="cell")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_many(d, heightmap_png16(g, stem="h"))
        files = {"png16": d / "h.png"}
        try:
            import rasterio
            from rasterio.transform import from_origin
            with rasterio.open(d / "h.tif", "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
                               crs="EPSG:32633", transform=from_origin(500000, 5200000, 10, 10)) as dst:
                dst.write(g["surface__height"].astype(np.float32), 1)
            files["geotiff"] = d / "h.tif"
        except ImportError:
            print("rasterio not installed: GeoTIFF skipped (pip install 'procgen-rules[geo]')")
        raster_mb = n * n * 8 / 2**20
        print(f"{n} x {n} raster ({raster_mb:.0f} MiB as float64)")
        print(f"{'format':>8} {'decode s':>9} {'load s':>8} {'x':>5} {'load/4 s':>9} {'x':>5} {'peak MiB':>9} {'peak/raster':>11}")
        for fmt, path in files.items():
            if fmt == "png16":
                base = _timed(lambda: np.asarray(Image.open(path)).astype(np.float64))[1]
            else:
                base = _timed(lambda: read_raster(path).values)[1]
            full, t_full, peak = _timed(lambda: LoadGrid(file=str(path)).build(read_raster(path)))
            quarter, t_q, _ = _timed(lambda: LoadGrid(file=str(path), nx=n // 4).build(read_raster(path)))
            assert full.shape == (n, n) and quarter.shape == (n // 4, n // 4)
            print(f"{fmt:>8} {base:9.2f} {t_full:8.2f} {t_full / base:5.1f} {t_q:9.2f} {t_q / base:5.1f} "
                  f"{peak / 2**20:9.0f} {peak / (n * n * 8):11.1f}")


if __name__ == "__main__":
    main()
