"""`cornerbif continue` as safe as `cornerbif sweep`: the output guard, the lock, what is
done with an existing output and partial file (as `sweep.plan_output` decides), incremental
writing (each branch and curve in the partial file as soon as it is finished), --resume
bitwise equal to an uninterrupted run after SIGKILL, SIGINT, SIGTERM, a real full disk and a
file-size limit, an interrupt during the seed search, admissibility always checked, why every
branch stopped, and every hostile [continue] value refused before any work
(docs/continuation.md).

The faults run a shipped scene with several branches and curves, shrunk in its steps so
that a run takes a few seconds: configs/cont_hysteresis.toml (three attractors at
omega = 2.001, alpha, beta and alpha beta gamma, each ending at a corner collision whose
curve in omega is continued too: 3 branches and 3 curves, 7 commits of the partial file).
"""

import errno
import fcntl
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import time
import tracemalloc

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FILL_DISK_SOURCE

from cornerbif import config, theory
from cornerbif import continuation as C
from cornerbif import continuation_run as CR
from cornerbif.analysis import MAX_WORD_LETTERS, MAX_WORD_TEXT, parse_word
from cornerbif.cli import main
from cornerbif.errors import SweepInterrupted, WriteFailed
from cornerbif.models.flow import orbit as FO

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HYST = os.path.join(ROOT, "configs", "cont_hysteresis.toml")
BETA = os.path.join(ROOT, "configs", "cont_beta.toml")
FOLD = os.path.join(ROOT, "configs", "cont_fold.toml")
FIG19 = os.path.join(ROOT, "configs", "cont_fig19.toml")
FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")
SETS = ["--set", "continue.ds=1e-5", "--set", "continue.ds_max=1e-4"]
SMALL_SWEEP = ["--set", "sweep.kappa.num=3", "--set", "initial.count=2",
               "--set", "run.transient=10", "--set", "run.record=10", "--no-progress"]


def cont(out, *extra, scene=HYST, sets=SETS, **kw):
    """`cornerbif continue` in a process of its own (signals, limits, a kill)."""
    return subprocess.run([sys.executable, "-m", "cornerbif.cli", "continue", scene, "-o",
                           str(out), *sets, *extra], capture_output=True, text=True,
                          timeout=600, **kw)


