"""Files in and out, safely: atomic writes, a lock for a busy output folder, capped reads.

* **Atomic writes.** Every file the project writes goes to a temporary name in the same
  folder and is renamed over the target (``os.replace``, atomic on POSIX and Windows), so
  Ctrl-C or a crash leaves either the old file or the new one, never half of one.
* **A busy ``--out``.** :func:`locked_folder` creates ``<folder>/.sma-gym.lock`` with
  ``O_EXCL`` (exactly one process can), holds it for the run and removes it at exit; a lock
  whose process is gone (killed, machine rebooted) is stale and taken over.
* **Capped reads.** :func:`read_text` reads at most a stated number of bytes (``/dev/zero``
  or a wrong multi-gigabyte file is refused, not read until memory runs out), accepts a
  UTF-8 byte-order mark, and turns directories and binary files into a ``ValueError`` that
  names the file.
* **Checks before work.** :func:`check_output_folder` / :func:`check_output_file` tell
  whether an output can be created *without creating anything*, so a command can refuse a
  bad ``--out`` before it spends minutes computing.
* **A stop from outside.** :func:`sigterm_as_interrupt` raises SIGTERM (``timeout``, ``kill``,
  a cluster scheduler) as :class:`Terminated`, a ``KeyboardInterrupt``: the lock and an
  empty ``--out`` are then cleaned up as after Ctrl-C, where the default action killed the
  process and left the folder behind with its lock.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import hashlib
import json
import os
import shutil
import signal
import socket
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "LOCK_NAME",
    "MAX_JSON_BYTES",
    "Terminated",
    "atomic_path",
    "check_output_file",
    "check_output_folder",
    "locked_folder",
    "read_json_object",
    "read_text",
    "output_list",
    "STAGING_PREFIX",
    "listed_outputs",
    "staged_outputs",
    "sha256_file",
    "sigterm_as_interrupt",
    "signals_deferred",
    "stopped",
    "write_bytes",
    "write_json",
    "write_text",
]

LOCK_NAME = ".sma-gym.lock"
STAGING_PREFIX = ".sma-gym-staging-"
"""Hidden folder inside an output folder where a run writes its files before they replace
the earlier ones (removed whatever happens; one left by a killed run is removed by the next)."""


def output_list(command: str) -> str:
    """The name of the list of the files a run of ``command`` wrote into its output folder
    (:func:`staged_outputs`): what the next run of that command with ``--overwrite`` may
    remove, and nothing else (one list per command: fidelity never removes an evaluation)."""
    return f".sma-gym-{command}-outputs.json"


MAX_JSON_BYTES = 16 * 1024 * 1024
"""Model files, sidecars and policy cards are a few kB; 16 MiB is far beyond any real one."""


# --------------------------------------------------------------------------------------
# Atomic writes
# --------------------------------------------------------------------------------------
@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` that becomes ``path`` when the block succeeds.

    For writers that want a file name (``model.save``, ``fig.savefig``): write to the
    yielded path; it is renamed over ``path`` on success and removed on any error or
    interrupt. The temporary name keeps the suffix, since some writers append one.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}", dir=target.parent)
    os.close(fd)
    tmp = Path(name)
    # mkstemp creates the file private (0600); the result gets the permissions any new
    # file of the user gets (0666 less the umask), as a plain open() would give it.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (see the module docstring)."""
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())
    return target


def write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, obj: Any, **dumps_kwargs: Any) -> Path:
    """Write ``obj`` as indented JSON (and a final newline) to ``path`` atomically."""
    dumps_kwargs.setdefault("indent", 2)
    return write_text(path, json.dumps(obj, **dumps_kwargs) + "\n")


