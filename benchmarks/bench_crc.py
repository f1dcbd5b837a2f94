"""Cost of checking chunk CRCs on clean recordings, interleaved in one process.

Each recording is extracted 16 times with ``verify_crc=True`` and 16 times with ``False``,
alternating (so that both see the same machine load), file in the page cache. Prints the
median and best-of-16 ratios (time with the check / time without).

Run:  RAYON_NUM_THREADS=1 python benchmarks/bench_crc.py REC.mcap [REC.mcap ...]
(e.g. the recordings ``benchmarks/bench_extract.py`` writes into its ``--dir``).
"""

from __future__ import annotations

import statistics
import sys
import time

import thermrs


def main() -> None:
    rig = thermrs.load_rig()
    for path in sys.argv[1:]:
        with open(path, "rb") as fh:  # warm the page cache
            while fh.read(16 << 20):
                pass
        times: dict[bool, list[float]] = {True: [], False: []}
        for i in range(16):
            for crc in (True, False) if i % 2 else (False, True):
                t0 = time.perf_counter()
                thermrs.extract(path, rig, verify_crc=crc)
                times[crc].append(time.perf_counter() - t0)
        on, off = times[True], times[False]
        print(
            f"{path}: median ratio {statistics.median(on) / statistics.median(off):.3f}, "
            f"best-of-16 ratio {min(on) / min(off):.3f}"
        )


if __name__ == "__main__":
    main()