def popen(out, *extra, scene=HYST, sets=SETS):
    """`cornerbif continue` running in a process of its own, SIGINT as a terminal's (a child
    of a shell without job control starts with SIGINT ignored)."""
    return subprocess.Popen([sys.executable, "-m", "cornerbif.cli", "continue", scene, "-o",
                             str(out), *sets, *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run: (its file, its wall time)."""
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    t = time.perf_counter()
    r = cont(out)
    assert r.returncode == 0, r.stderr
    return out, time.perf_counter() - t


def datasets(f):
    out = []
    f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return sorted(out)


UNCOMPARED = ("created", "completed", "command")


def assert_same(a, b):
    """Every dataset byte for byte, and every attribute but the times and the command line
    (which names the output)."""
    with h5py.File(a) as f, h5py.File(b) as g:
        assert datasets(f) == datasets(g)
        for n in datasets(f):
            x, y = f[n][...], g[n][...]
            assert x.dtype == y.dtype and x.shape == y.shape, n
            if x.dtype.kind == "O":
                assert list(x) == list(y), n
            else:
                assert x.tobytes() == y.tobytes(), n
        for obj in ["/"] + [f"branches/{k}" for k in f["branches"]]:
            ka = {k: str(v) for k, v in f[obj].attrs.items() if k not in UNCOMPARED}
            kb = {k: str(v) for k, v in g[obj].attrs.items() if k not in UNCOMPARED}
            assert ka == kb, obj


def one_clear_message(r, code):
    assert r.returncode == code, (r.returncode, r.stderr[-3000:])
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
    lines = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert len(lines) == 1, r.stderr
    return lines[0]


def kept_branches(partial):
    """The partial file opens whole (never empty, never cut) and every branch in it is
    complete: its points all admissible, its datasets of one length."""
    assert os.path.getsize(partial) > 0
    c = CR.read(partial)
    for b in c["branches"]:
        assert b["admissible"].all() and len(b["param"]) == len(b["stable"]) > 0
    return len(c["branches"]), len(c["curves"])


def wait_for(path, proc, timeout=120):
    """Wait until ``path`` exists while ``proc`` runs (``timeout``: a hang guard)."""
    deadline = time.time() + timeout
    while not os.path.exists(path):
        assert proc.poll() is None, f"the run ended before {path} was written"
        assert time.time() < deadline
        time.sleep(0.005)


# ------------------------------------------------------------------ the output guard and the lock
@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    """A small finished sweep of Fig. 6(a) (kappa at omega = 1.999: cont_beta's system)."""
    out = tmp_path_factory.mktemp("sweep") / "s.h5"
    r = CliRunner().invoke(main, ["sweep", FIG06A, "-o", str(out), *SMALL_SWEEP])
    assert r.exit_code == 0, r.output
    return out


def test_the_output_is_never_an_input_nor_a_foreign_file(tmp_path, sweep_file):
    """`-o my.toml --overwrite` (the scene file), `-o notes.txt --overwrite` (a text file),
    `seed_file = s.h5 -o s.h5 --overwrite` (its own input sweep), a sweep file with
    --overwrite or --resume, and a scene file named as the output's lock: each is refused
    before any work (exit 2, the input named) and every file is left byte for byte as it
    was (the lock is never taken on an input, so never removed)."""
    scene = tmp_path / "my.toml"
    shutil.copy(BETA, scene)
    text = tmp_path / "notes.txt"
    text.write_text("my notes\n")
    seeds = tmp_path / "seeds.h5"
    shutil.copy(sweep_file, seeds)
    lock_scene = tmp_path / "o.h5.lock"
    shutil.copy(BETA, lock_scene)
    before = {p: p.read_bytes() for p in (scene, text, seeds, lock_scene)}
    run = CliRunner()
    cases = [([str(scene), "-o", str(scene), "--overwrite"], "the scene file itself"),
             ([str(lock_scene), "-o", str(tmp_path / "o.h5")], "is the scene file"),
             ([str(scene), "-o", str(text), "--overwrite"], "not a cornerbif HDF5 file"),
             ([str(scene), "-o", str(seeds), "--overwrite", "--set",
               f'continue.seed_file="{seeds}"'], "continue.seed_file itself"),
             ([str(scene), "-o", str(seeds), "--overwrite"], "(a continuation)"),
             ([str(scene), "-o", str(seeds), "--resume"], "(a continuation)")]
    for args, needle in cases:
        r = run.invoke(main, ["continue", *args])
        assert r.exit_code == 2 and needle in r.output, (args, r.output)
        assert "Traceback" not in r.output
    for p, data in before.items():
        assert p.read_bytes() == data, p
    assert not list(tmp_path.glob("*.partial"))
    assert [p.name for p in tmp_path.glob("*.lock")] == ["o.h5.lock"]


@pytest.mark.slow
def test_a_second_writer_is_refused_at_once(tmp_path, reference, monkeypatch):
    """Two commands never write one output: the lock OUT.lock is held (as by a running
    `continue` or `sweep`), so a second `continue` is refused at once, exit 2, before
    anything is said (no compile announced) and before any file is judged: --resume on a
    finished output of the same scene is refused too, not called complete (the holder may
    be replacing it)."""
    from cornerbif import engine
    announced = []
    monkeypatch.setattr(engine, "announce_compiles", lambda *a, **k: announced.append(a))
    out = tmp_path / "c.h5"
    done = tmp_path / "done.h5"
    shutil.copy(reference[0], done)
    for target, extra in ((out, []), (done, [*SETS, "--resume"])):
        with open(str(target) + ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            r = CliRunner().invoke(main, ["continue", HYST, "-o", str(target), *extra])
        assert r.exit_code == 2, r.output
        assert "another cornerbif command is writing this output" in r.output
        assert "complete" not in r.output and not announced
    assert not out.exists() and not os.path.exists(str(out) + ".partial")
    assert done.read_bytes() == open(reference[0], "rb").read()


def test_a_link_at_the_lock_is_refused_and_never_written_through(tmp_path):
    """OUT.lock is a symbolic link to a user's file: refused (exit 2, the link named), the
    file it points to unchanged and still there (the lock is opened without following a
    link, without truncating, and only a lock file of our own is ever removed)."""
    out = tmp_path / "c.h5"
    mine = tmp_path / "mine.txt"
    mine.write_text("my notes\n")
    os.symlink(mine, str(out) + ".lock")
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), "--set", "run.transient=300"])
    assert r.exit_code == 2 and "is a symbolic link" in r.output, r.output
    assert mine.read_text() == "my notes\n" and os.path.islink(str(out) + ".lock")
    assert not out.exists() and not os.path.exists(str(out) + ".partial")


def test_nothing_is_announced_before_the_output_guard(tmp_path, monkeypatch):
    """A refused output is refused before anything is said: no compile is announced for a
    run that will not start (here a text file in the output's place, and a partial file
    waiting without --resume); a run that starts announces them (the guard passed)."""
    from cornerbif import engine
    announced = []
    monkeypatch.setattr(engine, "announce_compiles", lambda *a, **k: announced.append(a))
    text = tmp_path / "t.h5"
    text.write_text("mine\n")
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(text), "--overwrite"])
    assert r.exit_code == 2 and "not a cornerbif HDF5 file" in r.output and not announced
    out = tmp_path / "c.h5"
    args = ["continue", BETA, "-o", str(out), "--set", "run.transient=300"]
    shutil.copy(text, str(out) + ".partial")
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "is in the way" in r.output and not announced
    os.remove(str(out) + ".partial")
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0 and len(announced) == 1, r.output


# ------------------------------------------------------------------ faults: kills, signals, full disks
def _commits(partial):
    """What tells one rewrite of the partial file from the next (each is a new file renamed
    into place)."""
    try:
        st = os.stat(partial)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


