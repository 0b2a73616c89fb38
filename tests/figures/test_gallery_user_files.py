"""`cornerbif gallery` never replaces a file it did not write without --overwrite, even one at a
name its record lists.

A figure listed in gallery_run.json that the user replaced with a PNG of their own, or a data
file the gallery wrote that the user edited in place, was once replaced by the next run
without a word: the record listed paths, not what was written there. The record now keeps a
fingerprint of every file the gallery writes (``gallery.fingerprint``) and signs itself
(``gallery.record_digest``); a file that no longer matches is the user's, refused before any
work (exit 2, named, with what to do: --overwrite or move it). A record from before
fingerprints vouches for none of its figures, nor for itself; a data file the record does
not fingerprint is judged by its own root attributes, as before. A run stopped between
writing a file and recording it is continued by the same command, as before.

Every run here is ``--smoke --only fig07a`` (the theory's curves: one start of no length) on a
copy of the shipped scene in a temporary folder: a second or two each.
"""

import json
import os

import h5py
import pytest
from click.testing import CliRunner

from cornerbif import gallery
from cornerbif.cli import main
from cornerbif.errors import SweepInterrupted

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")


def setup(tmp_path):
    """A copy of the shipped fig07a in tmp_path/cfg; (its scene file, the CLI arguments of
    a smoke gallery of it into tmp_path/g and tmp_path/d, (out, data))."""
    cfg = tmp_path / "cfg"
    cfg.mkdir()
    scene = cfg / "fig07a.toml"
    scene.write_text(open(os.path.join(CONFIGS, "fig07a.toml")).read())
    out, data = tmp_path / "g", tmp_path / "d"
    args = ["--configs", cfg, "--out", out, "--data", data, "--smoke", "--only", "fig07a"]
    return scene, args, (out, data)


def gallery_cli(*args):
    return CliRunner().invoke(main, ["gallery", *map(str, args)])


def ran(args, *extra):
    r = gallery_cli(*args, *extra)
    assert r.exit_code == 0, r.output
    return r.output


def snapshot(*folders):
    """Every file under the folders: path -> bytes (what a refusal must not change)."""
    got = {}
    for f in folders:
        for dirpath, _, names in os.walk(f):
            for n in names:
                with open(os.path.join(dirpath, n), "rb") as fh:
                    got[os.path.join(dirpath, n)] = fh.read()
    return got


def record(out):
    return json.loads((out / "gallery_run.json").read_text())


def assert_refused(args, folders, path, *needles):
    """The run refused before any work: exit 2, ``path`` named with each of ``needles`` and
    what to do (move it, or --overwrite), nothing written nor changed in ``folders``."""
    before = snapshot(*folders)
    r = gallery_cli(*args)
    assert r.exit_code == 2, r.output
    assert f"{path}: " in r.output and "Traceback" not in r.output, r.output
    for n in needles + ("move it away", "pass --overwrite"):
        assert n in r.output, (n, r.output)
    assert snapshot(*folders) == before
    return r.output


def assert_recorded(out, data):
    """The record is signed and fingerprints the figure and the data file as they are."""
    rec = record(out)
    assert rec["digest"] == gallery.record_digest(rec) and "writing" not in rec
    assert rec["files"]["fig07a.png"] == gallery.fingerprint(str(out / "fig07a.png"))
    assert rec["files"][os.path.relpath(data / "fig07a.h5", out)] == gallery.fingerprint(
        str(data / "fig07a.h5"), h5=True)


def _own_png(path):
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(2, 2))
    fig.text(0.5, 0.5, "mine")
    fig.savefig(str(path) + ".new", format="png")
    plt.close(fig)
    os.replace(str(path) + ".new", path)


