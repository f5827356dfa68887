"""`make run` under a terminal, stopped with Ctrl-C as a user stops it: make must exit 0
and print no error, since the demo daemon stopped cleanly.

    python3 tests/e2e/ctrl_c.py MAKE BUILD
"""
import os
import pty
import select
import sys
import time

make, build = sys.argv[1], sys.argv[2]
pid, fd = pty.fork()
if pid == 0:
    os.execvp(make, [make, "--no-print-directory", "run", "BUILD=" + build])

out = b""


def read_for(seconds, until=None):
    global out
    end = time.time() + seconds
    while time.time() < end:
        if until is not None and until in out:
            return True
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(fd, 4096)
            except OSError:
                return until is None
            if not chunk:
                return until is None
            out += chunk
    return until is not None and until in out


if not read_for(300, b"Ctrl-C stops it"):
    os.kill(pid, 9)
    sys.exit("FAIL: the demo did not come up under make run:\n" + out.decode(errors="replace")[-3000:])
os.write(fd, b"\x03")
read_for(30)
_, status = os.waitpid(pid, 0)
text = out.decode(errors="replace")
if not os.WIFEXITED(status) or os.WEXITSTATUS(status) != 0:
    how = "exit %d" % os.WEXITSTATUS(status) if os.WIFEXITED(status) else "signal %d" % os.WTERMSIG(status)
    sys.exit("FAIL: make run ended with %s after Ctrl-C:\n%s" % (how, text[-3000:]))
if "make: ***" in text or "make[1]: ***" in text:
    sys.exit("FAIL: make reported an error after Ctrl-C:\n" + text[-3000:])
if "stopped:" not in text:
    sys.exit("FAIL: the daemon did not log a clean stop:\n" + text[-3000:])
print("ok: Ctrl-C stopped make run with exit 0, no make error, the daemon stopped cleanly")
