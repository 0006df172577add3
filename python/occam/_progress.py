"""Progress of a running job: a tqdm bar when tqdm is importable, else one line on stderr
rewritten in place (on a terminal; in a log, a plain line per tenth of the work, without
terminal escapes); the native job calls it with ``(done, total)`` about ten times a second."""

import sys
import time


class _Line:
    """``occam fit: 1200/8000 iterations (15%), 3 s, about 17 s to go`` on stderr."""

    def __init__(self, what, unit):
        self.what, self.unit = what, unit
        self.t0 = time.monotonic()
        self.first = None  # (t, done) when the work started: the time before it is not work
        self.shown = False
        # a log file or pipe gets whole lines and no escapes: `\r` and `\x1b[K` only mean
        # something to a terminal
        self.tty = sys.stderr.isatty()
        self.tenth = -1  # the last tenth of the work written to a log

    def __call__(self, done, total):
        if total <= 0:
            return
        now = time.monotonic()
        if self.first is None and done > 0:
            self.first = (now, done)
        eta = ""
        if self.first is not None and done > self.first[1] and done < total:
            t, d = self.first
            left = (now - t) * (total - done) / (done - d)
            eta = f", about {left:.0f} s to go"
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

    def __call__(self, done, total):
        if total <= 0:
            return
        if self.bar is None:
            self.bar = self.tqdm(total=total, desc=self.what, unit=f" {self.unit}", unit_scale=True)
        if self.bar.total != total:
            self.bar.total = total
        self.bar.n = min(done, total)
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