@pytest.mark.slow
@pytest.mark.parametrize("commits", [1, 4])
def test_sigkill_mid_run_then_resume_is_bitwise_equal(tmp_path, reference, commits):
    """SIGKILL (by process id) once the partial file has been rewritten ``commits`` times (of
    the 7 of this run: 3 branches, 3 curves, the finished file), after a seeded random
    delay within the next unit (0-0.3 s: in its computation or its write): the kill lands
    mid-run (asserted: no output yet, a partial file there); that file opens whole with
    complete branches (each rewrite goes to a temporary name, renamed), and --resume
    completes the output to the same bytes as the uninterrupted run."""
    ref, _ = reference
    out = tmp_path / "k.h5"
    partial = str(out) + ".partial"
    p = popen(out)
    try:
        seen, last = 0, None
        deadline = time.time() + 120            # a hang guard only
        while seen < commits:
            now = _commits(partial)
            if now is not None and now != last:
                seen, last = seen + 1, now
            assert p.poll() is None and time.time() < deadline, (seen, p.poll())
            time.sleep(0.002)
        time.sleep(random.Random(28 + commits).uniform(0.0, 0.3))
        os.kill(p.pid, signal.SIGKILL)
    finally:
        p.kill()
        p.communicate()
    assert not out.exists() and os.path.exists(partial)
    assert kept_branches(partial)[0] >= 1
    r = cont(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert not os.path.exists(partial) and not os.path.exists(partial + ".partial")
    assert_same(ref, out)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_during_the_seed_search_exits_130_at_once(tmp_path, sig):
    """At omega = 1e9 the starts' runs that find the seeds take minutes (139 s were measured
    before their kernel ran under a stop flag, the interrupt waiting for it).  SIGINT or
    SIGTERM sent while they run (the output's lock taken, then 1 s) ends the command with
    exit 130 and one line saying the seeds were being found and nothing was kept, no
    traceback, no file left (the 60 s timeout is a hang guard only)."""
    out = tmp_path / "s.h5"
    p = popen(out, scene=BETA, sets=["--set", "system.omega=1e9"])
    try:
        wait_for(str(out) + ".lock", p)
        time.sleep(1.0)
        assert p.poll() is None
        p.send_signal(sig)
        stdout, stderr = p.communicate(timeout=60)
    finally:
        p.kill()
        p.communicate()
    r = subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr)
    msg = one_clear_message(r, 130)
    assert "interrupted while the seeds were found; nothing was kept" in msg, msg
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_keeps_every_finished_branch_and_resume_completes(tmp_path, reference,
                                                                     sig):
    """Seen: an interrupt lost every branch ("Aborted!", exit 1).  Now SIGINT and SIGTERM
    end the run with exit 130 and one message saying how many branches were kept in which
    file and that --resume completes it; the console showed each branch as it finished;
    --resume completes the file bitwise equal to the uninterrupted run."""
    out = tmp_path / "i.h5"
    partial = str(out) + ".partial"
    p = popen(out)
    wait_for(partial, p)
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=120)
    r = subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr)
    msg = one_clear_message(r, 130)
    nb, nc = kept_branches(partial)
    assert "interrupted" in msg and f"kept in {partial}" in msg and "--resume" in msg
    assert f"the {nb} finished branch" in msg
    assert "branch 0: a over kappa" in stdout and "stopped at kappa" in stdout
    r = cont(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert f"resuming {partial}: {nb} finished branch" in r.stdout
    assert_same(reference[0], out)


# run with conftest.fill_disk defined before it (FILL_DISK_SOURCE)
FILL_AFTER = """
import sys
from cornerbif import continuation as C
from cornerbif import continuation_run as CR
from cornerbif.models.flow import orbit as FO
real = CR._write_bytes
n = [0]
def fill_then_write(path, image, kept):
    n[0] += 1
    if n[0] == {at}:            # another process takes the rest of the disk
        fill_disk({filler!r})
    real(path, image, kept)
CR._write_bytes = fill_then_write
from cornerbif.cli import main
sys.argv = ["cornerbif", "continue", {scene!r}, "-o", {out!r}] + {sets!r}
main()
"""


@pytest.mark.slow
def test_a_real_full_disk_keeps_the_finished_branches_and_resumes_bitwise(tmpfs, reference):
    """A real small filesystem, filled by another file while the run goes on: the write of
    the third unit fails (ENOSPC); the command says so in one line (exit 1) naming the two
    branches kept, the partial file is whole (never the 0-byte file seen before), and
    --resume, once there is room, completes it bitwise.  Filled before the first write:
    nothing is kept and no file is left at all."""
    mnt = tmpfs("4M")
    for at, kept in ((3, 2), (1, 0)):
        out, filler = mnt / f"d{at}.h5", mnt / "filler"
        code = FILL_DISK_SOURCE + FILL_AFTER.format(at=at, filler=str(filler), scene=HYST,
                                                    out=str(out), sets=SETS)
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=600)
        msg = one_clear_message(r, 1)
        assert "ENOSPC" in msg, msg
        assert not out.exists() and not os.path.exists(str(out) + ".partial.partial")
        if kept:
            assert kept_branches(str(out) + ".partial") == (kept, 0)
            assert f"the {kept} finished branches are kept" in msg and "--resume" in msg
        else:
            assert not os.path.exists(str(out) + ".partial")
            assert "nothing was kept" in msg
        os.remove(filler)
        r = cont(out, "--resume")
        assert r.returncode == 0, r.stderr
        assert_same(reference[0], out)


