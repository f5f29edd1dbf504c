"""addon/console.stdout_silenced: descriptor 1 on /dev/null while any silence lasts, from any
thread, and back where it was after the last."""
import contextlib
import os
import threading

import pytest

from snell.addon.console import stdout_silenced

pytestmark = pytest.mark.skipif(os.name != "posix", reason="file descriptors")


def same_file(fd, path):
    a, b = os.fstat(fd), os.stat(path)
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


@contextlib.contextmanager
def fd1_on_file(tmp_path):
    """Descriptor 1 on a file of the test's for the duration (pytest's capture restored).
    Not a fixture: pytest puts its own capture back on descriptor 1 before the test's body."""
    path = tmp_path / "stdout.txt"
    saved = os.dup(1)
    f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(f, 1)
    os.close(f)
    try:
        yield str(path)
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def test_nested_silences_restore_stdout(tmp_path):
    with fd1_on_file(tmp_path) as path:
        with stdout_silenced():
            with stdout_silenced():
                os.write(1, b"hidden\n")
            assert same_file(1, os.devnull)
            os.write(1, b"hidden\n")
        os.write(1, b"shown\n")
        assert same_file(1, path)
    with open(path) as f:
        assert f.read() == "shown\n"


def test_overlapping_silences_from_two_threads(tmp_path):
    """A enters, B enters, A leaves, B leaves: /dev/null until B leaves, then the file again
    (saving and restoring per call left descriptor 1 on /dev/null for good)."""
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def a():
        with stdout_silenced():
            a_in.set()
            b_in.wait(10)
        a_out.set()

    def b():
        a_in.wait(10)
        with stdout_silenced():
            b_in.set()
            a_out.wait(10)
            seen["between"] = same_file(1, os.devnull)

    with fd1_on_file(tmp_path) as path:
        threads = [threading.Thread(target=a), threading.Thread(target=b)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(20)
        assert seen["between"]             # A's leaving did not end B's silence
        assert same_file(1, path)          # B's leaving restored the file
