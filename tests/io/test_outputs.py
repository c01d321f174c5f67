"""Output folders: checked before work, staged, moved in whole, never writing through links."""

import os
import shutil
from pathlib import Path

import pytest

from inkarm.errors import InputError
from inkarm.io.outputs import atomic_file, check_out_dir, check_out_file, staged


def test_an_empty_out_is_refused():
    with pytest.raises(InputError, match=r"^--out: expected a folder name") as info:
        check_out_dir("")
    assert info.value.key == "--out"


def test_a_file_as_out_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"exists and is not a directory"):
        check_out_dir(tmp_path / "f")


def test_checking_creates_nothing(tmp_path):
    check_out_dir(tmp_path / "a" / "b")
    assert list(tmp_path.iterdir()) == []


def test_an_input_inside_out_that_would_be_overwritten_is_refused(tmp_path):
    (tmp_path / "reference.csv").write_text("t,x,y\n")
    with pytest.raises(InputError, match=r"holds the input .*reference.csv"):
        check_out_dir(tmp_path, inputs=[tmp_path / "reference.csv"], names=["reference.csv"])
    check_out_dir(tmp_path, inputs=[tmp_path / "mine.csv"], names=["reference.csv"])


def test_files_arrive_together_and_stale_owned_ones_go(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.json").write_text("old")
    (out / "notes.txt").write_text("the user's")
    with staged(out, marker="status.json", owned=("metrics.json", "status.json")) as stage:
        (stage / "status.json").write_text("new")
        (stage / "canvas.png").write_bytes(b"png")
        assert not (out / "canvas.png").exists()  # nothing visible before the end
    assert sorted(p.name for p in out.iterdir()) == ["canvas.png", "notes.txt", "status.json"]
    assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())


def test_a_failure_leaves_out_untouched(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "status.json").write_text("good run")
    with pytest.raises(OSError), staged(out, marker="status.json", owned=("status.json",)) as st:
        (st / "canvas.png").write_bytes(b"half")
        raise OSError("No space left on device")
    assert (out / "status.json").read_text() == "good run"
    assert [p.name for p in out.iterdir()] == ["status.json"]
    assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())


def test_a_planted_symlink_is_replaced_not_followed(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    os.symlink(victim, out / "canvas.png")
    with staged(out) as stage:
        (stage / "canvas.png").write_bytes(b"png")
    assert victim.read_text() == "precious"
    assert not (out / "canvas.png").is_symlink()
    assert (out / "canvas.png").read_bytes() == b"png"


def test_atomic_file_renames_a_complete_file_and_keeps_the_old_one_on_failure(tmp_path):

    out = tmp_path / "model.npz"
    with atomic_file(out) as partial:
        assert partial.parent == tmp_path and partial.suffix == ".npz"  # np.savez adds none
        assert partial.name.startswith(".") and not out.exists()
        partial.write_text("first")
    assert out.read_text() == "first"
    with pytest.raises(RuntimeError), atomic_file(out) as partial:
        partial.write_text("half")
        raise RuntimeError("disk full")
    assert out.read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.npz"]


@pytest.mark.parametrize("name, message", [
    ("", "expected a file name, got an empty string"),
    ("{tmp}", "is a folder: expected a model file name (.npz)"),
    ("{tmp}/m.txt", "m.txt: expected a model file name (.npz)"),
    ("{tmp}/no/m.npz", "no is not a writable folder"),
    ("{tmp}/data.npz", "is the input"),
])
def test_an_out_file_is_checked_before_any_work(tmp_path, name, message):
    (tmp_path / "data.npz").write_bytes(b"")
    with pytest.raises(InputError) as err:
        check_out_file(name.format(tmp=tmp_path), "model", (".npz",),
                       inputs=["letter:a", tmp_path / "data.npz"])
    assert message in str(err.value) and err.value.key == "--out"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.npz"]  # nothing created
    assert check_out_file(tmp_path / "M.NPZ", "model", (".npz",)) == tmp_path / "M.NPZ"


def _other_file_system(tmp_path: Path) -> Path:
    """A fresh folder on another file system than ``tmp_path`` (/dev/shm is a tmpfs on Linux),
    or a skip where there is none."""
    shm = Path("/dev/shm")
    if not shm.is_dir() or not os.access(shm, os.W_OK) or \
            shm.stat().st_dev == tmp_path.stat().st_dev:
        pytest.skip("no second file system (/dev/shm) to write to")
    import tempfile
    return Path(tempfile.mkdtemp(prefix="inkarm-test-", dir=shm))


@pytest.fixture
def elsewhere(tmp_path):
    folder = _other_file_system(tmp_path)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def test_out_linked_to_another_file_system_gets_its_files(tmp_path, elsewhere):
    """--out a link to a folder on another file system (as a mount point is): the staging
    folder is made there, so every rename stays on one file system (no 'Invalid cross-device
    link'), and an earlier run's marker survives a failure."""
    out = tmp_path / "out"
    os.symlink(elsewhere, out)
    (elsewhere / "status.json").write_text("earlier run")
    with pytest.raises(RuntimeError), staged(out, marker="status.json",
                                             owned=("status.json",)) as stage:
        (stage / "status.json").write_text("half")
        raise RuntimeError("the run failed")
    assert (elsewhere / "status.json").read_text() == "earlier run"
    with staged(out, marker="status.json", owned=("status.json", "metrics.json")) as stage:
        (stage / "status.json").write_text("new")
        (stage / "canvas.png").write_bytes(b"png")
    assert sorted(p.name for p in elsewhere.iterdir()) == ["canvas.png", "status.json"]
    assert (elsewhere / "status.json").read_text() == "new"
    assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())