@pytest.mark.slow
def test_a_file_size_limit_keeps_the_finished_branches_and_resumes_bitwise(tmp_path, reference):
    """`ulimit -f` (RLIMIT_FSIZE) at 3/4 of the finished file: the partial file grows
    branch by branch (50, 84, 129 kB here) until a write passes the limit (EFBIG; SIGXFSZ is
    ignored by the command); one message, exit 1, the partial file within the limit and
    whole; --resume without the limit completes it bitwise."""
    out = tmp_path / "f.h5"
    cap = int(0.75 * os.path.getsize(reference[0]))

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (cap, cap))

    r = cont(out, preexec_fn=limit)
    msg = one_clear_message(r, 1)
    assert "EFBIG" in msg and "--resume" in msg, msg
    partial = str(out) + ".partial"
    assert os.path.getsize(partial) <= cap
    assert kept_branches(partial)[0] >= 1
    r = cont(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same(reference[0], out)


# ------------------------------------------------------------------ resume, and an existing output
def _interrupted(tmp_path, name="p.h5", sets=SETS, at="branch 1:", command=""):
    """A partial file as an interrupt leaves it: the run stopped (KeyboardInterrupt from
    its console) once the unit whose line starts with ``at`` was written (a unit is said
    once it is on disk)."""
    out = tmp_path / name
    scene = config.load(HYST, [s for s in sets if s != "--set"])

    def log(msg):
        if msg.startswith(at):
            raise KeyboardInterrupt
    with pytest.raises(SweepInterrupted, match="--resume"):
        CR.run_to_file(scene, str(out), log=log, command=command)
    return out


@pytest.mark.slow
def test_resume_refuses_another_scene_naming_what_differs(tmp_path, reference):
    """--resume goes on only from the partial file of the same scene ([plot] aside, as
    `config.same_run`): a changed step is refused (exit 2) naming the key and both values;
    without --resume or --overwrite the partial file is never thrown away; a change to
    [plot] alone resumes, and the file is bitwise the uninterrupted run's."""
    out = _interrupted(tmp_path)
    partial = str(out) + ".partial"
    assert kept_branches(partial) == (2, 0)
    run = CliRunner()
    base = ["continue", HYST, "-o", str(out)]
    r = run.invoke(main, base + ["--resume", "--set", "continue.ds=2e-5", "--set",
                                 "continue.ds_max=1e-4"])
    assert r.exit_code == 2 and "another scene" in r.output, r.output
    assert "continue.ds: 1e-05 there, 2e-05 here" in r.output
    r = run.invoke(main, base + SETS)
    assert r.exit_code == 2 and "pass --resume to complete it" in r.output, r.output
    assert kept_branches(partial) == (2, 0)
    r = run.invoke(main, base + SETS + ["--resume", "--set", "plot.ylim=[0.0, 0.05]"])
    assert r.exit_code == 0, r.output
    assert "resuming" in r.output
    with h5py.File(reference[0]) as f, h5py.File(out) as g:      # the scene's [plot] aside
        assert datasets(f) == datasets(g)
        for n in datasets(f):
            x, y = f[n][...], g[n][...]
            assert (list(x) == list(y)) if x.dtype.kind == "O" else x.tobytes() == y.tobytes(), n


def test_resume_of_a_finished_output_says_it_is_complete(tmp_path, reference):
    """`--resume` on a finished output of the same scene: exit 0, "already complete", the
    file untouched; so a script may always pass --resume (an interrupted run of the same
    scene beside it is removed, and said: the output holds all of it).  Of another scene:
    refused, naming what differs."""
    out = _interrupted(tmp_path, name="done.h5")
    shutil.copy(reference[0], out)
    before = out.read_bytes()
    r = CliRunner().invoke(main, ["continue", HYST, "-o", str(out), *SETS, "--resume"])
    assert r.exit_code == 0 and "already complete" in r.output, r.output
    assert f"removed {out}.partial, an interrupted run of the same scene" in r.output
    assert out.read_bytes() == before and not os.path.exists(f"{out}.partial")
    r = CliRunner().invoke(main, ["continue", HYST, "-o", str(out), *SETS, "--resume"])
    assert r.exit_code == 0 and "already complete" in r.output and "removed" not in r.output
    assert out.read_bytes() == before
    r = CliRunner().invoke(main, ["continue", HYST, "-o", str(out), "--resume"])
    assert r.exit_code == 2 and "finished continuation of another scene" in r.output
    assert "continue.ds" in r.output and out.read_bytes() == before


@pytest.mark.slow
def test_run_to_file_as_the_gallery_calls_it(tmp_path, reference):
    """`continuation_run.run_to_file` with the gallery's flags: an interrupted run of its scene
    resumed (``resume``; bitwise), the file keeping the command it was started with; a
    finished one of the same scene left as it is (``resume``: None); one of another scene
    replaced (``overwrite``), with the command given."""
    scene = config.load(HYST, [s for s in SETS if s != "--set"])
    out = _interrupted(tmp_path, at="corner curve of branch 1", command="cornerbif continue mine")
    assert kept_branches(str(out) + ".partial") == (3, 2)
    quiet = []
    assert CR.run_to_file(scene, str(out), resume=True, log=quiet.append,
                         inputs=[("the scene file", HYST)], command="the gallery") == str(out)
    assert_same(reference[0], out)
    assert CR.read(out)["attrs"]["command"] == "cornerbif continue mine"
    before = out.read_bytes()
    assert CR.run_to_file(scene, str(out), resume=True, log=quiet.append) is None
    assert out.read_bytes() == before and "already complete" in quiet[-1]
    other = config.load(BETA, ["run.transient=300"])
    assert CR.run_to_file(other, str(out), overwrite=True, log=quiet.append,
                         command="the gallery") == str(out)
    assert CR.read(out)["scene"] == other.text and CR.read(out)["attrs"]["command"] == "the gallery"


def test_the_command_line_is_kept_in_the_file(tmp_path):
    """The file says which command made it (root attribute ``command``, as a sweep's file):
    the command line as run, its --set overrides quoted for a shell."""
    out = tmp_path / "c.h5"
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), "--set", "run.transient=300"])
    assert r.exit_code == 0, r.output
    assert CR.read(out)["attrs"]["command"] == (f"cornerbif continue {BETA} -o {out} --set "
                                               "run.transient=300")


def _finished_other(path):
    """A finished continuation of another scene than HYST's (cont_beta, shortened) put at
    ``path``."""
    other = path.parent / "other.h5"
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(other), "--set",
                                  "run.transient=300"])
    assert r.exit_code == 0, r.output
    os.replace(other, path)


