"""The heap trimmed when it holds much freed memory: given back to the system."""

import pytest

from unjello.run import heap


def _rss_kb() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))


def _glibc() -> None:
    if heap._malloc_trim() is None or heap.held() is None:
        pytest.skip("no glibc malloc_trim and mallinfo2 on this system: trimming is a no-op")


def test_trim_gives_freed_memory_back_when_much_is_held(monkeypatch):
    _glibc()
    assert heap.trim(heap.TRIM_EVERY + 1) is False  # not a multiple: nothing done
    # 100 KB blocks (under glibc's mmap threshold: on the heap), every other one kept,
    # so the freed ones sit between live ones where only a trim can give them back.
    blocks = [bytearray(100_000) for _ in range(2000)]
    del blocks[::2]
    held = heap.held()
    assert held is not None and held >= 90_000_000  # the 100 MB freed, kept for later
    monkeypatch.setattr(heap, "HELD_MAX", held + 10_000_000)  # (other frees meanwhile)
    assert heap.trim(heap.TRIM_EVERY) is False  # not over the limit: kept
    monkeypatch.setattr(heap, "HELD_MAX", held // 2)
    before = _rss_kb()
    assert heap.trim(heap.TRIM_EVERY) is True
    assert _rss_kb() < before - 50_000  # most of the 100 MB freed came back
    del blocks


def test_without_the_heap_counters_every_few_pictures(monkeypatch):
    calls = []
    monkeypatch.setattr(heap, "_malloc_trim", lambda: lambda pad: calls.append(pad) or 1)
    monkeypatch.setattr(heap, "_mallinfo2", lambda: None)  # glibc before 2.33
    assert heap.held() is None
    assert heap.trim(heap.TRIM_EVERY + 1) is False and not calls
    assert heap.trim(heap.TRIM_EVERY) is True and calls == [0]


def test_trim_is_a_no_op_without_glibc(monkeypatch):
    monkeypatch.setattr(heap, "_malloc_trim", lambda: None)
    assert heap.trim(0) is False
