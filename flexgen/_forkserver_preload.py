"""Imported only in the fork server that starts ``flexgen sweep``'s worker processes
(``sweep._context``: ``set_forkserver_preload``, first, and only where the process is the
command's own: a program calling ``flexgen.sweep`` keeps its fork server's children as they
are; the server started with SIGINT blocked until this module ignores it), never by flexgen
itself: what a worker that is still starting does when its study is interrupted.

A terminal's Ctrl-C reaches every process of its foreground group, a worker that is still
starting included: before the pool's initializer (``sweep._leave_interrupts_to_the_parent``)
ran, its KeyboardInterrupt printed a traceback under the one-line "interrupted" (review). The
fork server gives each child the signal handlers it had after its preloads, so ignoring SIGINT
here makes every worker ignore it from its first instruction; the parent stops them
(``sweep._stop_pool``). A worker forked just as the parent stopped finds the study's queue
semaphores already gone (``SemLock.__setstate__``: FileNotFoundError) and exits; the fork
server prints that through ``sys.excepthook``, which here stays silent for it alone. (Every
fork-server child of the command inherits both: they are all its workers.)
"""

import signal
import sys
import traceback

signal.signal(signal.SIGINT, signal.SIG_IGN)
# the server started with SIGINT blocked (``sweep._start_fork_server_deaf``: a Ctrl-C while it
# imported flexgen, before this line, is pending): ignored now, unblocking drops it
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

_print = sys.excepthook


def _quiet_if_the_study_is_gone(kind, value, tb) -> None:
    frames = traceback.extract_tb(tb)
    gone = issubclass(kind, FileNotFoundError) and any(
        f.name == "__setstate__" and f.filename.endswith("synchronize.py") for f in frames
    )
    if not gone:
        _print(kind, value, tb)


sys.excepthook = _quiet_if_the_study_is_gone