@pytest.mark.slow
def test_a_partial_file_behind_another_scenes_finished_output(tmp_path, reference):
    """OUT is a finished continuation of scene A and OUT.partial an interrupted run of scene
    B.  `--resume` with B is refused (exit 2) advising `--resume --overwrite`, and nothing
    is touched (the partial file byte for byte: it was once refused with advice that then
    deleted it); `--resume --overwrite` resumes it (never starts again) and the output
    becomes bitwise the uninterrupted run of B, replacing A's."""
    out = _interrupted(tmp_path)
    partial = str(out) + ".partial"
    _finished_other(out)
    kept, finished = open(partial, "rb").read(), out.read_bytes()
    base = ["continue", HYST, "-o", str(out), *SETS]
    r = CliRunner().invoke(main, base + ["--resume"])
    assert r.exit_code == 2, r.output
    assert "finished continuation of another scene" in r.output
    assert "pass --resume --overwrite to complete it" in r.output
    assert open(partial, "rb").read() == kept and out.read_bytes() == finished
    r = CliRunner().invoke(main, base + ["--resume", "--overwrite"])
    assert r.exit_code == 0, r.output
    assert f"resuming {partial}: 2 finished branches before" in r.output
    assert_same(reference[0], out)


def test_another_scenes_partial_file_is_removed_only_by_overwrite(tmp_path):
    """An interrupted run of scene B in OUT.partial and a run of scene A: refused without
    a flag, with --resume and with --resume --overwrite (a resume completes only its own
    scene's partial file and never removes another's), each saying what differs, the file
    byte for byte as it was; only --overwrite (start again) replaces it."""
    out = _interrupted(tmp_path)
    partial = str(out) + ".partial"
    kept = open(partial, "rb").read()
    base = ["continue", BETA, "-o", str(out), "--set", "run.transient=300"]
    for flags in ([], ["--resume"], ["--resume", "--overwrite"]):
        r = CliRunner().invoke(main, base + flags)
        assert r.exit_code == 2, (flags, r.output)
        assert "interrupted continuation of another scene" in r.output, (flags, r.output)
        assert " there, " in r.output and " here" in r.output, r.output
        assert open(partial, "rb").read() == kept and not out.exists()
    r = CliRunner().invoke(main, base + ["--overwrite"])
    assert r.exit_code == 0, r.output
    assert not os.path.exists(partial) and CR.read(out)["parameter"] == "kappa"


def _sweep_copy(path, sweep_file):
    shutil.copy(sweep_file, path)


def _link_to_notes(path, _):
    notes = path.parent / "notes.txt"
    notes.write_text("my notes\n")
    os.symlink(notes, path)


IN_THE_PARTIALS_PLACE = {
    "a text file": lambda path, _: path.write_text("my notes\n"),
    "a sweep file": _sweep_copy,
    "a link to a text file": _link_to_notes,
    "a FIFO": lambda path, _: os.mkfifo(path),
    "a directory": lambda path, _: path.mkdir(),
}


@pytest.mark.parametrize("case", sorted(IN_THE_PARTIALS_PLACE))
def test_a_file_in_the_partial_files_place_that_is_not_a_continuations_is_never_removed(
        tmp_path, sweep_file, case):
    """Whatever the flags (none, --resume, --overwrite, both), a file at OUT.partial that is
    not a continuation's partial file (a text file, a sweep, a link, a FIFO, a directory)
    is refused (exit 2, named, "remove it yourself"), never removed, opened or written: its
    bytes, or what it is, unchanged."""
    out = tmp_path / "c.h5"
    partial = tmp_path / "c.h5.partial"
    IN_THE_PARTIALS_PLACE[case](partial, sweep_file)

    def state():
        if partial.is_symlink():
            return "link", os.readlink(partial), (tmp_path / "notes.txt").read_bytes()
        if partial.is_dir() or not partial.is_file():
            return partial.is_dir(), partial.exists()
        return partial.read_bytes()
    before = state()
    for flags in ([], ["--resume"], ["--overwrite"], ["--resume", "--overwrite"]):
        r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), *flags])
        assert r.exit_code == 2, (flags, r.output)
        assert f"{partial}: is in the way" in r.output and "remove it yourself" in r.output
        assert state() == before and not out.exists()


# ------------------------------------------------------------------ admissibility
def test_no_events_still_ends_the_beta_orbit_at_its_corner_collision(tmp_path):
    """Seen: with `events = []` the beta orbit ran on past its corner collision to the
    range's end (kappa = 0.002), every point stored as stable with its impact before the
    corner.  The ending kinds are always watched: the branch ends at kappa_C of eq (11)
    (to 1e-10), saying it was a corner collision that continue.events does not list, and
    every stored point passed the admissibility check, stored with it."""
    out = tmp_path / "e.h5"
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), "--set",
                                  "continue.events=[]", "--set", "run.transient=300"])
    assert r.exit_code == 0, r.output
    c = CR.read(out)
    (b,) = c["branches"]
    kc = theory.kappa_C(1.999, 0.8)
    assert abs(b["param"].max() - kc) < 1e-10
    assert b["admissible"].all() and (b["admissibility_margin"] >= -C.ADMISSIBLE_TOL).all()
    assert [e["kind"] for e in c["events"]] == ["end", "end"]
    assert "corner collision: impact 0 reaches its corner" in b["stops"][1]
    assert "continue.events does not list 'corner'" in r.output


def _beta_problem():
    a, v, _ = theory.single_impact_orbit(1.999, -0.02, 0.8, exact=True)
    import cornerbif
    res = cornerbif.simulate([a], [v], obstacle="rectified_sine", transient=100, record=60,
                             omega=1.999, kappa=-0.02, beta=1.0, r=0.8)
    return FO.seed_from_run(dict(omega=1.999, kappa=-0.02, beta=1.0, r=0.8), "rectified_sine",
                           "kappa", res["t"][0], res["v_out"][0], res["corner_offset"][0],
                           int(res["impacts_per_cycle"][0]))


