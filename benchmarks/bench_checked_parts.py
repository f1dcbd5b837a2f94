"""Backs BENCHMARKS.md "checked extraction part by part: what the detector may cost at 0.9×".

What a one-core checked extraction spends beyond the CRC's pass, part by part, in one run.

A checked extraction of an uncompressed recording does three things on top of bringing every
byte to the core for its CRC: it walks and parses the records (and fills the tables), it
interprets every CCD frame (the spot detector), and it interprets every thermal frame (the
ROI maxima). Each part is measured here by taking it away through the rig, not by a switch in
the code: the same file, extracted with

- ``full``: the rig as given;
- ``no thermal``: the rig with its thermal camera's topic renamed, so that no thermal frame is
  interpreted (its chunks are still checksummed and its records parsed);
- ``nothing``: the rig with its CCD cameras' and thermal camera's topics renamed, so that
  only the joint states and the ambient temperature are interpreted.

With ``read`` (the file read once into a reused 16 MiB buffer) and ``crc only`` (every chunk's
CRC-32 through the map, nothing else; ``thermrs._native.checksum_chunks``), all routes run
interleaved in rotating order, ``--repeats`` times each, per round. Printed per round and as
medians over rounds, in µs per CCD frame:

- ``walk``   = nothing − crc only: walking, parsing, the tables, the joints (``crc only``
  always reads through the map; on a page cache where mapping is dear the extraction's
  chooser copies instead, and this difference can come out negative);
- ``detector`` = no thermal − nothing: the spot detector on every CCD frame;
- ``thermal`` = full − no thermal: the thermal ROIs;
- ``budget`` = read / 0.9 − nothing: what the detector and the ROIs may cost together for a
  checked extraction at 0.9× one read (the #20 target), given the walk as it is;
- ``ceiling`` = read / nothing: the checked extraction's speed if the detector and the ROIs
  cost nothing at all.

The parts add up only if the interpretation cannot run while the CRC's bytes are in flight;
``cargo run --release -p thermrs-core --example overlap -- FILE`` measures that on the same
file (BENCHMARKS.md).

Recording: ``benchmarks/bench_extract.py``'s ``make`` (752×582 mono8 frames, 10 % spots,
uncompressed, 4 MiB chunks), written first (``--frames``, default 2,000: 891 MB, fresh in the
page cache) unless ``--big`` names one.

Run:  RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_checked_parts.py
      [--big REC.mcap] [--rounds 5] [--repeats 7] [--dir bench-out/parts]
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1])]


def renamed(text: str, topics: list[str]) -> str:
    """The rig TOML ``text`` with each of ``topics`` renamed to one no recording has."""
    for t in topics:
        text, n = re.subn(
            rf'^(\s*topic\s*=\s*)"{re.escape(t)}"', rf'\1"/not-recorded{t}"', text, flags=re.M
        )
        if n != 1:
            raise SystemExit(f"topic {t} appears {n} times in the rig, expected once")
    return text


def main() -> None:
    import thermrs
    from bench_crc import core, interleaved
    from bench_extract import make
    from thermrs import _native

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--big", type=Path, default=None)
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--dir", type=Path, default=Path("bench-out/parts"))
    a = ap.parse_args()
    big = a.big
    if big is None:
        a.dir.mkdir(parents=True, exist_ok=True)
        big = a.dir / f"big-{a.frames}.mcap"
        make(big, a.frames, 0.1, "none")  # written now: fresh in the page cache

    rig = thermrs.load_rig()
    text = Path(thermrs.default_rig_path()).read_text()
    cams = [c.topic for c in rig.cameras]
    thermal = re.search(r'^\[thermal\][^\[]*?^\s*topic\s*=\s*"([^"]+)"', text, flags=re.M | re.S)
    if thermal is None:
        raise SystemExit("the rig has no thermal camera")
    rigs = {
        "full": rig,
        "no thermal": thermrs.Rig.from_toml(renamed(text, [thermal.group(1)])),
        "nothing": thermrs.Rig.from_toml(renamed(text, [*cams, thermal.group(1)])),
    }

    def ex(r: thermrs.Rig) -> Any:
        return cast(tuple[Any, ...], core(big, r, True))[0]

    frames = {k: int(ex(r)["t_ns"].shape[0]) for k, r in rigs.items()}
    n = frames["full"]
    if frames["nothing"] != 0 or frames["no thermal"] != n:
        raise SystemExit(f"unexpected CCD frame counts {frames}")
    buf = bytearray(16 << 20)

    def read() -> None:
        with open(big, "rb", buffering=0) as fh:
            while fh.readinto(buf):
                pass

    routes: dict[str, Callable[[], object]] = {
        "read": read,
        "crc only": lambda: _native.checksum_chunks(str(big)),
        **{k: (lambda r=r: ex(r)) for k, r in rigs.items()},
    }
    for g in routes.values():  # warm: page cache, first-call costs
        g()
    rows = []
    for rnd in range(a.rounds):
        us = {k: v / n * 1e6 for k, v in interleaved(routes, a.repeats).items()}
        row = {
            **us,
            "walk": us["nothing"] - us["crc only"],
            "detector": us["no thermal"] - us["nothing"],
            "thermal": us["full"] - us["no thermal"],
            "budget": us["read"] / 0.9 - us["nothing"],
            "now (x read)": us["read"] / us["full"],
            "ceiling (x read)": us["read"] / us["nothing"],
        }
        rows.append(row)
        print(f"round {rnd + 1}: " + ", ".join(f"{k} {v:.2f}" for k, v in row.items()), flush=True)
    print(f"{big.name}: {n} CCD frames; medians of {a.rounds} rounds (µs per CCD frame):")
    for k in rows[0]:
        print(f"  {k:18s} {statistics.median(x[k] for x in rows):7.2f}")


if __name__ == "__main__":
    main()
