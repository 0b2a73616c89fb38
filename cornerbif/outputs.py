"""The one guard of every file a command writes, and how it is written.

Every command that writes a file (``sweep``, ``continue``, ``plot``, ``gallery``) passes
its outputs through ``check_output`` before any work:

* the directory must exist and be writable, and the name (with the longest suffix the
  command may add beside it) must fit its filesystem;
* an output is never one of the command's inputs (the scene file, a seed file, a file
  being drawn, a style sheet), nor a directory;
* an existing output is replaced only with ``--overwrite`` (figures: without it, as a
  plotting command redraws), and only when it is a file of the kind the command writes
  (``KINDS``): never a scene, a text file, another command's output or a user's data.

What is written goes to a temporary name beside the output and replaces it only when
whole (``replacing``): a full disk, a file-size limit, an interrupt or a kill leaves the
old file as it was, and never a half-written or empty one in its place.  Critical
sections (an atomic rename after an HDF5 file is stamped) run with SIGINT and SIGTERM
deferred (``signals_deferred``), so an interrupt never lands inside HDF5.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import signal
import stat
import threading

from .errors import SweepError, WriteFailed

# the root attribute ``format`` of each kind of cornerbif file
SWEEP_FORMAT = "cornerbif"
CONTINUATION_FORMAT = "cornerbif-continuation"
# what a command may replace, by kind: a name for messages and a test of the file
KIND_NAMES = {
    "sweep": "a cornerbif HDF5 file (a sweep)",
    "continuation": "a cornerbif HDF5 file (a continuation)",
    "figure": "a figure of the same format",
    "gallery_record": "a gallery record (gallery_run.json)",
}
KIND_REPLACES = {
    "sweep": "cornerbif sweep files (--overwrite)",
    "continuation": "cornerbif continuation files (--overwrite)",
    "figure": "PNG, PDF or SVG figures of the format its name gives",
    "gallery_record": "its own gallery_run.json",
}
# the longest names a command writes beside its output (io.open_partial, io.rebuild, _amend,
# replacing): the output's name must leave room for them
SIDE_SUFFIXES = (".partial", ".lock", ".partial.init", ".partial.rebuild", ".partial.amend")
FIGURE_SIGNATURES = {".png": (b"\x89PNG\r\n\x1a\n",), ".pdf": (b"%PDF-",),
                     ".svg": (b"<?xml", b"<svg")}


def not_a_regular_file(path: str) -> str | None:
    """What ``path`` is when it is not a regular file a command may open and read ('a
    directory', 'a FIFO', 'a character device', ...), or None.  A FIFO or a device is never
    opened: reading one may block for ever or never end."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None                       # missing: the caller says so in its own words
    if stat.S_ISREG(mode):
        return None
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def hdf5_format(path):
    """The root attribute ``format`` of a regular HDF5 file ("cornerbif" for a sweep,
    "cornerbif-continuation"), or None (missing, not a regular file, not HDF5, unreadable)."""
    if not os.path.exists(path) or not_a_regular_file(path):
        return None
    try:
        import h5py  # start-up: loads h5py
        if not h5py.is_hdf5(path):
            return None
        with h5py.File(path, "r", locking=False) as f:
            v = f.attrs.get("format")
            return v.decode() if isinstance(v, bytes) else v
    except Exception:  # noqa: BLE001 - unreadable means: not ours
        return None


def is_kind(path: str, kind: str) -> bool:
    """Whether the existing file ``path`` is of ``kind`` (``KIND_NAMES``)."""
    if kind == "sweep":
        return hdf5_format(path) == SWEEP_FORMAT
    if kind == "continuation":
        return hdf5_format(path) == CONTINUATION_FORMAT
    if kind == "figure":
        if not_a_regular_file(path):
            return False
        sigs = FIGURE_SIGNATURES.get(os.path.splitext(path)[1].lower(), ())
        try:
            with open(path, "rb") as fh:
                head = fh.read(4096)
        except OSError:
            return False
        if not head:
            return True          # an empty figure (left by an older version): nothing to lose
        if any(head.startswith(s) for s in sigs):
            return os.path.splitext(path)[1].lower() != ".svg" or b"<svg" in head
        return False
    if kind == "gallery_record":
        if not_a_regular_file(path):
            return False
        try:
            with open(path, "rb") as fh:
                if os.fstat(fh.fileno()).st_size > 64 * 2**20:
                    return False
                doc = json.loads(fh.read().decode("utf-8"))
            return isinstance(doc, dict) and "figures" in doc
        except (OSError, ValueError, UnicodeDecodeError, RecursionError):
            return False
    raise ValueError(kind)


def check_directory(out_path: str, option: str = "-o") -> str:
    """The directory of an output file, refused unless it exists and is writable."""
    d = os.path.dirname(out_path) or "."       # as the OS will resolve it (no text '..')
    if not os.path.isdir(d):
        raise SweepError(f"{option} {out_path}: the directory {d} does not exist")
    if not os.access(d, os.W_OK | os.X_OK):
        raise SweepError(f"{option} {out_path}: the directory {d} is not writable (read-only "
                         "filesystem or no permission)")
    return d


def check_name_length(out_path: str, d: str, option: str = "-o", suffixes=SIDE_SUFFIXES):
    """Refuse a name that, with the longest suffix written beside it, the filesystem cannot
    hold (said of the output, never of an input)."""
    try:
        name_max = os.pathconf(d, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    longest = max(suffixes, key=len) if suffixes else ""
    need = len(os.fsencode(os.path.basename(out_path) + longest))
    if need > name_max:
        raise SweepError(f"{option} {out_path}: the file name is too long for its filesystem "
                         f"({need} bytes with the {longest!r} suffix written beside it; at most "
                         f"{name_max})" if longest else
                         f"{option} {out_path}: the file name is too long for its filesystem "
                         f"({need} bytes; at most {name_max})")
    try:
        path_max = os.pathconf(d, "PC_PATH_MAX")
    except (OSError, ValueError):
        path_max = 4096
    full = len(os.fsencode(os.path.abspath(out_path) + longest))
    if full >= path_max:
        raise SweepError(f"{option} {out_path}: the path is too long ({full} bytes; at most "
                         f"{path_max - 1})")


def same_file(a: str, b: str) -> bool:
    """Whether two paths name one existing file (links and '..' resolved)."""
    try:
        return os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b)
    except OSError:
        return False


def check_output(out_path: str, overwrite: bool, inputs=(), kind: str = "sweep",
                 option: str = "-o", suffixes=SIDE_SUFFIXES):
    """Refuse, before any work, an output the command could not write or must not replace.

    ``inputs``: files the command reads (the scene, a seed file, the files drawn, a style
    sheet), each named in the message when the output is one of them.  ``kind``: what the
    command writes (``KIND_NAMES``); an existing file is replaced only with ``overwrite``
    (figures always may be redrawn) and only when it is a file of that kind.
    """
    if not out_path:
        raise SweepError(f"{option} '': an empty name; name the file to write")
    d = check_directory(out_path, option)
    check_name_length(out_path, d, option, suffixes)
    for what, path in _named(inputs):
        if same_file(path, out_path):
            raise SweepError(f"{option} {out_path}: that is {what} itself, which this command "
                             "reads; name another output")
    if os.path.isdir(out_path):
        raise SweepError(f"{option} {out_path}: is a directory")
    if os.path.lexists(out_path):
        if not os.path.exists(out_path):
            raise SweepError(f"{option} {out_path}: is a broken symbolic link; remove it or "
                             "name another output")
        if not os.path.isfile(out_path):
            raise SweepError(f"{option} {out_path}: exists and is not a regular file")
        if not (overwrite or kind == "figure"):
            raise SweepError(f"{out_path} exists; pass --overwrite to replace it")
        if not is_kind(out_path, kind):
            raise SweepError(f"{option} {out_path}: exists and is not {KIND_NAMES[kind]}; "
                             f"this command replaces only {KIND_REPLACES[kind]} (remove it "
                             "yourself or name another output)")
    check_side_files(out_path, inputs, option, suffixes,
                     judge_partial=kind in ("figure", "gallery_record"))


def check_side_files(out_path: str, inputs=(), option: str = "-o", suffixes=SIDE_SUFFIXES,
                     judge_partial: bool = False):
    """Refuse, before any work, an output whose side files (``OUT.lock``, ``OUT.partial``,
    ...: written and removed beside it) would be one of the command's ``inputs`` (``sweep
    x.h5.lock -o x.h5`` would remove the scene file with its lock), or are held by anything
    but what a command of ours leaves there: a link, a directory, a device, a user's file
    (a lock is an empty file; the others HDF5 files or empty).  ``OUT.partial`` is judged
    here only with ``judge_partial`` (a figure's or a record's temporary: ``leftover``); a
    sweep's or a continuation's partial file is judged by its command, which knows its
    scene (``sweep.plan_output``)."""
    for suffix in suffixes:
        side = out_path + suffix
        for what, path in _named(inputs):
            if same_file(side, path):
                raise SweepError(f"{option} {out_path}: {side}, which this command writes "
                                 f"beside it, is {what}; name another output")
        if (suffix == ".partial" and not judge_partial) or not os.path.lexists(side):
            continue
        ours = (not os.path.islink(side) and os.path.isfile(side)
                and (os.path.getsize(side) == 0 if suffix == ".lock"
                     else leftover(side) if suffix == ".partial"
                     else leftover(side, (HDF5_SIGNATURE,))))
        if not ours:
            what = ("is a symbolic link" if os.path.islink(side)
                    else f"is {not_a_regular_file(side)}" if not_a_regular_file(side)
                    else "is a file that no command of ours left there")
            raise SweepError(f"{option} {out_path}: {side} {what}, in the way of a file this "
                             "command writes and removes there; remove it, or name another "
                             "output")


def _named(inputs):
    """(description, path) of each input: a bare path is 'the input <path>'; a pair
    (description, path) keeps its description (e.g. 'the scene file')."""
    for item in inputs:
        if isinstance(item, tuple):
            yield item
        elif item:
            yield f"the input {item}", item


# ------------------------------------------------------------------ whole or not at all
# the errors of a write that say the room ran out (a full disk or quota, a file-size limit), or
# that the device failed: a fault met while working (exit 1); any other error creating a file
# (no such folder, no permission, a directory in the way) is the input's (exit 2)
SPACE_ERRNOS = frozenset((errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO))


def reason(e: BaseException) -> str:
    """An OSError in a few words (HDF5's messages carry a whole error stack)."""
    if getattr(e, "errno", None):
        return f"{errno.errorcode.get(e.errno, e.errno)}: {os.strerror(e.errno)}"
    text = str(e)
    for code in ("ENOSPC", "EDQUOT", "EFBIG", "EIO", "EROFS"):
        num = getattr(errno, code)
        if f"errno = {num}," in text or os.strerror(num) in text:
            return f"{code}: {os.strerror(num)}"
    return (text.splitlines() or [type(e).__name__])[0][:200]


def temporary_name(path: str) -> str:
    """The name a file is written under until it is whole (``replacing``)."""
    return path + ".partial"


HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
# what a temporary file left by a write cut short begins with, by the output's extension
# (``fresh_file``): a figure's own signature, HDF5's, the gallery record's first bytes
LEFTOVER_SIGNATURES = {".png": FIGURE_SIGNATURES[".png"], ".pdf": FIGURE_SIGNATURES[".pdf"],
                       ".svg": FIGURE_SIGNATURES[".svg"], ".h5": (HDF5_SIGNATURE,),
                       ".json": (b'{\n "figures"',)}


def leftover(path: str, signatures=None) -> bool:
    """Whether the regular file at ``path`` is what a write of ours cut short leaves: empty,
    or beginning as such a file does (``signatures``, default by the extension of the name
    without its last suffix: 'fig.png.partial' -> a PNG)."""
    if signatures is None:
        signatures = LEFTOVER_SIGNATURES.get(
            os.path.splitext(os.path.splitext(path)[0])[1].lower(), ())
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return False
    return not head or any(head.startswith(s[:16]) for s in signatures)


def fresh_file(path: str, signatures=None):
    """Create ``path`` empty for a writer that opens it by name.  A leftover of an earlier
    write cut short (``leftover``) is replaced; anything else at that name (a link, a
    directory, a device, a file of another kind: a user's) is refused, never written
    through nor removed."""
    if os.path.lexists(path):
        if os.path.islink(path) or not os.path.isfile(path) or not leftover(path, signatures):
            raise SweepError(f"{path}: is in the way of a file this command writes and removes "
                             "there (it is not one it left); remove it, or name another output")
        os.remove(path)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    os.close(fd)


def remove_quietly(path):
    """Remove ``path`` if it is there (a temporary of ours); an error is no one's concern."""
    try:
        os.remove(path)
    except OSError:
        pass


@contextlib.contextmanager
def replacing(path: str, kept: str = "the previous file, if any, is unchanged"):
    """``with replacing(path) as tmp:`` write the file at ``tmp``; it replaces ``path``
    only when the block ends without an error.  A failed write (a full disk, a file-size
    limit, an I/O error) raises ``WriteFailed`` naming ``path``, the reason and what was
    ``kept``; an interrupt or any other error removes the temporary file and propagates."""
    tmp = temporary_name(path)
    fresh_file(tmp)             # refused (SweepError) before anything is created or removed
    try:
        yield tmp
        with signals_deferred():
            os.replace(tmp, path)
    except OSError as e:
        remove_quietly(tmp)
        raise WriteFailed(f"writing {path} failed ({reason(e)}); {kept}") from None
    except BaseException:
        remove_quietly(tmp)
        raise


def write_text(path: str, text: str, kept: str = "the previous file, if any, is unchanged"):
    """Write a text file whole or not at all (``replacing``)."""
    with replacing(path, kept) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())