def test_a_missed_sign_change_still_stops_at_the_last_admissible_point(monkeypatch):
    """Where no test function says so (a sign change through a pole, a non-finite value;
    here every event search is switched off), a point that is not an orbit of the flow is
    still never stored: the branch ends at its last admissible point, before kappa_C, and
    says why; every point returned passes `admissible` computed afresh."""
    prob, X = _beta_problem()
    monkeypatch.setattr(C, "_events_between", lambda *a, **k: False)
    pts, evs = C.continue_branch(prob, X, -0.02, (-0.02, 0.002), 1.0, ds=1e-4)
    assert pts[-1].lam < theory.kappa_C(1.999, 0.8)
    assert evs[-1].kind == "end" and "stops being one of the flow" in evs[-1].detail
    assert "beyond its corner" in evs[-1].detail
    for pt in pts:
        assert pt.admissible and C.admissible(pt.problem, pt.X, pt.lam)[0]


# ------------------------------------------------------------------ why a branch stopped
def test_every_branch_end_says_why_it_stopped(tmp_path, monkeypatch):
    """Seen: "end at -0.02199" where the step budget had run out.  The console and the file
    (branch attribute ``stops``) say why each end stopped: the range's end, a corner
    collision and whether the other side continues it, continue.switch = false; and, from
    `continue_branch`, the step budget, the step below ds_min (with the corrector's last
    failure) and a step that failed (the points before it kept)."""
    out = tmp_path / "b.h5"
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), "--set", "run.transient=300",
                                  "--set", "continue.switch=false"])
    assert r.exit_code == 0, r.output
    stops = list(CR.read(out)["branches"][0]["stops"])
    assert stops[0] == "kappa = -0.02: the end of the range"
    assert stops[1].startswith("kappa = -0.0141371698") and "a corner collision of impact 0" in stops[1]
    assert "not continued across it (continue.switch = false)" in stops[1]
    for s in stops:
        assert f"  stopped at {s}" in r.output
    prob, X = _beta_problem()
    _, evs = C.continue_branch(prob, X, -0.02, (-0.02, 0.002), 1.0, ds=1e-4, max_steps=3)
    assert "the step budget (3 steps) ran out" in CR.stop_reason(evs[-1], "kappa")
    def failing_once(name, nth):
        real, calls = getattr(C, name), [0]

        def failing(*a, **k):
            calls[0] += 1
            if calls[0] == nth:
                raise np.linalg.LinAlgError("SVD did not converge")
            return real(*a, **k)
        monkeypatch.setattr(C, name, failing)

    failing_once("_monitors", 6)
    pts, evs = C.continue_branch(prob, X, -0.02, (-0.02, 0.002), 1.0, ds=1e-4)
    # the 6th monitors are those of the 6th point (the first is the start's): the 5th point
    # is complete and kept, and the branch ends there
    assert len(pts) == 5 and evs[-1].lam == pts[-1].lam
    assert "the continuation failed after this point (SVD did not converge)" in evs[-1].detail
    monkeypatch.undo()
    failing_once("_tangent", 5)         # a tangent that fails once: the step is retried
    pts_t, evs_t = C.continue_branch(prob, X, -0.02, (-0.02, 0.002), 1.0, ds=1e-4)
    assert evs_t[-1].kind == "corner" and len(pts_t) > 5
    monkeypatch.undo()

    def no_corrector(*a, **k):
        raise C.OrbitError("the corrector did not converge")
    monkeypatch.setattr(C, "_correct", no_corrector)
    _, evs = C.continue_branch(prob, X, -0.02, (-0.02, 0.002), 1.0, ds=1e-4, ds_min=1e-6)
    assert ("the step fell below ds_min (1e-06; the last attempt: the corrector did not "
            "converge)") in evs[-1].detail


