"""What the command-line tests written in Python share: the binary under
test, a scratch folder, running it, and cases that count their failures.

    from clitest import run, path, case, f32, finish
"""
import os
import shutil
import struct
import subprocess
import sys
import tempfile

EPSNET = sys.argv[1] if len(sys.argv) > 1 else os.environ["EPSNET_BIN"]
TMP = tempfile.mkdtemp(prefix="epsnet-" + os.path.splitext(os.path.basename(sys.argv[0]))[0] + "-")
_failures = 0


def run(*args, timeout=300):
    """(exit code, stdout, stderr) of one epsnet command."""
    p = subprocess.run([EPSNET, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def path(name):
    return os.path.join(TMP, name)


def case(fn):
    """Run a test case now; an AssertionError fails it, and the run goes on.
    EPSNET_TEST_ONLY (names, comma-separated) runs only those cases (the
    thread sanitizer's build runs one case of a slow file)."""
    global _failures
    only = os.environ.get("EPSNET_TEST_ONLY")
    if only and fn.__name__ not in only.split(","):
        return fn
    try:
        fn()
        print("ok  ", fn.__name__)
    except AssertionError as e:
        _failures += 1
        print("FAIL", fn.__name__, "-", e)
    return fn


def f32(text):
    """The float32 bits a decimal text stands for: text written from the same
    float compares equal however many digits it was given."""
    return struct.pack("<f", float(text))


def read_ascii_ply_faced(p):
    """An ASCII PLY: the vertex and the face properties as (name, type), each
    vertex and each face's values as a dict of its values as written (text),
    and the faces as index lists."""
    with open(p) as f:
        lines = f.read().split("\n")
    i, props, counts, order = 0, {}, {}, []
    while lines[i] != "end_header":
        w = lines[i].split()
        if w and w[0] == "element":
            order.append(w[1])
            counts[w[1]] = int(w[2])
            props[w[1]] = []
        elif w and w[0] == "property" and w[1] != "list":
            props[order[-1]].append((w[2], w[1]))
        i += 1
    i += 1
    verts, faces, values = [], [], []
    for el in order:
        for _ in range(counts[el]):
            w = lines[i].split()
            i += 1
            if el == "vertex":
                verts.append(dict(zip([n for n, _ in props[el]], w)))
            elif el == "face":
                k = int(w[0])
                faces.append([int(x) for x in w[1:1 + k]])
                values.append(dict(zip([n for n, _ in props[el]], w[1 + k:])))
    return props["vertex"], props.get("face", []), verts, faces, values


def read_ascii_ply(p):
    """An ASCII PLY: the vertex properties as (name, type), each vertex as a
    dict of its values as written (text), and the faces as index lists."""
    vprops, _, verts, faces, _ = read_ascii_ply_faced(p)
    return vprops, verts, faces


def finish():
    """Print the count, clean up, and exit non-zero on any failure."""
    print(f"{_failures} failed")
    shutil.rmtree(TMP, ignore_errors=True)
    sys.exit(1 if _failures else 0)
