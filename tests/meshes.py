"""Meshes the Python tests write themselves, where `epsnet gen` has no
shape for what they need."""
import math
import os


def tube_ply(folder, name, around, along, lock_every=0):
    """A long closed tube as an ASCII PLY (once per name): `around` vertices
    around and `along` rings, its radius rippled along and around so that
    collapses cost more in some stretches than in others, and capped at both
    ends. Sorted along its length, its stream is only `around` vertices wide,
    so a mesh of a few thousand rings is long enough for what a long stream
    gets (a size target's pricing windows, docs/architecture.md §7). With
    lock_every, a uchar "lock" set on every lock_every-th vertex."""
    p = os.path.join(folder, name)
    if os.path.exists(p):
        return p
    nv = around * along + 2
    nf = 2 * around * (along - 1) + 2 * around
    with open(p, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % nv)
        if lock_every:
            f.write("property uchar lock\n")
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % nf)
        i = 0
        for k in range(along):
            x = k * 0.05
            for a in range(around):
                t = 2 * math.pi * a / around
                r = 1 + 0.15 * math.sin(x * 0.7) * math.sin(3 * t) + 0.05 * math.sin(x * 5.3 + t)
                f.write("%.6f %.6f %.6f" % (x, r * math.cos(t), r * math.sin(t)))
                f.write(" %d\n" % (i % lock_every == 0) if lock_every else "\n")
                i += 1
        for x in (-0.05, along * 0.05):
            f.write("%.6f 0 0" % x + (" %d\n" % (i % lock_every == 0) if lock_every else "\n"))
            i += 1
        for k in range(along - 1):
            for a in range(around):
                b = (a + 1) % around
                p0, p1, q0, q1 = k * around + a, k * around + b, (k + 1) * around + a, (k + 1) * around + b
                f.write("3 %d %d %d\n3 %d %d %d\n" % (p0, q0, q1, p0, q1, p1))
        s0, s1 = around * along, around * along + 1
        for a in range(around):
            b = (a + 1) % around
            f.write("3 %d %d %d\n" % (s0, b, a))
            f.write("3 %d %d %d\n" % (s1, (along - 1) * around + a, (along - 1) * around + b))
    return p
