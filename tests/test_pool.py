"""catadioptric._pool.imap_spawn: every result, a worker's error raised in the caller, and no
worker left running when the caller is killed (SIGTERM) or stops early."""
import os
import signal
import subprocess
import sys
import time

import pytest

from catadioptric._pool import imap_spawn


def _square(x):
    return x * x


def _fail_on_three(x):
    if x == 3:
        raise ValueError(f"task {x} failed")
    return x


def test_every_result_comes_back():
    assert sorted(imap_spawn(_square, range(7), 2)) == [x * x for x in range(7)]
    assert list(imap_spawn(_square, [], 2)) == []


def test_a_workers_error_is_raised_in_the_caller():
    with pytest.raises(ValueError, match="task 3 failed"):
        list(imap_spawn(_fail_on_three, range(6), 2))


def _write_pid_then_sleep(path):
    with open(path, "w") as f:
        f.write(str(os.getpid()))
    if path.endswith("slow.pid"):
        time.sleep(120)
    return path


def test_a_caller_that_stops_early_ends_the_workers(tmp_path):
    paths = [str(tmp_path / "fast.pid"), str(tmp_path / "slow.pid")]
    results = imap_spawn(_write_pid_then_sleep, paths, 2)
    assert next(results) == paths[0]
    deadline = time.monotonic() + 60
    while not (os.path.exists(paths[1]) and open(paths[1]).read()):
        assert time.monotonic() < deadline, "the slow task did not start"
        time.sleep(0.1)
    pid = int(open(paths[1]).read())
    assert _alive(pid)
    results.close()  # the caller stops: the pool is terminated, the sleeping worker with it
    assert not _alive(pid)


_SCRIPT = """
import os, sys, time
sys.path.insert(0, {root!r})
from catadioptric._pool import imap_spawn

def sleeper(path):
    with open(path, "w") as f:
        f.write(str(os.getpid()))
    time.sleep(120)
    return path

if __name__ == "__main__":
    paths = [os.path.join({tmp!r}, f"w{{i}}.pid") for i in range(2)]
    for _ in imap_spawn(sleeper, paths, 2):
        pass
"""


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie waiting for its parent counts as gone
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_to_the_caller_ends_its_workers(tmp_path):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    script = tmp_path / "run.py"
    script.write_text(_SCRIPT.format(root=root, tmp=str(tmp_path)))
    proc = subprocess.Popen([sys.executable, str(script)])
    pidfiles = [tmp_path / f"w{i}.pid" for i in range(2)]
    deadline = time.monotonic() + 60
    while not all(p.exists() and p.read_text() for p in pidfiles):
        assert time.monotonic() < deadline and proc.poll() is None, "the workers did not start"
        time.sleep(0.1)
    pids = [int(p.read_text()) for p in pidfiles]
    assert all(_alive(p) for p in pids)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 128 + signal.SIGTERM  # SystemExit raised by the handler
    deadline = time.monotonic() + 30
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(p) for p in pids), f"workers {pids} still running after the caller was killed"
