"""Progress of a running job: a tqdm bar when tqdm is importable, else one line on stderr
rewritten in place (on a terminal; in a log, a plain line per tenth of the work, without
terminal escapes); the native job calls it with ``(done, total)`` about ten times a second.

Both say how long is left as a range, as the command line's hint does
(``src/jobs/progress.rs``, ``Hint``): the low end at the pace of the counted work since the
counter first moved, which leaves out what the counter does not count (a select's MAP
searches after the first, its estimators and figures); the high end at the pace of the whole
call so far, which counts the set-up before the first unit as if it recurred."""

import sys
import time


# no range before the counter has moved for this long, nor before this fraction of the work
# is done since then: a projection from less is noise
AFTER_SECONDS = 5.0
MIN_FRACTION = 0.002


class _Left:
    """The range of seconds left, from ``(done, total)`` seen at the monotonic clock."""

    def __init__(self):
        self.t0 = time.monotonic()
        self.first = None  # (t, done) when the work started: the time before it is not work

    def __call__(self, now, done, total):
        """``(low, high)`` seconds to go, or ``None`` while that would rest on too little."""
        if self.first is None and done > 0:
            self.first = (now, done)
        if self.first is None or done >= total:
            return None
        t, d = self.first
        if now - t < AFTER_SECONDS or (done - d) < MIN_FRACTION * total:
            return None
        low = (now - t) * (total - done) / (done - d)
        high = (now - self.t0) * (total - done) / done
        return min(low, high), max(low, high)


def _range(left):
    """``", 17–31 s to go"`` (or ``""`` without a range)."""
    if left is None:
        return ""
    low, high = left
    if round(low) == round(high):
        return f", about {low:.0f} s to go"
    return f", {low:.0f}–{high:.0f} s to go"


class _Line:
    """``occam fit: 1200/8000 iterations (15%), 9 s, 17–31 s to go`` on stderr."""

    def __init__(self, what, unit):
        self.what, self.unit = what, unit
        self.left = _Left()
        self.t0 = self.left.t0
        self.shown = False
        # a log file or pipe gets whole lines and no escapes: `\r` and `\x1b[K` only mean
        # something to a terminal
        self.tty = sys.stderr.isatty()
        self.tenth = -1  # the last tenth of the work written to a log

    def __call__(self, done, total):
        if total <= 0:
            return
        now = time.monotonic()
        eta = _range(self.left(now, done, total))
        text = (
            f"{self.what}: {done}/{total} {self.unit} ({100 * done // total}%), "
            f"{now - self.t0:.0f} s{eta}"
        )
        if self.tty:
            sys.stderr.write(f"\r{text}\x1b[K")
            self.shown = True
        else:
            tenth = 10 * min(done, total) // total
            if tenth == self.tenth:
                return
            self.tenth = tenth
            sys.stderr.write(f"{text}\n")
        sys.stderr.flush()

    def close(self):
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


class _Tqdm:
    """A tqdm bar, opened when the job knows its total."""

    def __init__(self, tqdm, what, unit):
        self.tqdm, self.what, self.unit = tqdm, what, unit
        self.bar = None
        # tqdm's own remaining time counts only the pace of the counted work: the range
        # beside it says what the counter leaves out
        self.left = _Left()

    def __call__(self, done, total):
        if total <= 0:
            return
        if self.bar is None:
            self.bar = self.tqdm(total=total, desc=self.what, unit=f" {self.unit}", unit_scale=True)
        if self.bar.total != total:
            self.bar.total = total
        self.bar.n = min(done, total)
        left = self.left(time.monotonic(), done, total)
        if left is not None:
            self.bar.set_postfix_str(_range(left)[2:], refresh=False)
        self.bar.refresh()

    def close(self):
        if self.bar is not None:
            self.bar.close()


def reporter(progress, what, unit):
    """The callback for ``progress`` (``True``: tqdm if importable, else a line on stderr;
    ``False``/``None``: nothing; a callable: called with ``(done, total)`` itself), or ``None``.
    The returned object has ``close()``."""
    if progress is False or progress is None:
        return None
    if callable(progress) and progress is not True:
        return _Callable(progress)
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _Line(what, unit)
    return _Tqdm(tqdm, what, unit)


class _Callable:
    def __init__(self, f):
        self.f = f

    def __call__(self, done, total):
        self.f(done, total)

    def close(self):
        pass


def run(native, args, progress, what, unit):
    """Calls ``native(*args, progress)`` with the reporter of ``progress``, closed after."""
    r = reporter(progress, what, unit)
    try:
        return native(*args, r)
    finally:
        if r is not None:
            r.close()
