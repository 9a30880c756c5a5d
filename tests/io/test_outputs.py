"""mocapkit.io.outputs: a failed multi-file write leaves the files as they were; a file written meanwhile is never replaced."""

import os

import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io import atomic_write
from mocapkit.io.outputs import check_outputs, removed_on_failure


def test_created_files_are_removed_and_earlier_files_kept(tmp_path):
    old, new, never = tmp_path / "old.txt", tmp_path / "deep" / "new.txt", tmp_path / "never.txt"
    old.write_text("before")
    with pytest.raises(RuntimeError):
        with removed_on_failure([old, new, never, None]):
            with atomic_write(old) as fh:
                fh.write("replaced")
            with atomic_write(new) as fh:
                fh.write("new")
            raise RuntimeError("the third file failed")
    assert old.read_text() == "before"  # existed before: its old contents are back
    assert not new.exists() and not never.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.txt"]  # no hidden copy, nor the folder made for new.txt


def test_interrupts_clean_up_too_and_success_keeps_everything(tmp_path):
    a = tmp_path / "a.txt"
    with pytest.raises(KeyboardInterrupt):
        with removed_on_failure([a]):
            a.write_text("x")
            raise KeyboardInterrupt
    assert not a.exists()
    with removed_on_failure([a]):
        a.write_text("y")
    assert a.read_text() == "y"


def test_the_marker_is_gone_while_its_set_is_replaced_and_comes_back_on_failure(tmp_path):
    out, record = tmp_path / "take.bvh", tmp_path / "take.clean.npz"
    out.write_text("old take")
    record.write_text("old record")
    with pytest.raises(KeyboardInterrupt):
        with removed_on_failure([out, record], overwrite=True, marker=record):
            assert not record.exists()  # a run killed outright now leaves no old record beside a new take
            with atomic_write(out) as fh:
                fh.write("new take")
            raise KeyboardInterrupt
    assert (out.read_text(), record.read_text()) == ("old take", "old record")
    with removed_on_failure([out, record], overwrite=True, marker=record):
        with atomic_write(out) as fh:
            fh.write("new take")
        with atomic_write(record) as fh:
            fh.write("new record")
    assert (out.read_text(), record.read_text()) == ("new take", "new record")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take.bvh", "take.clean.npz"]


def test_a_file_written_meanwhile_is_never_replaced_nor_removed(tmp_path):
    out = tmp_path / "out.npz"
    out.write_text("another program's")  # appeared after the check, before the block
    with pytest.raises(MocapFormatError, match="appeared while this command ran"):
        with removed_on_failure([out], overwrite=False):
            pass
    out.unlink()
    with pytest.raises(MocapFormatError, match="out.npz: appeared while this command ran"):
        with removed_on_failure([out], overwrite=False):
            out.write_text("another program's")  # appears while the output is being written
            with atomic_write(out) as fh:
                fh.write("ours")
    assert out.read_text() == "another program's"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.npz"]


