"""One server per data directory: an OS file lock held for the server's whole life.

Two servers on one run store would both requeue and run the same unfinished runs, and each
would write the other's progress backwards. `twin serve` takes an exclusive `flock` on
`DATA_DIR/serve.lock` before it starts anything; a second server finds it taken and stops
(exit 2), naming the process that holds it. The kernel drops the lock when its holder exits,
however it exits (SIGKILL included), so a crash never leaves a stale lock behind; the pid
written into the file is only there to be named.

A server that stops keeps the lock until its process is gone (`hold_until_exit`), not merely
until its shutdown code has run: a process still ending (issue 43: one whose parse held the GIL
lived on for 160 s after "Finished server process") must not share the directory with a new
server that has already taken it.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from types import TracebackType

from twin.errors import TwinError

#: the lock's file inside the data directory
LOCK_FILE = "serve.lock"


class DataDirBusy(TwinError):
    """Another server holds the data directory's lock.

    Attributes:
        pid: the holder's process id, if it could be read.
    """

    def __init__(self, message: str, pid: int | None) -> None:
        super().__init__(message)
        self.pid = pid


class DataDirLock:
    """An exclusive, non-blocking lock on a data directory (`acquire`, then `release`).

    Args:
        folder: the data directory (created if missing).
    """

    def __init__(self, folder: str | Path) -> None:
        self.path = Path(folder) / LOCK_FILE
        self._fd: int | None = None

    def acquire(self) -> DataDirLock:
        """Take the lock and write this process's id into the file.

        Raises:
            DataDirBusy: another process holds it (the message names its pid).
            TwinError: the folder cannot be created or the file opened.
        """
        import fcntl  # POSIX; the server runs on Linux (Docker) and macOS

        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            # not O_TRUNC: the holder's pid must survive a refused opener
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise TwinError(f"data directory {self.path.parent}: {exc.strerror}") from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            pid = _read_pid(fd)
            os.close(fd)
            holder = f"the server with pid {pid}" if pid is not None else "another server"
            raise DataDirBusy(
                f"data directory {self.path.parent} is in use by {holder} (lock {self.path}); "
                "stop it first, or give this server another --data-dir",
                pid,
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        os.fsync(fd)
        self._fd = fd
        return self

    def hold_until_exit(self) -> None:
        """Keep the lock for the rest of this process's life: the kernel drops it when the
        process ends, however it ends (the descriptor is close-on-exec, so no child started
        after this keeps it either). `release` does nothing after this."""
        self._fd = None

    def release(self) -> None:
        """Let the lock go (idempotent); the file stays, empty of meaning until the next."""
        fd, self._fd = self._fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
            os.close(fd)  # closing the descriptor drops the flock

    @property
    def held(self) -> bool:
        return self._fd is not None

    def __enter__(self) -> DataDirLock:
        return self.acquire()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.release()


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text else None
    except (OSError, ValueError):
        return None
