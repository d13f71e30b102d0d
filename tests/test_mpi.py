"""epsnet-mpi under mpirun (docs/distributed.md): the bytes of one process for
1-4 ranks, and one status for every rank when any rank fails, with no output.

    test_mpi.py EPSNET EPSNET_MPI MPIRUN

Ranks share the two cores here (--oversubscribe); as root, mpirun needs
--allow-run-as-root. The protocol itself, and every failure path of it, is
tested with threads for ranks under the sanitizers (tests/test_peers.c).
"""
import os
import subprocess
import sys

from clitest import case, finish, path, run

EPSNET_MPI, MPIRUN = sys.argv[2], sys.argv[3]
ROOT = ["--allow-run-as-root"] if os.geteuid() == 0 else []


def mpirun(n, *args, each=None, limit_kb=None, own_exits=True, timeout=600):
    """(mpirun's exit code, stderr, each rank's exit code) of `n` ranks of
    epsnet-mpi simplify ARGS; each[r], when given, is rank r's arguments;
    limit_kb: `ulimit -f` on every rank. own_exits: mpirun lets every rank
    exit by itself (else it ends the others once one exits non-zero, and
    its own exit code tells the failure)."""
    status = path("status")
    if os.path.exists(status):
        os.remove(status)
    # every rank notes its own exit code: mpirun reports only one
    wrap = 'exec 3>>"$0"; "$@"; c=$?; echo "$OMPI_COMM_WORLD_RANK $c" >&3; exit $c'
    if limit_kb:
        wrap = f"ulimit -f {limit_kb}; " + wrap
    cmd = [MPIRUN, *ROOT, "--oversubscribe"]
    if own_exits:
        cmd += ["--mca", "orte_abort_on_non_zero_status", "0"]
    for r in range(n):
        if r:
            cmd.append(":")
        cmd += ["-n", "1", "sh", "-c", wrap, status, EPSNET_MPI, "simplify", *(each[r] if each else args)]
    p = subprocess.run(cmd, capture_output=True, timeout=timeout)
    codes = {}
    if os.path.exists(status):
        for line in open(status):
            r, c = line.split()
            codes[int(r)] = int(c)
    return p.returncode, p.stderr.decode(errors="replace"), [codes.get(r) for r in range(n)]


def same_file(a, b):
    with open(a, "rb") as f, open(b, "rb") as g:
        return f.read() == g.read()


MESH = path("bumpy2m.smz")
code, _, err = run("gen", "bumpy", "--faces", "2M", "-o", MESH, "-q", timeout=600)
assert code == 0, err


@case
def the_default_path_and_a_ratio_give_one_process_bytes_for_1_to_4_ranks():
    for opts in ([], ["--ratio", "0.1"]):
        one = path("one.smz")
        code, _, err = run("simplify", MESH, "-o", one, "-j", "1", "-q", *opts, timeout=600)
        assert code == 0, err
        for n in (1, 2, 3, 4):
            for j in ("1", "2"):
                out = path("shared.smz")
                code, err, codes = mpirun(n, MESH, "-o", out, "-j", j, "-q", *opts)
                assert code == 0 and codes == [0] * n, f"{opts} {n} ranks -j {j}: {codes} {err}"
                assert same_file(out, one), f"{opts} {n} ranks -j {j}: bytes differ"
                os.remove(out)