def save_figure(fig, path: str, **kw):
    """``fig.savefig(path)`` whole or not at all: a full disk or an interrupt never leaves an
    empty or truncated figure, nor removes the one drawn before."""
    fmt = os.path.splitext(path)[1].lower().lstrip(".") or "png"
    with replacing(path, "the previous figure, if any, is unchanged") as tmp:
        fig.savefig(tmp, format=fmt, **kw)


# ------------------------------------------------------------------ signals
class Terminated(KeyboardInterrupt):
    """SIGTERM, taken as an interrupt: every command keeps what it finished."""


def _terminate(signum, frame):
    raise Terminated()


def install_signal_handlers():
    """SIGTERM interrupts as Ctrl-C does (a command keeps what it finished and exits 130);
    past a file-size limit (``ulimit -f``) a write fails with EFBIG and the command stops
    with a message, instead of the process being killed by SIGXFSZ.  Returns what it
    replaced, for ``restore_signal_handlers``."""
    if threading.current_thread() is not threading.main_thread():
        return
    old = {signal.SIGTERM: signal.signal(signal.SIGTERM, _terminate)}
    if hasattr(signal, "SIGXFSZ"):
        old[signal.SIGXFSZ] = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return old


def restore_signal_handlers(old):
    """Put back what ``install_signal_handlers`` replaced (a command run inside another
    program leaves its handlers as it found them)."""
    for sig, h in (old or {}).items():
        if h is not None:
            signal.signal(sig, h)


