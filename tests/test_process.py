"""Owners of what a process leaves behind (search trials, staging folders), and when they are gone."""

import os
import socket
import subprocess
import sys
import time

from sindybench._process import owner, owner_is_gone


def test_owner_is_gone():
    me = owner()
    assert not owner_is_gone(**me)
    # the same host and PID with another token, or none: a restarted container's predecessor
    assert owner_is_gone(me["host"], me["pid"], "another token") and owner_is_gone(me["host"], me["pid"])
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    assert owner_is_gone(me["host"], int(dead.stdout))
    assert not owner_is_gone("another-host", int(dead.stdout))  # only this host's processes can be judged
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        assert not owner_is_gone(me["host"], child.pid)
        assert not owner_is_gone(me["host"], child.pid, since=time.time())
        # the PID now runs a process that started after the owner made its thing: a reused PID
        if os.path.exists(f"/proc/{child.pid}/stat"):
            assert owner_is_gone(me["host"], child.pid, since=time.time() - 600)
            assert not owner_is_gone(me["host"], child.pid, since=time.time() - 600, margin=3600)
    finally:
        child.kill()
        child.wait()
    assert me["host"] == socket.gethostname()
