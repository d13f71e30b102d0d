"""Meshes the Python tests write themselves, where `epsnet gen` has no
shape for what they need."""
import math
import os
import random


def tube_ply(folder, name, around, along, lock_every=0, shuffle=False):
    """A long closed tube as an ASCII PLY (once per name): `around` vertices
    around and `along` rings, its radius rippled along and around so that
    collapses cost more in some stretches than in others, and capped at both
    ends. Sorted along its length, its stream is only `around` vertices wide,
    so a mesh of a few thousand rings is long enough for what a long stream
    gets (a size target's pricing windows, docs/architecture.md §7). With
    lock_every, a uchar "lock" set on every lock_every-th vertex (as
    generated); with shuffle, vertices and faces in a random order, as a
    scanner writes them."""
    p = os.path.join(folder, name)
    if os.path.exists(p):
        return p
    verts = []
    for k in range(along):
        x = k * 0.05
        for a in range(around):
            t = 2 * math.pi * a / around
            r = 1 + 0.15 * math.sin(x * 0.7) * math.sin(3 * t) + 0.05 * math.sin(x * 5.3 + t)
            verts.append("%.6f %.6f %.6f" % (x, r * math.cos(t), r * math.sin(t)))
    verts += ["%.6f 0 0" % -0.05, "%.6f 0 0" % (along * 0.05)]
    if lock_every:
        verts = ["%s %d" % (v, i % lock_every == 0) for i, v in enumerate(verts)]
    faces = []
    for k in range(along - 1):
        for a in range(around):
            b = (a + 1) % around
            p0, p1, q0, q1 = k * around + a, k * around + b, (k + 1) * around + a, (k + 1) * around + b
            faces += [(p0, q0, q1), (p0, q1, p1)]
    s0, s1 = around * along, around * along + 1
    for a in range(around):
        b = (a + 1) % around
        faces += [(s0, b, a), (s1, (along - 1) * around + a, (along - 1) * around + b)]
    order = list(range(len(verts)))
    if shuffle:
        rng = random.Random(7)
        rng.shuffle(order)
        rng.shuffle(faces)
    new = {old: i for i, old in enumerate(order)}
    with open(p, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                % len(verts))
        if lock_every:
            f.write("property uchar lock\n")
        f.write("element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        f.write("".join(verts[old] + "\n" for old in order))
        f.write("".join("3 %d %d %d\n" % (new[a], new[b], new[c]) for a, b, c in faces))
    return p
