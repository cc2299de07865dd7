"""Progress of a run: a bar on terminals, a plain line at most every 5 s in logs."""
from __future__ import annotations

import time



class _Progress:
    """Progress of a run that has taken more than about a second.

    On a terminal: a tqdm bar. Otherwise (stderr redirected to a log file or a pipe): a plain
    line ``progress: t = ... of ... s (..%), ... s elapsed`` at most every ``interval`` seconds,
    never a carriage return."""

    def __init__(self, t0, t1, stream=None, interval: float = 5.0):
        import sys
        self.t0, self.t1 = t0, t1
        self.start = time.perf_counter()
        self.bar = None
        self.last = t0
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.terminal = bool(isatty and isatty())
        self.interval = interval
        self.next_line = self.start + 1.0

    def __call__(self, t):
        now = time.perf_counter()
        if not self.terminal:
            if now >= self.next_line:
                span = self.t1 - self.t0
                share = 100.0 * (t - self.t0) / span if span > 0 else 100.0
                print(f"progress: t = {t:.6g} of {self.t1:.6g} s ({share:.0f}%), "
                      f"{now - self.start:.0f} s elapsed", file=self.stream, flush=True)
                self.next_line = now + self.interval
            return
        if self.bar is None:
            if now - self.start < 1.0:
                return
            from tqdm import tqdm
            self.bar = tqdm(total=self.t1 - self.t0, unit="s(sim)", leave=False,
                            file=self.stream,
                            bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
        self.bar.update(t - self.last)
        self.last = t

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _progress(progress, t0, t1):
    if callable(progress):
        return progress
    if progress:
        return _Progress(t0, t1)
    return None
