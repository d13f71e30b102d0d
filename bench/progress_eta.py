#!/usr/bin/env python3
"""How well the progress bar's ETA predicts a run's end.

    bench/progress_eta.py build-rel/tools/epsnet simplify b20.smz -o o.smz -j 2 --ratio 0.1

Runs the command under a pseudo-terminal (the bar is drawn only on a
terminal), reads each redraw's percentage and ETA with the time it came, and
prints, every few redraws, the end it predicted (elapsed + ETA) beside the
true one.
"""
import os
import pty
import re
import select
import sys
import time


def main(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    pid, fd = pty.fork()
    if pid == 0:
        os.execv(argv[1], argv[1:])
    t0 = time.time()
    buf, rows = b"", []
    while True:
        try:
            ready, _, _ = select.select([fd], [], [], 0.5)
            if not ready:
                continue
            data = os.read(fd, 4096)
        except OSError:
            break
        if not data:
            break
        buf += data
        *done, buf = buf.split(b"\r")
        for part in done:
            m = re.search(rb"(\d+\.\d)% .*ETA (\d+)s", part)
            if m:
                rows.append((time.time() - t0, float(m.group(1)), int(m.group(2))))
    _, status = os.waitpid(pid, 0)
    total = time.time() - t0
    print("run: %.1f s, exit %d, %d redraws" % (total, os.waitstatus_to_exitcode(status), len(rows)))
    for t, f, eta in rows[:: max(1, len(rows) // 25)]:
        print("t=%5.1f s  %5.1f%%  ETA %3d s  predicted end %5.1f s" % (t, f, eta, t + eta))


if __name__ == "__main__":
    main(sys.argv)