# ------------------------------------------------------------------ hostile values
HOSTILE = [
    ('continue.curve=["omega"]', "continue.curve: ['omega']"),
    ("continue.curve=3", "continue.curve: 3"),
    ('continue.curve="kappa"', "continue.curve: 'kappa'"),
    ('continue.curve="omega"', "continue.curve_range is missing: continue.curve = 'omega'"),
    ('continue.curve="omega"|continue.curve_range=[1.9, 2.1]|continue.events=["grazing"]',
     "lists neither, so no curve would be made"),
    ('continue.curve="omega"|continue.curve_range=[1.9, 2.1]|continue.events=[]',
     "lists neither, so no curve would be made"),
    ('continue.curve="omega"|continue.curve_range=[-inf, inf]', "continue.curve_range: [-inf, inf]"),
    ('continue.curve="omega"|continue.curve_range=[nan, 2.0]', "continue.curve_range: [nan, 2.0]"),
    ('continue.curve="omega"|continue.curve_range=[-1e308, 1e308]', "continue.curve_range"),
    ('continue.curve="omega"|continue.curve_range=[2.1, 2.2]', "must hold system.omega"),
    ('continue.curve="r"|continue.curve_range=[0.5, 7.0]', "continue.curve_range: 7.0"),
    ('continue.curve="omega"|continue.curve_range="wide"', "continue.curve_range: 'wide'"),
    ('continue.seed="x"', "x is the cluster of a smooth obstacle"),
    ('continue.seed="b^1000000000"', "more than 1000 letters"),
    ('continue.seed="b^100000000000"', "more than 1000 letters"),
    ('continue.seed="g b^100000000000000000000"', "more than 1000 letters"),
    ('continue.seed="b^1001"', "more than 1000 letters"),
    ("continue.seed=[]", "continue.seed: []"),
    ('continue.seed=["b", 1]', "continue.seed: ['b', 1]"),
    ('continue.seed="q"', "continue.seed: 'q'"),
    ("continue.range=[-inf, inf]", "continue.range: [-inf, inf]"),
    ("continue.range=[-1e308, 1e308]", "continue.range"),
    ("continue.range=[0.0, nan]", "continue.range: [0.0, nan]"),
    ('continue.range="all"', "continue.range: 'all'"),
    ("continue.start=inf", "continue.start: inf"),
    ("continue.start=nan", "continue.start: nan"),
    ('continue.start="0"', "continue.start: '0'"),
    ("continue.ds=-1.0", "continue.ds: -1.0"),
    ("continue.ds=nan", "continue.ds: nan"),
    ("continue.ds=inf", "continue.ds: inf"),
    ("continue.ds=1e300", "continue.ds"),
    ("continue.ds_min=0", "continue.ds_min: 0"),
    ("continue.ds_min=1e-300", "continue.ds_min: 1e-300"),
    ("continue.ds_max=1e300", "continue.ds_max: 1e+300"),
    ('continue.events="corner"', "continue.events: 'corner'"),
    ("continue.events=[1]", "continue.events: [1]"),
    ('continue.events=["fold", "fold"]', "each at most once"),
    ('continue.switch="yes"', "continue.switch: 'yes'"),
    ("continue.switch=1", "continue.switch: 1"),
    ("continue.seed_file=3", "continue.seed_file: 3"),
    ('continue.seed_file=""', "continue.seed_file: ''"),
    ('continue.seed_file="a\\u0000b"', "continue.seed_file: 'a\\x00b'"),
    ("continue.over=3", "continue.over: 3"),
    ('continue.over="a\\nb"', "continue.over: 'a\\nb'"),
    ('continue.parameter=["kappa"]', "continue.parameter: ['kappa']"),
    ("continue.parameter=1e300", "continue.parameter: 1e+300"),
]


@pytest.mark.parametrize("sets,needle", HOSTILE)
def test_hostile_continue_values_are_refused_by_validate_and_continue(tmp_path, sets, needle):
    """Seen: `curve = ["omega"]` (TypeError), `curve_range = [-inf, inf]` (a crash after the
    branch, which was lost), `seed = "x"` on the rectified sine (accepted, then a crash),
    seed counts of 1e9 to 1e20 (2 GB, OverflowError, MemoryError).  Every [continue] key
    with a value of the wrong type, non-finite, out of its parameter's bounds or too large
    is refused by `validate` and by `continue` before any work: exit 2, the key and the
    value named, no traceback, nothing written."""
    args = []
    for s in sets.split("|"):
        args += ["--set", s]
    run = CliRunner()
    r = run.invoke(main, ["validate", BETA, *args])
    assert r.exit_code == 2 and needle in r.output, r.output
    assert "Traceback" not in r.output and "internal error" not in r.output
    out = tmp_path / "c.h5"
    r = run.invoke(main, ["continue", BETA, "-o", str(out), *args])
    assert r.exit_code == 2 and needle in r.output, r.output
    assert not os.listdir(tmp_path)