def sha256_file(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes (ties a policy card to the model it describes)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# --------------------------------------------------------------------------------------
# Lock for an output folder
# --------------------------------------------------------------------------------------
def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def _lock_owner(lock: Path) -> tuple[int, str]:
    """(pid, host) recorded in a lock file; (0, "") if unreadable (a half-written lock)."""
    try:
        pid_text, _, host = lock.read_text(encoding="utf-8").partition("\n")
        return int(pid_text.strip()), host.strip()
    except (OSError, ValueError):
        return 0, ""


@contextlib.contextmanager
def locked_folder(folder: str | Path, what: str = "--out", lock_name: str = LOCK_NAME) -> Iterator[Path]:
    """Hold an exclusive lock on ``folder`` (created if needed) for the block.

    Raises ``ValueError`` naming the folder and the holder's PID if another live process
    holds it. The lock is also removed at interpreter exit in case the block is skipped
    by ``os._exit``-free shutdown paths. ``lock_name``: the lock file's name, for a lock on
    one set of files in a folder that others may write beside (``sma-gym synth``).
    """
    target = Path(folder)
    existing = _nearest_existing(target)
    target.mkdir(parents=True, exist_ok=True)
    lock = target / lock_name
    me = f"{os.getpid()}\n{socket.gethostname()}\n"
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            pid, host = _lock_owner(lock)
            # Only a PID on this machine can be checked; another host's lock is respected.
            same_host = host in ("", socket.gethostname())
            if same_host and not _pid_alive(pid):
                with contextlib.suppress(FileNotFoundError):
                    lock.unlink()  # stale: its process is gone
                continue
            raise ValueError(
                f"{what} {str(target)!r}: busy, another sma-gym process (PID {pid} on {host or 'this machine'}) "
                f"is writing there (lock {lock}); wait for it, choose another folder, or delete the lock "
                "if that process no longer exists"
            ) from None
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(me)
        break
    else:  # pragma: no cover - lost a race twice in a row
        raise ValueError(f"{what} {str(target)!r}: could not take the lock {lock}")

    def release() -> None:
        if _lock_owner(lock)[0] == os.getpid():
            with contextlib.suppress(FileNotFoundError):
                lock.unlink()

    atexit.register(release)
    try:
        yield target
    except BaseException:
        release()
        # A run that failed before writing anything leaves no empty folders behind.
        _remove_empty_up_to(target, existing)
        raise
    finally:
        release()
        atexit.unregister(release)


def _remove_empty_up_to(folder: Path, keep: Path) -> None:
    """Remove ``folder`` and its parents below ``keep`` while they are empty."""
    probe = folder
    while probe != keep and probe != probe.parent:
        try:
            probe.rmdir()  # only ever succeeds on an empty folder
        except OSError:
            return
        probe = probe.parent


# --------------------------------------------------------------------------------------
# Checks before work
# --------------------------------------------------------------------------------------
def _nearest_existing(path: Path) -> Path:
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe


def _check_writable_dir(folder: Path, what: str, target: Path) -> None:
    if not folder.is_dir():
        raise ValueError(f"{what} {str(target)!r}: {str(folder)!r} is not a folder")
    try:
        # Actually try, since os.access is optimistic (root, network file systems).
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as err:
        raise ValueError(f"{what} {str(target)!r}: cannot write in {str(folder)!r} ({err.strerror or err})") from None


def _require_name(path: str | Path, what: str, expected: str) -> None:
    # Path("") is the current folder: an empty --out would scatter files there.
    if isinstance(path, str) and not path.strip():
        raise ValueError(f"{what} {path!r}: empty, expected a {expected}")


def check_output_folder(folder: str | Path, what: str = "--out", *, must_be_empty: bool = False) -> Path:
    """Check that ``folder`` can be created and written, creating nothing.

    ``must_be_empty``: refuse a folder that already has files (another run's outputs
    would be mixed with this one's).
    """
    _require_name(folder, what, "folder")
    target = Path(folder)
    if target.exists() and not target.is_dir():
        raise ValueError(f"{what} {str(target)!r}: exists and is not a folder")
    _check_writable_dir(_nearest_existing(target), what, target)
    if must_be_empty and target.is_dir():
        # A lock or staging folder left by a killed run is not an output (the next run takes
        # a stale lock over and removes the staging folder).
        entries = sorted(
            p.name for p in target.iterdir() if p.name != LOCK_NAME and not p.name.startswith(STAGING_PREFIX)
        )
        if entries:
            shown = ", ".join(entries[:5]) + (", ..." if len(entries) > 5 else "")
            raise ValueError(
                f"{what} {str(target)!r}: not empty ({shown}); a run never mixes its files with another's: "
                "choose a new folder or pass --overwrite"
            )
    return target


def listed_outputs(folder: str | Path, command: str) -> list[Path] | None:
    """The files an earlier run of ``command`` listed in ``folder`` (:func:`output_list`) that
    are still there; None when the folder has no readable list (no earlier run, or one from
    before the lists: its files are then left alone, whatever their names)."""
    try:
        names = json.loads((Path(folder) / output_list(command)).read_text(encoding="utf-8")).get("files")
    except (OSError, ValueError, AttributeError):
        return None
    if not isinstance(names, list) or not all(isinstance(n, str) and Path(n).name == n for n in names):
        return None
    return sorted(Path(folder) / n for n in set(names) if (Path(folder) / n).is_file())


@contextlib.contextmanager
def staged_outputs(folder: str | Path, command: str) -> Iterator[Path]:
    """For a run that writes a set of files into ``folder`` (held with :func:`locked_folder`):
    a hidden staging folder inside it to write them into.

    When the block ends normally each staged file replaces its namesake in ``folder`` (one
    rename each), the files the earlier run listed (:func:`listed_outputs`) that this run did
    not write are removed (an earlier report's figure of another experiment would otherwise
    read as this run's), and the list names this run's files. When it fails or is
    interrupted, ``folder`` is left as it was. Only listed files are removed, never a file
    by a name pattern (a user's ``chapter7_photo.png`` beside an evaluation stays); a file
    this run writes replaces its namesake (``--overwrite``: :func:`check_output_folder`).
    """
    target = Path(folder)
    for leftover in target.glob(STAGING_PREFIX + "*"):
        shutil.rmtree(leftover, ignore_errors=True)  # a killed run's (the caller holds the lock)
    before = {p.name for p in target.iterdir()}
    staging = target / f"{STAGING_PREFIX}{os.getpid()}"
    staging.mkdir()
    try:
        yield staging
        names = sorted(p.name for p in staging.iterdir() if p.is_file())
        blocked = [n for n in names if (target / n).is_dir()]
        if blocked:
            raise ValueError(
                f"{str(target)!r}: {', '.join(blocked)} is a folder where this run writes a file; the earlier "
                "files are unchanged: move it and run again"
            )
        earlier = listed_outputs(target, command)
        with signals_deferred():
            for name in names:
                os.replace(staging / name, target / name)
            write_json(target / output_list(command), {"command": command, "files": names})
            for path in earlier or []:
                if path.name not in names:
                    path.unlink(missing_ok=True)
        if earlier is None:
            others = sorted(n for n in before - set(names) if not n.startswith("."))
            if others:
                shown = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
                print(
                    f"sma-gym {command}: note: {str(target)!r} also holds {shown}, which no earlier run of {command} "
                    "listed (yours, another command's, or written before 2026-12-06): left alone",
                    file=sys.stderr,
                )
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def check_output_file(path: str | Path, what: str = "--out", *, overwrite: bool = False) -> Path:
    """Check that file ``path`` can be written (its folder created), creating nothing."""
    _require_name(path, what, "file name")
    target = Path(path)
    if target.is_dir():
        raise ValueError(f"{what} {str(target)!r}: is a folder, expected a file name")
    if target.exists() and not overwrite:
        raise ValueError(f"{what} {str(target)!r}: exists; pass --overwrite to replace it")
    _check_writable_dir(_nearest_existing(target.parent), what, target)
    return target


# --------------------------------------------------------------------------------------
# Capped reads
# --------------------------------------------------------------------------------------
def _mib(n: int) -> str:
    return f"{n / (1024 * 1024):g} MiB"


def read_text(path: str | Path, max_bytes: int, what: str = "file") -> str:
    """The UTF-8 text of ``path`` (a byte-order mark is dropped), at most ``max_bytes``.

    Raises ``ValueError`` naming the file for a missing file, a directory, a named pipe or
    socket (not waited on), a file larger than ``max_bytes`` (read is capped: ``/dev/zero``
    is refused, not read forever) and bytes that are not UTF-8 text.
    """
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{what} {str(p)!r}: is a folder, expected a file")
    if p.is_fifo() or p.is_socket():
        # Opening a named pipe waits for a writer: refused, not waited on forever.
        kind = "a named pipe" if p.is_fifo() else "a socket"
        raise ValueError(f"{what} {str(p)!r}: is {kind}, expected a file")
    try:
        with open(p, "rb") as handle:
            data = handle.read(max_bytes + 1)
    except FileNotFoundError:
        raise ValueError(f"{what} {str(p)!r} does not exist") from None
    except OSError as err:
        if err.errno == errno.EISDIR:
            raise ValueError(f"{what} {str(p)!r}: is a folder, expected a file") from None
        raise ValueError(f"{what} {str(p)!r}: cannot read ({err.strerror or err})") from None
    if len(data) > max_bytes:
        raise ValueError(
            f"{what} {str(p)!r}: larger than {_mib(max_bytes)}, the most this reader accepts; not read further"
        )
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(
            f"{what} {str(p)!r}: not UTF-8 text (byte {err.start} is 0x{data[err.start]:02x}; a binary file?)"
        ) from None


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``json.loads`` ``object_pairs_hook``: a key given twice in one object is an error (the
    last would silently win, e.g. a sidecar's second ``supply_voltage_v``)."""
    seen: dict[str, Any] = {}
    for key, value in pairs:
        if key in seen:
            raise ValueError(f"the key {key!r} appears twice in one object; expected each once")
        seen[key] = value
    return seen


def read_json_object(path: str | Path, what: str = "file", max_bytes: int = MAX_JSON_BYTES) -> dict[str, Any]:
    """A JSON object (``{...}``) from ``path``; anything else is a ``ValueError`` naming the file."""
    text = read_text(path, max_bytes, what)
    try:
        data = json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as err:
        raise ValueError(
            f"{what} {str(path)!r}: not valid JSON (line {err.lineno}, column {err.colno}: {err.msg})"
        ) from None
    except RecursionError:
        raise ValueError(f"{what} {str(path)!r}: nested too deeply to be read as JSON") from None
    except ValueError as err:  # e.g. an integer past Python's 4300-digit conversion limit
        raise ValueError(f"{what} {str(path)!r}: not readable as JSON ({err})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} {str(path)!r}: expected a JSON object {{...}}, got a JSON {type(data).__name__}")
    return data


# --------------------------------------------------------------------------------------
# A stop from outside
# --------------------------------------------------------------------------------------
class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the process is (see :func:`sigterm_as_interrupt`). A
    ``KeyboardInterrupt``, so every path that cleans up after Ctrl-C serves it too."""

    exit_code = 128 + signal.SIGTERM
    """143: what a shell reports for a process ended by SIGTERM."""


def stopped(err: KeyboardInterrupt) -> tuple[str, int]:
    """How a command stopped by ``err`` says so and the exit code it returns: the shell's
    for the signal (``("terminated", 143)`` for SIGTERM, ``("interrupted", 130)`` for Ctrl-C)."""
    return ("terminated", Terminated.exit_code) if isinstance(err, Terminated) else ("interrupted", 130)


def interrupt_behind(err: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C (or SIGTERM) an error was raised while handling, if any: a library that
    catches the interrupt mid-call and raises its own error (matplotlib drawing a figure gave
    a ``ValueError``, once in seven stops) was reported as bad input, exit 2, not as a stop."""
    seen: set[int] = set()
    cause: BaseException | None = err
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return None


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the block ends: a run's last renames happen all or none
    (a stop between two left a new report beside an old figure). The signal is then raised
    again for the handler it would have met (KeyboardInterrupt, :class:`Terminated`), the
    outputs whole. Python's handlers run in the main thread only, so elsewhere the block
    runs unchanged. (Handlers, not ``pthread_sigmask``: a mask holds for one thread, and the
    kernel gives a process's signal to any other thread, e.g. a worker's I/O thread.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    kinds = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, lambda signum, frame: received.append(signum)) for s in kinds}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if received:
            signal.raise_signal(received[0])


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` instead of killing the process
    at once (the default action runs no ``finally`` and no ``atexit``). Only the main
    thread can take a signal; elsewhere the block runs unchanged. The previous handler is
    restored at the end.

    A stop that lands inside a library leaves debris, handled here so that every command
    ends on its one line ("terminated", "interrupted") and the shell's code:

    * Python drops an exception raised inside a callback from C: numba's compiler calls
      back through ctypes while it compiles or loads a kernel, and a SIGTERM that lands
      there was lost, the run going on to its end (measured: one run in six stopped 1 s
      into a diagnosis). Such a lost :class:`Terminated` reaches ``sys.unraisablehook``,
      which sends the signal again a moment later, by then outside the callback.
    * The block may end before that: the stop is then raised at its end. Or the library
      fails before that, because its callback never finished (numba: "no compiled object
      yet", a traceback and exit 1, once in 60 stops with a cold cache): any error that
      leaves the block after a stop was lost is that stop, and leaves as
      :class:`Terminated`; so does an error raised while handling a stop (a library that
      catches the interrupt and raises its own error).
    * An object half-built when the stop landed fails in its ``__del__`` (llvmlite's
      ``PipelineTuningOptions``: "no attribute '_as_parameter_'", printed after the
      command's last line, in CI). When a stop leaves the block, the frames it unwound are
      cleared, releasing such objects there, and what their ``__del__`` raises is not
      printed: it is the stop's debris, not a finding."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    state = {"raised": 0, "lost": 0, "stopping": False, "resend": True}

    def handler(signum: int, frame: Any) -> None:
        if not state["stopping"]:  # a second SIGTERM does not cut short the first's cleanup
            state["raised"] += 1
            raise Terminated(f"signal {signum}")

    previous_hook = sys.unraisablehook
    resend_lock = threading.Lock()  # a resend never lands after the handler is restored
    timers: list[threading.Timer] = []

    def send_again() -> None:
        with resend_lock:
            if state["resend"]:
                os.kill(os.getpid(), signal.SIGTERM)

    def no_more_resends() -> None:
        with resend_lock:
            state["resend"] = False
        for timer in timers:
            timer.cancel()

    def hook(unraisable: Any) -> None:
        if state["stopping"]:
            return
        if isinstance(unraisable.exc_value, Terminated):
            state["lost"] += 1
            again = threading.Timer(0.05, send_again)
            again.daemon = True
            timers.append(again)
            again.start()
            return
        previous_hook(unraisable)

    previous = signal.signal(signal.SIGTERM, handler)
    sys.unraisablehook = hook
    try:
        yield
    except BaseException as err:
        stop = interrupt_behind(err)
        if stop is None and state["lost"]:
            stop = Terminated(f"signal {signal.SIGTERM}")
        if stop is None:
            raise
        state["stopping"] = True
        no_more_resends()
        _release_frames(err)
        if stop is err:
            raise
        if stop is interrupt_behind(err):
            raise stop from None  # the library's error, raised while handling the stop: the stop again
        raise stop from err  # the stop lost in a callback, for the error it caused
    else:
        if state["lost"] and state["raised"] == state["lost"]:  # the block ended before the resend
            state["stopping"] = True
            raise Terminated(f"signal {signal.SIGTERM}")
    finally:
        no_more_resends()
        sys.unraisablehook = previous_hook
        try:
            signal.signal(signal.SIGTERM, previous)
        except Terminated:
            # signal.signal first runs the handler of a SIGTERM still pending (a second one,
            # or one sent again): restore anyway; a stop already leaving is enough.
            signal.signal(signal.SIGTERM, previous)
            if not state["stopping"]:
                raise


def _release_frames(err: BaseException) -> None:
    """Clear the finished frames ``err`` and the errors chained to it unwound, and collect
    what only they held (a stop's half-built objects: see :func:`sigterm_as_interrupt`)."""
    import gc
    import traceback

    seen: set[int] = set()
    pending: list[BaseException | None] = [err]
    while pending:
        exc = pending.pop()
        if exc is None or id(exc) in seen:
            continue
        seen.add(id(exc))
        traceback.clear_frames(exc.__traceback__)  # frames still running are skipped
        pending += [exc.__cause__, exc.__context__]
    gc.collect()


PATH_ARGUMENTS = ("out", "files", "heldout", "policy", "model")
"""The options of any command that name files or folders (a name or a list of them)."""


def expand_home(args: Any) -> None:
    """``~`` at the start of a path option is the home folder, as a model path already was
    (``ModelConfig.load``): a quoted ``--out '~/x'`` wrote into a folder named ``~`` under
    the current one while the message said the home folder (a new user's trial)."""
    for name in PATH_ARGUMENTS:
        value = getattr(args, name, None)
        if isinstance(value, str):
            setattr(args, name, os.path.expanduser(value) if value.startswith("~") else value)
        elif isinstance(value, list):
            setattr(
                args, name, [os.path.expanduser(v) if isinstance(v, str) and v.startswith("~") else v for v in value]
            )
