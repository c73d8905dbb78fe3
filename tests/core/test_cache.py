"""The one cache policy (``core.system.cache``): least recently used dropped first, within a
count and a byte budget, each value made once however many threads ask."""

import threading
import time

from bo2_lighting.addon.core.system.cache import CACHES, Cache, clear_all, stamp


def test_the_least_recently_used_goes_first():
    c = Cache("test lru", kept=2)
    c.put("a", 1)
    c.put("b", 2)
    assert c.get("a") == 1  # "a" is now the newest
    c.put("c", 3)
    assert c.keys() == ["a", "c"] and c.get("b") is None


def test_a_byte_budget_keeps_the_newest_whatever_its_size():
    c = Cache("test bytes", kept=10, size=len, budget=5)
    c.put("a", b"123")
    c.put("b", b"45")
    assert c.keys() == ["a", "b"]
    c.put("c", b"6")  # 3 + 2 + 1 > 5: "a" goes
    assert c.keys() == ["b", "c"]
    c.put("d", b"123456789")  # alone over the budget: kept, the others go
    assert c.keys() == ["d"]


def test_a_value_is_made_once_while_threads_wait():
    c = Cache("test once", kept=4)
    made = []

    def make():
        made.append(1)
        time.sleep(0.05)
        return "value"

    threads = [threading.Thread(target=lambda: c.get_or_make("k", make)) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert made == [1] and c.get("k") == "value"


def test_every_cache_is_listed_and_cleared(tmp_path):
    c = Cache("test listed", kept=1)
    c.put("k", 1)
    assert CACHES["test listed"] is c
    clear_all()
    assert len(c) == 0
    f = tmp_path / "f"
    f.write_bytes(b"12")
    assert stamp(f)[1] == 2