_DEFERRED = threading.local()


@contextlib.contextmanager
def signals_deferred():
    """Run a critical section (an atomic rename, the removal of a finished output's partial
    file) with SIGINT and SIGTERM recorded instead of raised; a signal that came is raised at
    the end of the outermost such section, so an interrupt lands before or after it, never
    inside.  Nested sections are one section: the message of an interrupt then says what
    the whole of it did."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    depth = getattr(_DEFERRED, "depth", 0)
    if depth:
        _DEFERRED.depth = depth + 1
        try:
            yield
        finally:
            _DEFERRED.depth = depth
        return
    got = []
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old[sig] = signal.getsignal(sig)
        if old[sig] not in (signal.SIG_IGN, None):
            signal.signal(sig, lambda s, f: got.append(s))
    _DEFERRED.depth = 1
    try:
        yield
    finally:
        _DEFERRED.depth = 0
        for sig, h in old.items():
            if h not in (signal.SIG_IGN, None):
                signal.signal(sig, h)
    if got:
        if got[0] == signal.SIGTERM:
            raise Terminated()
        raise KeyboardInterrupt()


_LATE = threading.local()


def note_late_interrupt():
    """An interrupt that came once an output was whole (during its final rename): the
    command that wrote it ends as done, and a command that runs several (``gallery``) asks
    ``take_late_interrupt`` after each and stops there."""
    _LATE.pending = True


def take_late_interrupt() -> bool:
    """Whether an interrupt came once an output was whole since the last call (and forget it)."""
    pending = getattr(_LATE, "pending", False)
    _LATE.pending = False
    return pending


# ------------------------------------------------------------------ one writer per output
def check_unlocked(out_path: str, what: str = "cornerbif command"):
    """Refuse (``SweepError``) when another process holds ``out_path``'s lock: its files
    are being written, so nothing about them can be judged yet."""
    try:
        fd = os.open(out_path + ".lock", os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return                            # no lock file (or a link, refused when locking)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        raise SweepError(f"{out_path}: another {what} is writing this output (lock "
                         f"{out_path}.lock is held); wait for it to end") from None
    finally:
        os.close(fd)


@contextlib.contextmanager
def output_lock(out_path: str, what: str = "cornerbif command"):
    """Hold ``OUT.lock`` while a command writes ``out_path``: a second writer is refused at
    once (``SweepError``).  The lock file is opened without following a link and without
    truncating (a link planted at its name is refused, never written through), and removed
    while still held; a lock taken on a file that was removed meanwhile (its holder ended
    between our open and our lock) is taken again on the file now at the name."""
    lock_path = out_path + ".lock"
    for _ in range(8):
        try:
            fd = os.open(lock_path, os.O_WRONLY | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC
                         | os.O_NONBLOCK, 0o644)      # (a FIFO there: ENXIO, never a wait)
        except OSError as e:
            if e.errno == errno.ELOOP:
                raise SweepError(f"{lock_path}: is a symbolic link; a cornerbif lock is a plain "
                                 "file (remove the link)") from None
            if e.errno in SPACE_ERRNOS:
                raise WriteFailed(f"creating the lock {lock_path} failed ({reason(e)}); nothing "
                                  "was computed; free space and run the same command again"
                                  ) from None
            raise SweepError(f"{lock_path}: cannot be created ({reason(e)}); nothing was "
                             "computed") from None
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size:
            os.close(fd)                # a user's file at the lock's name: never removed
            raise SweepError(f"{lock_path}: is in the way and is not a cornerbif lock (an empty "
                             "file); remove it, or name another output")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise SweepError(f"{out_path}: another {what} is writing this output (lock "
                             f"{lock_path} is held); wait for it to end") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock_path, follow_symlinks=False).st_ino
        except OSError:
            same = False
        if same:
            break
        os.close(fd)
    else:
        raise SweepError(f"{out_path}: its lock {lock_path} keeps changing hands; run again")
    try:
        yield
    finally:
        try:
            os.remove(lock_path)        # while held: a newcomer finds no lock, or its own
        except OSError:
            pass
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


# a default output file name: its first 100 characters, made safe
DEFAULT_NAME_MAX = 100


def default_output(scene) -> str:
    """The default output ``NAME.h5`` for a scene, in the working directory: the last path
    component of ``scene.name``, other characters than letters, digits, '.', '_' and '-'
    replaced by '_', no leading dot, at most 100 characters (a name such as ``../x`` or
    ``/etc/x`` cannot place the file elsewhere)."""
    base = os.path.basename(scene.name.replace("\\", "/").rstrip("/"))
    base = re.sub(r"[^A-Za-z0-9._-]", "_", base).lstrip(".")[:DEFAULT_NAME_MAX]
    return (base or "scene") + ".h5"
