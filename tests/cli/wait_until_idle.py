#!/usr/bin/env python3
"""For golden cases that signal a tool reading a pipe: waits until the pipe the case writes into
(descriptor FD of the caller, inherited) holds nothing and the tool (PID) sleeps waiting for
more, twice 50 ms apart, so that everything written was read whatever the machine's load.
Gives up after 60 s (the case then fails on its output, not here).

usage: wait_until_idle.py PID FD
"""
import array
import fcntl
import sys
import termios
import time


def idle(pid: str, fd: int) -> bool:
    pending = array.array("i", [0])
    fcntl.ioctl(fd, termios.FIONREAD, pending)
    with open(f"/proc/{pid}/stat") as f:
        state = f.read().rsplit(")", 1)[1].split()[0]
    return pending[0] == 0 and state == "S"


def main() -> None:
    pid, fd = sys.argv[1], int(sys.argv[2])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if idle(pid, fd):
            time.sleep(0.05)
            if idle(pid, fd):
                return
        time.sleep(0.01)


if __name__ == "__main__":
    main()
