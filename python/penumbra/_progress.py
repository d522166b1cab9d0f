"""Progress of long calls: a tqdm bar per stage when tqdm is installed and someone is watching
(a terminal or a Jupyter kernel), a caller's callable as it is, or nothing."""

from __future__ import annotations

import sys
from typing import Callable, Optional, Tuple


def _watched() -> bool:
    if "ipykernel" in sys.modules:
        return True
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


class _Bars:
    """One bar per stage ("rendering", "shooting", ...), 0 to 100%, closed when the next stage
    starts or the call ends."""

    def __init__(self, tqdm):
        self._tqdm = tqdm
        self._stage = None
        self._bar = None

    def __call__(self, stage: str, fraction: float) -> None:
        if stage != self._stage:
            self.close(finished=True)  # a stage ends when the next begins
            self._stage = stage
            self._bar = self._tqdm(total=100, desc=stage, unit="%", leave=True,
                                   bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}")
        self._bar.n = round(100.0 * min(max(fraction, 0.0), 1.0), 1)
        self._bar.refresh()

    def close(self, finished: bool = False) -> None:
        if self._bar is not None:
            if finished:  # stages that converge early (a solve) report less than 100%
                self._bar.n = 100
                self._bar.refresh()
            self._bar.close()
            self._bar = None


def _nothing(finished: bool = False) -> None:
    pass


def callback(progress) -> Tuple[Optional[Callable[[str, float], None]], Callable[[bool], None]]:
    """The callable to hand the library for `progress` (None: tqdm if installed and watched;
    True: tqdm if installed; False: none; a callable: itself), and what to call at the end,
    with whether the call finished."""
    if progress is False:
        return None, _nothing
    if callable(progress):
        return progress, _nothing
    if progress is None or progress is True:
        if progress is None and not _watched():
            return None, _nothing
        try:
            from tqdm import tqdm
        except ImportError:
            return None, _nothing
        bars = _Bars(tqdm)
        return bars, bars.close
    from ._penumbra import InputError
    raise InputError(f"progress: must be a callable, True, False or None, not {progress!r}")
