"""The last few results of a pure kernel, given back when it is called with exactly the
same inputs.

A fit's Jacobian steps one parameter at a time, and a parameter that acts after the flow
solve (a seal's friction, a sensor's lag on the force) leaves the solve's inputs and the
chamber's bit for bit what they were at the point it steps from: on a diagnosis of friction
beside air a third of the chamber integrations repeated one of the eight before it. The
match is exact (every array element, NaN equal to NaN, and every scalar), so a result
reused is the one the kernel would have computed; a cheap fingerprint (shapes, scalars and
a few elements of each array) rules most entries out before the arrays are compared, and
its hash, worked out once a call, rules them out before the fingerprints are: comparing
the chamber's fingerprints (a record's dtype among them) entry by entry was a twentieth of
a diagnosis of aerated oil.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Generic, ParamSpec, TypeVar, cast

import numpy as np

SAMPLES = 16  # elements of each array in the fingerprint
P = ParamSpec("P")
R = TypeVar("R")


def _fingerprint(args: tuple[object, ...]) -> tuple[object, ...]:
    # Every call pays for this (36 000 in one diagnosis): the dtype itself, not its name,
    # and no reshape of an array that is flat already.
    out: list[object] = []
    for a in args:
        if isinstance(a, np.ndarray):
            flat = a if a.ndim == 1 else a.reshape(-1)
            step = max(1, flat.size // SAMPLES)
            out.append((a.dtype, a.shape, flat[::step].tobytes()))
        elif isinstance(a, tuple):  # a named tuple of arrays: each is fingerprinted
            out.append(_fingerprint(a))
        elif isinstance(a, np.void):  # a record is unhashable: its type and bits
            out.append((a.dtype, a.tobytes()))
        else:
            out.append(a)
    return tuple(out)


def _same(a: tuple[object, ...], b: tuple[object, ...]) -> bool:
    for x, y in zip(a, b, strict=True):
        if isinstance(x, np.ndarray):
            if not isinstance(y, np.ndarray):
                return False
            same = _bitwise(x, y) if x.dtype == np.float64 else None
            if same is None:
                same = bool(np.array_equal(x, y, equal_nan=x.dtype.kind == "f"))
            if not same:
                return False
        elif isinstance(x, tuple):
            if not isinstance(y, tuple) or not _same(x, y):
                return False
        elif not (x == y or (x != x and y != y)):  # NaN scalars alike
            return False
    return True


def _bitwise(x: np.ndarray, y: np.ndarray) -> bool | None:
    """Whether two float64 arrays hold the same bits (None when that cannot be read
    without a copy). One pass, where array_equal with NaNs equal takes three; bits alike
    are values alike (a NaN's payload or a zero's sign that differ only miss the cache)."""
    if x.shape != y.shape or y.dtype != x.dtype:
        return False
    if not (x.flags.c_contiguous and y.flags.c_contiguous):
        return None
    return bool(np.array_equal(x.view(np.int64), y.view(np.int64)))


def _nbytes(values: tuple[object, ...]) -> int:
    return sum(
        v.nbytes if isinstance(v, np.ndarray) else _nbytes(v) if isinstance(v, tuple) else 0
        for v in values
    )


def _copy(values: R) -> R:
    if isinstance(values, np.ndarray):
        return cast("R", values.copy())
    if isinstance(values, tuple):
        copied = (_copy(v) for v in values)
        # a named tuple keeps its class (numba types it by the class)
        return cast("R", type(values)(*copied) if hasattr(values, "_fields") else tuple(copied))
    return values


class Recent(Generic[P, R]):
    """Up to `size` calls of `kernel` (positional arguments: arrays, scalars and tuples of
    them), the most recent first, holding at most `max_bytes` of inputs and results.
    Results are copied in and out, so a caller that edits one in place changes no other's."""

    def __init__(self, kernel: Callable[P, R], size: int = 8, max_bytes: int = 64 << 20):
        self.kernel = kernel
        self.size = size
        self.max_bytes = max_bytes
        # (the fingerprint's hash, the fingerprint), the inputs, the result, their bytes
        self._entries: list[tuple[tuple[int, tuple[object, ...]], tuple[object, ...], R, int]] = []
        self._held = 0  # the entries' bytes, kept as they come and go (not summed per call)
        self._lock = threading.Lock()
        self.hits = 0
        self.calls = 0

    def __call__(self, *args: P.args, **kwargs: P.kwargs) -> R:
        if kwargs:  # the cache keys on positional arguments only
            raise TypeError(f"Recent takes positional arguments only, got {sorted(kwargs)}")
        key = _fingerprint(args)
        try:
            h = hash(key)
        except TypeError:  # an input the fingerprint cannot hash: not kept
            return self.kernel(*args, **kwargs)
        with self._lock:
            self.calls += 1
            for i, ((kh, k), stored, result, _) in enumerate(self._entries):
                if kh == h and k == key and _same(args, stored):
                    self.hits += 1
                    self._entries.insert(0, self._entries.pop(i))
                    return _copy(result)
        result = self.kernel(*args, **kwargs)
        stored = tuple(_copy(a) for a in args)
        cost = _nbytes(stored) + _nbytes(result if isinstance(result, tuple) else (result,))
        if cost > self.max_bytes // 4:
            return result
        with self._lock:
            self._entries.insert(0, ((h, key), stored, _copy(result), cost))
            self._held += cost
            while len(self._entries) > self.size or self._held > self.max_bytes:
                self._held -= self._entries.pop()[3]
        return result
