# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Progress of a long offline job on stderr: a tqdm bar on a terminal (when tqdm is
installed), else a whole line at most every ``plain_every`` seconds and one at the end, with
no carriage returns, so that a pipe or a log file reads line by line."""

from __future__ import annotations

import sys
import time


def isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class Progress:
    """``progress(done)`` as the job goes, ``close()`` at its end; ``done`` and ``total`` in
    ``unit`` (items, or seconds of sim time)."""

    PLAIN_EVERY_S = 10.0  # seconds between two plain lines

    def __init__(self, total: float, desc: str, unit: str = '', plain_every: float | None = None,
                 stream=None) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self.plain_every = self.PLAIN_EVERY_S if plain_every is None else plain_every
        self.stream = stream or sys.stderr
        self.start, self.bar = time.monotonic(), None
        self.last: float | None = None
        self.done: float = 0
        if isatty(self.stream):
            try:
                from tqdm import tqdm
            except ImportError:
                tqdm = None
            if tqdm is not None:
                self.bar = tqdm(total=total, unit=unit or 'it', desc=desc, file=self.stream,
                                dynamic_ncols=True)

    def __call__(self, done: float) -> None:
        self.done = done
        if self.bar is not None:
            self.bar.update(done - self.bar.n)
            return
        now = time.monotonic()
        if self.last is None:
            self.last = now  # the first line waits a period too
            return
        if now - self.last >= self.plain_every:
            self.last = now
            self._line(now)

    def close(self, finished: bool = True) -> None:
        """The end: of the whole job (the bar full, a last line), or, not ``finished``
        (interrupted), where it stopped: the bar left as it is and no line (the caller says
        what was done)."""
        if self.bar is not None:
            if finished:
                self.bar.update(self.total - self.bar.n)
            self.bar.close()
            self.bar = None
        elif finished:
            self.done = self.total
            self._line(time.monotonic())

    def _line(self, now: float) -> None:
        share = 100.0 * self.done / self.total if self.total else 100.0
        rate = self.done / max(now - self.start, 1e-9)
        eta = (f', about {(self.total - self.done) / rate:.0f} s left'
               if 0 < rate and self.done < self.total else '')
        unit = f' {self.unit}' if self.unit else ''
        print(f'{self.desc}: {self.done:g}/{self.total:g}{unit} ({share:.1f}%){eta}',
              file=self.stream, flush=True)