def test_a_seed_word_is_bounded_without_being_expanded():
    """`parse_word` counts a word's letters from its repeat counts and refuses one past
    MAX_WORD_LETTERS (1000) before expanding it: counts of 1e9, 1e20 and a 5000-digit count
    are refused with under 1 MB allocated (validate took 2 GB for 1e9: the word expanded);
    1000 letters pass; a text past MAX_WORD_TEXT is refused by its length; `validate` says
    so (exit 2) allocating as little."""
    assert parse_word("b^999 g") == "b" * 999 + "g"
    for word in ("b^1000000000", "b^100000000000000000000", "b^" + "9" * 5000, "b^1000 g",
                 "b" * (MAX_WORD_LETTERS + 1), "b^0 " * (MAX_WORD_TEXT // 4 + 1)):
        tracemalloc.start()
        with pytest.raises(ValueError, match="letters|characters"):
            parse_word(word)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 2**20, (word[:20], peak)
    config.load(BETA)                  # the scene's own imports, before the count starts
    tracemalloc.start()
    r = CliRunner().invoke(main, ["validate", BETA, "--set", 'continue.seed="b^1000000000"'])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert r.exit_code == 2 and "more than 1000 letters" in r.output, r.output
    assert peak < 64 * 2**20, peak


def test_the_x_word_only_where_every_cluster_is_x():
    """`x` names a cluster of a smooth obstacle (the sine: every cluster is x); a word of
    x seeds there ("x", "x^2"), and only there: on the rectified sine, the maps and the two
    particles it is refused (their words are letters a, b, g), and on the sine a word of
    a, b, g is refused (it could never match)."""
    config.load(FOLD, ['continue.seed="x^2"'])
    config.load(FOLD, ['continue.seed=["x", "xx"]'])
    with pytest.raises(config.SceneError, match="on the smooth obstacle 'sine' every cluster"):
        config.load(FOLD, ['continue.seed="b"'])
    for scene in (BETA, FIG19):
        with pytest.raises(config.SceneError, match="x is the cluster of a smooth obstacle"):
            config.load(scene, ['continue.seed="x"'])
    assert CR._matches("xx", "x^2") and not CR._matches("x", "x^2")


SEED_SWEEP = """[scene]
name = "s"
model = "flow"
[system]
obstacle = "rectified_sine"
omega = 1.999
kappa = -0.02
beta = 1.0
r = 0.8
[sweep]
{sweep}
[initial]
count = 2
u = [0.0, 20.0]
v = [-0.02, 0.02]
[run]
transient = 10
record = 10
"""


def test_seed_files_that_cannot_seed_are_refused_before_any_work(tmp_path, sweep_file):
    """`continue.seed_file` naming a directory, a missing file, a text file, /dev/zero, a
    pipe (never opened: it would block), a continuation file, a sweep of another
    parameter, a sweep over two parameters, or a sweep whose grid point nearest the start
    is not done: each refused before any work, exit 2, naming the key and the path; the
    output is not written."""
    run = CliRunner()
    bad = {}
    bad["a directory"] = (tmp_path, "is a directory")
    bad["missing"] = (tmp_path / "none.h5", "cannot be read")
    (tmp_path / "t.txt").write_text("not a sweep\n")
    bad["text"] = (tmp_path / "t.txt", "not an HDF5 file")
    bad["dev zero"] = ("/dev/zero", "is not a regular file")
    os.mkfifo(tmp_path / "fifo")
    bad["fifo"] = (tmp_path / "fifo", "is not a regular file")
    c = tmp_path / "c.h5"
    assert run.invoke(main, ["continue", BETA, "-o", str(c), "--set",
                             "run.transient=300"]).exit_code == 0
    bad["continuation"] = (c, "is a continuation file")
    for name, sweep, needle in (("omega", 'omega = { start = 1.998, stop = 1.999, num = 2 }',
                                 "sweeps 'omega', not 'kappa' alone"),
                                ("two", "kappa = { start = -0.02, stop = -0.01, num = 2 }\n"
                                        "omega = { start = 1.998, stop = 1.999, num = 2 }",
                                 "sweeps 'kappa', 'omega', not 'kappa' alone")):
        scene = tmp_path / f"{name}.toml"
        scene.write_text(SEED_SWEEP.format(sweep=sweep))
        h5 = tmp_path / f"{name}.h5"
        r = run.invoke(main, ["sweep", str(scene), "-o", str(h5), "--no-progress"])
        assert r.exit_code == 0, r.output
        bad[name] = (h5, needle)
    undone = tmp_path / "undone.h5"
    shutil.copy(sweep_file, undone)
    with h5py.File(undone, "r+") as f:
        f["done"][0] = 0
    bad["not done"] = (undone, "is not done")
    for name, (path, needle) in bad.items():
        out = tmp_path / "o.h5"
        r = run.invoke(main, ["continue", BETA, "-o", str(out), "--set",
                              f'continue.seed_file="{path}"'])
        assert r.exit_code == 2, (name, r.output)
        assert "continue.seed_file" in r.output and str(path) in r.output, (name, r.output)
        assert needle in r.output, (name, r.output)
        assert "Traceback" not in r.output and not out.exists(), name
        assert not os.path.exists(str(out) + ".partial")


def test_the_partial_file_is_rewritten_once_per_finished_unit(tmp_path):
    """The partial file is rewritten whole once per finished unit and once when finished,
    never more (an HDF5 image made in memory, written under a temporary name, renamed):
    on the shrunk hysteresis scene 3 branches and 3 curves, so 7 writes, each holding one
    unit more than the one before (branches first, then curves), the last the finished
    file (no resume state, a completion time)."""
    scene = config.load(HYST, [s for s in SETS if s != "--set"])
    written = []
    real = CR._write_bytes

    def counted(path, image, kept):
        real(path, image, kept)
        written.append(CR._load(path))
    CR._write_bytes = counted
    try:
        CR.run_to_file(scene, str(tmp_path / "t.h5"), log=lambda m: None)
    finally:
        CR._write_bytes = real
    units = [(len(b), len(c)) for _, b, c, _ in written]
    assert units == [(1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (3, 3), (3, 3)]
    assert all(state is not None for *_, state in written[:-1])
    attrs, *_, state = written[-1]
    assert state is None and attrs["completed"]


def test_write_failure_is_reported_by_errno(tmp_path, monkeypatch):
    """A write that fails (here ENOSPC raised by the file's write) ends the run with
    WriteFailed naming the reason, the branches kept and --resume."""
    scene = config.load(HYST, [s for s in SETS if s != "--set"])
    real = CR._write_bytes
    n = [0]

    def failing(path, image, kept):
        n[0] += 1
        if n[0] == 2:
            from cornerbif import outputs
            with outputs.replacing(path, kept):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(path, image, kept)
    monkeypatch.setattr(CR, "_write_bytes", failing)
    with pytest.raises(WriteFailed, match="ENOSPC.*the 1 finished branch is kept in .*--resume"):
        CR.run_to_file(scene, str(tmp_path / "w.h5"), log=lambda m: None)
    assert kept_branches(str(tmp_path / "w.h5.partial")) == (1, 0)


def test_a_link_at_the_partial_files_temporary_name_is_refused_before_any_work(tmp_path):
    """OUT.partial.partial (where each rewrite of the partial file is made) is a link to a
    user's file: refused before any work (exit 2, named), the file it points to unchanged
    (never written through), nothing else written."""
    out = tmp_path / "c.h5"
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    os.symlink(notes, str(out) + ".partial.partial")
    r = CliRunner().invoke(main, ["continue", BETA, "-o", str(out), "--set", "run.transient=300"])
    assert r.exit_code == 2 and f"{out}.partial.partial: is in the way" in r.output, r.output
    assert notes.read_text() == "my notes\n" and sorted(os.listdir(tmp_path)) == [
        "c.h5.partial.partial", "notes.txt"]
