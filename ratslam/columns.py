"""Column arrays with amortised O(1) append (the experience map's experiences and links, a
system's kept ticks and anchors)."""

from __future__ import annotations

import numpy as np


class Growable:
    """Named column arrays (each of a fixed row shape and dtype) that grow by appending rows."""

    def __init__(self, spec: dict[str, tuple[tuple, type]]):
        self._spec = spec
        self.n = 0
        self._cap = 64
        self.cols: dict[str, np.ndarray] = {
            k: np.zeros((self._cap, *shape), dtype=dt) for k, (shape, dt) in spec.items()
        }

    def append(self, **values) -> int:
        """Append one row (columns not given stay zero); returns its index."""
        if self.n == self._cap:
            self._cap *= 2
            for k, arr in self.cols.items():
                new = np.zeros((self._cap,) + arr.shape[1:], dtype=arr.dtype)
                new[: self.n] = arr[: self.n]
                self.cols[k] = new
        i = self.n
        for k, v in values.items():
            self.cols[k][i] = v
        self.n += 1
        return i

    def view(self, key: str) -> np.ndarray:
        """The filled rows of one column (a view: writes go into the column)."""
        return self.cols[key][: self.n]

    def load(self, arrays: dict[str, np.ndarray]) -> None:
        """Replace every column by ``arrays`` (one per column, all of one length)."""
        n = len(next(iter(arrays.values())))
        self._cap = max(64, 1 << max(n - 1, 1).bit_length())
        self.n = n
        for k, (shape, dt) in self._spec.items():
            self.cols[k] = np.zeros((self._cap,) + shape, dtype=dt)
            self.cols[k][:n] = arrays[k]

    def state(self, prefix: str) -> dict[str, np.ndarray]:
        """A copy of the filled rows of every column, keyed ``prefix + name`` (for a saved state)."""
        return {prefix + k: self.view(k).copy() for k in self.cols}

    def load_state(self, s: dict[str, np.ndarray], prefix: str) -> None:
        """Restore the columns from :meth:`state`'s arrays in ``s``."""
        self.load({k: s[prefix + k] for k in self.cols})