def damaged_copy():
    """MESH with a late block's payload damaged (docs/smz.md: block headers start "SMZB")."""
    with open(MESH, "rb") as f:
        b = bytearray(f.read())
    at = b.rfind(b"SMZB", 0, len(b) * 3 // 4)
    assert at > len(b) // 2
    for i in range(at + 100, at + 164):
        b[i] ^= 0x5A
    bad = path("bad.smz")
    with open(bad, "wb") as f:
        f.write(b)
    return bad


def all_failed(n, err, codes, exit_code, words, out):
    assert codes == [exit_code] * n, f"each rank's exit: {codes} (all {exit_code} wanted); {err}"
    assert words in err, f"no '{words}' in: {err}"
    assert err.count("epsnet: ") == 1, f"one message, from rank 0: {err}"
    assert not os.path.exists(out), "output left behind"
    leftovers = [f for f in os.listdir(os.path.dirname(out)) if ".epsnet-" in f]
    assert not leftovers, f"temporary files left: {leftovers}"


@case
def a_corrupt_block_stops_every_rank():
    bad = damaged_copy()
    out = path("nothing.smz")
    code, _, err = run("simplify", bad, "-o", out, "-j", "1")
    assert code == 2 and "corrupt" in err, err
    # rank 0 reads the input and meets it: the error one process gives, on every rank
    code, err, codes = mpirun(3, bad, "-o", out, "-j", "1")
    all_failed(3, err, codes, 2, "corrupt", out)
    # as users run it: mpirun's own exit says the failure, nothing is left
    code, err, codes = mpirun(3, bad, "-o", out, "-j", "1", own_exits=False)
    assert code == 2, f"mpirun's exit {code}: {err}"
    assert "corrupt" in err and not os.path.exists(out), err


@case
def one_rank_given_a_budget_it_exceeds_stops_every_rank():
    out = path("nothing.smz")
    good = [MESH, "-o", out, "-j", "1"]
    # rank 1 alone may hold less than the slabs it is sent
    code, err, codes = mpirun(3, each=[good, good + ["--mem", "1M"], good])
    all_failed(3, err, codes, 4, "rank 1: ", out)
    assert "budget" in err, err


@case
def a_full_disk_on_rank_0_stops_every_rank():
    folder = path("small")
    os.makedirs(folder, exist_ok=True)
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", folder],
                             capture_output=True).returncode == 0
    out = os.path.join(folder, "out.smz")
    try:
        if mounted:
            code, err, codes = mpirun(2, MESH, "-o", out, "-j", "1")
        else:
            # no mount here (a container without the right): a file size
            # limit on every rank, which only rank 0 meets (it alone writes)
            print("note: no tmpfs mount here; a file size limit stands for the full disk")
            code, err, codes = mpirun(2, MESH, "-o", out, "-j", "1", limit_kb=64)
        all_failed(2, err, codes, 3, "out.smz", out)
    finally:
        if mounted:
            subprocess.run(["umount", folder], capture_output=True)


@case
def a_budget_exceeded_stops_every_rank():
    out = path("budget.smz")
    # 2M: rank 0's stitcher holds too much; 500K: its chunker (and the
    # slabs another rank holds)
    for mem in ("2M", "500K"):
        code, _, err = run("simplify", MESH, "-o", out, "-j", "1", "--mem", mem)
        assert code == 4, err
        code, err, codes = mpirun(3, MESH, "-o", out, "-j", "1", "--mem", mem)
        all_failed(3, err, codes, 4, "budget", out)


CORPUS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "fuzz", "corpus")


def corpus_sample(every):
    """Every `every`-th file of the fuzz corpus's readers (tests/fuzz/corpus),
    named with its format's extension (OBJ and OFF are told by it)."""
    picked = []
    for fmt in ("ply", "obj", "off", "stl", "sma", "smb", "smz"):
        folder = os.path.join(CORPUS, fmt)
        if not os.path.isdir(folder):
            continue
        for i, name in enumerate(sorted(os.listdir(folder))):
            if i % every == 0:
                picked.append((os.path.join(folder, name), fmt))
    return picked


def error_line(err):
    """The one error line a run printed (its "epsnet: " line), or ""."""
    lines = [l for l in err.splitlines() if l.startswith("epsnet: ")]
    return lines[0] if lines else ""


@case
def the_bad_input_corpus_gives_one_process_errors():
    # EPSNET_MPI_CORPUS_EVERY=1 walks the whole corpus (some 630 files;
    # CI takes every 12th)
    every = int(os.environ.get("EPSNET_MPI_CORPUS_EVERY", "12"))
    seen = 0
    for src, fmt in corpus_sample(every):
        mesh = path("corpus." + fmt)
        with open(src, "rb") as f, open(mesh, "wb") as g:
            g.write(f.read())
        one_out, out = path("c_one.ply"), path("c_shared.ply")
        # (a damaged file's bytes may be quoted in its error: not text)
        p = subprocess.run([sys.argv[1], "simplify", mesh, "-o", one_out, "-j", "1", "-q"], capture_output=True,
                           timeout=300)
        code, err = p.returncode, p.stderr.decode(errors="replace")
        _, merr, codes = mpirun(2, mesh, "-o", out, "-j", "1", "-q")
        want = error_line(err).replace(one_out, "OUT")
        got = error_line(merr).replace(out, "OUT")
        assert codes == [code, code], f"{src}: one process exits {code}, the ranks {codes}: {merr}"
        assert got == want, f"{src}: one process says\n  {want}\nthe ranks say\n  {got}"
        assert os.path.exists(out) == (code == 0), f"{src}: output {'missing' if code == 0 else 'left'}"
        if code == 0:
            assert same_file(out, one_out), f"{src}: bytes differ"
            os.remove(out)
            os.remove(one_out)
        seen += 1
    assert seen >= 40, f"only {seen} corpus files"


@case
def usage_errors_are_said_once():
    code, err, codes = mpirun(3, MESH, "-j", "1")
    assert codes == [1, 1, 1], codes
    assert err.count("needs -o OUT") == 1, err


sys.exit(finish())
