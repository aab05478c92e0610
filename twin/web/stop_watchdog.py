"""The server's stop deadline, armed the moment SIGTERM arrives (issue 43, finding 1).

`docker stop` sends SIGTERM and, 10 s later, SIGKILL. The server's Python SIGTERM handler
only runs when the main thread next executes bytecode: under load, or behind a call that holds
the GIL, seconds late (12.1 s to exit once, at load 6.9, when the deadline was a kernel timer
armed by that handler). So the deadline is kept outside Python's handler:

- a small watchdog process, started with the server, blocks on a pipe;
- `faulthandler` writes to that pipe from its C-level SIGTERM handler, at delivery, needing
  neither the GIL nor the main thread, then chains to the Python handler (the graceful stop);
- from the first byte the watchdog counts `STOP_DEADLINE` seconds and then SIGKILLs the server
  if it still lives (it stops waiting as soon as the server is gone).

Without SIGTERM the watchdog only waits: the pipe's end-of-file (the server closed it or
ended) ends it. It ignores SIGINT and SIGTERM itself, so a signal to the whole process group
(Ctrl-C, a service manager) leaves it to enforce the deadline.
"""

from __future__ import annotations

import faulthandler
import os
import signal
import subprocess
import sys

#: [s] after SIGTERM reaches the process, it ends by then whatever it is doing; under
#: `docker stop`'s 10 s before its SIGKILL
STOP_DEADLINE = 9.5

#: the watchdog process's program: argv = read fd, server pid, deadline [s]. Only builtins,
#: run with -I -S, so it starts in milliseconds and reads nothing of the environment.
_WATCHDOG = """
import os, signal, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.signal(signal.SIGTERM, signal.SIG_IGN)
fd, pid, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
if not os.read(fd, 65536):
    sys.exit(0)
deadline = time.monotonic() + seconds
os.set_blocking(fd, False)
while os.getppid() == pid and time.monotonic() < deadline:
    try:
        os.read(fd, 65536)
    except BlockingIOError:
        pass
    time.sleep(0.05)
if os.getppid() == pid:
    os.kill(pid, signal.SIGKILL)
"""


class StopWatchdog:
    """The watchdog process and the pipe that arms it; main thread only (signals).

    Call `arm()` after every installation of a Python SIGTERM handler (installing one replaces
    the C-level handler that `arm` puts in front of it), `close()` once the server is done.
    """

    def __init__(self, seconds: float = STOP_DEADLINE) -> None:
        read, self._write = os.pipe()
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-I", "-S", "-c", _WATCHDOG, str(read), str(os.getpid()),
                 repr(float(seconds))],
                pass_fds=(read,), stdin=subprocess.DEVNULL, close_fds=True,
            )  # fmt: skip
        finally:
            os.close(read)

    def arm(self) -> None:
        """Put the C-level writer in front of the SIGTERM handler installed now."""
        faulthandler.register(signal.SIGTERM, file=self._write, all_threads=False, chain=True)

    def close(self) -> None:
        """Take the writer away and close the pipe: an idle watchdog ends; one already counting
        (SIGTERM came) goes on until the deadline or until this process is gone."""
        faulthandler.unregister(signal.SIGTERM)
        os.close(self._write)
