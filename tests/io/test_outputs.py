"""mocapkit.io.outputs.removed_on_failure: a failed multi-file write leaves none of the files it created."""

import pytest

from mocapkit.io import atomic_write
from mocapkit.io.outputs import removed_on_failure


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
    assert old.read_text() == "replaced"  # existed before: never deleted
    assert not new.exists() and not never.exists()


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
