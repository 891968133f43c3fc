"""The progress display of many runs: a tqdm bar on a terminal, nothing elsewhere (a log file gets no
carriage-return frames)."""


class _Quiet:
    """A bar that shows nothing."""

    n = 0

    def update(self, k=1):
        """Count ``k`` more done."""
        self.n += k

    def set_postfix_str(self, text):
        """Say ``text`` after the bar (nowhere)."""

    def close(self):
        """Finish the bar."""


def bar(total, done=0, desc=None, unit="run", show=True):
    """A progress bar of ``total`` items, ``done`` of them finished already.

    A tqdm bar when ``show`` and stderr is a terminal; else one that shows nothing.
    Either has ``update(k)``, ``set_postfix_str(text)`` and ``close()``.
    """
    from hybridsim.engine.simulator import on_terminal

    if not show or not on_terminal():
        return _Quiet()
    from tqdm import tqdm

    return tqdm(total=total, initial=done, desc=desc, unit=unit, smoothing=0.1)
