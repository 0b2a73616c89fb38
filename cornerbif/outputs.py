"""The one guard of every file a command writes, and how it is written (issue 28).

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
import json
import os
import signal
import threading

from .errors import SweepError, WriteFailed

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


def _hdf5_format(path):
    """The root attribute ``format`` of an HDF5 file, or None (not HDF5, unreadable)."""
    try:
        import h5py
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
        return _hdf5_format(path) == "cornerbif"
    if kind == "continuation":
        return _hdf5_format(path) == "cornerbif-continuation"
    if kind == "figure":
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
        try:
            with open(path, "rb") as fh:
                if os.fstat(fh.fileno()).st_size > 64 * 2**20:
                    return False
                doc = json.loads(fh.read().decode("utf-8"))
            return isinstance(doc, dict) and "figures" in doc
        except (OSError, ValueError, UnicodeDecodeError):
            return False
    raise ValueError(kind)


def is_cornerbif_file(path: str) -> bool:
    """Whether ``path`` is an HDF5 file that ``cornerbif sweep`` wrote."""
    return is_kind(path, "sweep")


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


def _named(inputs):
    """(description, path) of each input: a bare path is 'the input <path>'; a pair
    (description, path) keeps its description (e.g. 'the scene file')."""
    for item in inputs:
        if isinstance(item, tuple):
            yield item
        elif item:
            yield f"the input {item}", item


# ------------------------------------------------------------------ whole or not at all
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


def _remove(path):
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
    try:
        yield tmp
        with signals_deferred():
            os.replace(tmp, path)
    except OSError as e:
        _remove(tmp)
        raise WriteFailed(f"writing {path} failed ({reason(e)}); {kept}") from None
    except BaseException:
        _remove(tmp)
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
    with a message, instead of the process being killed by SIGXFSZ."""
    if threading.current_thread() is not threading.main_thread():
        return
    signal.signal(signal.SIGTERM, _terminate)
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        pass                     # started in the background with SIGINT ignored: keep it so
    if hasattr(signal, "SIGXFSZ"):
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


@contextlib.contextmanager
def signals_deferred():
    """Run a critical section (an atomic rename, a stamp that must not be cut in HDF5) with
    SIGINT and SIGTERM recorded instead of raised; a signal that came is raised at its end,
    so an interrupt lands before or after the section, never inside it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old[sig] = signal.getsignal(sig)
        if old[sig] not in (signal.SIG_IGN, None):
            signal.signal(sig, lambda s, f: got.append(s))
    try:
        yield
    finally:
        for sig, h in old.items():
            if h not in (signal.SIG_IGN, None):
                signal.signal(sig, h)
    if got:
        if got[0] == signal.SIGTERM:
            raise Terminated()
        raise KeyboardInterrupt()
