"""Results kept by content: the same bytes give the kept result whatever object holds them;
any other bytes, dtype, shape or scalar do not; a failure is kept as a failure (in process).
On disk: a result is read back by another cache object (another process), a damaged file is
computed again, a folder that cannot be written only keeps nothing, the last used are kept,
and ``off`` keeps nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from thermrs.memo import CACHE_ENV, ContentCache, DiskCache, cache_dir, content_key


def test_a_result_is_kept_by_the_content_of_its_inputs() -> None:
    cache: ContentCache[float] = ContentCache(8)
    calls = []

    def total(a: np.ndarray) -> float:
        calls.append(1)
        return float(a.sum())

    a = np.arange(10.0)
    assert cache.get(content_key(a, 1.5), lambda: total(a)) == 45.0
    b = a.copy()  # another object, the same bytes
    assert cache.get(content_key(b, 1.5), lambda: total(b)) == 45.0
    assert len(calls) == 1
    for other in (
        content_key(a[::-1].copy(), 1.5),  # other bytes
        content_key(a.astype(np.float32), 1.5),  # other dtype
        content_key(a.reshape(2, 5), 1.5),  # other shape
        content_key(a, 1.25),  # other scalar
    ):
        assert other != content_key(a, 1.5)


def test_a_failure_is_kept_and_the_oldest_result_leaves_first() -> None:
    cache: ContentCache[int] = ContentCache(2)

    def fail() -> int:
        raise ValueError("no fit")

    with pytest.raises(ValueError, match="no fit"):
        cache.get(b"k", fail)
    with pytest.raises(ValueError, match="no fit"):
        cache.get(b"k", lambda: 1)  # kept: not computed again
    cache.get(b"a", lambda: 2)
    cache.get(b"b", lambda: 3)  # "k" leaves
    assert cache.get(b"k", lambda: 4) == 4
    assert cache.misses == 4 and cache.hits == 1


def counting(value: object, calls: list[object]) -> object:
    calls.append(value)
    return value


def test_a_result_on_disk_is_read_back_by_another_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "c"))
    calls: list[object] = []
    hits: list[Path] = []
    key = content_key(np.arange(3.0), "x")
    a: DiskCache[object] = DiskCache("kind")
    assert a.get(key, lambda: counting({"v": [1.5, 2]}, calls)) == {"v": [1.5, 2]}
    b: DiskCache[object] = DiskCache("kind")  # a new process's cache reads the same folder
    assert b.get(key, lambda: counting("other", calls), on_hit=hits.append) == {"v": [1.5, 2]}
    assert calls == [{"v": [1.5, 2]}]
    assert hits == [tmp_path / "c" / "kind" / f"{key.hex()}.pickle"]
    # Other inputs, another result; a failure raised, never kept.
    assert b.get(content_key(np.arange(4.0), "x"), lambda: counting(7, calls)) == 7
    with pytest.raises(ZeroDivisionError):
        b.get(content_key("fails"), lambda: 1 / 0)
    assert len(list((tmp_path / "c" / "kind").iterdir())) == 2


def test_a_damaged_file_is_computed_again_and_replaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    cache: DiskCache[int] = DiskCache("kind")
    key = content_key("k")
    cache.get(key, lambda: 1)
    f = tmp_path / "kind" / f"{key.hex()}.pickle"
    f.write_bytes(f.read_bytes()[:2] + b"damaged")
    assert cache.get(key, lambda: 2) == 2
    assert cache.get(key, lambda: 3) == 2


def test_a_folder_that_cannot_be_written_keeps_nothing_and_fails_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "file").write_text("not a folder")
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "file"))
    cache: DiskCache[int] = DiskCache("kind")
    calls: list[object] = []
    assert cache.get(content_key("k"), lambda: int(str(counting(5, calls)))) == 5
    assert cache.get(content_key("k"), lambda: int(str(counting(5, calls)))) == 5
    assert len(calls) == 2
    assert (tmp_path / "file").read_text() == "not a folder"


def test_the_last_used_are_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    cache: DiskCache[int] = DiskCache("kind", keep=3)
    keys = [content_key(i) for i in range(5)]
    for i, k in enumerate(keys):
        cache.get(k, lambda i=i: i)  # type: ignore[misc]
        # Each file a second newer than the last, whatever the file system's clock grain.
        f = tmp_path / "kind" / f"{k.hex()}.pickle"
        os.utime(f, ns=(10**9 * (i + 1), 10**9 * (i + 1)))
    kept = {f.stem for f in (tmp_path / "kind").glob("*.pickle")}
    assert kept <= {k.hex() for k in keys} and len(kept) == 3
    assert keys[4].hex() in kept


@pytest.mark.parametrize("value", ["off", "0", ""])
def test_off_keeps_nothing(value: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(CACHE_ENV, value)
    monkeypatch.chdir(tmp_path)
    assert cache_dir() is None
    calls: list[object] = []
    cache: DiskCache[object] = DiskCache("kind")
    cache.get(content_key("k"), lambda: counting(1, calls))
    cache.get(content_key("k"), lambda: counting(1, calls))
    assert calls == [1, 1] and not list(tmp_path.iterdir())