def test_a_new_out_under_a_link_to_another_file_system(tmp_path, elsewhere):
    os.symlink(elsewhere, tmp_path / "mnt")
    with staged(tmp_path / "mnt" / "run") as stage:
        (stage / "canvas.png").write_bytes(b"png")
    assert (elsewhere / "run" / "canvas.png").read_bytes() == b"png"
    assert sorted(p.name for p in elsewhere.iterdir()) == ["run"]


def test_a_rename_that_crosses_file_systems_is_copied_then_renamed(tmp_path, monkeypatch):
    """The fallback for a target that is itself a mount point: every rename onto it fails
    with EXDEV, so the file is copied (whole) onto it and nothing hidden is left behind."""
    import errno

    from inkarm.io import outputs

    real = os.replace
    target = tmp_path / "model.npz"
    target.write_bytes(b"old")

    def replace(src, dst):
        if Path(dst) == target:
            raise OSError(errno.EXDEV, "Invalid cross-device link")
        return real(src, dst)

    monkeypatch.setattr(outputs.os, "replace", replace)
    with atomic_file(target) as partial:
        partial.write_bytes(b"new model")
    assert target.read_bytes() == b"new model"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.npz"]


def test_other_rename_errors_are_not_hidden(tmp_path, monkeypatch):
    import errno

    from inkarm.io import outputs

    def replace(src, dst):
        raise OSError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(outputs.os, "replace", replace)
    with pytest.raises(PermissionError), atomic_file(tmp_path / "a.json") as partial:
        partial.write_text("{}")
    assert list(tmp_path.iterdir()) == []


def test_an_atomic_file_gets_the_usual_mode_not_mkstemps_private_one(tmp_path):
    mask = os.umask(0o022)
    try:
        with atomic_file(tmp_path / "job.gcode") as partial:
            partial.write_text("G0 X0\n")
    finally:
        os.umask(mask)
    assert (tmp_path / "job.gcode").stat().st_mode & 0o777 == 0o644


@pytest.mark.parametrize("make", [
    lambda d: os.symlink(d / "loop", d / "loop") or d / "loop",
    lambda d: (os.symlink(d / "b", d / "a"), os.symlink(d / "a", d / "b")) and d / "a" / "run",
    lambda d: os.symlink(d / "gone", d / "dangling") or d / "dangling" / "run",
])
def test_an_out_through_a_link_loop_or_a_dangling_link_is_refused(tmp_path, make):
    out = make(tmp_path)
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(InputError, match="a link that leads nowhere or in a loop"):
        check_out_dir(out)
    assert sorted(os.listdir(tmp_path)) == before
