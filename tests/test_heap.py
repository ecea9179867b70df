"""The heap trimmed every few pictures: freed memory given back to the system."""

import pytest

from unjello import heap


def _rss_kb() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))


def test_trim_gives_freed_memory_back_every_few_pictures():
    if heap._malloc_trim() is None:
        pytest.skip("no glibc malloc_trim on this system: trimming is a no-op here")
    assert heap.trim(heap.TRIM_EVERY + 1) is False  # not a multiple: nothing done
    # 100 KB blocks (under glibc's mmap threshold: on the heap), every other one kept,
    # so the freed ones sit between live ones where only a trim can give them back.
    blocks = [bytearray(100_000) for _ in range(2000)]
    del blocks[::2]
    before = _rss_kb()
    assert heap.trim(heap.TRIM_EVERY) is True
    assert _rss_kb() < before - 50_000  # most of the 100 MB freed came back
    del blocks


def test_trim_is_a_no_op_without_glibc(monkeypatch):
    monkeypatch.setattr(heap, "_malloc_trim", lambda: None)
    assert heap.trim(0) is False
