"""Backs the BENCHMARKS.md claims "extraction ≥ 5× the Python route" and "CRC check on clean files".

End-to-end extraction throughput: thermrs vs the Python route, side by side in one run.

Recordings: ``--frames`` (default 2,000) 752×582 mono8 frames of the paper rig's two cameras,
uncompressed, lz4 and zstd, with 10 % and 100 % of frames holding a spot (joint states, a
thermal frame and an ambient reading every 20 frames). Written once into ``--dir`` by the
reference Python writer.

Routes, each in its own process, file to tables:
- python: the ``mcap`` Python reader, the Image payload viewed with numpy (header offsets read
  with ``struct``, no copy), detection by the frame maximum against a threshold, then a
  background-subtracted windowed centre of gravity: what a user would otherwise write;
- thermrs-1 / thermrs-2: ``thermrs.extract`` with 1 and 2 rayon threads (chunk CRCs checked,
  the default), and beside them with ``verify_crc=False``: the cost of the check.
Each file is read once before timing so that all routes see it in the page cache; best of
``--repeats``. Also reported: the time ``zstd``/``lz4`` take to decompress the same chunks in
one thread (the decompressor's own speed), from the ``zstandard``/``lz4`` Python bindings.

Run:  python benchmarks/bench_extract.py [--frames 2000] [--dir bench-out/rec]
      [--compressions none lz4 zstd]
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

W, H = 752, 582


def messages(frames: int, spot_fraction: float):  # type: ignore[no-untyped-def]
    """The benchmark recording's messages, generated lazily (constant memory)."""
    import thermrs

    from tests.support.recordings import dark_image, header, image_msg, spot_image

    rig = thermrs.load_rig()
    rng = np.random.default_rng(0)
    spots = [
        spot_image(W, H, 375.5 + rng.uniform(-20, 20), 290.5 + rng.uniform(-20, 20), rng=rng)
        for _ in range(16)
    ]
    darks = [dark_image(W, H, rng=rng) for _ in range(16)]
    t0 = 1_750_000_000 * 10**9
    every = round(1 / spot_fraction)
    counts = np.full((240, 320), 29515, np.uint16)
    for i in range(frames):
        t = t0 + i * 40_000_000
        cam = "A" if (i // 10) % 2 == 0 else "B"
        if i % 20 == 0:
            q = np.radians(rig.camera_pose(cam).joints_deg).tolist()
            yield (
                "/joint_states",
                "sensor_msgs/msg/JointState",
                t - 1,
                {
                    "header": header(t - 1, "base"),
                    "name": rig.joint_names,
                    "position": q,
                    "velocity": [],
                    "effort": [],
                },
            )
            yield (
                "/thermal/image_raw",
                "sensor_msgs/msg/Image",
                t,
                image_msg(counts, t, "thermal", encoding="16UC1"),
            )
            yield (
                "/ambient/temperature",
                "sensor_msgs/msg/Temperature",
                t,
                {
                    "header": header(t, "ambient"),
                    "temperature": 22.0,
                    "variance": 0.0,
                },
            )
        img = spots[i % 16] if i % every == 0 else darks[i % 16]
        yield (
            rig.camera(cam).topic,
            "sensor_msgs/msg/Image",
            t,
            image_msg(img, t, cam, encoding="mono8"),
        )


def make(path: Path, frames: int, spot_fraction: float, compression: str) -> None:
    from tests.support.recordings import write_messages

    tmp = path.with_suffix(".tmp")
    with open(tmp, "wb") as fh:
        write_messages(
            fh, messages(frames, spot_fraction), compression=compression, chunk_size=4 << 20
        )
    tmp.replace(path)


def python_route(path: Path) -> int:
    """The route a user would write with the mcap Python reader and numpy."""
    from mcap.reader import make_reader

    topics = ["/ccd_a/image_raw", "/ccd_b/image_raw"]
    n = 0
    rows = []
    with open(path, "rb") as f:
        for _schema, _channel, message in make_reader(f).iter_messages(topics=topics):
            d = message.data
            # Header: 4 encapsulation + stamp 8 + frame_id string, then the fixed fields.
            (flen,) = struct.unpack_from("<I", d, 12)
            p = (16 + flen + 3) & ~3
            h, w, elen = struct.unpack_from("<III", d, p)
            p = (p + 12 + elen + 1 + 3) & ~3
            step, _count = struct.unpack_from("<II", d, p)
            img = np.frombuffer(d, np.uint8, h * step, p + 8).reshape(h, step)[:, :w]
            n += 1
            peak = int(img.max())
            if peak < 60:
                rows.append((np.nan, np.nan))
                continue
            y0, x0 = np.unravel_index(int(img.argmax()), img.shape)
            r = 16
            win = img[max(0, y0 - r) : y0 + r + 1, max(0, x0 - r) : x0 + r + 1].astype(np.float64)
            bg = np.median(np.concatenate([win[0], win[-1], win[:, 0], win[:, -1]]))
            win = np.clip(win - bg, 0, None)
            ys, xs = np.mgrid[0 : win.shape[0], 0 : win.shape[1]]
            s = win.sum()
            rows.append(
                (max(0, x0 - r) + (xs * win).sum() / s, max(0, y0 - r) + (ys * win).sum() / s)
            )
    return n


def thermrs_route(path: Path) -> int:
    import thermrs

    ex = thermrs.extract(path, thermrs.load_rig())
    return ex.frames.height


def thermrs_no_crc_route(path: Path) -> int:
    import thermrs

    ex = thermrs.extract(path, thermrs.load_rig(), verify_crc=False)
    return ex.frames.height


def decompress_only(path: Path) -> int:
    """Decompress every chunk on one thread and nothing else (same zstd/lz4 libraries as
    thermrs, via ``thermrs._native.decompress_chunks``): the decompressor's own speed."""
    from thermrs import _native

    _native.decompress_chunks(str(path))
    return 0


def warm(path: Path) -> None:
    """Read the file once in blocks so every route finds it in the page cache."""
    with open(path, "rb") as fh:
        while fh.read(16 << 20):
            pass


def child(route: str, path: Path, repeats: int) -> None:
    fn = {
        "python": python_route,
        "thermrs": thermrs_route,
        "thermrs-no-crc": thermrs_no_crc_route,
        "decompress": decompress_only,
    }[route]
    warm(path)
    best, n = float("inf"), 0
    for _ in range(repeats):
        t = time.perf_counter()
        n = fn(path)
        best = min(best, time.perf_counter() - t)
    rss = 0
    try:
        import resource

        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    except ImportError:  # pragma: no cover
        pass
    print(json.dumps({"seconds": best, "frames": n, "peak_rss_mb": rss}))


def spawn(route: str, path: Path, threads: int, repeats: int) -> dict[str, float]:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads), OMP_NUM_THREADS="1")
    p = subprocess.run(
        [
            sys.executable,
            __file__,
            "--child",
            route,
            "--path",
            str(path),
            "--repeats",
            str(repeats),
        ],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(p.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/rec"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument(
        "--compressions", nargs="+", default=["none", "lz4", "zstd"], help="recordings to run"
    )
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--path", type=Path, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, args.path, args.repeats)
        return
    args.dir.mkdir(parents=True, exist_ok=True)
    rows = []
    print(f"| recording ({args.frames:,} frames) | route | frames/s | × python | peak RSS (MB) |")
    print("| --- | --- | ---: | ---: | ---: |")
    for comp in args.compressions:
        for frac in (0.1, 1.0):
            path = args.dir / f"{comp}-{int(frac * 100)}pct-{args.frames}.mcap"
            if not path.exists():
                make(path, args.frames, frac, comp)
            name = f"{comp}, {int(frac * 100)} % spots"
            py = spawn("python", path, 1, args.repeats)
            res = [("python (mcap + numpy)", py)]
            res.append(("thermrs, 1 thread", spawn("thermrs", path, 1, args.repeats)))
            res.append(("thermrs, 2 threads", spawn("thermrs", path, 2, args.repeats)))
            for t in (1, 2):
                label = f"thermrs, {t} thread{'s' if t > 1 else ''}, no CRC check"
                res.append((label, spawn("thermrs-no-crc", path, t, args.repeats)))
            if comp != "none":
                res.append(
                    (
                        f"{comp} decompress only, 1 thread",
                        spawn("decompress", path, 1, args.repeats),
                    )
                )
            base = args.frames / py["seconds"]
            for route, r in res:
                fps = args.frames / r["seconds"]
                print(f"| {name} | {route} | {fps:,.0f} | {fps / base:.1f}× | {r['peak_rss_mb']} |")
                rows.append(
                    {
                        "recording": name,
                        "route": route,
                        "frames_per_s": fps,
                        "peak_rss_mb": r["peak_rss_mb"],
                    }
                )
    (args.dir / "extract.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
