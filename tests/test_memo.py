"""The one memo every cache of derived objects uses (phasemap.core.memo)."""

from __future__ import annotations

import subprocess
import sys
import threading

from phasemap.core.memo import MEMOS, Memo


class Owner:
    pass


def test_a_dead_owner_cannot_lend_its_id_to_a_new_one():
    """An entry holds its owners: a new object never matches another's entry, even when
    CPython would give it the address of an object made and dropped before (a memo that
    kept only the id would hand the first owner's value to the second: without the hold,
    this loop gets 0 back 199 times).  No gc.collect(): in a process holding numba and
    sympy a full collection takes seconds, and reference counting frees ``o`` at once."""
    memo = Memo("test.ids")
    seen = []
    for i in range(200):
        o = Owner()  # freed at once by reference counting where nothing holds it
        seen.append(memo.get((o,), (), lambda i=i: i))
        del o
    assert seen == list(range(200))
    assert len(memo) == 200


def test_values_are_part_of_the_key():
    memo = Memo("test.values")
    o = Owner()
    assert memo.get((o,), ("a",), lambda: 1) == 1
    assert memo.get((o,), ("b",), lambda: 2) == 2
    assert memo.get((o,), ("a",), lambda: 3) == 1


def test_replace_keeps_the_latest_owner_only():
    """replace=True: one entry per values; another owner builds anew and replaces it, so
    the old owner can be freed."""
    memo = Memo("test.replace", replace=True)
    a, b = Owner(), Owner()
    assert memo.get((a,), ("k",), lambda: "a") == "a"
    assert memo.get((b,), ("k",), lambda: "b") == "b"
    assert len(memo) == 1
    assert memo.get((a,), ("k",), lambda: "a again") == "a again"


def test_maxsize_drops_the_oldest():
    memo = Memo("test.bounded", maxsize=3)
    for k in range(5):
        memo.get((), (k,), lambda k=k: k)
    assert len(memo) == 3
    built = []
    memo.get((), (0,), lambda: built.append(0) or 0)
    assert built == [0]  # 0 was dropped, so it is built again


def test_threads_agree_on_one_value():
    """Threads that miss together may each build; every one returns the stored value."""
    memo = Memo("test.threads")
    o = Owner()
    start = threading.Barrier(8)
    out = []

    def work():
        start.wait()
        out.append(memo.get((o,), (), lambda: object()))

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len({id(x) for x in out}) == 1


def test_clear_and_the_library_uses_memos():
    """clear() empties a memo (clear_all, every one, runs in a child process below: the
    compiled kernels of the other tests in this process live in memos too)."""
    import phasemap

    memo = Memo("test.clear")
    memo.get((), (1,), lambda: 1)
    memo.clear()
    assert len(memo) == 0 and MEMOS["test.clear"] is memo
    phasemap.layers_for("hinge_pendulum")
    assert len(MEMOS["layers.registries"]) >= 1


def test_clear_all_in_a_process_of_its_own():
    code = ("from phasemap.core.memo import Memo, clear_all\n"
            "a, b = Memo('a'), Memo('b', replace=True)\n"
            "a.get((), (1,), lambda: 1); b.get((), (2,), lambda: 2)\n"
            "clear_all()\n"
            "assert len(a) == 0 and len(b) == 0\n")
    subprocess.run([sys.executable, "-c", code], check=True)
