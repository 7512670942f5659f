"""A text progress bar on stderr for ``progress=True``."""

import sys


class TextProgress:
    """Callable progress(phase, done, total, elapsed): draws ``phase [####    ] 42% 3 s left``
    on stderr, one line per phase."""

    def __init__(self, stream=None, width=30):
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self._phase = None

    def __call__(self, phase, done, total, elapsed):
        if phase != self._phase and self._phase is not None:
            self.stream.write("\n")
        self._phase = phase
        frac = done / total if total else 1.0
        filled = int(round(self.width * frac))
        left = ""
        if 0 < frac < 1 and elapsed > 0:
            left = " %.0f s left" % (elapsed * (1 - frac) / frac)
        self.stream.write("\r%s [%s%s] %3.0f%%%s  " % (phase, "#" * filled,
                                                        " " * (self.width - filled),
                                                        100 * frac, left))
        if done >= total:
            self.stream.write("\n")
            self._phase = None
        self.stream.flush()