def _edited_in_place(path):
    """One byte in the middle changed, the size kept (a PNG still, by its first bytes)."""
    with open(path, "r+b") as fh:
        fh.seek(os.path.getsize(path) // 2)
        b = fh.read(1)
        fh.seek(-1, os.SEEK_CUR)
        fh.write(bytes([b[0] ^ 0xFF]))


@pytest.mark.parametrize("change", [_own_png, _edited_in_place], ids=["own PNG", "same size"])
def test_a_figure_the_user_replaced_is_refused_before_any_work(tmp_path, change):
    """A figure the record lists, replaced by the user (their own PNG, or the same size with
    one byte changed): refused (exit 2, named: changed since the gallery drew it; move it or
    --overwrite), nothing written; --overwrite draws it again, the record fingerprints the
    new figure, and the next run needs no --overwrite."""
    _, args, (out, data) = setup(tmp_path)
    ran(args)
    assert_recorded(out, data)
    png = out / "fig07a.png"
    change(png)
    mine = png.read_bytes()
    assert_refused(args, (out, data), png, "changed since the gallery drew it")
    assert png.read_bytes() == mine
    ran(args, "--overwrite")
    assert png.read_bytes() != mine
    assert_recorded(out, data)
    ran(args)


@pytest.mark.slow
def test_a_data_file_the_user_edited_is_refused_when_stale(tmp_path):
    """A data file the gallery wrote, edited in place (h5py "r+": its root attributes, so
    its command, kept): once its scene changes, refused (exit 2, named, nothing written);
    --overwrite sweeps it again. The gallery's own stale file, unedited, is replaced without
    --overwrite, as before; and so is a file the gallery made again (under another --out:
    other root attributes than the one fingerprinted), judged by its attributes."""
    scene, args, (out, data) = setup(tmp_path)
    ran(args)
    h5 = data / "fig07a.h5"
    with h5py.File(h5, "r+") as f:
        f["status"][...] = 3
    assert gallery.made_by(str(h5)) == "smoke"
    assert "fig07a: reused" in ran(args)       # the same scene: reused, whoever made it
    scene.write_text(scene.read_text().replace("transient = 0", "transient = 1"))
    assert_refused(args, (out, data), h5, "changed since the gallery wrote it")
    assert "fig07a: swept" in ran(args, "--overwrite")
    assert_recorded(out, data)
    scene.write_text(scene.read_text().replace("transient = 1", "transient = 2"))
    assert "fig07a: swept" in ran(args)
    assert_recorded(out, data)
    other = list(args)
    other[other.index("--out") + 1] = tmp_path / "g2"
    scene.write_text(scene.read_text().replace("transient = 2", "transient = 3"))
    assert "fig07a: swept" in ran(other)       # no fingerprint in g2: by its attributes
    scene.write_text(scene.read_text().replace("transient = 3", "transient = 4"))
    assert "fig07a: swept" in ran(args)        # made again since g's fingerprint


@pytest.mark.slow
def test_a_record_from_before_fingerprints_vouches_for_no_figure(tmp_path):
    """A record written before fingerprints (no ``files``, no ``digest``): the gallery cannot
    tell its figures, nor the record itself, from the user's: refused (exit 2, each named,
    saying so); one run with --overwrite gives the folder a signed record fingerprinting
    what it drew, and the next needs no --overwrite. Its data files are judged by their
    attributes, as before: a stale one of the gallery's is swept again without asking."""
    scene, args, (out, data) = setup(tmp_path)
    ran(args)
    rec = record(out)
    for k in ("files", "digest"):
        del rec[k]
    (out / "gallery_run.json").write_text(json.dumps(rec, indent=1))
    said = assert_refused(args, (out, data), out / "fig07a.png", "without a fingerprint",
                          f"{out / 'gallery_run.json'}: written before the gallery signed")
    assert "for each of these 2 files" in said
    scene.write_text(scene.read_text().replace("transient = 0", "transient = 1"))
    assert str(data / "fig07a.h5") not in gallery_cli(*args).output
    assert "fig07a: swept" in ran(args, "--overwrite")
    assert_recorded(out, data)
    ran(args)


@pytest.mark.slow
def test_a_record_edited_by_hand_is_the_users(tmp_path):
    """gallery_run.json edited by hand (a note added: still a gallery record by its
    structure) no longer matches its digest: refused (exit 2, named); --overwrite replaces
    it with a signed record."""
    _, args, (out, data) = setup(tmp_path)
    ran(args)
    rec = record(out)
    rec["note"] = "mine"
    (out / "gallery_run.json").write_text(json.dumps(rec, indent=1))
    assert_refused(args, (out, data), out / "gallery_run.json", "changed since the gallery wrote")
    ran(args, "--overwrite")
    assert "note" not in record(out)
    assert_recorded(out, data)


@pytest.mark.slow
def test_a_run_stopped_before_it_recorded_a_figure_is_continued(tmp_path, monkeypatch):
    """A run stopped after it replaced a figure but before the record says so (an interrupt
    as the record is written): the record it left lists the figure among the files it was
    writing (``writing``), so the same command again redraws it without --overwrite, though
    the figure is no longer the one fingerprinted; the record then fingerprints it."""
    _, args, (out, data) = setup(tmp_path)
    ran(args)
    scene = tmp_path / "cfg" / "fig07a.toml"
    scene.write_text(scene.read_text().replace("xlim = [1.99, 2.01]", "xlim = [1.99, 2.02]"))
    real, calls = gallery._write_record, []

    def stop_at_the_second(*a, **kw):           # the first: before the figure; the second: after
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*a, **kw)
    with monkeypatch.context() as m:
        m.setattr(gallery, "_write_record", stop_at_the_second)
        with pytest.raises(SweepInterrupted):
            gallery.run(str(tmp_path / "cfg"), str(out), str(data), only=("fig07a",), smoke=True,
                        echo=lambda *a: None)
    rec = record(out)
    assert rec["writing"] == ["fig07a.png"] and rec["digest"] == gallery.record_digest(rec)
    assert rec["files"]["fig07a.png"] != gallery.fingerprint(str(out / "fig07a.png"))
    ran(args)
    assert_recorded(out, data)


CRAFTED = {
    "files a list": {"files": []},
    "a fingerprint without its hash": {"files": {"fig07a.png": {"size": 3}}},
    "a negative size": {"files": {"fig07a.png": {"size": -1, "sha256": "0" * 64}}},
    "writing a string": {"writing": "fig07a.png"},
    "digest a number": {"digest": 5},
}


@pytest.mark.parametrize("case", sorted(CRAFTED))
def test_a_record_with_crafted_fingerprints_is_refused_in_the_plan(tmp_path, case):
    """Nothing in a record is trusted: fingerprint fields of another structure make it no
    gallery record (exit 2, named, nothing swept), with --overwrite too."""
    _, args, (out, data) = setup(tmp_path)
    out.mkdir()
    text = json.dumps({"figures": [], **CRAFTED[case]})
    (out / "gallery_run.json").write_text(text)
    for extra in ([], ["--overwrite"]):
        r = gallery_cli(*args, *extra)
        assert r.exit_code == 2, r.output
        assert f"{out / 'gallery_run.json'}: exists and is not a gallery record" in r.output
        assert "Traceback" not in r.output and not data.exists()
        assert (out / "gallery_run.json").read_text() == text