def test_a_nested_block_s_files_are_removed_when_the_outer_one_fails(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    with pytest.raises(RuntimeError):
        with removed_on_failure([a, b], overwrite=False):
            with removed_on_failure([a], overwrite=False):
                with atomic_write(a) as fh:
                    fh.write("a")
            raise RuntimeError("b failed")
    assert not a.exists() and not b.exists()


def test_a_dangling_link_is_an_existing_output(tmp_path):
    link = tmp_path / "take.npz"
    os.symlink(tmp_path / "nowhere" / "take.npz", link)
    with pytest.raises(MocapFormatError, match="already exists"):
        check_outputs([link])
    check_outputs([link], overwrite=True)


def test_folders_made_for_a_failed_output_are_removed_too(tmp_path):
    out = tmp_path / "new" / "deeper" / "take.bvh"
    with pytest.raises(KeyboardInterrupt):
        with removed_on_failure([out], overwrite=False):
            with atomic_write(out) as fh:
                fh.write("x")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_overwrite_replaces_a_linked_output_and_puts_the_link_back_on_failure(tmp_path):
    target = tmp_path / "elsewhere.bvh"
    target.write_text("the link's target")
    out = tmp_path / "out.bvh"
    os.symlink(target, out)
    with pytest.raises(KeyboardInterrupt):
        with removed_on_failure([out], overwrite=True):
            with atomic_write(out) as fh:
                fh.write("new")
            raise KeyboardInterrupt
    assert out.is_symlink() and os.readlink(out) == str(target) and target.read_text() == "the link's target"
    with removed_on_failure([out], overwrite=True):  # --overwrite replaces the link itself, as before
        with atomic_write(out) as fh:
            fh.write("new")
    assert not out.is_symlink() and out.read_text() == "new" and target.read_text() == "the link's target"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere.bvh", "out.bvh"]


def test_with_overwrite_a_file_written_meanwhile_is_replaced(tmp_path):
    out = tmp_path / "out.npz"
    with removed_on_failure([out], overwrite=True):
        out.write_text("another program's")
        with atomic_write(out) as fh:
            fh.write("ours")
    assert out.read_text() == "ours"


def test_two_outputs_that_are_one_file_are_refused(tmp_path):
    """Two spellings of one path (``..``, a symlinked folder) are one output: the second would replace the first."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "sub", target_is_directory=True)
    a = tmp_path / "sub" / "take.bvh"
    for b in (tmp_path / "sub" / ".." / "sub" / "take.bvh", tmp_path / "alias" / "take.bvh"):
        with pytest.raises(MocapFormatError, match="given as two outputs"):
            check_outputs([a, b])
    check_outputs([a, tmp_path / "sub" / "take.html"])  # two files: fine


def test_an_output_that_is_a_hard_link_of_an_input_is_refused_even_with_overwrite(tmp_path):
    inp = tmp_path / "in.bvh"
    inp.write_text("the take")
    out = tmp_path / "out.bvh"
    os.link(inp, out)
    for overwrite in (False, True):
        with pytest.raises(MocapFormatError, match="refusing to write over an input"):
            check_outputs([out], [inp], overwrite=overwrite)


@pytest.mark.parametrize("failure", [KeyboardInterrupt, OSError])
def test_a_failure_before_an_old_output_is_replaced_leaves_no_hidden_link(tmp_path, failure):
    # the old file is kept aside as a hard link; putting back an output never replaced is a rename onto
    # the same file, which leaves both names: the link must still go
    out, report = tmp_path / "out.bvh", tmp_path / "out.html"
    out.write_text("old take")
    report.write_text("old report")
    with pytest.raises(failure):
        with removed_on_failure([out, report], overwrite=True):
            with atomic_write(report) as fh:
                fh.write("new report")
            raise failure(28, "No space left on device") if failure is OSError else failure()
    assert (out.read_text(), report.read_text()) == ("old take", "old report")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bvh", "out.html"]
    assert os.stat(out).st_nlink == 1


def test_another_user_s_file_in_a_sticky_folder_is_kept_aside_as_a_copy(tmp_path, monkeypatch):
    # a hard link to another user's file in a sticky folder could not be removed again (EPERM): a copy of
    # our own is kept aside instead, and goes when the replacement is refused
    from mocapkit.io import outputs

    out = tmp_path / "x.bvh"
    out.write_text("theirs")
    tmp_path.chmod(0o1777)
    monkeypatch.setattr(outputs.os, "geteuid", lambda: os.stat(out).st_uid + 1)  # we are someone else
    kept = outputs.keep_aside([out])
    assert os.stat(kept[out]).st_ino != os.stat(out).st_ino  # a copy, not a second name
    monkeypatch.setattr(outputs.os, "replace", lambda a, b: (_ for _ in ()).throw(PermissionError(1, "not permitted")))
    outputs.put_back([out], kept)
    outputs.drop_kept(kept)
    monkeypatch.undo()
    assert out.read_text() == "theirs"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bvh"]


def test_an_output_named_as_a_missing_input_is_refused_as_missing(tmp_path):
    """``clean ghost.c3d -o ghost.c3d`` with no ghost.c3d: the missing input is the problem, not a collision."""
    ghost = tmp_path / "ghost.c3d"
    with pytest.raises(MocapFormatError) as err:
        check_outputs([ghost], [ghost])
    assert str(err.value) == f"{ghost}: no such file"
    ghost.write_bytes(b"")
    with pytest.raises(MocapFormatError, match="refusing to write over an input"):
        check_outputs([ghost], [ghost])


def test_an_existing_output_is_refused_in_the_callers_words(tmp_path):
    """Called from Python, the refusal names the keyword (``overwrite=True``), not the command line's flag; the CLI's
    guard says ``--overwrite``."""
    out = tmp_path / "out.bvh"
    out.write_text("someone's file")
    with pytest.raises(MocapFormatError, match=r"out\.bvh: already exists; pass overwrite=True to replace it") as exc:
        check_outputs([out], [tmp_path / "in.bvh"])
    assert "--" not in str(exc.value)
    with pytest.raises(MocapFormatError, match=r"already exists; pass --overwrite to replace it"):
        check_outputs([out], [tmp_path / "in.bvh"], how="pass --overwrite")


def test_a_python_output_path_ending_with_a_separator_is_refused_by_every_writer(tmp_path):
    """``mocapkit.save(m, "out/x.bvh/")`` named a folder; before 0.15.0 it, ``save_markers`` and the
    ``mocapkit.io`` writers (which do not go through the commands' output guard) wrote ``out/x.bvh``. Each now
    refuses it in one MocapFormatError line naming the path as given (:func:`check_file_path`), writing nothing."""
    from pathlib import Path

    import mocapkit
    from mocapkit.io.amc_writer import write_amc
    from mocapkit.io.bvh import write_bvh
    from mocapkit.io.npz import write_npz
    from mocapkit.io.trc import write_trc

    data = Path(mocapkit.__file__).parent / "data"
    m = mocapkit.load(data / "12_walk.amc", asf=data / "12.asf")
    markers = mocapkit.io.load_markers(Path(__file__).parents[1] / "data" / "85_02.c3d")
    out = tmp_path / "o"
    calls = [lambda p: mocapkit.save(m, p + ".bvh/"), lambda p: mocapkit.save(m, p + ".amc/"),
             lambda p: mocapkit.save(m, p + ".npz/"), lambda p: mocapkit.save(markers, p + ".trc/"),
             lambda p: mocapkit.io.save_markers(markers, p + ".c3d/"), lambda p: write_bvh(m, p + ".bvh/"),
             lambda p: write_amc(m, p + ".amc/"), lambda p: write_npz(m, p + ".npz/"),
             lambda p: write_trc(markers, p + ".trc/")]
    for k, call in enumerate(calls):
        given = f"{out}/x{k}"
        with pytest.raises(MocapFormatError, match="ends with a path separator") as exc:
            call(given)
        assert str(exc.value).startswith(f"{given}.") and "\n" not in str(exc.value)
    with pytest.raises(MocapFormatError, match="ends with a path separator"):
        with atomic_write(f"{out}/y.txt/") as fh:
            fh.write("x")
    assert not out.exists()


def test_an_output_name_of_up_to_255_bytes_is_written_and_replaced(tmp_path):
    """The hidden temporary beside an output (``.NAME.RANDOM.part``, 15 bytes longer than NAME) made every name
    of 241-255 bytes fail with 'File name too long', after the work was done; now it is cut to fit NAME_MAX.
    A replaced file's set-aside copy (keep_aside), a C3D's staging folder and a batch's sweep name it alike, and
    an error still names the output whole."""
    import errno

    from mocapkit.batch_folder import sweep
    from mocapkit.errors import os_error_line
    from mocapkit.io.outputs import drop_kept, keep_aside, named_as_given, temp_prefix

    for name in ("b" * 251 + ".bvh", "\u00e9" * 125 + ".bvh"):  # 255 bytes; 254, two bytes a character
        out = tmp_path / name
        with atomic_write(out) as fh:
            fh.write("first")
        kept = keep_aside([out])
        with atomic_write(out) as fh:
            fh.write("second")
        assert out.read_text() == "second" and len(os.fsencode(kept[out].name)) <= 255
        drop_kept(kept)
        left = tmp_path / (temp_prefix(name) + "abcdefgh.part")  # what a killed worker leaves
        left.write_text("")
        exc = OSError(errno.EROFS, "Read-only file system", str(left))
        named_as_given(exc, out)
        assert os_error_line(exc) == f"{out}: read-only file system"
        sweep([out])
        assert sorted(p.name for p in tmp_path.iterdir()) == [name]
        out.unlink()


def test_an_output_name_longer_than_255_bytes_is_refused_in_one_line_before_any_work(tmp_path):
    """A take of a 250-byte name is a legal file, but its record (stem + .clean.npz, 256 bytes) is not: the check let
    it through where its folder did not exist yet (the take was cleaned, then its write failed) and raised a bare
    OSError ('File name too long') where it did. Now both are refused, naming the output, as is a 'é' name of 256
    bytes (128 characters: bytes are what the file system counts)."""
    for folder in (tmp_path, tmp_path / "new"):
        for name in ("a" * 246 + ".clean.npz", "\u00e9" * 126 + ".npz"):
            with pytest.raises(MocapFormatError, match="its name is 256 bytes, more than the 255 a file name may hold"):
                check_outputs([tmp_path / "ok.bvh", folder / name], [])
    check_outputs([tmp_path / ("a" * 245 + ".clean.npz")], [])  # 255 bytes: fine
    assert sorted(p.name for p in tmp_path.iterdir()) == []
